"""Retimed starts along a friction (or any non-geometric) axis of a study (issue 16).

Along a friction line the converged load histories of neighbouring cases are alike but
*shifted in time*: a higher friction coefficient holds a body a little longer before it
slides, so the slide's onset, its progress and the closing of a gap come later by about a
load step per grid step (B1 at μ1 = 0.3: u_A = 2.1, 9.5, 18.5, 27.4 µm at steps 6–9 for
μ2 = 0.05, 3.3, 8.2, 17.2, 26.1 µm at steps 7–10 for μ2 = 0.1). The nearest neighbour's
fields at the same step are then off by a whole step of sliding, and that error decays at
the slide's slow rate (docs/convergence.md, session 27); a secant in the parameter at a
fixed step does not see it either (a slide's onset is not smooth at a fixed step: 11 % more
iterations, session 12).

A retimed start moves the start neighbour's history instead. With P the start neighbour of
case C and G the case one grid step further back on the same line (P's own start):

1. per load step t, the shift δ_t (in steps, |δ_t| ≤ ``MAX_SHIFT``) for which
   ŝ_P(t) ≈ ŝ_G(t − δ_t) best (``step_shifts``: least squares over δ, the history linearly
   interpolated between steps, the state before the first step zero; fields scaled by P's
   norms of Ŵ and F̂, so unit-free);
2. the events move on by the same amount per grid step: what P reaches at t, C reaches at
   τ_t = t + δ_t, so C's shift at its own step is δ interpolated from the points (τ_t, δ_t)
   (``retimed_fields``);
3. C starts from ŝ_P(t − δ_C(t)), interpolated the same way.

Steps where G and P agree keep δ = 0 (the preload: C starts there from P's fields exactly).
A start is only a start: the iteration's fixed point does not depend on it, and cases whose
answer the discrete problem does not determine are solved from zero as before
(``starts.set_aside``). Measured: docs/performance.md ("Retimed starts", session 33).
"""

from __future__ import annotations

import numpy as np

from ..fem.elasticity import FloatArray

Fields = tuple[FloatArray, FloatArray]

#: the largest shift, in load steps, either way
MAX_SHIFT = 2
#: the shifts are kept where they bring the two whole histories closer than this times
#: their difference without a shift: where they do not, what differs is no event moving in
#: time (B1 along the stop's gap: the block slides further, not later; shifted, the
#: histories are 0.96–0.98 as far apart, and retimed starts took 3 times the iterations;
#: on B1's friction grid retimed starts saved 20–36 % of the iterations where that ratio
#: was below 0.85 and nothing above: docs/performance.md, session 33); a step's own shift
#: where it brings that step any closer (0.5 per step lost half the saving on B1)
EXPLAINED = 0.85
#: histories that differ by less than this (relative, over all steps) are taken as one:
#: their difference is the tolerance's, not an event's (B1 at μ1 ≥ 0.5, where nothing
#: slides: retiming such a difference took cases that stop after one iteration to 5–14)
SIGNIFICANT = 1e-2


def _grams(earlier: Fields, later: Fields, scale: tuple[float, float]
           ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The scaled inner products of the steps: earlier × earlier and earlier × later with a
    zero step first (the state before the first step), and later's squared norms."""
    n = earlier[0].shape[0]
    gg, gp = np.zeros((n + 1, n + 1)), np.zeros((n + 1, later[0].shape[0]))
    pp = np.zeros(later[0].shape[0])
    for a, b, c in zip(earlier, later, scale, strict=True):
        rows_a, rows_b = a.reshape(n, -1), b.reshape(b.shape[0], -1)
        gg[1:, 1:] += (rows_a @ rows_a.T) / c**2
        gp[1:] += (rows_a @ rows_b.T) / c**2
        pp += np.einsum("ij,ij->i", rows_b, rows_b) / c**2
    return gg, gp, pp


def step_shifts(earlier: Fields, later: Fields) -> FloatArray:
    """Per load step t, δ_t ∈ [−``MAX_SHIFT``, ``MAX_SHIFT``] with later(t) ≈ earlier(t − δ_t)
    best in the least-squares sense (``earlier`` linearly interpolated between its steps,
    zero before the first); closed form on each segment between two consecutive steps of
    ``earlier``. δ_t = 0 where no shift does better, where the step's fields differ by
    less than ``SIGNIFICANT`` of its size, and at every step where the shifts do not explain
    the histories' difference (``EXPLAINED``) or it is below ``SIGNIFICANT``."""
    scale = (float(np.linalg.norm(later[0])) or 1.0, float(np.linalg.norm(later[1])) or 1.0)
    gg, gp, pp = _grams(earlier, later, scale)  # row i of gg, gp: step i − 1
    n = pp.size
    t = np.arange(n)[:, None]
    j = np.arange(-MAX_SHIFT, MAX_SHIFT)[None, :]  # segment from step t − j to t − j − 1
    i0 = np.clip(t - j + 1, 0, n)  # row of earlier(t − j)
    i1 = np.clip(t - j, 0, n)  # row of earlier(t − j − 1)
    valid = (t - j >= 0) & (t - j + 1 <= n)
    tt = np.broadcast_to(t, i0.shape)
    dd = gg[i1, i1] - 2.0 * gg[i0, i1] + gg[i0, i0]  # |g1 − g0|²
    r0 = gg[i0, i0] - 2.0 * gp[i0, tt] + pp[tt]  # |g0 − p|²
    rd = gg[i0, i1] - gg[i0, i0] - gp[i1, tt] + gp[i0, tt]  # ⟨g0 − p, g1 − g0⟩
    a = np.where(dd > 0.0, np.clip(-rd / np.where(dd > 0.0, dd, 1.0), 0.0, 1.0), 0.0)
    error = np.where(valid, r0 + 2.0 * a * rd + a * a * dd, np.inf)
    best = np.argmin(error, axis=1)
    rows = np.arange(n)
    unshifted = np.maximum(gg[rows + 1, rows + 1] - 2.0 * gp[rows + 1, rows] + pp, 0.0)
    shift = j[0, best] + a[rows, best]
    keep = (error[rows, best] < unshifted) & (unshifted > SIGNIFICANT ** 2 * pp)
    total = float(unshifted.sum())
    if (total < SIGNIFICANT ** 2 * float(pp.sum())
            or np.where(keep, error[rows, best], unshifted).sum() > EXPLAINED ** 2 * total):
        keep[:] = False
    return np.asarray(np.where(keep, shift, 0.0), dtype=np.float64)


def shifted_history(fields: Fields, shift: FloatArray) -> Fields:
    """Per step t, the fields at t − shift_t: linear between steps, zero before the first
    step, held after the last."""
    n = fields[0].shape[0]
    x = np.clip(np.arange(n) - shift, -1.0, n - 1.0)
    lo = np.minimum(np.floor(x).astype(np.int64), n - 2)  # −1: from the zero state
    weight = x - lo
    below = np.where(lo >= 0, 1.0 - weight, 0.0)
    out = []
    for field in fields:
        shape = (n,) + (1,) * (field.ndim - 1)
        out.append(np.take(field, np.maximum(lo, 0), axis=0) * below.reshape(shape)
                   + np.take(field, lo + 1, axis=0) * weight.reshape(shape))
    return out[0], out[1]


def retimed_fields(start: Fields, partner: Fields) -> Fields | None:
    """The retimed start of a case from its start neighbour's converged fields ``start``
    (P) and those of the case one grid step further back on the same line ``partner`` (G),
    module docstring; None for a single load step, histories that no shift explains (nothing
    to retime: the case starts from ``start`` as it is) or fields that differ in shape."""
    if any(a.shape != b.shape for a, b in zip(start, partner, strict=True)):
        return None
    n = start[0].shape[0]
    if n < 2:
        return None
    shift = step_shifts(partner, start)
    if not shift.any():
        return None
    reached = np.maximum.accumulate(np.arange(n) + shift)  # P's step t happens at C's τ_t
    return shifted_history(start, np.interp(np.arange(n), reached, shift))
