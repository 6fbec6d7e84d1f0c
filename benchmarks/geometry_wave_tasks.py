"""Issue 16's Dask target, predicted for a schedule not built: B3's 845-case study (5 hole
positions × 13 × 13 frictions, ``dask_waves.py``'s) as geometry waves of independent tasks
on the NumPy backend. The middle position's frictions from zero in ``--chunks`` tasks, then
each chunk at the positions one step out from the same chunk one step in (each case from
the same frictions there); the tasks of a wave need nothing from one another.

    python benchmarks/geometry_wave_tasks.py [--chunks 16] [--workers 1 2 4 8 16]

Each task is solved and timed here, one after another (its operators built anew, as a
worker meeting the geometry would), then list-scheduled on W workers
(``dask_waves.makespan``); the speed-up is against the serial study (``run_study``'s
default, one process) of the same run. Not counted: Dask's start-up, per-task overhead and
the parents' fields sent between workers (~0.46 MB a case).
"""

from __future__ import annotations

import argparse
import tempfile
import time

from dask_waves import makespan  # benchmarks/dask_waves.py (this script's folder)

import multilatin as ml
from multilatin.latin.options import STUDY_QOI_RTOL
from multilatin.study.chain_state import ChainState
from multilatin.study.cluster import load_kernels
from multilatin.study.plan import Case, _solve_together, clear_operator_cache, plan_study

GRID = ["xc=23:27:5", "mu1=0:0.6:13", "mu2=0:0.6:13", "rc=3"]
#: the positions' order (grid index along xc) and each one's parent position
WAVES = ((2, None), (1, 2), (3, 2), (0, 1), (4, 3))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--chunks", type=int, default=16)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2, 4, 8, 16])
    args = parser.parse_args()
    model, grid = ml.load_model("b3"), ml.Grid.parse(GRID)
    options = ml.LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    plan = plan_study(model, grid, options, 1)
    load_kernels(model, plan.cases[0], options)
    clear_operator_cache()
    with tempfile.TemporaryDirectory() as folder:
        t0 = time.perf_counter()
        serial = ml.run_study(model, grid, options=options, out=folder, progress=False)
        serial_wall = time.perf_counter() - t0
    print(f"serial study: {serial_wall:.1f} s, "
          f"{sum(r['iterations'] for r in serial.records)} iterations")
    positions: dict[int, list[Case]] = {}
    for case in plan.cases:
        positions.setdefault(case.index[0], []).append(case)
    converged: dict[tuple[int, ...], tuple] = {}
    durations: list[float] = []
    parents: list[tuple[int, ...]] = []
    task_of: dict[tuple[int, int], int] = {}
    iterations = 0
    for position, parent in WAVES:
        cases = sorted(positions[position], key=lambda c: c.index[1:])
        for chunk in range(args.chunks):
            part = tuple(cases[chunk::args.chunks])
            state = ChainState(len(part) * 2 + 1)
            if parent is not None:
                state = state.added_all([((parent, *c.index[1:]),
                                          converged[(parent, *c.index[1:])], False)
                                         for c in part])
            clear_operator_cache()
            t0 = time.perf_counter()
            records, after = _solve_together(model, grid, part, "multiresolution", options,
                                             state)
            durations.append(time.perf_counter() - t0)
            iterations += sum(r["iterations"] for r in records)
            assert after is not None
            converged.update((c.index, after.retained[c.index]) for c in part
                             if c.index in after.retained)
            parents.append(() if parent is None else (task_of[(parent, chunk)],))
            task_of[(position, chunk)] = len(durations) - 1
    print(f"geometry waves: {len(durations)} tasks, {iterations} iterations, "
          f"{sum(durations):.1f} s one after another here")
    for workers in args.workers:
        span = makespan(durations, parents, workers)
        print(f"  {workers} workers: {span:.1f} s predicted, {serial_wall / span:.1f} × the "
              "serial study")


if __name__ == "__main__":
    main()
