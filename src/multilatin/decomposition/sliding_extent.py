"""Where a contact slides farther than its pairs allow (the small-sliding hypothesis).

Both solvers join the two sides of a contact by pairs of points that face each other in
the undeformed configuration (paper §2.2, small perturbations), and keep them joined
whatever the sides slide. A pressed point that has slipped farther than half its partner's
dual cell faces another point of the partner side: the pairs then no longer join the
points that touch, and the answer is that of a contact whose sides did not slide — its
forces act where the points were, a side that slides past its partner's end is still
held there, and a curved face's gaps are read at the old places. LATIN and the monolithic
reference solve the same discrete problem, so they agree; the model is what is out of its
range (B1 with a gap of 1 mm: the centre block slides 1.01 mm on cells of 2.08 mm).

``large_slips`` finds, per pair of bodies in contact, the pressed pair and step where the slip is
largest against ``SLIP_LIMIT`` × its dual cell, and reports it when it exceeds that.
Refining the mesh does not help (its cells shrink, the slip does not); the answers hold
only as far as the slip is small against the contact's length and its features.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..fem.elasticity import FloatArray
from .assembly import Assembly
from .interfaces import InterfacePoints

#: the largest slip of a pressed pair, as a share of its dual cell (the larger of its two
#: points' lengths), before the pair no longer faces its partner: half the cell
SLIP_LIMIT = 0.5


@dataclass(frozen=True)
class LargeSlip:
    """The largest slip of a pressed pair of the contact between ``bodies`` (at ``step``,
    1-based, at the first side's ``point``), beyond ``SLIP_LIMIT`` × its dual ``cell``;
    ``length`` is the length of their contact (its first sides' points)."""

    bodies: tuple[str, str]
    step: int
    point: tuple[float, float]
    slip: float
    cell: float
    length: float

    def describe(self) -> str:
        x, y = self.point
        return (f"step {self.step}: the contact {self.bodies[0]}|{self.bodies[1]} slips "
                f"{self.slip:.3g} at ({x:.4g}, {y:.4g}), more than half its pair's cell "
                f"({self.cell:.3g}) and {100 * self.slip / self.length:.2g} % of the contact's "
                "length: its pairs, set facing in the undeformed configuration, no "
                "longer join the points that touch (small sliding)")


def large_slips(assembly: Assembly, points: InterfacePoints, w_hat: FloatArray,
                f_hat: FloatArray) -> tuple[LargeSlip, ...]:
    """Per pair of bodies in contact, the largest slip beyond ``SLIP_LIMIT`` (module docstring),
    read on the converged interface fields ``w_hat``, ``f_hat`` (n_steps, n_points, 2):
    the tangential part of the displacement jump of each pair pressed at that step."""
    first, second = points.contact_pairs
    if first.size == 0:
        return ()
    normal = points.normals[first]
    jump = w_hat[:, second] - w_hat[:, first]
    along = np.einsum("tpc,pc->tp", jump, normal)
    tangential = jump - along[..., None] * normal
    slip = np.hypot(tangential[..., 0], tangential[..., 1])  # (T, pairs)
    pushed = np.einsum("tpc,pc->tp", f_hat[:, first], normal)  # < 0: pressed
    scale = float(np.abs(f_hat[:, first]).max(initial=0.0))
    pressed = pushed < -1e-9 * scale
    cell = np.maximum(points.weights[first], points.weights[second])
    ratio = np.where(pressed, slip / (SLIP_LIMIT * cell), 0.0)
    # one report per pair of bodies (a contact cut into pieces by substructures is one)
    body_of = [sub.body for sub in assembly.substructures]
    touching = [(body_of[points.substructure[a]], body_of[points.substructure[b]])
                for a, b in zip(first.tolist(), second.tolist(), strict=True)]
    found = []
    for bodies in dict.fromkeys(touching):
        on = np.array([k for k, pair in enumerate(touching) if pair == bodies])
        step, at = np.unravel_index(int(np.argmax(ratio[:, on])), (ratio.shape[0], on.size))
        pair = int(on[at])
        if ratio[step, pair] <= 1.0:
            continue
        found.append(LargeSlip(
            bodies, int(step) + 1,
            (float(points.coords[first[pair], 0]), float(points.coords[first[pair], 1])),
            float(slip[step, pair]), float(cell[pair]), float(points.weights[first[on]].sum())))
    return tuple(found)
