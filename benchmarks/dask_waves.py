"""Sharing a multiresolution study among workers: contiguous chains (each from zero) against
the wave schedule (``multilatin.study.waves``: grid lines as tasks, each from its parent line).

    python benchmarks/dask_waves.py --study b1 --workers 2 4 8 16 [--dask 2]
    python benchmarks/dask_waves.py --study b3 --workers 16
    python benchmarks/dask_waves.py --study b3 --no-predict --dask 4 8 16   # 16 free cores

Iterations are the solver's, whatever the machine. The times are *predicted* for a machine
with as many free cores as workers, from costs measured here one task at a time (so that
two shared cores can say something about sixteen): chains, each chain's cases solved in
this process (``run_study(chains=W)``), the slowest chain's time; waves, every task of the
graph solved in this process in order, then a list schedule of the graph on W workers
(ready tasks to free workers, longest first). Speed-ups against the serial study (one
chain, lines batched) of the same run: the sum of its cases' times. Not counted: Dask's
per-task overhead and transfers, and each worker building the operators of its geometries
(once per worker and geometry); ``--dask W [W ...]`` also runs both schedules on a real
local Dask cluster of W processes and prints their wall times and the time their cases took on the
workers (meaningful only where W cores are free: on 2 shared cores the client, the
scheduler and two workers compete).
"""

from __future__ import annotations

import argparse
import heapq
import tempfile
import time
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.latin.options import STUDY_QOI_RTOL
from multilatin.study.cluster import local_cluster
from multilatin.study.plan import clear_operator_cache, plan_study
from multilatin.study.waves import line_tasks, run_line_task

#: model, grid, and a small grid that loads the compiled kernels first (warm-up)
STUDIES = {
    "b1": ("b1", ["mu1=0:0.6:13", "mu2=0:0.6:13"], ["mu1=0:0.6:13", "mu2=0.3"]),
    "b3": ("b3", ["xc=23:27:5", "mu1=0:0.6:13", "mu2=0:0.6:13", "rc=3"],
           ["xc=23:27:5", "mu1=0.3"]),
}


def makespan(durations: list[float], parents: list[tuple[int, ...]], workers: int) -> float:
    """List schedule of a task graph (tasks in an order where parents come first) on
    ``workers``: a ready task goes to the first free worker, longest ready task first."""
    children: dict[int, list[int]] = {}
    waiting = [len(p) for p in parents]
    for t, ps in enumerate(parents):
        for p in ps:
            children.setdefault(p, []).append(t)
    ready = [(-durations[t], t) for t in range(len(durations)) if not parents[t]]
    heapq.heapify(ready)
    running: list[tuple[float, int]] = []  # (finish time, task)
    now, free = 0.0, workers
    while ready or running:
        while ready and free:
            _, t = heapq.heappop(ready)
            heapq.heappush(running, (now + durations[t], t))
            free -= 1
        now, t = heapq.heappop(running)
        free += 1
        for child in children.get(t, []):
            waiting[child] -= 1
            if waiting[child] == 0:
                heapq.heappush(ready, (-durations[child], child))
    return now


def waves_in_process(model: ml.Model, grid: ml.Grid, options: ml.LatinOptions, workers: int
                     ) -> tuple[list[float], list[tuple[int, ...]], int]:
    """Every task of the wave graph solved here in order: durations, parents, iterations."""
    plan = plan_study(model, grid, options, 1)
    tasks = line_tasks(plan, plan.chains[0], workers, 16)
    outputs: dict[int, Any] = {}
    durations = []
    for t, task in enumerate(tasks):
        start = time.perf_counter()
        outputs[t] = run_line_task(model, grid, task.cases, "multiresolution", options,
                                   [outputs[p] for p in task.parents], None)
        durations.append(time.perf_counter() - start)
    iterations = sum(r["iterations"] for output in outputs.values() for r in output[0])
    return durations, [task.parents for task in tasks], iterations


def study(model: ml.Model, grid: ml.Grid, options: ml.LatinOptions, **kwargs: Any
          ) -> tuple[float, list[dict[str, Any]]]:
    clear_operator_cache()
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        result = ml.run_study(model, grid, options=options, out=out, progress=False,
                              on_failure="ignore", **kwargs)
        return time.perf_counter() - start, result.records


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", choices=sorted(STUDIES), default="b1")
    parser.add_argument("--workers", type=int, nargs="+", default=[2, 4, 8, 16])
    parser.add_argument("--dask", type=int, nargs="*", default=[],
                        help="also run on W Dask workers (several numbers: one cluster each)")
    parser.add_argument("--no-predict", action="store_true",
                        help="only the serial study and the Dask runs (no in-process "
                             "chains or wave tasks: a short run on a lent machine)")
    args = parser.parse_args()
    name, spec, warm_up = STUDIES[args.study]
    model = ml.load_model(name)
    grid = ml.Grid.parse(spec)
    options = ml.LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    study(model, ml.Grid.parse(warm_up), options)
    serial_wall, serial = study(model, grid, options)
    serial_s = sum(r["wall_s"] for r in serial)  # its cases' computing, as for the others
    serial_iterations = sum(r["iterations"] for r in serial)
    print(f"{args.study}: {grid.size} cases; serial study (one chain) {serial_s:.1f} s "
          f"computing ({serial_wall:.1f} s wall), {serial_iterations} iterations", flush=True)
    if not args.no_predict:
        predictions(model, grid, options, args.workers, serial_s)
    for workers in args.dask:
        on_dask(model, grid, options, workers, serial_s, serial_wall)


def predictions(model: ml.Model, grid: ml.Grid, options: ml.LatinOptions, workers_list:
                list[int], serial_s: float) -> None:
    """Chains (each chain's cases solved here) and waves (a list schedule of the tasks'
    times measured here) predicted for as many free cores as workers."""
    clear_operator_cache()
    durations, parents, wave_iterations = waves_in_process(model, grid, options,
                                                           max(workers_list))
    print(f"wave tasks in this process "
          f"{sum(durations):.1f} s ({len(durations)} tasks for {max(workers_list)} workers), "
          f"{wave_iterations} iterations\n")
    print("| workers | chains: iterations | chains: slowest chain (s) | chains: speed-up | "
          "waves: iterations | waves: predicted (s) | waves: speed-up |")
    print("|---|---|---|---|---|---|---|")
    for workers in workers_list:
        _, records = study(model, grid, options, chains=workers)
        per_chain: dict[int, float] = {}
        for r in records:
            per_chain[r["chain"]] = per_chain.get(r["chain"], 0.0) + r["wall_s"]
        slowest = max(per_chain.values())
        predicted = makespan(durations, parents, workers)
        print(f"| {workers} | {sum(r['iterations'] for r in records)} | {slowest:.1f} | "
              f"{serial_s / slowest:.1f} | {wave_iterations} | {predicted:.1f} | "
              f"{serial_s / predicted:.1f} |")


def on_dask(model: ml.Model, grid: ml.Grid, options: ml.LatinOptions, workers: int,
            serial_s: float, serial_wall: float) -> None:
    """Both schedules on a real local cluster of ``workers`` processes: wall times against
    the serial study's."""
    start = time.perf_counter()
    local_cluster(workers).close()  # the study's own kind of cluster
    print(f"\nDask, {workers} workers (a local cluster alone starts and stops in "
          f"{time.perf_counter() - start:.1f} s); the cases' time on the workers against "
          f"the serial study's {serial_s:.1f} s ({serial_wall:.1f} s wall):\n")
    print("| schedule | wall (s) | speed-up (serial wall / wall) | first case done at (s) "
          "| cases' time on the workers (s) | iterations | converged |")
    print("|---|---|---|---|---|---|---|")
    for schedule in ("chains", "waves"):
        wall, records = study(model, grid, options, workers=workers, schedule=schedule)
        print(f"| {schedule} | {wall:.1f} | {serial_wall / wall:.1f} | "
              f"{min(r['elapsed_s'] for r in records):.1f} | "
              f"{sum(r['wall_s'] for r in records):.1f} | "
              f"{sum(r['iterations'] for r in records)} | "
              f"{np.mean([r['converged'] for r in records]) * 100:.0f} % |", flush=True)


if __name__ == "__main__":
    main()
