"""Structured solver results: fields, iteration history, timings, quantities of interest."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..fem.elasticity import FloatArray
from .assembly import Assembly
from .qoi import ContactPressures, determined_values
from .sliding_extent import LargeSlip
from .uniqueness import FreeMotion


@dataclass(frozen=True)
class InterfaceFields:
    """Interface fields at every point and step, shapes ``(n_steps, n_points, 2)``.

    ``displacement``/``force`` are the admissible pair s (linear stage, A_d);
    ``displacement_hat``/``force_hat`` the pair ŝ that satisfies the interface behaviour (Γ).
    Forces are per unit length (a traction times its part's thickness); ``weights`` are the
    points' lengths (the diagonal of M0).
    """

    coords: FloatArray
    weights: FloatArray
    interface: np.ndarray
    substructure: np.ndarray
    displacement: FloatArray
    force: FloatArray
    displacement_hat: FloatArray
    force_hat: FloatArray


@dataclass(frozen=True)
class SolveResult:
    """The answer of one computation (LATIN or monolithic reference)."""

    method: str
    assembly: Assembly
    converged: bool
    iterations: int
    indicator: float
    history: FloatArray  # error indicator η after each iteration
    timings: dict[str, float]
    displacements: dict[str, FloatArray]  # substructure name -> (n_steps, n_nodes, 2)
    reactions: dict[str, FloatArray]  # boundary name -> (n_steps, 2) force on the structure
    qoi: dict[str, float | list[float]]
    interface: InterfaceFields | None = None
    options: dict[str, Any] = field(default_factory=dict)
    #: rigid motions that change no force in the converged state (``multilatin.uniqueness``)
    free_motions: tuple[FreeMotion, ...] = ()
    #: contacts whose converged slip leaves the small-sliding range (``sliding_extent``)
    large_slips: tuple[LargeSlip, ...] = ()
    #: why the solve failed, when it did ("" when converged)
    failure: str = ""
    #: estimated |QoI − its converged value| (LATIN: ``multilatin.latin.tracking``; None
    #: where not estimated, e.g. a warm start of fewer than 6 iterations; empty for the
    #: monolithic reference, which is solved directly)
    qoi_error: dict[str, float | list[float] | None] = field(default_factory=dict)
    #: LATIN stopped this case on its QoIs' estimated errors (``LatinOptions.qoi_rtol``)
    #: before η reached ``tol``
    stopped_on_qoi: bool = False
    #: the contact pressure at the nodes of the contact interfaces between bodies, per step
    #: (None without contact between bodies)
    contact: ContactPressures | None = None
    #: LATIN: the state's estimated remaining relative change η / (1 − ρ), ρ the
    #: indicator's rate over the last iterations (``multilatin.latin.tracking``); the QoI
    #: estimates are withheld where it exceeds ``tracking.SETTLED`` (NaN: not measured)
    state_change: float = float("nan")

    @property
    def wall_s(self) -> float:
        return self.timings.get("total", float("nan"))

    @property
    def unique(self) -> bool:
        """False when the discrete problem does not determine the last step's answer (a free
        rigid motion at the friction limit, ``multilatin.uniqueness``): another solver, or
        this one from another start, may return another answer."""
        return not any(m.reaches_last_step for m in self.free_motions)

    @property
    def qoi_determined(self) -> dict[str, bool | list[bool]]:
        """Per QoI (shaped as ``qoi``): False at the values the discrete problem does not
        determine (``qoi.determined_values``: a free motion's displacements, and every
        value after a motion that reaches the last step)."""
        if not self.free_motions:
            return {name: (True if not isinstance(value, list) else [True] * len(value))
                    for name, value in self.qoi.items()}
        return determined_values(self.assembly, self.free_motions)

    def to_json_dict(self) -> dict[str, Any]:
        """The command-line JSON contract: converged, iterations, indicator, wall_s, qoi, …"""
        return {
            "model": self.assembly.name,
            "method": self.method,
            "params": dict(self.assembly.mu),
            "converged": self.converged,
            "failure": self.failure,
            "unique": self.unique,
            "free_motions": [m.describe() for m in self.free_motions],
            "qoi_determined": self.qoi_determined,
            "large_slips": [s.describe() for s in self.large_slips],
            "iterations": self.iterations,
            "indicator": _finite_or_none(self.indicator),
            "wall_s": self.wall_s,
            # no answer from a failed solve: the QoIs are withheld (null)
            "qoi": self.qoi if self.converged else withheld(self.qoi),
            "qoi_error": self.qoi_error if self.converged else withheld(self.qoi_error),
            "stopped_on_qoi": self.stopped_on_qoi,
            "state_change": _finite_or_none(self.state_change),
            "n_steps": self.assembly.n_steps,
            "n_substructures": len(self.assembly.substructures),
            "n_dofs": self.assembly.n_dofs,
            "timings": self.timings,
            "history": [_finite_or_none(v) for v in self.history],
            "options": self.options,
        }


def withheld(qoi: dict[str, Any]) -> dict[str, None]:
    """The QoIs of a computation that did not converge, as JSON gives them: null."""
    return {name: None for name in qoi}


def _finite_or_none(value: float) -> float | None:
    """JSON has no NaN or infinity: null instead."""
    value = float(value)
    return value if np.isfinite(value) else None
