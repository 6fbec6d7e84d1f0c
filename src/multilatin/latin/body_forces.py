"""Body forces and temperature changes in the linear stage (paper eq. [1] and [13] with
f_d on Ω_E; a temperature change's initial strain ε₀ loads it as ∫ Bᵀ D ε₀).

A substructure loaded inside by f_E (per step) solves (K_E + T_Eᵀ M0 H T_E) u_E = f_E +
T_Eᵀ M0 (F̂ + H Ŵ) in the linear stage, so its interface displacement is the unloaded
one plus a constant of the iteration, W = C_E (F̂ + H Ŵ) + T_E S_E⁻¹ f_E, and F = F̂ +
H (Ŵ − W) follows from that W. The macro problem is unchanged: its constraint is the
interface forces' macro balance, which body forces do not enter; they reach it through
the micro stage's F. The interior displacements take S_E⁻¹ f_E too, and so does a point
QoI read through them (``with_body_constants``; a stress −D ε₀ too). ``body_response``
computes S_E⁻¹ f_E once per case and geometry: one solve of n_steps columns per loaded
substructure.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..decomposition.assembly import Assembly
from ..decomposition.qoi import initial_stress, point_functional
from ..fem.elasticity import FloatArray

if TYPE_CHECKING:
    from .operators import LatinOperators
    from .tracking import QoiFunctionals

__all__ = ["BodyResponse", "body_response", "stacked_offsets", "with_body_constants"]


@dataclass(frozen=True)
class BodyResponse:
    """What a case's body forces add to its linear stage: per loaded substructure, S_E⁻¹
    f_E per step (n_steps, n_dofs), and T_E S_E⁻¹ f_E at the interface points (n_steps,
    n_points, 2), zero on unloaded substructures."""

    interior: dict[int, FloatArray]
    offsets: FloatArray

    def add_interior(self, fields: dict[str, FloatArray], assembly: Assembly) -> None:
        """Adds S_E⁻¹ f_E to the recovered interior displacements ``fields`` (by
        substructure name, (n_steps, n_nodes, 2)), in place."""
        for s, displacement in self.interior.items():
            name = assembly.substructures[s].name
            if name in fields:
                fields[name] = fields[name] + displacement.reshape(fields[name].shape)


def body_response(ops: LatinOperators, assembly: Assembly) -> BodyResponse | None:
    """The case's ``BodyResponse`` on its geometry's operators; None without body forces
    (a body force of zero value still gives one, of zeros)."""
    if not assembly.interior_loads:
        return None
    points = ops.points
    interior: dict[int, FloatArray] = {}
    offsets = np.zeros((assembly.n_steps, points.n_points, 2))
    for s in range(len(assembly.substructures)):
        load = assembly.interior_load(s)
        if load is None:
            continue
        response = np.asarray(ops.factors[s].solve(np.asfortranarray(load.T)).T)
        interior[s] = response
        lo, hi = points.offsets[s], points.offsets[s + 1]
        offsets[:, lo:hi] = (points.traces[s] @ response.T).T.reshape(-1, hi - lo, 2)
    return BodyResponse(interior, offsets)


def stacked_offsets(responses: Sequence[BodyResponse | None], n_steps: int,
                    n_points: int) -> FloatArray | None:
    """The cases' offsets (n_cases, n_steps, n_points, 2), zeros for a case without body
    forces; None where no case has any (the linear stage adds nothing)."""
    if all(response is None for response in responses):
        return None
    out = np.zeros((len(responses), n_steps, n_points, 2))
    for c, response in enumerate(responses):
        if response is not None:
            out[c] = response.offsets
    return out


def with_body_constants(functional: QoiFunctionals, response: BodyResponse | None,
                        assembly: Assembly) -> QoiFunctionals:
    """``functional`` with the constants body forces add to point QoIs (displacement,
    stress): φ · S_E⁻¹ f_E per step, φ the QoI's functional on the substructure's dofs.
    Reactions and contact pressures read the interface forces alone, which already carry
    the body forces' share. Returns ``functional`` itself without body forces."""
    if response is None:
        return functional
    constant = np.zeros((len(assembly.qois), assembly.n_steps))
    for i, q in enumerate(assembly.qois):
        if q.kind in ("displacement", "stress"):
            s, phi = point_functional(assembly.substructures, q)
            if s in response.interior:
                constant[i] = q.scale * (response.interior[s] @ phi)
            initial = initial_stress(assembly, q) if q.kind == "stress" else None
            if initial is not None:  # σ = D (B u − ε₀)
                constant[i] += q.scale * initial
    return dataclasses.replace(functional, constant=constant)
