"""The LATIN micro-macro solver (paper §2.3, §4; method.md §4).

Every load step is one column of the same right-hand side: the linear stage solves all
steps at once. The linear stage works on interface quantities only, through the condensed
operator ``C_E = T_E (K_E + T_Eᵀ M0 k T_E)⁻¹ T_Eᵀ M0`` of each substructure (computed once
per geometry from its factorisation), so that W = C (F̂ + k Ŵ + k W̃ᴹ) (eq. [13]).
Interior displacements are recovered once, at the end.
"""

from __future__ import annotations

import gc
import logging
import time
from collections.abc import Sequence
from dataclasses import asdict, replace

import numpy as np

from ..decomposition.assembly import Assembly
from ..decomposition.interfaces import InterfacePoints, with_contact_data
from ..decomposition.qoi import evaluate_qois, latin_contact_pressures
from ..decomposition.result import InterfaceFields, SolveResult
from ..decomposition.sliding_extent import large_slips
from ..decomposition.uniqueness import free_motions_batch
from ..errors import ModelError, NotConvergedError
from ..fem.elasticity import FloatArray, IntArray
from ..limits import check_scale
from .batching import interface_families, operators_per_case
from .body_forces import BodyResponse, body_response, stacked_offsets, with_body_constants
from .case_state import IterationState
from .engine import one_blas_thread
from .guards import (
    BLOWUP,
    CAPPED,
    DRIFT_WINDOW,
    NO_EQUILIBRIUM,
    VANISH,
    blows_up,
    drifting_steps,
    drop_unloaded_starts,
    explain_capped,
    vanishes,
)
from .iteration import IterationObserver, iterate
from .local_stage import LocalStage
from .operators import LatinOperators
from .options import LatinOptions
from .tracking import SETTLED, QoiFunctionals, error_estimates, qoi_functionals, state_change

__all__ = ["IterationObserver", "solve_latin", "solve_latin_batch"]

log = logging.getLogger(__name__)


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
    chunks (``torch_memory.cases_per_chunk``), and one the device runs out of memory for
    again in halves (``_in_halves``); the observer then sees each chunk's cases.
    Results carry the batch's timings (``timings["batch_size"]``) and the leading steps
    each case settled (``timings["settled_steps"]``).
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
        from .torch_memory import cases_per_chunk

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
    bodies = [body_response(ops_list[g], assembly) for g, assembly in zip(
        geometry, assemblies, strict=True)]
    local = LocalStage(assemblies, points, ops.search_direction, macro_only=ops.macro_only,
                       body=stacked_offsets(bodies, n_steps, ops.points.n_points))
    check_scale(assemblies, points[0], ops.search_direction, local)
    drop_unloaded_starts(local, bodies, w_hat, f_hat, [a.label for a in assemblies])

    t1 = time.perf_counter()
    functionals = [with_body_constants(functional, body, assembly) for functional, body,
                   assembly in zip(_functionals(ops_list, geometry, assemblies, points),
                                   bodies, assemblies, strict=True)]
    # one BLAS thread for the iteration (``one_blas_thread``) and for the recovery too (one
    # product per substructure): with two, OpenBLAS's spinning workers slowed the next
    # cases' iterations (B3 5 × 5 study: 2.2 s against 2.0). Overflow and NaN are detected
    # in η and end the case as a failure (``_outcome``)
    with one_blas_thread(), np.errstate(over="ignore", invalid="ignore"):
        try:
            state = iterate(ops, local, options, w_hat, f_hat, observer, functionals,
                            (ops_list, geometry))
        except _out_of_memory(options) as exc:  # the failed batch's tensors go with exc
            out_of_memory: str | None = str(exc).split(". ")[0] or type(exc).__name__
        else:
            out_of_memory = None
            t_iter = time.perf_counter() - t1
            t2 = time.perf_counter()
            fields_of = (_recovered(state, range(n_cases), ops_list, geometry, bodies,
                                    assemblies)
                         if options.recover_displacements else [{} for _ in range(n_cases)])
    if out_of_memory is not None:
        return _in_halves(assemblies, options, [ops_list[g] for g in geometry], check,
                          starts, observer, out_of_memory)
    results = results_of(range(n_cases), assemblies, points, state, fields_of, options,
                         functionals)
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
        log_result(result, n_cases)
    if check:
        for result in results:
            if not result.converged:
                raise NotConvergedError(f"LATIN did not converge: {result.failure}", result)
    return results


def _out_of_memory(options: LatinOptions) -> type[Exception]:
    """The exception a device that ran out of memory raises (PyTorch's), or one never
    raised (the NumPy backend)."""
    if options.backend != "torch":
        return _NeverRaised
    from .torch_engine import load_torch

    error: type[Exception] = load_torch(options.device).OutOfMemoryError
    return error


class _NeverRaised(Exception):
    """Stands for a device's out-of-memory error where there is no device."""


def _in_halves(assemblies: Sequence[Assembly], options: LatinOptions,
               per_case: list[LatinOperators], check: bool,
               starts: Sequence[tuple[FloatArray, FloatArray] | None],
               observer: IterationObserver | None, why: str) -> list[SolveResult]:
    """A batch the device ran out of memory for, solved again as two halves: its footprint
    beyond ``cases_per_chunk``'s estimate, or other processes sharing the GPU (session 40:
    8 processes under CUDA's MPS filled an H100). Never an out-of-memory crash (issue 19);
    a ``ModelError`` where one case does not fit. The observer has seen the failed
    attempt's iterations too."""
    n_cases = len(assemblies)
    if n_cases == 1:
        raise ModelError(f"device: one case does not fit in the memory left on "
                         f"{options.device!r} ({why})")
    from .torch_engine import load_torch

    torch = load_torch(options.device)
    gc.collect()  # the failed batch's tensors and graphs, then the cache they leave
    if options.device.startswith("cuda"):  # pragma: no cover - a GPU's
        torch.cuda.empty_cache()
    half = (n_cases + 1) // 2
    log.warning("%s ran out of memory for a batch of %d cases (%s); solving it again as "
                "batches of %d", options.device, n_cases, why, half)
    return [result for lo in (0, half)
            for result in solve_latin_batch(assemblies[lo:lo + half], options,
                                            per_case[lo:lo + half], check,
                                            starts[lo:lo + half], observer)]


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
        return False, (f"{CAPPED}{eta:.3e} >= tol = {options.tol:g} after {history.size} "
                       "iterations (max_iter); a larger max_iter or another kappa (the "
                       "search direction, which the answer does not depend on; "
                       "docs/convergence.md, 'kappa on every bundled model') may converge")
    return True, ""


def log_result(result: SolveResult, batch: int) -> None:
    """A solve's line in the log (its case, outcome, iterations, η, time), and what the
    discrete problem leaves undetermined."""
    log.info("%s: %s after %d iterations, eta = %.2e, %.3f s%s", result.assembly.label,
             "converged" if result.converged else "NOT converged", result.iterations,
             result.indicator, result.timings["total"],
             f" (batch of {batch})" if batch > 1 else "")
    for motion in result.free_motions:
        if motion.reaches_last_step:
            log.info("%s: not unique: %s", result.assembly.label, motion.describe())
    for slip in result.large_slips:
        log.info("%s: large slip: %s", result.assembly.label, slip.describe())


def _recovered(state: IterationState, cases: Sequence[int],
               ops_list: Sequence[LatinOperators], geometry: IntArray,
               bodies: Sequence[BodyResponse | None], assemblies: Sequence[Assembly]
               ) -> list[dict[str, FloatArray]]:
    """Per case of ``cases`` (``geometry``: each one's index into ``ops_list``; ``bodies``
    and ``assemblies``: each one's body forces' response and assembly), the interior
    displacements of every substructure from its exit fields, geometry by geometry."""
    fields_of: list[dict[str, FloatArray]] = [{} for _ in cases]
    for g, ops_g in enumerate(ops_list):
        members = np.flatnonzero(geometry == g).tolist()
        if not members:
            continue
        w = np.stack([state.exits[cases[m]][0] for m in members])
        f = np.stack([state.exits[cases[m]][1] for m in members])
        recovered = ops_g.recover(w.reshape(-1, *w.shape[2:]), f.reshape(-1, *f.shape[2:]))
        for i, member in enumerate(members):
            fields_of[member] = {name: u.reshape(len(members), w.shape[1], -1, 2)[i]
                                 for name, u in recovered.items()}
    for fields, body, assembly in zip(fields_of, bodies, assemblies, strict=True):
        if body is not None:
            body.add_interior(fields, assembly)
    return fields_of


def results_of(cases: Sequence[int], assemblies: Sequence[Assembly],
               points: Sequence[InterfacePoints], state: IterationState,
               fields: Sequence[dict[str, FloatArray]], options: LatinOptions,
               functionals: Sequence[QoiFunctionals]) -> list[SolveResult]:
    """Cases ``cases`` of ``state`` as results (``_result``; ``fields``: their recovered
    displacements, empty where not recovered, then the QoIs come from ``functionals``), the
    converged ones' free motions found together (``free_motions_batch``: vectorised over
    the cases of a geometry), and their slips beyond the small-sliding range."""
    results = [_result(c, assembly, pts, state, field, options, functional)
               for c, assembly, pts, field, functional
               in zip(cases, assemblies, points, fields, functionals, strict=True)]
    converged = [n for n, result in enumerate(results) if result.converged]
    if converged:
        exits = [state.exits[cases[n]] for n in converged]
        motions = free_motions_batch([assemblies[n] for n in converged],
                                     [points[n] for n in converged],
                                     [exit_fields[2] for exit_fields in exits],
                                     [exit_fields[3] for exit_fields in exits])
        for n, found, (_, _, w_hat, f_hat) in zip(converged, motions, exits, strict=True):
            slips = large_slips(assemblies[n], points[n], w_hat, f_hat)
            results[n] = replace(results[n], free_motions=tuple(found), large_slips=slips)
    return explain_capped(results, [state.exits[c] for c in cases], assemblies, points)


def _result(c: int, assembly: Assembly, pts: InterfacePoints, state: IterationState,
            fields: dict[str, FloatArray], options: LatinOptions,
            functional: QoiFunctionals) -> SolveResult:
    """Case ``c`` of ``state`` as a result: reactions, contact pressures, QoIs, its
    outcome and error estimates (timings filled in by the caller; its free motions by
    ``results_of``)."""
    history = np.array(state.histories[c])
    w, f, w_hat, f_hat = state.exits[c]
    reactions = _reactions(assembly, pts, f_hat)
    a = pts.contact_pairs[0]
    pressures = None
    if options.recover_displacements:
        tangents = np.column_stack([-pts.normals[a, 1], pts.normals[a, 0]])
        pressures = latin_contact_pressures(
            assembly, pts, -np.sum(f_hat[:, a] * pts.normals[a], axis=2),
            np.sum(f_hat[:, a] * tangents, axis=2))
        qoi = evaluate_qois(assembly, fields, reactions, pressures)
    else:
        qoi = _functional_qois(functional, w, f, f_hat)
    converged, failure = _outcome(history, qoi, options, bool(state.stopped_on_qoi[c]))
    if state.force_eta[c] > 0.0:
        converged, failure = False, (
            f"the interface forces have not converged: their own indicator eta_F = "
            f"{state.force_eta[c]:.2e} after {history.size} iterations (max_iter), while eta "
            f"= {history[-1]:.2e} is small because the interface displacements are large "
            "(a prescribed or rigid displacement far larger than the deformation weighs "
            "in eta's norm): no equilibrium, or a larger max_iter may converge")
    if state.drifting[c]:
        steps, others = drifting_steps(pts.weights, w, f, w_hat, f_hat)
        where = (f"at step(s) {', '.join(map(str, steps))} (the other steps settled to "
                 f"{others:.1e} of their fields)" if len(steps) < w.shape[0] else "")
        converged, failure = False, (
            f"{NO_EQUILIBRIUM}{' ' + where if where else ''}: the interface fields grow at a "
            f"steady rate over the last {DRIFT_WINDOW} iterations (eta = {history[-1]:.2e}, "
            "falling only because they grow): a body slides without end, the load "
            "exceeding what friction, contact and stops can hold (or the iteration is too "
            "slow to finish)")
    if blows_up(np.asarray(state.sizes[c][-1:]), np.asarray(state.sizes[c][:1])).any():
        converged, failure = False, (
            f"diverged: the interface fields grew to more than {BLOWUP:g} times their size "
            f"after the first iteration (to {state.sizes[c][-1]:.3e} from "
            f"{state.sizes[c][0]:.3e} in {history.size} iterations); the iteration is "
            f"unstable (its acceleration, relaxation or search direction), and eta "
            f"(= {history[-1]:.2e}, relative to that size) measures no error")
    if vanishes(np.asarray(state.sizes[c][-1:]), np.asarray(state.sizes[c][:1]),
                state.warm[c:c + 1]).any():
        converged, failure = False, (
            f"vanished: from its warm start the interface fields fell to less than "
            f"{VANISH:g} times their size after the first iteration (to "
            f"{state.sizes[c][-1]:.3e} from {state.sizes[c][0]:.3e} in {history.size} "
            f"iterations) while eta (= {history[-1]:.2e}, relative to that size) stayed: "
            "the answer is zero or far smaller than the start's; solve it from zero")
    # Anderson's and RRE's steps break the contraction the estimate reads, and a state
    # still changing by more than SETTLED may hold changes its QoIs have not begun: NaN (None)
    change = state_change(history)
    jumped = int(state.jumped_at[c])  # after a jump among the held iterates: those after it
    recent = (state.estimates(c, history.size, jumped)
              if 0 <= jumped and history.size - jumped < state.qoi_recent.shape[1]
              else error_estimates(state.recent_qoi(c, history.size), history,
                                   rate_floor=float(state.jump_rate[c])))
    estimates = (np.maximum(recent, state.qoi_settled_error[c])  # settled: as they settled
                 if options.acceleration == "relaxation" and not change > SETTLED
                 else np.full(state.qoi_recent.shape[2:], np.nan))
    return SolveResult(
        method="latin",
        assembly=assembly,
        converged=converged,
        iterations=history.size,
        indicator=float(history[-1]),
        history=history,
        # not a time: the leading load steps it stopped iterating (``LatinOptions.
        # settled_steps``), beside ``batch_size``
        timings={"settled_steps": float(state.settled_steps[c])},
        displacements=fields,
        reactions=reactions,
        qoi=qoi,
        interface=InterfaceFields(pts.coords, pts.weights, pts.interface, pts.substructure,
                                  w, f, w_hat, f_hat),
        options=asdict(options),
        failure=failure,
        contact=pressures if a.size else None,
        qoi_error=_per_qoi(assembly, estimates),
        stopped_on_qoi=bool(state.stopped_on_qoi[c]),
        state_change=change,
    )


def _functional_qois(functional: QoiFunctionals, w: FloatArray, f: FloatArray,
                     f_hat: FloatArray) -> dict[str, float | list[float]]:
    """The QoIs of a case from its interface fields by their functionals, in
    ``evaluate_qois``' form (a number for a QoI of one step, else a list over the steps)."""
    values = functional.values(w[None], f[None], f_hat[None])[0] + 0.0  # no "-0"
    out: dict[str, float | list[float]] = {}
    for name, step, row in zip(functional.names, functional.steps, values, strict=True):
        chosen = row[step - 1:step] if step is not None else row
        out[name] = float(chosen[0]) if chosen.size == 1 else [float(v) for v in chosen]
    return out


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

