"""A serial multiresolution study as one rolling batch against grid lines solved batch
after batch (``run_study(rolling=...)``), side by side in one process, alternately.

    python benchmarks/rolling.py [--studies b1 b3-positions b3-frictions] [--repeat 3]

Studies (the studies' default options, QoI stopping at 1e-3):

- b1: B1's 13 × 13 frictions (the README's main job);
- b3-positions: B3's 5 × 5 hole positions, rc = 3 (paper table 2);
- b3-frictions: B3's 7 × 7 frictions at two hole positions (xc = 23, 27).

Per study and schedule: the multiresolution study's wall time (median of ``--repeat``
runs, with the spread), the process's CPU time over the whole ``run_study`` call (median;
less moved by other tenants of a shared machine than the wall time), its iterations, the
largest relative R_stop difference between the two schedules (the same starts; the
products grouped otherwise round otherwise, which a contact status flipping mid-iteration
can carry to the stopping accuracy) and the mean number of cases iterating together
(case-iterations over batch iterations).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import multilatin as ml
from multilatin.latin import iteration
from multilatin.parameters import Grid
from multilatin.study.plan import clear_operator_cache

STUDIES = {
    "b1": ("b1", ["mu1=0:0.6:13", "mu2=0:0.6:13"]),
    "b3-positions": ("b3", ["xc=23:27:5", "yc=73:77:5", "rc=3"]),
    "b3-frictions": ("b3", ["xc=23,27", "mu1=0:0.6:7", "mu2=0:0.6:7"]),
}


class _Widths:
    """Counts the batch iterations and the case-iterations in them."""

    def __init__(self) -> None:
        self.steps = self.case_iterations = 0
        self.original = iteration.BatchIterations.step

    def __enter__(self) -> _Widths:
        original, counter = self.original, self

        def step(batch: iteration.BatchIterations) -> Any:
            counter.steps += 1
            counter.case_iterations += int(batch.active.size)
            return original(batch)

        iteration.BatchIterations.step = step  # type: ignore[method-assign,assignment]
        return self

    def __exit__(self, *args: object) -> None:
        iteration.BatchIterations.step = self.original  # type: ignore[method-assign]


def _run(model: ml.Model, grid: Grid, rolling: bool, folder: Path) -> dict[str, Any]:
    clear_operator_cache()
    cpu = time.process_time()
    with _Widths() as widths:
        result = ml.run_study(model, grid, out=folder, progress=False, rolling=rolling)
    cpu = time.process_time() - cpu
    records = sorted(result.records, key=lambda r: r["number"])
    return {"time": result.elapsed_s["multiresolution"], "cpu": cpu,
            "iterations": sum(r["iterations"] for r in records),
            "R_stop": [r["qoi"]["R_stop"] for r in records],
            "width": widths.case_iterations / max(widths.steps, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--studies", nargs="+", default=list(STUDIES), choices=list(STUDIES))
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    print("| study | schedule | multiresolution s (median; runs) | process CPU s (median) | "
          "iterations | cases together (mean) | R_stop vs lines (max rel.) |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.studies:
            model_name, items = STUDIES[name]
            model, grid = ml.load_model(model_name), Grid.parse(items)
            _run(model, grid, True, Path(tmp) / f"{name}-warm-up")  # kernels, caches
            runs: dict[bool, list[dict[str, Any]]] = {False: [], True: []}
            for n in range(args.repeat):
                for rolling in (False, True):
                    folder = Path(tmp) / f"{name}-{rolling}-{n}"
                    runs[rolling].append(_run(model, grid, rolling, folder))
            reference = runs[False][0]["R_stop"]
            for rolling in (False, True):
                times = [run["time"] for run in runs[rolling]]
                cpu = statistics.median(run["cpu"] for run in runs[rolling])
                last = runs[rolling][-1]
                difference = max(abs(a - b) / max(abs(b), 1e-12)
                                 for run in runs[rolling]
                                 for a, b in zip(run["R_stop"], reference, strict=True))
                print(f"| {name} | {'rolling' if rolling else 'lines'} | "
                      f"{statistics.median(times):.2f} ({', '.join(f'{t:.2f}' for t in times)})"
                      f" | {cpu:.2f} | {last['iterations']} | {last['width']:.1f} | {difference:.1e} |")


if __name__ == "__main__":
    main()
