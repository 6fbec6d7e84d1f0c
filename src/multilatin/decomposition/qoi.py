"""Quantities of interest from displacement fields, boundary reactions and contact
pressures."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from ..fem.elasticity import FloatArray, interpolate
from .assembly import Assembly


@dataclass(frozen=True)
class ContactPressures:
    """Contact pressure (positive in compression), piecewise constant on interface elements.

    ``bodies[i]`` names the two bodies the element ``i`` joins; ``extents[i]`` is its start
    and end along the interface; ``pressure`` is shaped (n_steps, n_elements).
    """

    bodies: list[frozenset[str]] = field(default_factory=list)
    extents: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))
    pressure: FloatArray = field(default_factory=lambda: np.zeros((1, 0)))

    def mean(self, bodies: frozenset[str], segment: tuple[float, float]) -> FloatArray:
        """Mean pressure over ``segment`` of the interfaces between ``bodies``, per step."""
        chosen = np.array([b == bodies for b in self.bodies], dtype=bool)
        lo = np.maximum(self.extents[chosen, 0], segment[0])
        hi = np.minimum(self.extents[chosen, 1], segment[1])
        overlap = np.clip(hi - lo, 0.0, None)
        if overlap.sum() <= 0.0:
            raise ValueError(f"no contact interface between {sorted(bodies)} over {segment}")
        return np.asarray(self.pressure[:, chosen] @ overlap / overlap.sum(), dtype=np.float64)


def evaluate_qois(
    assembly: Assembly,
    displacements: Mapping[str, FloatArray],
    reactions: Mapping[str, FloatArray],
    pressures: ContactPressures | None = None,
) -> dict[str, float | list[float]]:
    """Each QoI as a number (one load step, or ``step`` chosen) or a list over the steps."""
    out: dict[str, float | list[float]] = {}
    for q in assembly.qois:
        if q.kind == "displacement":
            assert q.point is not None
            sub = next(s for s in assembly.substructures if s.mesh.contains(q.point))
            cell, ref = sub.mesh.locate(q.point)
            values = interpolate(sub.mesh.nodes, sub.mesh.cells, displacements[sub.name],
                                 cell, ref)[:, q.component]
        elif q.kind == "reaction":
            assert q.boundary is not None
            values = reactions[q.boundary][:, q.component]
        elif q.kind == "contact_pressure":
            assert q.bodies is not None and q.segment is not None
            values = (pressures or ContactPressures()).mean(frozenset(q.bodies), q.segment)
        else:  # pragma: no cover - rejected when the model is read
            raise ValueError(q.kind)
        values = q.scale * values + 0.0  # + 0.0: no "-0" for a zero force
        if q.step is not None:
            values = values[q.step - 1:q.step]
        out[q.name] = float(values[0]) if values.size == 1 else [float(v) for v in values]
    return out
