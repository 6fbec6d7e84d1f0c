"""Quantities of interest followed through the LATIN iteration, and the estimate of their
remaining error (issue 16).

Every quantity of interest is a linear functional of the interface fields at each load
step, taken from the same fields as the reported value: a reaction is a weighted sum of F̂
on a boundary, a mean contact pressure a weighted sum of F̂·n (the consistent recovery is
linear), both from the local stage's ŝ; a displacement at a point, from the admissible s, is
φᵀ u_E = φᵀ S_E⁻¹ T_Eᵀ M0 (F + H W) = (T_E S_E⁻¹ φ)ᵀ M0 (F + H W), one solve with the
substructure's factorisation per QoI (``QoiFunctionals``). Their values after each
iteration cost a few dot products.

The estimate (``error_estimates``): the largest change of the QoI over two iterations in
the newer half of the last ``WINDOW`` iterations, |q_i − q_{i−2}|max, summed as a geometric
series with the slower of two measured rates over two iterations, the indicator's
(η_n / η_{n−W})^{2/W} and the QoI's own (the decay of the envelope of its increments from
the window's older half to its newer half):

    error ≈ |q_i − q_{i−2}|max / (1 − ρ²),   ρ² = max(ρ_η², ρ_q²) ≤ 0.999.

(Until session 15 the envelope was taken over the whole window: on the 25-case B1 grid of
``tests/test_qoi_error.py`` a median 11.9 times the true error with the two-scale search
direction, 3.9 with the newer half, none below it; docs/tolerance.md.)

It is an estimate of |q_n − q_∞|, not a proof: measured against tightly converged solves
in docs/tolerance.md (``benchmarks/qoi_error.py``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from ..decomposition.assembly import Assembly
from ..decomposition.interfaces import InterfacePoints
from ..decomposition.qoi import latin_contact_pressures, point_functional
from ..errors import ModelError
from ..fem.elasticity import FloatArray, IntArray
from .operators import LatinOperators

#: iterations the estimate looks back over
WINDOW = 10
#: a two-iteration rate this close to 1 is taken as 1 − 1e-3: the estimate stays finite
MAX_RATE = 0.999
#: the QoI estimates are reported only once the state's own remaining change η / (1 − ρ)
#: (``remaining_change``) is below this: a QoI can stall while the state still moves, and
#: its increments then show no change that has not begun (B1 (0.1, 0.3) at η < 1.5e-3:
#: R_stop 2.9 % off, its estimate 0.42 %, the state's change 1.0 %). Of 161 solves of B1's
#: 7 × 7 grid at tol 1e-5 to 3e-3, the three R_stop estimates below their error had a
#: state change ≥ 4.4e-3 (``benchmarks/estimate_trust.py``, docs/tolerance.md)
SETTLED = 1e-3
#: ``error_estimates`` takes as its rate at least the newest two two-iteration increments'
#: decay from the two before them (their growth: the largest rate), except where the
#: increments turn (False: as before session 61; ``benchmarks/random_studies.py``)
GROWING_CHECK = True
#: ``oscillation_estimates`` taken where sharper (session 34: off — measured, not adopted:
#: B3's cold cases stop 15 % sooner under the studies' rule, but the estimate bounds fewer
#: entries, B1 126 of 128 at η < 1e-6 instead of 128; docs/tolerance.md); the largest
#: misfit of the increments' two-term fit, the largest modulus of its complex roots, and
#: the factor on the sum ahead
OSCILLATION = False
OSCILLATION_FIT = 0.05
OSCILLATION_RATE = 0.97
OSCILLATION_SAFETY = 2.0


def indicator_rate(eta: FloatArray, before: FloatArray, width: int | IntArray
                   ) -> FloatArray:
    """The indicator's rate per iteration over the last ``width`` iterations, (η /
    η_before)^(1 / width): 1 where η_before is zero, NaN where η is."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        rate: FloatArray = np.where(before > 0.0, eta / np.where(before > 0.0, before, 1.0),
                                    1.0) ** (1.0 / np.asarray(width, dtype=np.float64))
    return rate


def remaining_change(eta: FloatArray, before: FloatArray, width: int | IntArray
                     ) -> FloatArray:
    """The state's estimated remaining relative change η / (1 − ρ), ρ = (η / η_before)^(1 /
    width) the indicator's rate per iteration over the last ``width`` iterations (taken
    as ``MAX_RATE`` where it is not measured: η_before zero, or a rate ≥ 1)."""
    rate = np.clip(np.nan_to_num(indicator_rate(eta, before, width), nan=MAX_RATE), 0.0,
                   MAX_RATE)
    return np.asarray(eta / (1.0 - rate), dtype=np.float64)


def state_change(history: FloatArray, window: int = WINDOW) -> float:
    """``remaining_change`` at the end of an indicator history (over its last ``window``
    iterations, or all of them); NaN after a single iteration."""
    width = min(window, history.size - 1)
    if width < 1:
        return float("nan")
    return float(remaining_change(history[-1:], history[-1 - width:-width], width)[0])


@dataclass(frozen=True)
class QoiFunctionals:
    """q[i, t] = Σ_p (on_w[i, p] · W[t, p] + on_f[i, p] · F[t, p] + on_f_hat[i, p] ·
    F̂[t, p]) + constant[i, t] for QoI ``names[i]`` (the constant: body forces' share, which
    does not change during the iteration). Kept sparse: each QoI reads a few points."""

    names: tuple[str, ...]
    on_w: FloatArray  # (n_qoi, n_points, 2)
    on_f: FloatArray  # (n_qoi, n_points, 2)
    on_f_hat: FloatArray  # (n_qoi, n_points, 2)
    #: the load step (from 1) each QoI reports, None for every step (``QuantityOfInterest``)
    steps: tuple[int | None, ...] = ()
    #: (n_qoi, n_steps) added to the values: body forces' share of point QoIs
    #: (``body_forces.with_body_constants``); None: zero
    constant: FloatArray | None = None
    #: per field (W, F, F̂): the flat (point, component) columns read and their coefficients
    parts: tuple[tuple[IntArray, FloatArray], ...] = field(init=False, repr=False)
    #: the same columns as a slice where they are a run (a view: no gather per iteration)
    selectors: tuple[IntArray | slice, ...] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        parts = []
        for coefficients in (self.on_w, self.on_f, self.on_f_hat):
            flat = coefficients.reshape(len(self.names), coefficients[0].size
                                        if len(self.names) else 0)
            used = np.flatnonzero(np.any(flat != 0.0, axis=0))
            parts.append((used, np.ascontiguousarray(flat[:, used].T)))
        object.__setattr__(self, "parts", tuple(parts))
        object.__setattr__(self, "selectors", tuple(_as_slice(used) for used, _ in parts))

    def reported(self, n_steps: int) -> npt.NDArray[np.bool_]:
        """(n_qoi, n_steps): the steps each QoI reports — the values its error and its
        stopping (``LatinOptions.qoi_rtol``) are about. The functionals give every step; a
        QoI of one step (R_stop at step 15) is not waited for at the others."""
        mask = np.ones((len(self.names), n_steps), dtype=bool)
        for i, step in enumerate(self.steps):
            if step is not None:
                mask[i] = np.arange(1, n_steps + 1) == step
        return mask

    def values(self, w: FloatArray, f: FloatArray, f_hat: FloatArray) -> FloatArray:
        """(n_cases, n_qoi, n_steps) from fields shaped (n_cases, n_steps, n_points, 2)."""
        n_cases, n_steps = w.shape[:2]
        total = np.zeros((n_cases * n_steps, len(self.names)))
        for (used, coefficients), columns, values in zip(self.parts, self.selectors,
                                                        (w, f, f_hat), strict=True):
            if used.size:
                total += values.reshape(n_cases * n_steps, -1)[:, columns] @ coefficients
        out = total.reshape(n_cases, n_steps, len(self.names)).transpose(0, 2, 1)
        if self.constant is not None:
            out = out + self.constant[None, :, :n_steps]
        return np.asarray(out, dtype=np.float64)

    def magnitudes(self, w: FloatArray, f: FloatArray, f_hat: FloatArray) -> FloatArray:
        """Σ_p |coefficient| · |field| (+ |constant|), shaped as ``values``: the size of a
        QoI's terms before they cancel. Where a QoI is a small rest of large terms (a point
        held still, read through the substructure's response), its relative accuracy is
        out of the iteration's reach and its floor comes from here (``CANCELLED``)."""
        n_cases, n_steps = w.shape[:2]
        total = np.zeros((n_cases * n_steps, len(self.names)))
        for (used, coefficients), columns, values in zip(self.parts, self.selectors,
                                                        (w, f, f_hat), strict=True):
            if used.size:
                total += (np.abs(values.reshape(n_cases * n_steps, -1)[:, columns])
                          @ np.abs(coefficients))
        out = total.reshape(n_cases, n_steps, len(self.names)).transpose(0, 2, 1)
        if self.constant is not None:
            out = out + np.abs(self.constant[None, :, :n_steps])
        return np.asarray(out, dtype=np.float64)


def _two_term_fit(series: FloatArray, window: int) -> tuple[
        FloatArray, FloatArray, FloatArray, npt.NDArray[np.bool_], FloatArray] | None:
    """The least-squares fit δ_i = a δ_{i−1} + b δ_{i−2} of a QoI's increments over the last
    ``window`` + 2 iterations: (a, b, the misfit relative to the increments' norm, where
    the fit is usable, the increments); None with fewer than 7 iterations."""
    m = min(window + 2, series.shape[0] - 1)
    if m < 6:
        return None
    d = np.diff(series[-(m + 1):], axis=0)
    y, x1, x2 = d[2:], d[1:-1], d[:-2]
    s11, s22, s12 = (x1 * x1).sum(axis=0), (x2 * x2).sum(axis=0), (x1 * x2).sum(axis=0)
    r1, r2, yy = (y * x1).sum(axis=0), (y * x2).sum(axis=0), (y * y).sum(axis=0)
    det = s11 * s22 - s12 * s12
    usable = (det > 1e-12 * s11 * s22) & (yy > 0.0)
    safe = np.where(usable, det, 1.0)
    a = np.where(usable, (r1 * s22 - r2 * s12) / safe, 0.0)
    b = np.where(usable, (r2 * s11 - r1 * s12) / safe, 0.0)
    misfit = np.sqrt(np.maximum(yy - a * r1 - b * r2, 0.0) / np.where(usable, yy, 1.0))
    return a, b, misfit, usable, d


def _turning(series: FloatArray, window: int) -> npt.NDArray[np.bool_]:
    """Where a QoI's increments over the last ``window`` + 2 iterations are a damped
    oscillation: their two-term fit (``_two_term_fit``) within ``OSCILLATION_FIT``, its
    roots complex and inside the unit disc."""
    fit = _two_term_fit(series, window)
    if fit is None:
        return np.zeros(series.shape[1:], dtype=bool)
    a, b, misfit, usable, _ = fit
    return np.asarray(usable & (a * a + 4.0 * b < 0.0) & (-b < 1.0)
                      & (misfit <= OSCILLATION_FIT), dtype=np.bool_)


def _as_slice(used: IntArray) -> IntArray | slice:
    """A run of consecutive columns as a slice (a view: no gather per iteration)."""
    if used.size and used[-1] - used[0] == used.size - 1:
        return slice(int(used[0]), int(used[-1]) + 1)
    return used


def qoi_functionals(ops: LatinOperators, assembly: Assembly,
                    points: InterfacePoints) -> QoiFunctionals:
    """The functionals of ``assembly``'s quantities of interest on the operators' points."""
    n_points = points.n_points
    on_w = np.zeros((len(assembly.qois), n_points, 2))
    on_f = np.zeros_like(on_w)
    on_f_hat = np.zeros_like(on_w)
    k = ops.search_direction.reshape(n_points, 2)
    for i, q in enumerate(assembly.qois):
        if q.kind == "reaction":
            for j, itf in enumerate(assembly.interfaces):
                if itf.condition is not None and itf.condition.name == q.boundary:
                    side = points.side_points[(j, 0)]
                    on_f_hat[i, side, q.component] += q.scale * points.weights[side]
        elif q.kind == "contact_pressure":
            assert q.bodies is not None and q.segment is not None
            first = points.contact_pairs[0]
            unit = latin_contact_pressures(assembly, points, np.eye(first.size))
            try:  # mean = weights · pressure
                weights = unit.mean(frozenset(q.bodies), q.segment)
            except ModelError as exc:
                raise ModelError(f"qoi {q.name!r}: {exc}") from None
            # pressure = −F·n at the contact pair's first-side points
            on_f_hat[i, first] -= q.scale * weights[:, None] * points.normals[first]
        elif q.kind in ("displacement", "stress"):
            s, phi = point_functional(assembly.substructures, q)
            response = np.ravel(ops.factors[s].solve(phi[:, None]))  # S_E⁻¹ φ (S symmetric)
            lo, hi = points.offsets[s], points.offsets[s + 1]
            trace = (points.traces[s] @ response).reshape(hi - lo, 2)
            weights = q.scale * ops.m0[2 * lo:2 * hi].reshape(hi - lo, 2) * trace
            on_f[i, lo:hi] += weights
            on_w[i, lo:hi] += weights * k[lo:hi]
            if ops.two_scale is not None:  # weightsᵀ H W = ((H − D)ᵀ weights)ᵀ W + …
                flat = np.zeros((1, 2 * n_points))
                flat[0, 2 * lo:2 * hi] = weights.ravel()
                on_w[i] += ops.two_scale.transposed_correction(flat).reshape(n_points, 2)
    return QoiFunctionals(tuple(q.name for q in assembly.qois), on_w, on_f, on_f_hat,
                          tuple(q.step for q in assembly.qois))


def estimates_after(series: FloatArray, eta: FloatArray, after: int | None,
                    rate_floor: float = 0.0) -> FloatArray:
    """``error_estimates`` of one case's held QoIs ``series`` (n_iter, n_qoi, n_steps) and
    their η (n_iter,), where NaN (fewer than 6 iterations) how far each QoI moved over them.
    ``after``: how many of them came after a jump (``sliding``; None or not fewer than
    held: none among them): read those alone, how far each moved counted from the iterate
    before the jump (its shift included); across a jump the envelope grows and the
    estimate takes a rate of 0.999. ``rate_floor``: as in ``error_estimates``."""
    moved_from = series
    if after is not None and 0 < after < series.shape[0]:
        moved_from, series, eta = series[-after - 1:], series[-after:], eta[-after:]
    estimate = error_estimates(series, eta[:, None, None], rate_floor=rate_floor)
    moved = moved_from.max(axis=0) - moved_from.min(axis=0)
    return np.where(np.isnan(estimate), moved, estimate)


def error_estimates(series: FloatArray, eta: FloatArray, window: int = WINDOW,
                    rate_floor: float | FloatArray = 0.0) -> FloatArray:
    """Estimated |q_n − q_∞| per QoI and step from the tracked values ``series`` (n_iter,
    n_qoi, n_steps) and the indicator history ``eta`` (n_iter,); NaN with fewer than 6
    iterations. Cases may be stacked after the iteration axis, ``series`` (n_iter, n_cases,
    n_qoi, n_steps) with ``eta`` (n_iter, n_cases, 1, 1).

    On two-iteration increments d_i = q_i − q_{i−2}, over the last ``window`` iterations:
    |d|max over the window's newer half / (1 − ρ²), ρ² the slower of the indicator's rate
    over two iterations, the decay of max |d| from the window's older half to its newer
    half and (``GROWING_CHECK``, unless the increments turn: a damped oscillation) the
    decay of the newest two |d| from the two before them — a slow mode under a fast one
    sets the newest increments before the envelope shows it. Two-iteration steps
    make every mode of the iteration non-alternating (ρ² > 0), so that an oscillating mode
    (the LATIN relaxation's, ρ ≈ −0.8 on B0) neither hides a slow monotone one nor is summed
    as if it were monotone. An envelope that grows over the window (increments of two modes
    of opposite signs cancelling in its older half) shows no convergence of the QoI yet: the
    rate is then taken as 0.999, a large estimate rather than a small wrong one.
    ``rate_floor``: a per-iteration rate the estimate assumes at least (a short window's;
    after a geometric jump, the slowest mode it summed: the modes left decay no faster).
    """
    n = series.shape[0]
    width = min(window, n - 5)
    if width < 2:
        return np.full(series.shape[1:], np.nan)
    recent = series[-(width + 4):]
    steps2 = recent[2:] - recent[:-2]  # width + 2 two-iteration increments
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        rate_eta = np.where(eta[-1 - width] > 0.0,
                            (eta[-1] / np.where(eta[-1 - width] > 0.0, eta[-1 - width], 1.0))
                            ** (2.0 / width), 0.0)
        # the QoI's own rate from the decay of the increments' envelope over the window
        # (older half against newer half): unlike ratios of single increments, robust to an
        # increment that passes through zero when two modes of opposite signs meet
        half = (steps2.shape[0] - 2) // 2
        older = np.abs(steps2[2:2 + half]).max(axis=0)
        newer = np.abs(steps2[-half:]).max(axis=0)
        gap = steps2.shape[0] - 2 - half
        rate_q = (newer / np.where(older > 0.0, older, 1e-300)) ** (2.0 / gap)
        if GROWING_CHECK:
            # and at least the newest two increments' decay from the two before them: a
            # slow mode under a fast one sets the tail's rate before the envelope shows it
            # (random models' studies stopped 2-4 x outside the rule; session 61) — unless
            # the increments turn (a damped oscillation: B3's R_stop), whose envelope it is
            before = np.abs(steps2[-4:-2]).sum(axis=0)
            latest = np.abs(steps2[-2:]).sum(axis=0) / np.where(before > 0.0, before, 1e-300)
            rate_q = np.where((before > 0.0) & ~_turning(series, window),
                              np.maximum(rate_q, latest), rate_q)
    rate = np.clip(np.maximum(np.maximum(np.nan_to_num(rate_q, nan=MAX_RATE),
                                         np.nan_to_num(rate_eta, nan=MAX_RATE)),
                              rate_floor ** 2), 0.0, MAX_RATE)
    estimate = newer / (1.0 - rate)
    if not OSCILLATION:
        return np.asarray(estimate, dtype=np.float64)
    oscillating, misfit = oscillation_estimates(series, window)
    # what the two-term fit leaves unexplained is summed as the envelope's series sums it
    sharper = oscillating + misfit * estimate
    return np.asarray(np.where(np.isfinite(oscillating), np.minimum(estimate, sharper),
                               estimate), dtype=np.float64)


def oscillation_estimates(series: FloatArray, window: int = WINDOW
                          ) -> tuple[FloatArray, FloatArray]:
    """Estimated |q_n − q_∞| where a QoI's increments δ_i = q_i − q_{i−1} over the last
    ``window`` + 2 iterations are a damped oscillation: fitted by δ_i = a δ_{i−1} + b δ_{i−2}
    (least squares) to ``OSCILLATION_FIT`` of their norm, with complex roots of z² − a z − b
    of modulus below ``OSCILLATION_RATE``. The increments still ahead then sum to T = ((a +
    b) δ_n + b δ_{n−1}) / (1 − a − b), and the estimate is ``OSCILLATION_SAFETY`` × max(|T|,
    |δ_n|) (``error_estimates`` adds the misfit times its own, for what the fit leaves
    unexplained, where ``OSCILLATION``); NaN elsewhere. For such a mode the
    envelope's geometric series of ``error_estimates`` sums turns as if they did not turn:
    B3's R_stop oscillates with a period of ~12 iterations at modulus ≈ 0.87, and a cold B3
    case stopped 12 iterations after every error was inside the rule's bound, its largest
    estimate 12 times the bound there (docs/tolerance.md, session 34).
    Returns the estimates and the fit's misfit."""
    fit = _two_term_fit(series, window)
    if fit is None:
        return np.full(series.shape[1:], np.nan), np.ones(series.shape[1:])
    a, b, misfit, usable, d = fit
    # complex roots: a² + 4 b < 0, modulus √(−b)
    held = (usable & (a * a + 4.0 * b < 0.0) & (-b < OSCILLATION_RATE ** 2)
            & (misfit <= OSCILLATION_FIT))
    denominator = np.where(held, 1.0 - a - b, 1.0)  # > 0 for complex roots inside the disc
    ahead = np.abs(((a + b) * d[-1] + b * d[-2]) / denominator)
    return (np.where(held, OSCILLATION_SAFETY * np.maximum(ahead, np.abs(d[-1])), np.nan),
            misfit)
