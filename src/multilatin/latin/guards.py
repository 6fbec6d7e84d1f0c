"""The guards of the LATIN iteration's control (``solver._iterate``) for cases that do not
converge the normal way: a state that grows without end (no equilibrium), one that blows
up (an unstable iteration), a warm start that vanishes or that nothing loads, an η that
stagnates (the relaxation lowered), and what a case at the cap leaves free."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from ..decomposition.uniqueness import free_motions_batch
from ..fem.elasticity import FloatArray, IntArray
from .indicator_kernel import weighted_squares
from .options import LatinOptions

if TYPE_CHECKING:
    from ..decomposition.assembly import Assembly
    from ..decomposition.interfaces import InterfacePoints
    from ..decomposition.result import SolveResult
    from .body_forces import BodyResponse
    from .local_stage import LocalStage

__all__ = ["BLOWUP", "CAPPED", "DRIFT_WINDOW", "FORCE_FLOOR", "FORCE_MARGIN",
           "FORCE_ROUNDOFF", "LOWEST_RELAXATION", "NO_EQUILIBRIUM", "RELAXATION_STEP",
           "START_FAILURES", "STEP_SPREAD", "VANISH", "blows_up", "can_lower",
           "damp_stagnating", "drifting_steps", "drifts", "drop_unloaded_starts",
           "explain_capped", "force_indicator", "forces_unsettled", "lowered", "started_warm",
           "unloaded", "vanishes"]

log = logging.getLogger(__name__)

#: every so many iterations, a case whose ½(‖s‖ + ‖ŝ‖) grew by as much in the second half of
#: the window as in the first (and by more than 0.1 %) is stopped as having no equilibrium
DRIFT_WINDOW = 100
#: a case whose ½(‖s‖ + ‖ŝ‖) grows beyond this many times its value after the first
#: iteration is stopped as diverging. The first linear stage is already the elastic answer's
#: scale: over the B1 13 × 13 and B3 5 × 5 studies (cold and warm) the size never grew past
#: 1.03 × its first value, over every bundled model 2.4 × (lug), and 4.3 × in the tests'
#: cases with no equilibrium, stopped by ``drifts`` (session 38, ``benchmarks/blowup.py``)
BLOWUP = 1e3
#: a warm-started case whose ½(‖s‖ + ‖ŝ‖) falls below this share of its value after the
#: first iteration stops as "vanished": its answer is zero, or far below the neighbour's it
#: started from. η, relative to the fields' size, then stays put while they decay: a spun
#: hub at ω = 0 and no interference (answer zero) started from its neighbour at ω = 500
#: rad/s ran 1 000 iterations at η = 0.36, its fields 1e-7 of their start by iteration 50,
#: 1e-65 by 400 (session 52). Studies solve such a case again from zero (``study.starts``);
#: a case nothing loads drops its warm start at once (``drop_unloaded_starts``)
VANISH = 1e-6
#: a drifting case's steps whose s − ŝ (relative to each step's size) is within this factor
#: of the worst step's are named as those without equilibrium (``drifting_steps``)
STEP_SPREAD = 1e-2
#: how the failure of a drifting case begins: no equilibrium exists, whatever the start
NO_EQUILIBRIUM = "no equilibrium"
#: how the failure of a case at the cap (``max_iter``) begins: η, then its value
CAPPED = "eta = "
#: how the failures a start can cause begin (``solver``'s messages): fields that vanish
#: from it (``vanishes``), blow up (``blows_up``) or overflow. A study solves a warm start
#: that failed so again from zero (``study.starts.set_aside``); not one that reached the
#: cap (the lap joint at p = 0 crawls there from either start: solved again, 1 000 → 2 000
#: iterations for the same failure, session 52) or has no equilibrium
START_FAILURES = ("vanished", "diverged", "non-finite")


#: a case stops only where its interface forces have converged too: their own indicator
#: η_F = ‖F − F̂‖ / ½(‖F‖ + ‖F̂‖) (the force part of §4.3's norm) at most ``FORCE_MARGIN`` ×
#: ``tol`` where η stopped it, at most ``qoi_rtol`` where its QoIs did. η's size counts the
#: interface displacements as k‖W‖², so a prescribed displacement that moves the assembly by
#: far more than it deforms leaves η small while the forces are still far from balanced:
#: the sliding block pushed by a force beyond what friction holds, its foundation moved
#: 100 mm, "converged" in 46 iterations with η = 5e-9 and η_F = 2.3e-3 (no equilibrium
#: exists). At the stop η_F / η measured 0.8–2.6 on every bundled model but the cantilever
#: B0 (51, its size being its deflection); under the QoI rule η_F ≤ 2.6e-4 (session 41,
#: docs/correctness.md)
FORCE_MARGIN = 100.0
#: η_F's size ½(‖F‖ + ‖F̂‖) is at least this share of the state's ½(‖s‖ + ‖ŝ‖): forces
#: below it are zero to the solver's precision. Where the answer has no interface force at
#: all (a block moved rigidly by a prescribed displacement, its contact never closing) the
#: relative η_F read rounding (0.2 with forces of 3e-15 against a state of 4.9) and the case
#: ran to ``max_iter`` as "not converged" (session 45). The moved block above has forces
#: of 2.2e-6 of its state: the floor leaves its guard as it was.
FORCE_FLOOR = 1e-8
#: ‖F − F̂‖ below this share of the state's size is rounding: F is a difference of
#: state-sized terms (F̂ + H (Ŵ − W)). A stress-free answer (a plate expanding freely under a
#: temperature change) stopped at η = 3e-16 with ‖F − F̂‖ at 2.5e-16 of its state, which
#: over ``FORCE_FLOOR`` read η_F = 2.5e-8, above the bound 100 tol of tol = 1e-10: the case
#: ran to ``max_iter`` (session 48). The moved block above stops with 2e-10 of its state.
FORCE_ROUNDOFF = 1e-13


def force_indicator(force_weight: FloatArray, force: FloatArray, force_hat: FloatArray,
                    state_size: FloatArray | None = None) -> FloatArray:
    """η_F per case (first axis) of fields ``(n_cases, n_steps, n_points, 2)``: ‖F − F̂‖ /
    ½(‖F‖ + ‖F̂‖), ‖F‖² = Σ_t Σ_points ∫ k⁻¹ F·F dΓ (``force_weight``: ∫ k⁻¹ per flattened
    point and component); 0 where both are zero. ``state_size``: per case, the state's
    ½(‖s‖ + ‖ŝ‖): the size is at least ``FORCE_FLOOR`` times it, and a gap of at most
    ``FORCE_ROUNDOFF`` times it is zero."""
    gap = np.sqrt(weighted_squares(force_weight, force - force_hat))
    size = 0.5 * (np.sqrt(weighted_squares(force_weight, force))
                  + np.sqrt(weighted_squares(force_weight, force_hat)))
    if state_size is not None:
        size = np.maximum(size, FORCE_FLOOR * state_size)
        gap = np.where(gap <= FORCE_ROUNDOFF * state_size, 0.0, gap)
    out = np.zeros(force.shape[0])
    np.divide(gap, size, out=out, where=size > 0.0)
    out[(size == 0.0) & (gap > 0.0)] = np.inf
    return out


def forces_unsettled(state: Any, cases: IntArray, fields: Sequence[FloatArray],
                     eta: FloatArray, ended: npt.NDArray[np.bool_], force_weight: FloatArray,
                     options: LatinOptions, eta_under: float = 1.0, jump_hold: int = 0
                     ) -> npt.NDArray[np.bool_]:
    """Per case leaving the batch (``cases``, their ``fields`` (W, F, Ŵ, F̂) and η): its
    forces' η_F above its bound, so that it goes on — ``FORCE_MARGIN`` × η's bound where η
    stopped it (``tol``, or ``eta_under`` × tol where η below that stopped it before its
    QoIs settled), ``qoi_rtol`` where its QoIs did (``state.stopped_on_qoi``, cleared
    there). One at the cap (``ended``) leaves, its η_F kept in ``state.force_eta`` (its
    result: not converged). Failures (η not finite, a drift) are not checked. Within
    ``jump_hold`` iterations of a jump (``sliding``; where η alone may stop a case there,
    ``iteration.ETA_JUMP_HOLD``) the bound is η's own, without ``FORCE_MARGIN``: an
    extrapolated s can leave η small while its forces are still off (the moved block of
    ``tests/test_large_displacement.py`` stopped 0.18 % off with η_F below 100 tol)."""
    on_qoi = state.stopped_on_qoi[cases]
    checked = np.isfinite(eta) & ~state.drifting[cases] & ((eta < options.tol) | on_qoi)
    unsettled = np.zeros(cases.size, dtype=bool)
    eta_force = np.zeros(cases.size)
    if checked.any():
        state_size = np.array([state.sizes[c][-1] if state.sizes[c] else 0.0
                               for c in cases[checked]])
        eta_force[checked] = force_indicator(force_weight, fields[1][checked],
                                             fields[3][checked], state_size)
        # η's own bound: ``tol``, or ``eta_under`` × tol where η that far under it stopped
        # the case before its QoIs' estimates settled (``iteration.ETA_STOP_UNDER``)
        on_eta = options.tol * np.where(eta < eta_under * options.tol, eta_under, 1.0)
        jumped = np.asarray(state.jumped_at)[cases[checked]]  # −1: no jump
        since = np.array([len(state.histories[c]) for c in cases[checked]]) - jumped
        margin = np.where((jumped >= 0) & (since <= jump_hold), 1.0, FORCE_MARGIN)
        bound = np.where(on_qoi, np.inf if options.qoi_rtol is None else options.qoi_rtol,
                         margin * on_eta)
        unsettled = checked & (eta_force > bound)
    state.force_eta[cases] = np.where(unsettled & ended, eta_force, 0.0)
    going_on = unsettled & ~ended
    state.stopped_on_qoi[cases[going_on]] = False
    return np.asarray(going_on, dtype=bool)


def drifts(sizes: list[float]) -> bool:
    """The state's norm grows at a steady rate over the last ``DRIFT_WINDOW`` iterations: a
    rigid sliding that never ends, not a convergence (whose growth decays geometrically:
    B1's slowest tails, 0.985 per iteration, halve it over half a window)."""
    if len(sizes) < DRIFT_WINDOW + 1:
        return False
    half = DRIFT_WINDOW // 2
    first = sizes[-1 - half] - sizes[-1 - DRIFT_WINDOW]
    second = sizes[-1] - sizes[-1 - half]
    return bool(first > 0.0 and second >= 0.9 * first and second > 1e-3 * sizes[-1])


def drifting_steps(weights: FloatArray, w: FloatArray, f: FloatArray, w_hat: FloatArray,
                   f_hat: FloatArray) -> tuple[list[int], float]:
    """The load steps (1-based) of a drifting case whose fields have not settled — s − ŝ
    at least ``STEP_SPREAD`` of the worst step's, relative to each step's own size (points
    weighted by their lengths) — and the largest such share among the others: the steps
    where no equilibrium exists (the block pushed by a rising force of
    ``tests/test_held_by_contact.py``: steps 9–10 at 8.3e-3 and 3.2e-2, steps 1–8 at most
    1.8e-7 of their sizes). Fields ``(n_steps, n_points, 2)``."""
    def relative(x: FloatArray, x_hat: FloatArray) -> FloatArray:
        gap = np.sqrt(np.einsum("tpc,p->t", np.square(x - x_hat), weights))
        size = np.sqrt(np.einsum("tpc,p->t", np.square(x_hat), weights))
        return np.asarray(np.where(size > 0.0, gap / np.where(size > 0.0, size, 1.0),
                                   np.where(gap > 0.0, np.inf, 0.0)))

    share = np.maximum(relative(w, w_hat), relative(f, f_hat))
    worst = float(share.max()) if share.size else 0.0
    unsettled = share >= STEP_SPREAD * worst
    others = share[~unsettled]
    return ([int(t) + 1 for t in np.flatnonzero(unsettled)],
            float(others.max()) if others.size else float("nan"))


def blows_up(size: FloatArray, first_size: FloatArray) -> npt.NDArray[np.bool_]:
    """Per case: its ½(‖s‖ + ‖ŝ‖) ``size`` beyond ``BLOWUP`` times ``first_size``, its
    value after the first iteration. η is relative to that size: an iteration that grows
    without bound in a mode the local stage keeps (s ≈ ŝ there) sees η fall while its
    fields run away (session 37: a trial step reached η < tol with fields of 1e14). A
    first size of zero (no load yet) sets no bound."""
    return np.asarray((first_size > 0.0) & (size > BLOWUP * first_size), dtype=bool)


def started_warm(w_hat: FloatArray, f_hat: FloatArray) -> npt.NDArray[np.bool_]:
    """Per case of ŝ = (``w_hat``, ``f_hat``): whether it starts from fields other than
    zero."""
    n_cases = w_hat.shape[0]
    return np.asarray(np.any(w_hat.reshape(n_cases, -1) != 0.0, axis=1)
                      | np.any(f_hat.reshape(n_cases, -1) != 0.0, axis=1), dtype=bool)


def vanishes(size: FloatArray, first_size: FloatArray, warm: npt.NDArray[np.bool_]
             ) -> npt.NDArray[np.bool_]:
    """Per case: warm-started and its ½(‖s‖ + ‖ŝ‖) ``size`` below ``VANISH`` times its
    ``first_size`` (after the first iteration). From zero the first size is the answer's
    scale; from a neighbour's fields it is the neighbour's."""
    return np.asarray(warm & (first_size > 0.0) & (size < VANISH * first_size), dtype=bool)


def unloaded(local: LocalStage, bodies: Sequence[BodyResponse | None]
             ) -> npt.NDArray[np.bool_]:
    """Per case: nothing loads it — no prescribed displacement or force, no interference
    (every contact and stop gap ≥ 0), no body force, temperature change or point load — so
    that its answer is zero, reached from zero in one iteration. A warm start there would
    only decay (``vanishes``). Something missed here costs a solve from zero, never an
    answer."""
    n_cases = local.prescribed.shape[0]
    quiet = ~np.any(local.prescribed.reshape(n_cases, -1) != 0.0, axis=1)
    quiet &= np.all(local.gap_contact.reshape(n_cases, -1) >= 0.0, axis=1)
    quiet &= np.all(local.gap_stop.reshape(n_cases, -1) >= 0.0, axis=1)
    for c, body in enumerate(bodies):
        if body is not None and (np.any(body.offsets != 0.0)
                                 or any(np.any(x != 0.0) for x in body.interior.values())):
            quiet[c] = False
    return np.asarray(quiet, dtype=bool)


def drop_unloaded_starts(local: LocalStage, bodies: Sequence[BodyResponse | None],
                         w_hat: FloatArray, f_hat: FloatArray, labels: Sequence[str]) -> None:
    """The warm starts ŝ = (``w_hat``, ``f_hat``) of the cases nothing loads (``unloaded``)
    set to zero, in place: from zero such a case is done in one iteration."""
    for c in np.flatnonzero(started_warm(w_hat, f_hat) & unloaded(local, bodies)).tolist():
        log.info("%s: nothing loads it; its warm start is dropped (from zero: one "
                 "iteration)", labels[c])
        w_hat[c] = f_hat[c] = 0.0


#: a lowered relaxation: ω − ``RELAXATION_STEP``, not below ``LOWEST_RELAXATION`` (the
#: stagnation check here and the oscillation watch, ``oscillation``)
RELAXATION_STEP = 0.1
LOWEST_RELAXATION = 0.5


def can_lower(omega: float) -> bool:
    """Whether ω is above ``LOWEST_RELAXATION`` (to rounding)."""
    return bool(omega > LOWEST_RELAXATION + 1e-12)


def lowered(omega: float) -> float:
    """ω lowered by ``RELAXATION_STEP``, not below ``LOWEST_RELAXATION``."""
    return max(float(omega) - RELAXATION_STEP, LOWEST_RELAXATION)


def damp_stagnating(histories: list[list[float]], active: IntArray, relaxation: FloatArray,
                    options: LatinOptions) -> None:
    """Lower ω (in place, ``lowered``) of the active cases whose η stagnated over the last
    ``stagnation_window`` iterations (see ``LatinOptions``)."""
    window = options.stagnation_window
    for position, case in enumerate(active):
        history = histories[case]
        if len(history) < 2 * window or not can_lower(relaxation[position]):
            continue
        latest, before = min(history[-window:]), min(history[-2 * window:-window])
        if latest > options.stagnation_ratio * before:
            relaxation[position] = lowered(relaxation[position])
            log.info("case %d of the batch: eta stagnates (%.2e after %.2e), relaxation "
                     "lowered to %.1f", case, latest, before, relaxation[position])


def explain_capped(results: list[SolveResult],
                   exits: Sequence[tuple[FloatArray, FloatArray, FloatArray, FloatArray]],
                   assemblies: Sequence[Assembly], points: Sequence[InterfacePoints]
                   ) -> list[SolveResult]:
    """The results that reached the cap (``max_iter``), their failure completed with what
    their last state (``exits``: per result (W, F, Ŵ, F̂)) leaves free — a body nothing holds,
    along which the iteration crawls, says why better than "a larger max_iter may
    converge" (session 52: the lap joint at p = 0, its upper plate free to lift)."""
    capped = [n for n, result in enumerate(results) if result.failure.startswith(CAPPED)]
    if not capped:
        return results
    motions = free_motions_batch([assemblies[n] for n in capped], [points[n] for n in capped],
                                 [exits[n][2] for n in capped], [exits[n][3] for n in capped])
    out = list(results)
    for n, found in zip(capped, motions, strict=True):
        if not found:
            continue
        motion = next((m for m in found if m.reaches_last_step), found[-1])
        more = f" (and {len(found) - 1} more)" if len(found) > 1 else ""
        out[n] = replace(results[n], failure=(
            f"{results[n].failure}; in its last state, {motion.describe()}{more}: a body "
            "nothing holds may be what the iteration crawls along — `multilatin reference` "
            "says whether the discrete problem determines the answer"))
    return out
