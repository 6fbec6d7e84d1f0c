"""Where a serial multiresolution study starts: from a corner (the traversal's rule, each
grid line from the line before it) against from the middle (Dask's waves' rule, since
session 19 the serial default for studies of one geometry over two or more parameters),
side by side in one process, alternately.

    python benchmarks/middle_starts.py [--models b1 b1-4] [--repeat 3] [--no-tight]

On the 13 × 13 grid (μ1, μ2 ∈ {0, 0.05, …, 0.6}; the studies' default options, QoI stopping
at 1e-3; the rolling batch of 16): per model and rule, the multiresolution study's wall
time (median of ``--repeat`` runs, with the runs), the process's CPU time (median), the
iterations, the rolling batch's iterations and its mean width (case-iterations per batch
iteration), the longest chain of starts (cases from the one started from zero), and
R_stop's worst error against tight solves (η < 1e-10) with the cases within 0.1 %.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.latin import iteration
from multilatin.parameters import Grid
from multilatin.study import rolling
from multilatin.study.plan import clear_operator_cache

GRID = ["mu1=0:0.6:13", "mu2=0:0.6:13"]


def _run(model: ml.Model, grid: Grid, middle: bool, folder: Path) -> dict[str, Any]:
    clear_operator_cache()
    original_rule = rolling.from_the_middle
    original_step = iteration.BatchIterations.step
    counts = {"steps": 0, "case_iterations": 0}

    def step(batch: iteration.BatchIterations) -> Any:
        counts["steps"] += 1
        counts["case_iterations"] += int(batch.active.size)
        return original_step(batch)

    rolling.from_the_middle = original_rule if middle else lambda plan: False
    iteration.BatchIterations.step = step
    try:
        cpu = time.process_time()
        result = ml.run_study(model, grid, out=folder, progress=False)
        cpu = time.process_time() - cpu
    finally:
        rolling.from_the_middle = original_rule
        iteration.BatchIterations.step = original_step
    records = sorted(result.records, key=lambda r: r["number"])
    by_label = {", ".join(f"{n}={grid[n][i]:g}" for n, i in zip(grid, r["index"], strict=True)):
                r for r in records}  # as a record names its start
    depth = 0
    for record in records:  # the chain of starts back to the case started from zero
        steps, current = 0, record
        while not current["start"].startswith("zero"):
            current, steps = by_label[current["start"]], steps + 1
        depth = max(depth, steps)
    return {"time": result.elapsed_s["multiresolution"], "cpu": cpu,
            "iterations": sum(r["iterations"] for r in records),
            "steps": counts["steps"], "depth": depth,
            "width": counts["case_iterations"] / max(counts["steps"], 1),
            "R_stop": {tuple(r["index"]): r["qoi"]["R_stop"] for r in records}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=["b1"])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--no-tight", action="store_true",
                        help="skip the tight solves (R_stop's error not measured)")
    args = parser.parse_args()
    grid = Grid.parse(GRID)
    print("| model | starts | multiresolution s (median; runs) | process CPU s (median) | "
          "iterations | batch iterations | cases together (mean) | longest chain of starts "
          "| R_stop within 0.1 % | worst R_stop error |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.models:
            model = ml.load_model(name)
            tight: dict[tuple[int, ...], float] = {}
            if not args.no_tight:
                options = ml.LatinOptions(tol=1e-10, max_iter=10000)
                for index in np.ndindex(*grid.shape):
                    mu = grid.mu(index, model.parameters)
                    tight[index] = float(model.solve(mu, options=options).qoi["R_stop"])  # type: ignore[arg-type]
            _run(model, grid, True, Path(tmp) / f"{name}-warm-up")  # kernels, caches
            runs: dict[bool, list[dict[str, Any]]] = {False: [], True: []}
            for n in range(args.repeat):
                for middle in (False, True):
                    runs[middle].append(_run(model, grid, middle,
                                             Path(tmp) / f"{name}-{middle}-{n}"))
            for middle in (False, True):
                times = [run["time"] for run in runs[middle]]
                last = runs[middle][-1]
                accuracy = "— | —"
                if tight:
                    error = np.array([abs(last["R_stop"][i] - t) / max(abs(t), 1.0)
                                      for i, t in tight.items()])
                    accuracy = (f"{int(np.sum(error <= 1e-3))}/{error.size} | "
                                f"{100 * float(error.max()):.3f} %")
                print(f"| {name} | {'middle' if middle else 'corner'} | "
                      f"{statistics.median(times):.2f} ({', '.join(f'{t:.2f}' for t in times)})"
                      f" | {statistics.median(run['cpu'] for run in runs[middle]):.2f} | "
                      f"{last['iterations']} | {last['steps']} | {last['width']:.1f} | "
                      f"{last['depth']} | {accuracy} |")


if __name__ == "__main__":
    main()
