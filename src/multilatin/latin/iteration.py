"""The control of batched LATIN iterations (method.md §4, §7): η, stopping, relaxation and
the guards, per case, over a batch whose cases may also *join while it runs*.

``BatchIterations`` holds the active cases' fields in a backend (``engine``) and steps
them together; each case keeps its own iteration count, so a case that joins later (a
rolling batch: ``solver.solve_latin_stream``) is stopped, relaxed and extrapolated exactly
as if it had started alone. A batch whose cases all start together (``solve_latin_batch``)
is the special case with no later joins.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt

from ..fem.elasticity import FloatArray, IntArray
from .batching import make_engine
from .case_state import PER_CASE, RECENT, IterationState
from .engine import NumpyFields, indicator_weights
from .extrapolation import ReducedRankExtrapolation
from .guards import (
    DRIFT_WINDOW,
    blows_up,
    damp_stagnating,
    drifts,
    forces_unsettled,
    started_warm,
    vanishes,
)
from .local_stage import LocalStage
from .operators import LatinOperators
from .options import LatinOptions
from .oscillation import OscillationWatch
from .rigid_balance import RigidBalance
from .sliding import WINDOW as SLIDING_WINDOW
from .sliding import SlidingExtrapolation
from .tracking import (
    WINDOW,
    QoiFunctionals,
    error_estimates,
    indicator_rate,
    remaining_change,
)

log = logging.getLogger(__name__)

#: called after every iteration with (iteration, active cases, W, F) of the active cases,
#: s = (W, F) after relaxation, shapes ``(n_active, n_steps, n_points, 2)``; the arrays are
#: the solver's own and change in place on the next iteration (copy what you keep)
IterationObserver = Callable[[int, IntArray, FloatArray, FloatArray], None]

#: with ``qoi_rtol``, η < tol stops a case only once its QoIs' estimates have settled too,
#: or once η is this much below tol: a study honours the accuracy it asked for (session 14:
#: a B1-9 warm case stopped on η 0.69 % off, its estimate saying so)
ETA_STOP_UNDER = 0.1
#: with QoI stopping, no jump (``sliding``) for a case whose QoIs' estimates would fall
#: below their bounds within ``RECENT`` iterations at the indicator's rate: a jump holds
#: the case that long (``BatchIterations._stopping_soon``; session 37: b1-9 and b3 at
#: (0.3, 0.15) 96 → 82 / 83 cold iterations, a jump two iterations before the stop)
JUMP_HOLD = True
#: a leading load step that settles within ``RECENT`` iterations of a jump keeps an
#: estimate read after the jump alone (``IterationState.settled``'s ``since``; session 37:
#: step 1 of b1 (0.3, 0.1), settled four iterations after a jump, kept an estimate read
#: across it, 4 000 × its error, which held the warm start from μ2 = 0.05 until η < 1e-7:
#: 71 iterations instead of 56)
ESTIMATE_AFTER_JUMPS = True
#: lower ω where η oscillates without falling and s goes back and forth
#: (``oscillation``; False: only the stagnation check, as before session 56)
OSCILLATIONS = True
#: with η stopping alone (no ``qoi_rtol``), the iterations a case is held after a jump, as
#: with it. Fewer (session 46: 10, 0) stop sooner, but QoI estimates read over fewer
#: iterates miss their errors more often: not adopted (``benchmarks/eta_hold.py``)
ETA_JUMP_HOLD = RECENT


def state_settled(state: IterationState, active: IntArray, counts: IntArray,
                  rtol: float | FloatArray, window: int = WINDOW) -> npt.NDArray[np.bool_]:
    """Per active case: the state's own remaining change, η / (1 − ρ) with ρ the
    indicator's rate per iteration over the last ``window`` iterations, is below ``rtol``.
    A QoI's increments can stall while the state still moves (a block sliding while the
    QoIs read stay put, then move when it reaches a stop): b1 at (0.1, 0.3) with R_stop
    its only QoI stopped after 35 iterations 2.9 % off, its estimate 0.085 %, η =
    1.4e-3 (docs/tolerance.md). With every B1 QoI watched, cases stop at η ≤ 1.4e-4."""
    eta = state.eta_recent[active, (counts - 1) % RECENT]
    before = state.eta_recent[active, (counts - 1 - window) % RECENT]
    return np.asarray(remaining_change(eta, before, window) <= rtol, dtype=bool)


#: the QoI rule's floor: a QoI's error is asked below rtol × max(|value|, this share of the
#: largest magnitude at its steps over the last ``RECENT`` iterations; over all of them, a
#: start's first reactions to a base moved by 1 mm, 2e6 N, set a 20 N bound on a 31 N
#: reaction, stopped 0.68 % off: ``tests/test_large_displacement.py``)
QOI_FLOOR = 1e-2
#: ... or below rtol × ``CANCELLED`` × the size of its terms at that step
#: (``QoiFunctionals.magnitudes``): a QoI whose terms cancel to a small rest is one the
#: iteration cannot resolve relatively, and gets the same 1 % share of its terms' size as a
#: QoI near zero gets of its largest value (B1 with the stop's gap at 0: u_A ≈ 1e-9 mm from
#: terms of 8e-3 mm held cold solves under the rule to η < 1e-7. Session 53's floor, 1 % of
#: the largest of |value| and a tenth of the terms, still held b1-4 and b1-9 there,
#: 96–121 iterations; with this one, 62–104. A tenth of the terms, 49–62, let two modes of
#: the B1 13 × 13 study differ by 2.3e-3 in u_A at (0, 0.05), beyond the 2e-3 the study's
#: agreement check allows: its floor is 1 % of the grid's largest value; session 55).
#: Elsewhere inert: the terms of B1's QoIs are 1–1.8 times their largest value
CANCELLED = 0.01

#: a case may stop on its QoIs from this many iterations on, before ``WINDOW`` + 5, with
#: the shorter window it has (its count − 5), every estimate below ``EARLY_MARGIN`` times
#: its bound and assuming a rate of at least ``EARLY_RATE`` per iteration. Off (session 35,
#: measured, not adopted: ≤ 2.4 % fewer iterations at margin 0.1, 1–7 % at 1 with estimates
#: read over 2–6 iterations; docs/performance.md, ``benchmarks/study_anatomy.py --early``)
EARLY_COUNT = WINDOW + 5
EARLY_MARGIN = 0.1
EARLY_RATE = 0.0


def qoi_settled(state: IterationState, active: IntArray, counts: IntArray, rtol: float,
                window: int = WINDOW, margin: float | FloatArray = 1.0
                ) -> npt.NDArray[np.bool_]:
    """Per active case: every QoI's estimated error (``tracking.error_estimates``, over the
    last ``window`` + 5 iterations) below ``margin`` × ``rtol`` × max(|value|,
    ``QOI_FLOOR`` (1 %) of the largest magnitude it took lately, ``CANCELLED`` (1 %) of
    its terms' size), at the steps it reports, and
    the state's remaining change below ``margin`` × ``rtol`` (``margin``: one, or one per
    case). ``counts``: each active case's own iterations, at least ``window`` + 5."""
    values = state.qoi_recent[active, (counts - 1) % RECENT]
    margins = np.broadcast_to(np.asarray(margin, dtype=np.float64), active.shape)
    bound = margins[:, None, None] * rtol * np.maximum(np.maximum(
        np.abs(values), QOI_FLOOR * state.qoi_scale[active].max(axis=1)[:, :, None]),
        state.qoi_terms[active])
    ignored = ~state.qoi_reported[active]
    # the estimate is at least the latest two-iteration change: where that alone exceeds
    # the bound, the case goes on without the full estimate
    settled = np.all((np.abs(values - state.qoi_recent[active, (counts - 3) % RECENT])
                      <= bound) | ignored, axis=(1, 2))
    settled &= state_settled(state, active, counts, margins * rtol, window)
    candidates = np.flatnonzero(settled)
    if candidates.size:
        # its last window + 5 iterations, oldest first (iteration i sits at (i − 1) % RECENT)
        read = window + 5
        order = (counts[candidates, None] - read + np.arange(read)) % RECENT
        chosen = active[candidates]
        recent = state.qoi_recent[chosen[:, None], order].transpose(1, 0, 2, 3)
        eta = state.eta_recent[chosen[:, None], order].T
        floor = np.maximum(EARLY_RATE if window < WINDOW else 0.0, state.jump_rate[chosen])
        estimates = np.maximum(error_estimates(recent, eta[:, :, None, None], window,
                                               floor[:, None, None]),
                               state.qoi_settled_error[chosen])
        settled[candidates] = np.all((estimates <= bound[candidates]) | ignored[candidates],
                                     axis=(1, 2))
    return np.asarray(settled, dtype=bool)


class BatchIterations:
    """LATIN iterations of a batch of cases (``step``), each until its η < tol (or its QoIs
    settle, ``qoi_rtol``) or the cap; cases may join a running batch (``join``, NumPy
    backend, relaxation only). Cases are numbered in the order they joined; ``state``
    holds their fields as they leave and their histories."""

    def __init__(self, ops: LatinOperators, local: LocalStage, options: LatinOptions,
                 w_hat: FloatArray, f_hat: FloatArray,
                 observer: IterationObserver | None = None,
                 functionals: list[QoiFunctionals] | None = None,
                 geometries: tuple[list[LatinOperators], IntArray] | None = None) -> None:
        """ŝ = (``w_hat``, ``f_hat``), shapes ``(n_cases, n_steps, n_points, 2)``.
        geometries: the distinct operators of the cases and each case's index into them;
        None: ``ops`` for every case."""
        self.ops, self.options, self.observer = ops, options, observer
        self.local = local  # every case that ever joined, by its number
        n_cases, self.n_steps = w_hat.shape[0], w_hat.shape[1]
        self.n_qoi = len(functionals[0].names) if functionals else 0
        self.tracked = bool(functionals)  # QoIs tracked for their error estimates
        self.state = IterationState.empty(self._reported(functionals, w_hat.shape))
        self.state.warm[:] = started_warm(w_hat, f_hat)
        self.active = np.arange(n_cases)
        self.counts = np.zeros(n_cases, dtype=np.int64)  # per case: its own iterations
        self.iteration = 0  # the batch's steps
        macro_data = self._macro_data(local, n_cases)
        geometries = geometries or ([ops], np.zeros(n_cases, dtype=np.int64))
        self.engine = make_engine(ops, local, options, w_hat, f_hat, macro_data, functionals,
                                  geometries)
        self.relaxation = np.full(n_cases, options.relaxation)  # per active case
        self.oscillations = OscillationWatch()
        self.anderson = options.acceleration == "anderson"
        weights = indicator_weights(ops.points.weights, ops.indicator_k)
        self.force_weight = weights[1]  # the forces' own indicator (``guards``)
        self.sliding = (SlidingExtrapolation(local, n_cases, options.qoi_rtol is not None)
                        if options.extrapolate_sliding and not self.anderson else None)
        self.rre = (ReducedRankExtrapolation(options.rre_cycle, *weights, n_cases)
                    if options.acceleration == "rre" else None)
        self.balance = RigidBalance(ops) if options.rigid_balance else None

    def _reported(self, functionals: list[QoiFunctionals] | None,
                  shape: tuple[int, ...]) -> npt.NDArray[np.bool_]:
        if functionals:
            return np.stack([fn.reported(shape[1]) for fn in functionals])
        return np.ones((shape[0], self.n_qoi, shape[1]), dtype=bool)

    def _macro_data(self, local: LocalStage, n_cases: int) -> FloatArray | None:
        """F_dᴹ per case and step: (n_cases, n_steps, n_macro), or None without a macro
        basis."""
        ops = self.ops
        if ops.macro_basis is None:
            return None
        n_steps = local.prescribed.shape[1]
        # F_d is zero off the boundary points (each an interface's own): Π's columns there
        # only (b3: 0.2 ms a case with the whole fields)
        columns = (2 * local.boundary[:, None] + np.arange(2)).ravel()
        values = local.prescribed_forces().reshape(n_cases * n_steps, -1)
        return np.asarray((ops.project[:, columns] @ values.T).T.reshape(n_cases, n_steps, -1))

    def join(self, local: LocalStage, w_hat: FloatArray, f_hat: FloatArray,
             functionals: list[QoiFunctionals] | None, geometry: LatinOperators
             ) -> IntArray:
        """Cases join the running batch (their own local stage, start ŝ, QoI functionals
        and operators, which share this batch's interfaces); returns their numbers. Their
        first linear stage is not relaxed (as a batch's first is not)."""
        if not isinstance(self.engine, NumpyFields) or self.anderson or self.rre is not None:
            raise ValueError("cases join a running batch on the NumPy backend with "
                             "relaxation only")
        n_new = w_hat.shape[0]
        first = len(self.state.histories)
        numbers = np.arange(first, first + n_new)
        self.state.extend(self._reported(functionals, w_hat.shape))
        self.state.warm[first:first + n_new] = started_warm(w_hat, f_hat)
        self.local = self.local.joined(local)
        self.counts = np.concatenate([self.counts, np.zeros(n_new, dtype=np.int64)])
        self.engine.join(local, w_hat, f_hat, self._macro_data(local, n_new), functionals,
                         geometry)
        self.active = np.concatenate([self.active, numbers])
        self.relaxation = np.concatenate([self.relaxation, np.full(n_new, 1.0)])
        if self.sliding is not None:
            self.sliding.join(self.local, n_new)
        return numbers

    def renumber(self) -> IntArray:
        """The active cases become cases 0 … n − 1 in their order, and what the batch kept
        for the cases that left (their histories, QoI buffers, local-stage data) is let go:
        a rolling batch that never empties stays as large as its width, not as the number of
        cases that went through it. Returns the active cases' former numbers. Only between
        steps, with no case's exit fields left in ``state``."""
        if not isinstance(self.engine, NumpyFields) or self.state.exits:
            raise ValueError("renumber: NumPy backend, exit fields handed on first")
        kept = self.active.copy()
        state = self.state
        for name in PER_CASE:
            setattr(state, name, getattr(state, name)[kept])
        state.histories = [state.histories[c] for c in kept]
        state.sizes = [state.sizes[c] for c in kept]
        self.counts = self.counts[kept]
        self.local = self.local.subset(kept)
        self.engine.renumber()
        if self.sliding is not None:
            self.sliding.renumber(kept, self.local)
        if self.balance is not None:
            self.balance.renumber(kept)
        self.active = np.arange(kept.size)
        return kept

    def _stopping_soon(self) -> npt.NDArray[np.bool_] | None:
        """Per active case (after this iteration's leavers went): whether, with QoI
        stopping, its QoIs' estimates are within reach of their bounds — at the rate the
        indicator fell over the last window, below them in fewer than ``RECENT``
        iterations, the hold a jump imposes. A jump there costs more than it saves."""
        options, active = self.options, self.active
        if options.qoi_rtol is None or not self.tracked or not JUMP_HOLD:
            return None
        counts = self.counts[active]
        due = np.flatnonzero((counts % SLIDING_WINDOW == 0) & (counts >= WINDOW + 5))
        hold = np.zeros(active.size, dtype=bool)
        if not due.size:
            return hold
        state = self.state
        now = state.eta_recent[active[due], (counts[due] - 1) % RECENT]
        before = state.eta_recent[active[due], (counts[due] - 1 - WINDOW) % RECENT]
        rate = np.clip(np.nan_to_num(indicator_rate(now, before, WINDOW), nan=1.0), 1e-3,
                       1.0)
        margin = np.minimum(rate ** -float(RECENT), 1e6)
        hold[due] = qoi_settled(state, active[due], counts[due], options.qoi_rtol,
                                margin=margin)
        return hold

    def step(self) -> IntArray:
        """One iteration of every active case; returns the cases that left the batch
        (converged, failed, or at the cap), their fields in ``state``."""
        options, out, engine = self.options, self.state, self.engine
        self.iteration += 1
        active = self.active
        self.counts[active] += 1
        counts = self.counts[active]
        relaxation = self.relaxation
        engine.linear_stage(relaxation)
        relaxation[counts == 1] = options.relaxation  # a joined case: relaxed from now on
        if self.observer is not None:
            w, f = engine.fields()[:2]
            self.observer(self.iteration, active, w, f)
        engine.local_stage()
        if self.tracked:  # the QoIs, for their error estimate (tracking.py)
            values = engine.qoi_values()
            out.qoi_recent[active, (counts - 1) % RECENT] = values
            if options.qoi_rtol is not None:  # the floor only the QoI rule reads
                out.qoi_terms[active] = CANCELLED * engine.qoi_magnitudes()
            out.qoi_scale[active, (counts - 1) % RECENT] = np.where(
                out.qoi_reported[active], np.abs(values), 0.0).max(axis=2, initial=0.0)
        # η = ‖s − ŝ‖ / ½(‖s‖ + ‖ŝ‖), ‖s‖² = Σ_t Σ_points ∫ (k⁻¹ F·F + k W·W) dΓ (§4.3)
        gap, size = engine.indicator()
        # a NaN or overflowed norm leaves η NaN; η = 0 only for a zero solution (no load)
        eta = np.full_like(gap, np.nan)
        finite = np.isfinite(gap) & np.isfinite(size)
        np.divide(gap, size, out=eta, where=finite & (size > 0))
        eta[finite & (size == 0)] = 0.0  # then gap = 0 too (gap ≤ ‖s‖ + ‖ŝ‖)
        out.eta_recent[active, (counts - 1) % RECENT] = eta
        if isinstance(engine, NumpyFields):
            before = engine.first.copy()
            engine.settle(size, options.settled_steps * options.tol)
            for position in np.flatnonzero(engine.first > before).tolist():
                since = (int(self.sliding.jumped_at[active[position]])
                         if self.sliding is not None and ESTIMATE_AFTER_JUMPS else -1)
                out.settled(int(active[position]), int(counts[position]),
                            slice(int(before[position]), int(engine.first[position])),
                            since if since >= 0 else None)
        for c, value, norm in zip(active, eta, size, strict=True):
            out.histories[c].append(float(value))
            out.sizes[c].append(float(norm))
        if self.iteration % 50 == 0:
            log.debug("iteration %d: eta = %.3e (worst of %d cases)", self.iteration,
                      eta.max(), active.size)
        if OSCILLATIONS and not self.anderson:
            self.oscillations(engine, active, counts, out.histories, relaxation, options)
        due = np.flatnonzero(counts % options.stagnation_window == 0)
        if due.size and not self.anderson:
            damped = relaxation[due]
            damp_stagnating(out.histories, active[due], damped, options)
            relaxation[due] = damped
        capped = counts >= options.max_iter
        # with QoI stopping, none within ``RECENT`` iterations of a jump: its check one window
        # later runs first, and the QoIs' estimates then read iterates after it alone
        out.jumped_at[active] = -1 if self.sliding is None else self.sliding.jumped_at[active]
        out.jump_rate[active] = 0.0 if self.sliding is None else self.sliding.jump_rate[active]
        held = RECENT if options.qoi_rtol is not None else ETA_JUMP_HOLD
        after_jumps = (out.jumped_at[active] < 0) | (counts - out.jumped_at[active] > held)
        first = counts == 1
        out.first_size[active[first]] = size[first]
        blown = blows_up(size, out.first_size[active])
        blown |= vanishes(size, out.first_size[active], out.warm[active])
        done = ((eta < options.tol) & after_jumps) | ~np.isfinite(eta) | capped | blown
        due = (counts % DRIFT_WINDOW == 0) & ~done
        if due.any():
            drifting = np.zeros_like(done)
            # a sliding jump moves s by a crawl's remaining iterations at once: the growth
            # is read from the last jump on (a slide without end has no gap ahead to jump to)
            drifting[due] = [drifts(out.sizes[c][max(int(out.jumped_at[c]), 0):])
                             for c in active[due]]
            out.drifting[active[drifting]] = True
            done |= drifting
        if options.qoi_rtol is not None and self.tracked:
            eligible = np.flatnonzero(counts >= WINDOW + 5)
            settled = np.zeros_like(done)
            settled[eligible] = qoi_settled(out, active[eligible], counts[eligible],
                                            options.qoi_rtol)
            early = np.flatnonzero((counts >= EARLY_COUNT) & (counts < WINDOW + 5))
            for count in np.unique(counts[early]).tolist():
                rows = early[counts[early] == count]
                settled[rows] = qoi_settled(out, active[rows], counts[rows], options.qoi_rtol,
                                            count - 5, EARLY_MARGIN)
            # η < tol alone is no QoI accuracy
            done &= (settled | ~np.isfinite(eta) | (eta < ETA_STOP_UNDER * options.tol)
                     | capped | blown | out.drifting[active] | (counts < WINDOW + 5))
            on_qoi = settled & ~done & np.isfinite(eta) & after_jumps
            out.stopped_on_qoi[active[on_qoi]] = True
            done |= on_qoi
        fields = self._forces_checked(done, eta, capped | blown)
        leaving = active[done]
        if self.balance is not None:
            for case in leaving.tolist():
                self.balance.forget(case)
        if leaving.size:
            assert fields is not None
            for i, case in enumerate(leaving.tolist()):
                out.exits[case] = (fields[0][i], fields[1][i], fields[2][i], fields[3][i])
            keep = np.flatnonzero(~done)
            self.active = active[keep]
            self.relaxation = relaxation[keep]
            if keep.size:
                engine.keep(keep)
        if self.rre is not None and self.active.size:
            for case in self.rre(self.active, engine):
                if self.sliding is not None:
                    self.sliding.forget(case)
        if self.sliding is not None and self.active.size:
            hold = self._stopping_soon()
            for case in self.sliding(self.counts[self.active], self.active, eta[~done],
                                     engine, hold):
                if self.rre is not None:
                    self.rre.forget(case)
        if self.balance is not None and self.active.size:
            assert isinstance(engine, NumpyFields)
            self.balance(engine, self.active)
        out.t_linear, out.t_macro, out.t_local = engine.t_linear, engine.t_macro, engine.t_local
        return leaving

    def _forces_checked(self, done: npt.NDArray[np.bool_], eta: FloatArray,
                        ended: npt.NDArray[np.bool_]) -> tuple[FloatArray, ...] | None:
        """The fields of the active cases that leave (``done``, updated in place: a case
        whose forces have not settled goes on, ``guards.forces_unsettled``)."""
        positions = np.flatnonzero(done)
        if not positions.size:
            return None
        fields: tuple[FloatArray, ...] = self.engine.fields(positions)
        on_qois = self.tracked and self.options.qoi_rtol is not None
        going_on = forces_unsettled(self.state, self.active[positions], fields,
                                    eta[positions], ended[positions], self.force_weight,
                                    self.options, ETA_STOP_UNDER if on_qois else 1.0,
                                    RECENT if self.options.qoi_rtol is None else 0)
        if going_on.any():
            done[positions[going_on]] = False
            fields = tuple(x[~going_on] for x in fields)
        return fields


def iterate(ops: LatinOperators, local: LocalStage, options: LatinOptions,
            w_hat: FloatArray, f_hat: FloatArray, observer: IterationObserver | None = None,
            functionals: Sequence[QoiFunctionals] | None = None,
            geometries: tuple[list[LatinOperators], IntArray] | None = None
            ) -> IterationState:
    """Batched LATIN iterations from ŝ = (``w_hat``, ``f_hat``), every case until it
    leaves (``BatchIterations``)."""
    batch = BatchIterations(ops, local, options, w_hat, f_hat, observer,
                            list(functionals) if functionals is not None else None,
                            geometries)
    while batch.active.size:
        batch.step()
    return batch.state
