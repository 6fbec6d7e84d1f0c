"""Where a serial multiresolution study starts: from a corner (the traversal's rule, each
grid line from the line before it) against from the middle (Dask's waves' rule, since
session 19 the serial default for studies over two or more parameters, all geometric or
none), side by side in one process, alternately.

    python benchmarks/middle_starts.py [--studies b1 b1-4 b1-9 b3-positions] [--repeat 3]
                                       [--no-tight]

Studies: b1, b1-4, b1-9: the 13 × 13 grid μ1, μ2 ∈ {0, 0.05, …, 0.6}; b3-positions: B3's 5 × 5
hole positions, rc = 3 (paper table 2). The studies' default options (QoI stopping at 1e-3,
the rolling batch of 16). Per study and rule, the multiresolution study's wall
time (median of ``--repeat`` runs, with the runs), the process's CPU time (median), the
iterations, the rolling batch's iterations and its mean width (case-iterations per batch
iteration), the longest chain of starts (cases from the one started from zero), and
R_stop's worst error against tight solves (η < 1e-10) with the cases within 0.1 %. Then
the iterations per case by how it started (from zero, solved again from zero, from a
neighbour along each parameter) and per value of the grid's first parameter.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from rolling import _Widths as Widths  # benchmarks/rolling.py (this script's folder)

import multilatin as ml
from multilatin.parameters import Grid
from multilatin.study import rolling as study_rolling
from multilatin.study.plan import clear_operator_cache

STUDIES = {
    "b1": ("b1", ["mu1=0:0.6:13", "mu2=0:0.6:13"]),
    "b1-4": ("b1-4", ["mu1=0:0.6:13", "mu2=0:0.6:13"]),
    "b1-9": ("b1-9", ["mu1=0:0.6:13", "mu2=0:0.6:13"]),
    "b3-positions": ("b3", ["xc=23:27:5", "yc=73:77:5", "rc=3"]),
}


def _run(model: ml.Model, grid: Grid, middle: bool, folder: Path) -> dict[str, Any]:
    clear_operator_cache()
    original_rule = study_rolling.from_the_middle
    study_rolling.from_the_middle = original_rule if middle else lambda plan: False
    try:
        cpu = time.process_time()
        with Widths() as widths:  # benchmarks/rolling.py's counter of batch iterations
            result = ml.run_study(model, grid, out=folder, progress=False)
        cpu = time.process_time() - cpu
    finally:
        study_rolling.from_the_middle = original_rule
    records = sorted(result.records, key=lambda r: r["number"])
    by_label = {", ".join(f"{n}={grid[n][i]:g}" for n, i in zip(grid, r["index"], strict=True)):
                r for r in records}  # as a record names its start
    depth = 0
    for record in records:  # the chain of starts back to the case started from zero
        steps, current = 0, record
        while not current["start"].startswith("zero"):
            current, steps = by_label[current["start"]], steps + 1
        depth = max(depth, steps)
    kinds: dict[str, list[int]] = {}  # iterations per case by how it started
    for record in records:
        if record["start"].startswith("zero"):
            kind = "from zero" if record["start"] == "zero" else "again from zero"
        else:
            start = by_label[record["start"]]["index"]
            kind = "along " + next(n for n, a, b in zip(grid, start, record["index"],
                                                        strict=True) if a != b)
        kinds.setdefault(kind, []).append(record["iterations"])
    first = next(iter(grid))
    rows = [float(np.mean([r["iterations"] for r in records if r["index"][0] == i]))
            for i in range(len(grid[first]))]
    return {"time": result.elapsed_s["multiresolution"], "cpu": cpu, "kinds": kinds,
            "rows": rows,
            "iterations": sum(r["iterations"] for r in records),
            "steps": widths.steps, "depth": depth,
            "width": widths.case_iterations / max(widths.steps, 1),
            "R_stop": {tuple(r["index"]): r["qoi"]["R_stop"] for r in records}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--studies", nargs="+", default=["b1", "b3-positions"],
                        choices=list(STUDIES))
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--no-tight", action="store_true",
                        help="skip the tight solves (R_stop's error not measured)")
    args = parser.parse_args()
    print("| study | starts | multiresolution s (median; runs) | process CPU s (median) | "
          "iterations | batch iterations | cases together (mean) | longest chain of starts "
          "| R_stop within 0.1 % | worst R_stop error |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    breakdown: dict[tuple[str, bool], dict[str, Any]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.studies:
            model_name, items = STUDIES[name]
            model, grid = ml.load_model(model_name), Grid.parse(items)
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
                breakdown[(name, middle)] = last
    print("\nIterations per case by start (cases × mean), and per value of the first "
          "parameter (mean), in the last run of each:")
    for (name, middle), run in breakdown.items():
        kinds = "; ".join(f"{kind} {len(its)} × {np.mean(its):.1f}"
                          for kind, its in sorted(run["kinds"].items()))
        print(f"- {name}, {'middle' if middle else 'corner'}: {kinds}; per value: "
              + " ".join(f"{r:.1f}" for r in run["rows"]))


if __name__ == "__main__":
    main()
