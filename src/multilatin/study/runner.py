"""Running a study: serially or as Dask tasks, with progress, into a resumable store."""

from __future__ import annotations

import functools
import json
import logging
import os
import sys
import tempfile
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from hashlib import sha1
from pathlib import Path
from typing import Any

import xarray as xr

from ..decomposition.result import withheld
from ..errors import ModelError, NotConvergedError
from ..latin import LatinOptions
from ..latin.options import STUDY_QOI_RTOL
from ..limits import check_study
from ..model import Model
from ..parameters import Grid
from . import plan as plans
from .agreement import mode_agreement
from .chain_state import ChainState
from .cluster import load_kernels, local_cluster, warm_workers, worker_addresses
from .defaults import count_geometries, on_gpu, study_defaults
from .plan import MODES, SCHEDULES, START_FROM, Case, StudyPlan, plan_study
from .rolling import rolls, run_rolling
from .store import StudyStore
from .waves import from_the_middle, run_line_tasks, submit_line_tasks

log = logging.getLogger(__name__)

#: seconds to reach a Dask scheduler given by address before giving up
SCHEDULER_TIMEOUT_S = 10.0


@dataclass(frozen=True)
class StudyResult:
    """A finished (or resumed and finished) study."""

    plan: StudyPlan
    dataset: xr.Dataset
    records: list[dict[str, Any]]
    elapsed_s: dict[str, float]  # per mode: the study's wall time (summed over resumptions)
    folder: Path | None
    repairs: tuple[str, ...] = ()  # what resuming repaired in the folder (``StudyStore``)

    @property
    def failed(self) -> list[dict[str, Any]]:
        """The records of the cases that did not converge (their QoIs are no answer)."""
        return [r for r in self.records if not r["converged"]]

    @property
    def main_mode(self) -> str:
        """The mode the study is about: multiresolution when it ran, else cold."""
        return "multiresolution" if self.mode_records("multiresolution") else "cold"

    def mode_records(self, mode: str) -> list[dict[str, Any]]:
        return sorted((r for r in self.records if r["mode"] == mode), key=lambda r: r["number"])

    @property
    def gains(self) -> dict[str, float] | None:
        """Both modes run: the gain (Σ cold times / the multiresolution study's time), the
        paper's gain (cases × the first cold time / the study's time) and the gain of the
        warm starts alone (iteration times only, operators set aside). Cases that did not
        converge in either mode are left out of every sum (the study's time loses their
        share); ``gain_cases`` says over how many cases the gains stand."""
        cold = {r["number"]: r for r in self.mode_records("cold")}
        warm = {r["number"]: r for r in self.mode_records("multiresolution")}
        if not cold or not warm or set(cold) != set(warm):
            return None
        kept = [n for n in sorted(cold) if cold[n]["converged"] and warm[n]["converged"]]
        if not kept:
            return None
        warm_total = sum(r["wall_s"] for r in warm.values())
        study_time = self.elapsed_s["multiresolution"] * (
            sum(warm[n]["wall_s"] for n in kept) / warm_total if warm_total > 0 else 1.0)
        first_cold = cold[min(cold)]["wall_s"]
        return {
            "gain": sum(cold[n]["wall_s"] for n in kept) / study_time,
            "paper_gain": len(kept) * first_cold / study_time,
            "warm_start_gain": (sum(cold[n]["wall_s"] - cold[n]["setup_s"] for n in kept)
                                / sum(warm[n]["wall_s"] - warm[n]["setup_s"] for n in kept)),
            "iterations_ratio": (sum(cold[n]["iterations"] for n in kept)
                                 / sum(warm[n]["iterations"] for n in kept)),
            "gain_cases": float(len(kept)),
        }

    @property
    def modes_within(self) -> dict[str, float]:
        """Both modes run: per QoI the largest difference between their answers
        (``agreement.mode_agreement``); empty otherwise."""
        return mode_agreement(self.mode_records("multiresolution"), self.mode_records("cold"))

    def to_json_dict(self) -> dict[str, Any]:
        main = self.main_mode
        out: dict[str, Any] = {
            "model": self.dataset.attrs.get("model"),
            "grid": {name: list(self.plan.grid[name]) for name in self.plan.grid},
            "mode": main,
            "cases": [_case_json(r) for r in self.mode_records(main)],
            "wall_s": self.elapsed_s[main],
            "peak_rss_mb": max((r.get("peak_rss_mb", float("nan")) for r in self.records),
                               default=float("nan")),
            "converged": all(r["converged"] for r in self.records),
            "not_converged": len(self.failed),
            "not_unique": sum(not r.get("unique", True) for r in self.records),
            "large_slip": sum(bool(r.get("large_slips")) for r in self.records),
            "repairs": list(self.repairs),
            "store": str(self.folder) if self.folder else None,
        }
        if main == "multiresolution" and self.mode_records("cold"):
            out["cold_cases"] = [_case_json(r) for r in self.mode_records("cold")]
            out["cold_wall_s"] = self.elapsed_s["cold"]
            out.update(self.gains or {})
            out["modes_within"] = self.modes_within
        return out


def _case_json(record: dict[str, Any]) -> dict[str, Any]:
    out = {key: record[key] for key in ("params", "iterations", "wall_s", "converged", "qoi",
                                         "setup_s", "start")}
    out["unique"] = record.get("unique", True)
    out["large_slips"] = record.get("large_slips", [])
    out["qoi_error"] = record.get("qoi_error", {})
    if not record["converged"]:  # no answer: masked, as in study.nc
        out["qoi"] = withheld(record["qoi"])
        out["qoi_error"] = withheld(out["qoi_error"])
    return out


#: options that change what a solve returns besides its answers: not in a study's identity
OUTPUT_CHOICES = ("recover_displacements",)


def run_study(
    model: Model,
    grid: Grid,
    *,
    options: LatinOptions | None = None,
    modes: Sequence[str] = ("multiresolution",),
    out: str | Path | None = None,
    chains: int | None = None,
    batch: int | None = None,
    start: str | None = None,
    workers: int = 0,
    schedule: str = "waves",
    scheduler: str | None = None,
    progress: bool = True,
    command: str = "",
    on_case: Callable[[dict[str, Any]], None] | None = None,
    on_failure: str = "warn",
    rolling: bool = True,
) -> StudyResult:
    """Run (or resume) a study of ``model`` over ``grid``.

    modes: ``"multiresolution"`` and/or ``"cold"`` (both: the gain is measured).
    out: the results folder (a temporary one when None); a folder holding the same study
        resumes it: finished cases are kept, not recomputed.
    chains: independent multiresolution chains (default: 1; with ``schedule="chains"``,
        the number of workers).
    batch: multiresolution solves up to ``batch`` cases of a grid line (one geometry)
        together, each from its nearest converged neighbour (``study.run_batch``); 1 solves
        case after case. Default: 16; ``GPU_BATCH`` on a GPU from zero (with ``workers``
        sharing it, ``GPU_BATCHES_PER_WORKER`` batches per worker).
    start: how the multiresolution mode starts a case (``plan.START_FROM``): ``"neighbour"``
        (the paper's multiresolution; along hole positions from converged neighbours
        extrapolated, ``study.predictors``; along friction lines from the neighbour's load
        history retimed, ``study.retiming``), ``"nearest"`` (the nearest
        alone, as the paper), or ``"zero"``: every case of a geometry from zero, in
        batches of up to ``batch`` cases sharing the operators (for the torch backend on a
        GPU: a wide batch there costs little more than a narrow one). Default:
        ``"neighbour"``; on a CUDA device (torch) ``"zero"`` unless the study is wide enough
        for geometry waves to pay (``defaults.study_defaults``, docs/gpu.md).
    workers / scheduler: run the study's cases as tasks on a local Dask cluster of
        ``workers`` processes, or on the cluster at ``scheduler``; 0 and None: serial.
    schedule: how a Dask run shares out multiresolution work (``SCHEDULES``):
        ``"waves"`` (default), one chain whose grid lines are tasks, each starting from a
        neighbour line one step nearer the middle one (``study.waves``: one start from
        zero, lines side by side where the grid allows); ``"chains"``, ``chains``
        contiguous pieces of the traversal, each from zero (the earlier rule: 29 % more
        iterations on B1's 13 × 13 grid with 16). The torch backend's multiresolution
        (geometry waves, or a wavefront of lines) uses chains; from zero
        (``start="zero"``) ``"waves"`` makes every batch its own task, handed to the
        workers as they free up (its batches need no other's output).
    options: the solver's; default ``LatinOptions(qoi_rtol=STUDY_QOI_RTOL)``: a case stops
        once its QoIs' estimated errors are below 0.1 % (or at η < 3e-6 before), which keeps
        R_stop within 0.1 % of its tight value on B1's 13 × 13 and B3's 5 × 5 grids with 27 %
        and 66 % fewer multiresolution iterations (docs/tolerance.md).
    rolling: a serial multiresolution chain (NumPy, relaxation, ``batch`` > 1) runs as one
        rolling batch of up to ``batch`` cases, each joining as soon as its neighbour has
        converged (``study.rolling``: the same starts and answers as grid lines solved
        batch after batch, which ``rolling=False`` does).
    on_failure: when cases did not converge (recorded, QoIs NaN in ``dataset``, left out of
        ``gains``): ``"warn"`` (a ``RuntimeWarning`` naming them), ``"raise"``
        (``NotConvergedError`` once the study is written, the result attached) or
        ``"ignore"``.
    """
    options = options or LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    options = replace(options, recover_displacements=False)  # a study keeps the QoIs alone
    chosen_on_gpu = start is None and on_gpu(options)
    geometries = count_geometries(model, grid, options) if chosen_on_gpu else 1
    batch, start = study_defaults(options, batch, start, workers, grid.size, geometries)
    if chosen_on_gpu:
        log.info("on %s, %d cases over %d geometries: start %r (study.defaults)",
                 options.device, grid.size, geometries, start)
    for mode in modes:
        if mode not in MODES:
            raise ModelError(f"mode: expected one of {MODES}, got {mode!r}")
    if workers < 0:
        raise ModelError(f"--workers: must be >= 0, got {workers}")
    if batch < 1:
        raise ModelError(f"--batch: must be >= 1, got {batch}")
    if schedule not in SCHEDULES:
        raise ModelError(f"--schedule: expected one of {SCHEDULES}, got {schedule!r}")
    if start not in START_FROM:
        raise ModelError(f"--start: expected one of {START_FROM}, got {start!r}")
    # "nearest": the neighbour's start without the extrapolations along geometric axes and
    # the retimed starts along the others
    requested, start = start, ("neighbour" if start == "nearest" else start)
    if on_failure not in ("warn", "raise", "ignore"):
        raise ModelError(f"on_failure: expected 'warn', 'raise' or 'ignore', got {on_failure!r}")
    if start == "neighbour" and options.backend == "torch":
        schedule = "chains"  # the device batches many geometries (geometry waves)
    n_chains = (chains if chains is not None else
                1 if schedule == "waves" else max(workers, 1))
    check_study(grid.size, len(modes))
    plan = plan_study(model, grid, options, n_chains, extrapolate=requested != "nearest")
    identity = {
        "model": model.name,
        "model_sha1": sha1(json.dumps(model.spec.data, sort_keys=True, default=str)
                           .encode()).hexdigest(),
        "defaults": dict(model.parameters.defaults()),
        "grid": [[name, list(grid[name])] for name in grid],  # in order: it sets the traversal
        "options": {k: v for k, v in asdict(options).items() if k not in OUTPUT_CHOICES},
        "chains": len(plan.chains),
    }
    if requested != "neighbour":  # studies written before the option keep their identity
        identity["start"] = requested
    if model.spec.mesh_files:  # their contents: a mesh edited between runs is another model
        identity["mesh_sha1"] = {path: sha1(Path(path).read_bytes()).hexdigest()
                                 for path in model.spec.mesh_files}
    folder = Path(out) if out is not None else Path(tempfile.mkdtemp(prefix="multilatin-"))
    store = StudyStore(folder, identity, record_fits=_record_fits(plan))
    attrs = {"model": model.name, "title": model.title, "command": command,
             "tolerance": options.tol, "chains": len(plan.chains),
             **({} if options.qoi_rtol is None else {"qoi_rtol": options.qoi_rtol}),
             "geometric_parameters": list(plan.geometric), "units": model.spec.units}
    elapsed: dict[str, float] = {}
    try:  # the store (and its folder's lock) is closed however the study ends
        if not (workers or scheduler) and any(not store.finished(mode, case.number)
                                              for mode in modes for case in plan.cases):
            load_kernels(model, plan.cases[0], options)
            # study.nc from the start (the cases a resumed study has): xarray's first write
            # (its backends' discovery, ~0.2 s) is then charged to no mode's clock
            store.write_dataset(grid, attrs)
        for mode in modes:
            previous = _elapsed(store, mode)
            pending = [c for c in plan.cases if not store.finished(mode, c.number)]
            if pending:
                log.info("%s: %d of %d cases to compute (%s)", model.name, len(pending),
                         plan.size, mode)
            runner = (_run_dask if (workers or scheduler) else
                      functools.partial(_run_serial, rolling=rolling))
            bar = _progress_bar(plan.size, plan.size - len(pending), mode, progress,
                                model.name)
            started = time.perf_counter()

            def finished(records: list[dict[str, Any]], state: ChainState | None,
                         started: float = started, previous: float = previous,
                         bar: Any = bar) -> None:
                elapsed_now = previous + time.perf_counter() - started
                for record in records:
                    record["elapsed_s"] = elapsed_now
                store.add_batch(records, state)
                store.maybe_write_dataset(grid, attrs)
                if bar is not None:
                    bar.set_postfix_str(", ".join(f"{k}={v:g}" for k, v in
                                                  records[-1]["params"].items()))
                    bar.update(len(records))
                if on_case is not None:
                    for record in records:
                        on_case(record)

            runner(model, grid, plan, mode, options, store, finished, batch, workers,
                   scheduler, start, schedule)
            if bar is not None:
                bar.close()
            elapsed[mode] = _elapsed(store, mode)
        records = [r for r in store.records.values() if r["mode"] in modes]
        dataset = store.write_dataset(grid, {**attrs, "elapsed_s": elapsed})
    finally:
        store.close()
    result = StudyResult(plan, dataset, records, elapsed, folder, tuple(store.repairs))
    failed = result.failed
    if failed and on_failure != "ignore":
        message = (f"{len(failed)} of {len(records)} case(s) did not converge (converged = "
                   "False; their QoIs are NaN in the dataset and left out of the gains): "
                   + "; ".join(r["log"] for r in failed[:3]) + ("; ..." if len(failed) > 3
                                                                 else ""))
        if on_failure == "raise":
            raise NotConvergedError(message, result)
        warnings.warn(message, RuntimeWarning, stacklevel=2)
    return result


def _record_fits(plan: StudyPlan) -> Callable[[dict[str, Any]], bool]:
    """Whether a journal record is a case of ``plan`` (number, grid index and parameters)."""
    by_number = {case.number: case for case in plan.cases}

    def fits(record: dict[str, Any]) -> bool:
        try:
            case = by_number[int(record["number"])]
            return (record["mode"] in MODES and list(case.index) == list(record["index"])
                    and all(abs(case.mu[k] - float(v)) <= 1e-12 * max(1.0, abs(v))
                            for k, v in record["params"].items()))
        except (KeyError, TypeError, ValueError):
            return False
    return fits


def _elapsed(store: StudyStore, mode: str) -> float:
    """The study time of ``mode`` so far: the latest finished case's, over all runs."""
    return max((r.get("elapsed_s", 0.0) for (m, _), r in store.records.items() if m == mode),
               default=0.0)


#: where progress goes when stderr is no terminal (a log file, CI): a line every
#: ``PROGRESS_INTERVAL_S`` seconds and one at the end (the CLI shows this logger at INFO)
progress_log = logging.getLogger("multilatin.progress")
PROGRESS_INTERVAL_S = 5.0


class _LoggedProgress:
    """tqdm's ``update``/``set_postfix_str``/``close`` for a stderr that is no terminal:
    cases done, rate and the time left, as log lines every few seconds."""

    def __init__(self, total: int, done: int, mode: str, name: str) -> None:
        self.total, self.done, self.mode, self.name = total, done, mode, name
        self.start_done, self.start = done, time.perf_counter()
        self.last, self.postfix = self.start, ""

    def set_postfix_str(self, text: str) -> None:
        self.postfix = text

    def update(self, count: int) -> None:
        self.done += count
        now = time.perf_counter()
        if now - self.last >= PROGRESS_INTERVAL_S:
            self.last = now
            self._line(now)

    def close(self) -> None:
        self._line(time.perf_counter())

    def _line(self, now: float) -> None:
        elapsed = now - self.start
        rate = (self.done - self.start_done) / elapsed if elapsed > 0 else 0.0
        left = (self.total - self.done) / rate if rate > 0 else float("nan")
        progress_log.info("%s %s: %d/%d cases, %.1f s, %.2f cases/s, %.0f s left%s",
                          self.name, self.mode, self.done, self.total, elapsed, rate, left,
                          f" (last: {self.postfix})" if self.postfix else "")


def _progress_bar(total: int, done: int, mode: str, enabled: bool, name: str = "") -> Any:
    if not enabled:
        return None
    if not sys.stderr.isatty():  # a log or CI: lines every few seconds, not a bar
        return _LoggedProgress(total, done, mode, name)
    from tqdm import tqdm

    return tqdm(total=total, initial=done, desc=mode, unit="case", file=sys.stderr,
                dynamic_ncols=True)


def _pending_batches(plan: StudyPlan, chain: tuple[Case, ...], mode: str, store: StudyStore,
                     size: int, start: str = "neighbour", backend: str = "numpy"
                     ) -> list[tuple[Case, ...]]:
    """The batches of ``chain`` still to compute, finished cases left out: grid lines (or
    whole geometries from zero) on NumPy; on torch, consecutive cases from zero, or from
    the neighbour geometry waves (one geometry: the wavefront of its lines)."""
    if mode != "cold" and backend == "torch":
        batches = (plan.batches(chain, size, "any") if start == "zero" else
                   plan.geometry_waves(chain) or plan.wavefront(chain, size))
    else:
        batches = plan.batches(chain, size,
                               "geometry" if start == "zero" and mode != "cold" else "line")
    pending = [tuple(c for c in batch if not store.finished(mode, c.number))
               for batch in batches]
    return [batch for batch in pending if batch]


def _run_serial(model: Model, grid: Grid, plan: StudyPlan, mode: str, options: LatinOptions,
                store: StudyStore, finished: Callable[[list[dict[str, Any]], ChainState | None], None],
                batch: int, workers: int, scheduler: str | None, start: str,
                schedule: str, rolling: bool = True) -> None:
    for chain_number, chain in enumerate(plan.chains):
        state = store.chain_state(mode, chain_number) if mode != "cold" else None
        if rolling and rolls(mode, options, start, batch):
            pending = {c.number for c in chain if not store.finished(mode, c.number)}
            run_rolling(model, grid, plan, chain, mode, options, state, pending, batch,
                        finished)
            continue
        if (mode != "cold" and start == "neighbour" and options.backend == "numpy"
                and from_the_middle(plan)):  # the waves' starts, as the rolling batch's
            pending = {c.number for c in chain if not store.finished(mode, c.number)}
            run_line_tasks(model, grid, plan, chain, mode, options, pending, batch, state,
                           start, finished)
            continue
        for cases in _pending_batches(plan, chain, mode, store, batch, start,
                                      options.backend):
            records, state = plans.run_chain_step(model, grid, cases, mode, options, state, start)
            finished(records, state)


def _run_dask(model: Model, grid: Grid, plan: StudyPlan, mode: str, options: LatinOptions,
              store: StudyStore, finished: Callable[[list[dict[str, Any]], ChainState | None], None],
              batch: int, workers: int, scheduler: str | None, start: str,
              schedule: str) -> None:
    """Each batch of cases a task: with ``schedule="waves"`` the tasks of ``study.waves``
    (a grid line after its parent line); with ``"chains"``, within a chain each task takes
    the previous one's output (its warm-start state), chains run in parallel. The client
    alone writes the store."""
    try:
        from dask.distributed import Client, as_completed
    except ImportError:
        raise ModelError("--workers/--scheduler need Dask: pip install 'multilatin[dask]'"
                         ) from None
    cluster: Any = None
    warm_ups: list[Any] = []
    # Dask's nanny writes its workers' environment (OMP_NUM_THREADS=1, …) into this
    # process's too: the caller's environment is restored when the study ends
    environment = dict(os.environ)
    if scheduler:
        try:
            client = Client(scheduler, timeout=SCHEDULER_TIMEOUT_S)
        except (OSError, TimeoutError) as exc:
            raise ModelError(f"--scheduler {scheduler}: cannot connect within "
                             f"{SCHEDULER_TIMEOUT_S:g} s ({type(exc).__name__}: {exc})") from None
    else:
        cluster = local_cluster(workers)
        client = Client(cluster)
    try:
        model_future = client.scatter(model, broadcast=True)
        # every worker loads the compiled kernels now, beside the first task (the middle
        # line's root on one worker), not at its own first task, on the waves' critical path
        warm_ups = warm_workers(client, model_future, plan.cases[0], options,
                                f"{mode}-{id(store)}")
        futures = []
        if schedule == "waves" and start != "zero":
            n_workers = workers or len(worker_addresses(client))
            futures = submit_line_tasks(client, model_future, grid, plan, mode, options,
                                        store, batch, n_workers, start)
        else:
            # "chains": each batch takes its chain's previous one's output; "waves" from
            # zero: the batches need no other's output, each a task handed out as workers
            # free up
            chained = schedule == "chains"
            for chain_number, chain in enumerate(plan.chains):
                previous: Any = (store.chain_state(mode, chain_number)
                                 if chained and mode != "cold" else None)
                for cases in _pending_batches(plan, chain, mode, store, batch, start,
                                              options.backend):
                    task = client.submit(plans.run_chain_step, model_future, grid, cases, mode,
                                         options, previous, start, pure=False,
                                         key=f"{mode}-batch-{cases[0].number}-{id(store)}")
                    # the chain's state (GBs on torch) stays on its worker for the next
                    # batch; the client gets the records and what the store keeps
                    futures.append(client.submit(plans.chain_step_stored, task, pure=False)
                                   if chained and mode != "cold" else task)
                    previous = task if chained else None
            previous = task = None
        # as_completed holds each future until done; a chained batch's full state is held by
        # the chain's next batch and its summary alone, and leaves its worker after both
        completed = as_completed(futures)
        futures.clear()
        for future in completed:
            records, state = future.result()
            future.release()
            finished(records, state)
    finally:
        del warm_ups
        client.close()
        if cluster is not None:
            cluster.close()
        os.environ.clear()
        os.environ.update(environment)
