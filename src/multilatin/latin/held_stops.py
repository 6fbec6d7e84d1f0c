"""The local stage of stops held tangentially at their node (``held_nodes.held_stops``):
a frictional flat under a face whose sliding component is prescribed, a block in a rigid
corner. The node's tangential force is shared there between the stop's friction and its
holder, and only the sum is determined; left to the iteration, the split depended on the
search direction (a block on a frictional flat, its side held: the flat's reaction at the
first step −146.1 N at κ = 0.5, −148.3 N at κ = 2, −145.7 N by the reference; in a rigid
corner 1.9 % apart between the two κ, and 15 % of its largest value from the reference,
which merged the corner's two stops). As at a held corner between two bodies
(``LocalStage._contact_and_stops``),
the friction keeps its previous step's value, limited to the cone, while the holder holds
(a prescribed displacement that did not move since the last step, a closed stop its node
was on at the step before, ``ATTACHED``), and the
stop's Ŵ follows the holder; a prescribed displacement that moved makes the stop slide, by
its own Coulomb law. The monolithic reference applies the same rule
(``reference.contact_newton``). The compiled kernel (``kernels._contact_and_stops``) and
the PyTorch stage (``torch_local``) do the same.

``moving_corners``: the held corners between two bodies whose prescribed holders moved —
against each other, or one against a closed stop that holds the other side — those slide,
by Coulomb's law.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from ..fem.elasticity import FloatArray, IntArray

if TYPE_CHECKING:
    from .local_stage import LocalStage

__all__ = ["ATTACHED", "attached", "beyond_stop", "hold_stops", "moving_corners", "open_arrivals"]

#: a closed stop holds a corner (its friction kept at its previous value) only where its
#: node was on the stop at the previous step already: |gap − n·Ŵ(t − 1)| ≤ this × (|gap| +
#: |n·Ŵ(t − 1)| + |n·W(t)| + |n·F(t)| / k), the rounding of the stop's update. A node that
#: reaches the stop within the step slid along the contact to get there, and slides by
#: Coulomb's law. Held from the moment the stop closed, B1 with the stop's gap at 1e-5 mm
#: slid its centre block's top corner onto the stop with a friction force of 1 % of the
#: normal one against μ = 0.3, and R_stop ended 1.3 % off the reference's stick; at the
#: bundled gap, (μ1, μ2) = (0.3, 0.15) slid it there at 0.13 against 0.15, R_stop 0.16 %
#: off (session 53, docs/correctness.md). A corner is held, besides, only by a stop that
#: was closed at the step before (carrying force, not touched at rest; ``open_arrivals``)
ATTACHED = 1e-9


def attached(closing: Any, gap: Any, normal_w: Any, normal_f: Any, k_normal: Any) -> Any:
    """Whether a stop's node was on it at the previous step already (``ATTACHED``), from
    its ``closing`` = gap − n·Ŵ(t − 1), its ``gap``, n·W(t), n·F(t) and n·k·n: written
    with ``abs`` and arithmetic alone, so that the NumPy and PyTorch stages call it on
    arrays and the compiled and CUDA kernels compile it for one stop."""
    return abs(closing) <= ATTACHED * (abs(gap) + abs(gap - closing) + abs(normal_w)
                                       + abs(normal_f) / k_normal)


def beyond_stop(beyond: Any, gap: Any, size: Any) -> Any:
    """Whether a sticking corner's node is ``beyond`` its stop (n·Ŵ − gap) by more than the
    rounding (``ATTACHED``) of its ``gap``, its position and ``size``: |W| + |F| / k of
    the contact pair at the node (1-norms; the stop's own W and F vanish where it is
    open, and so would the rounding). Arithmetic alone, as ``attached``."""
    return beyond > ATTACHED * (abs(gap) + abs(gap + beyond) + size)


def hold_stops(local: LocalStage, t: int, prev_stop: FloatArray,
               stop_closed: npt.NDArray[np.bool_], f_hat: FloatArray, w_hat: FloatArray,
               stop_holds: npt.NDArray[np.bool_]) -> None:
    """The held stops' F̂ and Ŵ in step ``t``, in place (after every stop's own law);
    ``stop_holds``: the stops closed with their node on them at the step before already
    (``ATTACHED``), which alone hold another stop."""
    q = local.held_stops
    p = local.stops[q]
    n = local.n_stop[q]
    d = 1 - np.argmax(np.abs(n), axis=1)
    by_boundary, by_stop = local.stop_held_boundary[q], local.stop_held_stop[q]
    boundary = np.maximum(by_boundary, 0)
    now = local.prescribed[:, t, boundary, d]  # (cases, held)
    before = local.prescribed[:, t - 1, boundary, d] if t > 0 else np.zeros_like(now)
    holder = np.maximum(by_stop, 0)
    holding = np.where(by_boundary >= 0, now == before, stop_holds[:, holder])
    target = np.where(by_boundary >= 0, now, prev_stop[:, holder, d])
    bound = np.where(stop_closed[:, q],
                     -local.mu_stop[:, q] * np.sum(n * f_hat[:, t, p], axis=-1), 0.0)
    kept = f_hat[:, t - 1, p, d] if t > 0 else np.zeros_like(bound)
    f_hat[:, t, p, d] = np.where(holding, np.clip(kept, -bound, bound), f_hat[:, t, p, d])
    prev_stop[:, q, d] = np.where(holding, target, prev_stop[:, q, d])
    w_hat[:, t, p, d] = prev_stop[:, q, d]


def moving_corners(prescribed: FloatArray, corner_boundaries: IntArray, normals: FloatArray
                   ) -> npt.NDArray[np.bool_]:
    """Per case, step and held corner (``held_nodes.held_corners``): whether its holders
    moved against each other along the contact since the step before — two prescribed
    displacements that moved differently, or one that moved against a stop (which holds
    the other side still) — the pair then slides, and its friction is Coulomb's (at the
    cone), not the held corner's previous value. ``prescribed``: (cases, steps, boundary,
    2); ``normals``: the corners' contact normals."""
    n_cases, n_steps = prescribed.shape[:2]
    if not corner_boundaries.size:
        return np.zeros((n_cases, n_steps, 0), dtype=bool)
    by = corner_boundaries >= 0
    d = 1 - np.argmax(np.abs(normals), axis=1)
    held = np.maximum(corner_boundaries, 0)
    step = np.diff(prescribed, axis=1, prepend=np.zeros_like(prescribed[:, :1]))
    side_a, side_b = step[:, :, held[:, 0], d], step[:, :, held[:, 1], d]
    # two prescribed holders: their relative motion; one (a closed stop holds the other
    # side still): its own
    moving: npt.NDArray[np.bool_] = np.where(
        by[:, 0] & by[:, 1], side_b - side_a != 0.0,
        (by[:, 0] & (side_a != 0.0)) | (by[:, 1] & (side_b != 0.0)))
    return moving


def open_arrivals(local: LocalStage, t: int, trial: FloatArray, normal_force: FloatArray,
                  held: npt.NDArray[np.bool_], sides: tuple[FloatArray, FloatArray],
                  stop_closed: npt.NDArray[np.bool_], prev_stop: FloatArray,
                  displacement: FloatArray, force: FloatArray, w_hat: FloatArray,
                  f_hat: FloatArray) -> npt.NDArray[np.bool_]:
    """Friction first at a corner that is not held: a stop of it that closed in step ``t``
    while the corner's contact pair sticks, with the node (the pair's Ŵ on the stop's
    side, ``sides``: both sides' Ŵ after the step) short of the stop or on it within
    rounding (``beyond_stop``), opens — F̂ = 0, Ŵ = W − F / k, in place. A sticking node is
    where its partner holds it: it did not reach the stop, and the stop carries nothing
    while friction can. Returns the stops' closed status after that.

    Without it, B1 with its stop's gap below what the iteration resolves (1e-9 to 1e-6 mm)
    settled on the stop carrying the corner and the pair sticking 1e-7 mm apart (η
    stalling at about 6 × the gap in mm), R_stop 1245.9 N against the reference's 1230.4 N
    (session 54, docs/correctness.md); at gap = 0 the corner was held from the first step
    (1245.5 N), not the limit of small gaps."""
    corner = local.corner
    n = local.n_contact[corner]
    source = trial[:, corner]
    tangential = source - np.sum(source * n, axis=-1)[..., None] * n
    friction = np.sqrt(np.sum(tangential**2, axis=-1))
    pushed = normal_force[:, corner]
    stick = local._branch((pushed <= 0.0) & (friction <= local.mu_contact[:, corner] * -pushed))
    closed = stop_closed.copy()
    for side, shift in enumerate(sides):
        has = local.corner_stops[:, side] >= 0
        if not has.any():
            continue
        q, i = np.flatnonzero(has), local.corner_stops[has, side]
        node, normal = local.stops[i], local.n_stop[i]
        pair = corner[q]
        point = local.contact_pairs[side][pair]
        k = (local.k_contact, local.k_contact_b)[side][pair]
        size = (np.sum(np.abs(displacement[:, t, point]), axis=-1)
                + np.sum(np.abs(force[:, t, point]) / k, axis=-1))
        gap = local.gap_stop[:, i]
        beyond = np.sum(normal * shift[:, pair], axis=-1) - gap
        reached = local._branch(beyond_stop(beyond, gap, size))
        opens = stop_closed[:, i] & ~held[:, q] & stick[:, q] & ~reached
        open_w = displacement[:, t, node] - force[:, t, node] / local.k_stop[i]
        f_hat[:, t, node] = np.where(opens[..., None], 0.0, f_hat[:, t, node])
        w_hat[:, t, node] = np.where(opens[..., None], open_w, w_hat[:, t, node])
        prev_stop[:, i] = np.where(opens[..., None], open_w, prev_stop[:, i])
        closed[:, i] &= ~opens
    return closed
