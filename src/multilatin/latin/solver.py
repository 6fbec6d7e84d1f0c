"""The LATIN micro-macro solver (paper §2.3, §4; method.md §4).

Every load step is one column of the same right-hand side: the linear stage solves all
steps at once. The linear stage works on interface quantities only, through the condensed
operator ``C_E = T_E (K_E + T_Eᵀ M0 k T_E)⁻¹ T_Eᵀ M0`` of each substructure (computed once
per geometry from its factorisation), so that W = C (F̂ + k Ŵ + k W̃ᴹ) (eq. [13]).
Interior displacements are recovered once, at the end.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass

import numpy as np
import numpy.typing as npt

from ..decomposition.assembly import Assembly
from ..decomposition.interfaces import InterfacePoints, with_contact_data
from ..decomposition.qoi import evaluate_qois, latin_contact_pressures
from ..decomposition.result import InterfaceFields, SolveResult
from ..decomposition.uniqueness import free_motions
from ..errors import ModelError, NotConvergedError
from ..fem.elasticity import FloatArray, IntArray
from ..limits import check_scale
from .batching import interface_families, operators_per_case
from .engine import FieldEngine, NumpyFields, indicator_weights, one_blas_thread
from .extrapolation import ReducedRankExtrapolation
from .guards import DRIFT_WINDOW, damp_stagnating, drifts
from .local_stage import LocalStage
from .operators import LatinOperators
from .options import LatinOptions
from .sliding import SlidingExtrapolation
from .tracking import WINDOW, QoiFunctionals, error_estimates, qoi_functionals

__all__ = ["IterationObserver", "solve_latin", "solve_latin_batch"]

log = logging.getLogger(__name__)

#: called after every iteration with (iteration, active cases, W, F) of the active cases,
#: s = (W, F) after relaxation, shapes ``(n_active, n_steps, n_points, 2)``; the arrays are
#: the solver's own and change in place on the next iteration (copy what you keep)
IterationObserver = Callable[[int, IntArray, FloatArray, FloatArray], None]


def solve_latin(assembly: Assembly, options: LatinOptions | None = None,
                operators: LatinOperators | None = None, check: bool = True,
                initial: tuple[FloatArray, FloatArray] | None = None,
                observer: IterationObserver | None = None) -> SolveResult:
    """Solve ``assembly`` with the micro-macro LATIN method.

    operators: reuse the operators of an assembly with the same geometry (checked by
        signature), e.g. across friction coefficients, gaps or loads.
    initial: start from these interface fields ŝ = (Ŵ, F̂), shapes ``(n_steps, n_points,
        2)`` — typically a neighbouring converged solution (multiresolution, paper §6) —
        beginning with a linear stage; None starts from ŝ = 0.
    observer: see ``IterationObserver`` (diagnostics, e.g. ``benchmarks/tail_modes.py``).

    Raises ``NotConvergedError`` (with the unconverged result attached) when η ≥ tol after
    ``max_iter`` iterations, unless ``check`` is False.
    """
    return solve_latin_batch([assembly], options, operators, check, [initial],
                             observer)[0]


def solve_latin_batch(
    assemblies: Sequence[Assembly],
    options: LatinOptions | None = None,
    operators: LatinOperators | Sequence[LatinOperators] | None = None,
    check: bool = True,
    initial: Sequence[tuple[FloatArray, FloatArray] | None] | None = None,
    observer: IterationObserver | None = None,
) -> list[SolveResult]:
    """Solve cases that share their operators (same geometry and search direction; friction
    coefficients, gaps and loads may differ) together, as one batched LATIN iteration
    (method.md §7): the linear stage sees the steps of every case as more right-hand-side
    columns of the same condensed operators, the local stage is vectorised over the cases,
    and each case leaves the batch as soon as its own η < tol. The answers are those of
    ``solve_latin`` case by case; a batch is faster because it replaces many small products
    by few large ones.

    operators: for every case (one ``LatinOperators``), per case (a sequence), or None
        (built here). Cases of several geometries may share a batch: those that share the
        interface discretisation are solved together (a hole moved inside
        a substructure: the substructures that differ, and the macro operator, act per
        geometry on its cases' columns, the others on all at once); other cases are
        solved as batches of their own (``batching.interface_families``), the results in
        the cases' order.
    initial: per case, the interface fields to start from (see ``solve_latin``) or None.
    observer: see ``IterationObserver``.
    With the torch backend, a batch larger than the device's memory holds is solved in
    chunks (``torch_engine.cases_per_chunk``); the observer then sees each chunk's cases.
    Results carry the batch's timings (``timings["batch_size"]``).
    """
    if not assemblies:
        raise ModelError("a batch needs at least one case")
    first = assemblies[0]
    if isinstance(operators, LatinOperators):
        options = options or operators.options
    options = options or LatinOptions()
    t0 = time.perf_counter()
    ops_list, geometry = operators_per_case(assemblies, options, operators)
    t_setup = time.perf_counter() - t0
    starts = list(initial) if initial is not None else [None] * len(assemblies)
    if len(starts) != len(assemblies):
        raise ModelError(f"initial: expected {len(assemblies)} entries (one per case), got "
                         f"{len(starts)}")
    # one batch per family of interfaces (geometries that differ inside substructures
    # only); answers in order
    groups = interface_families(ops_list)[geometry]
    if np.any(groups != groups[0]):
        by_case: dict[int, SolveResult] = {}
        for group in np.unique(groups):
            members = np.flatnonzero(groups == group).tolist()
            part = solve_latin_batch([assemblies[i] for i in members], options,
                                     [ops_list[geometry[i]] for i in members], check,
                                     [starts[i] for i in members], observer)
            by_case.update(zip(members, part, strict=True))
        return [by_case[i] for i in range(len(assemblies))]
    ops = ops_list[0]
    # friction, gaps and loads live on the points and the local stage: per case
    points = [ops.points if ops.assembly is assembly else
              with_contact_data(ops.points, assembly) for assembly in assemblies]
    n_cases, n_steps = len(assemblies), first.n_steps
    if any(assembly.n_steps != n_steps for assembly in assemblies):
        raise ModelError("a batch of cases must share the number of load steps")
    shape = (n_steps, ops.points.n_points, 2)
    if options.backend == "torch" and n_cases > 1:  # a batch that fits the device's memory
        from .torch_engine import cases_per_chunk

        size = cases_per_chunk(n_steps, ops.points.n_points, options.device)
        if size < n_cases:
            log.info("batch of %d cases solved in chunks of %d (device memory)", n_cases, size)
            per_case = [ops_list[g] for g in geometry]
            return [result for lo in range(0, n_cases, size)
                    for result in solve_latin_batch(assemblies[lo:lo + size], options,
                                                    per_case[lo:lo + size], check,
                                                    starts[lo:lo + size], observer)]
    w_hat = np.zeros((n_cases, *shape))
    f_hat = np.zeros((n_cases, *shape))
    for c, start in enumerate(starts):
        if start is None:
            continue
        if any(np.shape(field) != shape for field in start):
            raise ModelError(f"initial: interface fields must have shape {shape}, got "
                             f"{[np.shape(field) for field in start]}")
        w_hat[c], f_hat[c] = start
    local = LocalStage(assemblies, points, ops.search_direction,
                       macro_only=ops.macro_only)
    check_scale(assemblies, points[0], ops.search_direction, local)

    t1 = time.perf_counter()
    functionals = _functionals(ops_list, geometry, assemblies, points)
    # one BLAS thread for the iteration (``one_blas_thread``) and for the recovery too (one
    # product per substructure): with two, OpenBLAS's spinning workers slowed the next
    # cases' iterations (B3 5 × 5 study: 2.2 s against 2.0). Overflow and NaN are detected
    # in η and end the case as a failure (``_outcome``)
    with one_blas_thread(), np.errstate(over="ignore", invalid="ignore"):
        state = _iterate(ops, local, options, w_hat, f_hat, observer, functionals,
                         (ops_list, geometry))
        t_iter = time.perf_counter() - t1

        t2 = time.perf_counter()
        fields_of: list[dict[str, FloatArray]] = [{} for _ in range(n_cases)]
        for g, ops_g in enumerate(ops_list):  # interior displacements, geometry by geometry
            members = np.flatnonzero(geometry == g).tolist()
            recovered = ops_g.recover(state.w[members].reshape(-1, *shape[1:]),
                                      state.f[members].reshape(-1, *shape[1:]))
            for i, member in enumerate(members):
                fields_of[member] = {name: u.reshape(len(members), n_steps, -1, 2)[i]
                                     for name, u in recovered.items()}
    results = []
    for c, (assembly, pts) in enumerate(zip(assemblies, points, strict=True)):
        history = np.array(state.histories[c])
        fields = fields_of[c]
        reactions = _reactions(assembly, pts, state.f_hat[c])
        a = pts.contact_pairs[0]
        tangents = np.column_stack([-pts.normals[a, 1], pts.normals[a, 0]])
        pressures = latin_contact_pressures(
            assembly, pts, -np.sum(state.f_hat[c][:, a] * pts.normals[a], axis=2),
            np.sum(state.f_hat[c][:, a] * tangents, axis=2))
        qoi = evaluate_qois(assembly, fields, reactions, pressures)
        converged, failure = _outcome(history, qoi, options, bool(state.stopped_on_qoi[c]))
        if state.drifting[c]:
            converged, failure = False, (
                f"no equilibrium: the interface fields grow at a steady rate over the last "
                f"{DRIFT_WINDOW} iterations (eta = {history[-1]:.2e}, falling only because "
                "they grow): a body slides without end, the load exceeding what friction, "
                "contact and stops can hold (or the iteration is too slow to finish)")
        # Anderson's and RRE's steps break the contraction the estimate reads: NaN (None)
        estimates = (error_estimates(state.recent_qoi(c, history.size), history)
                     if options.acceleration == "relaxation"
                     else np.full(state.qoi_recent.shape[2:], np.nan))
        motions = (tuple(free_motions(assembly, pts, state.w_hat[c], state.f_hat[c]))
                   if converged else ())
        results.append(SolveResult(
            method="latin",
            assembly=assembly,
            converged=converged,
            iterations=history.size,
            indicator=float(history[-1]),
            history=history,
            timings={},
            displacements=fields,
            reactions=reactions,
            qoi=qoi,
            interface=InterfaceFields(pts.coords, pts.weights, pts.interface, pts.substructure,
                                      state.w[c], state.f[c], state.w_hat[c], state.f_hat[c]),
            options=asdict(options),
            free_motions=motions,
            failure=failure,
            contact=pressures if a.size else None,
            qoi_error=_per_qoi(assembly, estimates),
            stopped_on_qoi=bool(state.stopped_on_qoi[c]),
        ))
    t_post = time.perf_counter() - t2
    timings = {
        "setup": t_setup,
        "iterations": t_iter,
        "linear_stage": state.t_linear,
        "macro_problem": state.t_macro,
        "local_stage": state.t_local,
        "per_iteration": t_iter / max(len(h) for h in state.histories),
        "postprocess": t_post,
        "total": time.perf_counter() - t0,
        "batch_size": float(n_cases),
    }
    for result in results:
        result.timings.update(timings)
        log.info("%s%s: %s after %d iterations, eta = %.2e, %.3f s%s", result.assembly.name,
                 _parameters_text(result.assembly),
                 "converged" if result.converged else "NOT converged", result.iterations,
                 result.indicator, timings["total"],
                 f" (batch of {n_cases})" if n_cases > 1 else "")
        for motion in result.free_motions:
            if motion.reaches_last_step:
                log.info("%s%s: not unique: %s", result.assembly.name,
                         _parameters_text(result.assembly), motion.describe())
    if check:
        for result in results:
            if not result.converged:
                raise NotConvergedError(f"LATIN did not converge: {result.failure}", result)
    return results


#: with ``qoi_rtol``, η < tol stops a case only once its QoIs' estimates have settled too,
#: or once η is this much below tol: a study honours the accuracy it asked for (session 14:
#: a B1-9 warm case stopped on η 0.69 % off, its estimate saying so)
ETA_STOP_UNDER = 0.1
#: the iterations of tracked QoIs an error estimate reads (``tracking.error_estimates``)
RECENT = WINDOW + 5

def _qoi_settled(state: _IterationState, active: IntArray, iteration: int, rtol: float
                 ) -> npt.NDArray[np.bool_]:
    """Per active case: every QoI's estimated error (``tracking.error_estimates``) below
    ``rtol`` × max(|value|, 1 % of the largest magnitude it took), at the steps it reports.
    The active cases of a batch have all made ``iteration`` iterations (they start
    together)."""
    latest, before = (iteration - 1) % RECENT, (iteration - 3) % RECENT
    values = state.qoi_recent[active, latest]
    bound = rtol * np.maximum(np.abs(values), 1e-2 * state.qoi_scale[active][:, :, None])
    ignored = ~state.qoi_reported[active]
    # the estimate is at least the latest two-iteration change: where that alone exceeds
    # the bound, the case goes on without the full estimate
    settled = np.all((np.abs(values - state.qoi_recent[active, before]) <= bound) | ignored,
                     axis=(1, 2))
    candidates = np.flatnonzero(settled)
    if candidates.size:
        order = np.roll(np.arange(RECENT), -(iteration % RECENT))  # oldest first
        chosen = active[candidates]
        recent = state.qoi_recent[chosen][:, order].transpose(1, 0, 2, 3)
        eta = state.eta_recent[chosen][:, order].T
        estimates = error_estimates(recent, eta[:, :, None, None])  # (n, n_qoi, n_steps)
        settled[candidates] = np.all((estimates <= bound[candidates]) | ignored[candidates],
                                     axis=(1, 2))
    return np.asarray(settled, dtype=bool)


def _outcome(history: FloatArray, qoi: dict[str, float | list[float]],
             options: LatinOptions, stopped_on_qoi: bool = False) -> tuple[bool, str]:
    """Converged or not, and why not: the cap reached, or non-finite fields (an overflow or
    a NaN is a failure, never an answer)."""
    eta = float(history[-1])
    if not np.isfinite(eta):
        return False, (f"non-finite fields (overflow or NaN) at iteration {history.size}: the "
                       "data's scale is beyond double precision, or the problem is singular")
    bad = [name for name, value in qoi.items() if not np.all(np.isfinite(value))]
    if bad:
        return False, f"non-finite quantities of interest ({', '.join(bad)})"
    if eta >= options.tol and not stopped_on_qoi:
        return False, (f"eta = {eta:.3e} >= tol = {options.tol:g} after {history.size} "
                       "iterations (max_iter)")
    return True, ""


@dataclass
class _IterationState:
    """Per case: s = (W, F), ŝ = (Ŵ, F̂) at exit and the history of η; batch timings."""

    w: FloatArray
    f: FloatArray
    w_hat: FloatArray
    f_hat: FloatArray
    histories: list[list[float]]
    #: per case, the tracked QoIs of the last ``RECENT`` iterations (n_cases, RECENT, n_qoi,
    #: n_steps) and their η, written round the buffer (iteration i at (i − 1) % RECENT)
    qoi_recent: FloatArray
    eta_recent: FloatArray
    qoi_scale: FloatArray  # per case and QoI, the largest magnitude seen at its steps
    #: per case, QoI and step: whether the QoI reports that step (``QoiFunctionals.reported``)
    qoi_reported: npt.NDArray[np.bool_]
    stopped_on_qoi: FloatArray  # per case: stopped by ``qoi_rtol`` before η < tol
    sizes: list[list[float]]  # per case, ½(‖s‖ + ‖ŝ‖) after each iteration
    drifting: FloatArray  # per case: stopped because s grows without bound (no equilibrium)
    t_linear: float = 0.0  # linear stage, macro problem included
    t_local: float = 0.0
    t_macro: float = 0.0

    def recent_qoi(self, case: int, iterations: int) -> FloatArray:
        """The tracked QoIs of the case's last iterations (at most ``RECENT``), oldest first."""
        held = min(iterations, RECENT)
        order = np.roll(np.arange(RECENT), -(iterations % RECENT))[RECENT - held:]
        return np.asarray(self.qoi_recent[case, order], dtype=np.float64)


def _iterate(ops: LatinOperators, local: LocalStage, options: LatinOptions,
             w_hat: FloatArray, f_hat: FloatArray,
             observer: IterationObserver | None = None,
             functionals: list[QoiFunctionals] | None = None,
             geometries: tuple[list[LatinOperators], IntArray] | None = None
             ) -> _IterationState:
    """Batched LATIN iterations from ŝ = (``w_hat``, ``f_hat``), shapes ``(n_cases, n_steps,
    n_points, 2)``, each case until its η < tol or the cap. The field work runs on the
    options' backend (``engine``); the control (η, stopping, relaxation) here.
    geometries: the distinct operators of the cases and each case's index into them (the
    torch backend batches several geometries); None: ``ops`` for every case."""
    pts = ops.points
    n_cases, n_steps = w_hat.shape[:2]
    n_qoi = len(functionals[0].names) if functionals else 0
    out = _IterationState(np.zeros_like(w_hat), np.zeros_like(w_hat), np.zeros_like(w_hat),
                          np.zeros_like(w_hat), [[] for _ in range(n_cases)],
                          np.zeros((n_cases, RECENT, n_qoi, n_steps)),
                          np.zeros((n_cases, RECENT)), np.zeros((n_cases, n_qoi)),
                          (np.stack([fn.reported(n_steps) for fn in functionals])
                           if functionals else np.ones((n_cases, n_qoi, n_steps), dtype=bool)),
                          np.zeros(n_cases, dtype=bool), [[] for _ in range(n_cases)],
                          np.zeros(n_cases, dtype=bool))
    active = np.arange(n_cases)
    macro_data = None
    if ops.macro_basis is not None:  # F_dᴹ per case and step: (n_cases, n_steps, n_macro)
        prescribed = local.prescribed_force_field(pts.n_points)
        macro_data = (ops.project @ prescribed.reshape(n_cases * n_steps, -1).T
                      ).T.reshape(n_cases, n_steps, -1)
    engine = _engine(ops, local, options, w_hat, f_hat, macro_data, functionals,
                     geometries or ([ops], np.zeros(n_cases, dtype=np.int64)))
    relaxation = np.full(n_cases, options.relaxation)  # per active case
    anderson = options.acceleration == "anderson"
    weights = indicator_weights(pts.weights, ops.indicator_k)
    sliding = (SlidingExtrapolation(local, *weights, n_cases)
               if options.extrapolate_sliding and not anderson else None)
    rre = (ReducedRankExtrapolation(options.rre_cycle, *weights, n_cases)
           if options.acceleration == "rre" else None)
    for iteration in range(1, options.max_iter + 1):
        engine.linear_stage(relaxation)
        if observer is not None:
            w, f = engine.fields()[:2]
            observer(iteration, active, w, f)
        engine.local_stage()
        if functionals is not None:  # the QoIs, for their error estimate (tracking.py)
            values = engine.qoi_values()
            out.qoi_recent[active, (iteration - 1) % RECENT] = values
            out.qoi_scale[active] = np.maximum(out.qoi_scale[active], np.where(
                out.qoi_reported[active], np.abs(values), 0.0).max(axis=2, initial=0.0))
        # η = ‖s − ŝ‖ / ½(‖s‖ + ‖ŝ‖), ‖s‖² = Σ_t Σ_points ∫ (k⁻¹ F·F + k W·W) dΓ (§4.3)
        gap, size = engine.indicator()
        # a NaN or overflowed norm leaves η NaN; η = 0 only for a zero solution (no load)
        eta = np.full_like(gap, np.nan)
        finite = np.isfinite(gap) & np.isfinite(size)
        np.divide(gap, size, out=eta, where=finite & (size > 0))
        eta[finite & (size == 0)] = 0.0  # then gap = 0 too (gap ≤ ‖s‖ + ‖ŝ‖)
        out.eta_recent[active, (iteration - 1) % RECENT] = eta
        for c, value, norm in zip(active, eta, size, strict=True):
            out.histories[c].append(float(value))
            out.sizes[c].append(float(norm))
        if iteration % 50 == 0:
            log.debug("iteration %d: eta = %.3e (worst of %d cases)", iteration, eta.max(),
                      active.size)
        if iteration % options.stagnation_window == 0 and not anderson:
            damp_stagnating(out.histories, active, relaxation, options)
        done = ((eta < options.tol) | ~np.isfinite(eta) if iteration < options.max_iter
                else np.ones_like(eta, bool))
        if iteration % DRIFT_WINDOW == 0:
            drifting = np.array([drifts(out.sizes[c]) for c in active]) & ~done
            out.drifting[active[drifting]] = True
            done |= drifting
        if options.qoi_rtol is not None and functionals and iteration >= WINDOW + 5:
            settled = _qoi_settled(out, active, iteration, options.qoi_rtol)
            if iteration < options.max_iter:  # η < tol alone is no QoI accuracy
                done &= settled | ~np.isfinite(eta) | (eta < ETA_STOP_UNDER * options.tol)
            on_qoi = settled & ~done & np.isfinite(eta)
            if sliding is not None:  # the QoIs' recent history spans a jump: not yet
                on_qoi &= (sliding.jumped_at[active] < 0) | (
                    iteration - sliding.jumped_at[active] > RECENT)
            out.stopped_on_qoi[active[on_qoi]] = True
            done |= on_qoi
        if done.any():
            leaving = active[done]
            out.w[leaving], out.f[leaving], out.w_hat[leaving], out.f_hat[leaving] = (
                engine.fields(np.flatnonzero(done)))
            if done.all():
                break
            keep = np.flatnonzero(~done)
            active = active[keep]
            relaxation = relaxation[keep]
            engine.keep(keep)
        if rre is not None:
            for case in rre(active, engine):
                if sliding is not None:
                    sliding.forget(case)
        if sliding is not None:
            for case in sliding(iteration, active, eta[~done], engine):
                if rre is not None:
                    rre.forget(case)
    out.t_linear, out.t_macro, out.t_local = engine.t_linear, engine.t_macro, engine.t_local
    return out


def _engine(ops: LatinOperators, local: LocalStage, options: LatinOptions,
            w_hat: FloatArray, f_hat: FloatArray, macro_data: FloatArray | None,
            functionals: list[QoiFunctionals] | None,
            geometries: tuple[list[LatinOperators], IntArray]) -> FieldEngine:
    """The backend that does the iteration's field work (``LatinOptions.backend``)."""
    if options.backend == "torch":
        from .torch_engine import TorchFields  # PyTorch loads only when asked for

        return TorchFields(geometries[0], geometries[1], local, options, w_hat, f_hat,
                           macro_data, functionals)
    return NumpyFields(ops, local, options, w_hat, f_hat, macro_data, functionals,
                       geometries)


def _functionals(ops_list: list[LatinOperators], geometry: IntArray,
                 assemblies: Sequence[Assembly], points: list[InterfacePoints]
                 ) -> list[QoiFunctionals]:
    """The QoI functionals of each case, built once per geometry and set of QoIs."""
    built: dict[tuple[int, str], QoiFunctionals] = {}
    out = []
    for g, assembly, pts in zip(geometry, assemblies, points, strict=True):
        key = (int(g), repr(assembly.qois))
        if key not in built:
            built[key] = qoi_functionals(ops_list[g], assembly, pts)
        out.append(built[key])
    return out


def _per_qoi(assembly: Assembly, estimates: FloatArray) -> dict[str, float | list[float] | None]:
    """The estimates (n_qoi, n_steps) in the shape of ``qoi``: one number for a QoI of one
    step (or with ``step``), a list over the steps otherwise; None where not estimated."""
    out: dict[str, float | list[float] | None] = {}
    for i, q in enumerate(assembly.qois):
        row = estimates[i] if q.step is None else estimates[i, q.step - 1:q.step]
        values = [float(v) for v in row]
        if not all(np.isfinite(values)):
            out[q.name] = None
        else:
            out[q.name] = values[0] if len(values) == 1 else values
    return out


def _parameters_text(assembly: Assembly) -> str:
    """`` (mu1=0.3, mu2=0.2)``: the case's parameters, for log lines."""
    values = ", ".join(f"{name}={value:g}" for name, value in dict(assembly.mu).items())
    return f" ({values})" if values else ""


def _reactions(assembly: Assembly, pts: InterfacePoints, force_hat: FloatArray
               ) -> dict[str, FloatArray]:
    """Resultant force of each named boundary on the structure, per step."""
    out: dict[str, FloatArray] = {}
    for i, itf in enumerate(assembly.interfaces):
        if itf.condition is None:
            continue
        p = pts.side_points[(i, 0)]
        total = np.einsum("p,tpc->tc", pts.weights[p], force_hat[:, p])
        name = itf.condition.name
        out[name] = out.get(name, 0.0) + total
    return out

