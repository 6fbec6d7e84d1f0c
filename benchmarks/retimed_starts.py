"""Retimed starts along friction lines (issue 16, session 33; ``multilatin.study.retiming``):
what they save, side by side with the start neighbour's fields as they are, in one process.

    python benchmarks/retimed_starts.py                 # the main job's study, 3 rounds
    python benchmarks/retimed_starts.py --lines         # single friction lines of B1, B1-9, B3
    python benchmarks/retimed_starts.py --b3            # + B3's 13 x 13 frictions x 5 positions

Studies run with ``run_study``'s defaults (the studies' QoI rule, rolling batch of 16),
alternately with retimed starts on ("retimed") and off ("as they are": the start
neighbour's fields, as before session 33; ``predictors.retimed_fields`` patched to give
none), ``--rounds`` times each; printed: iterations in all, the study's wall time (median
and spread), the cases that started retimed, and R_stop's largest difference between the
two (relative, floored at 1 N; each is checked against tight solves by
``benchmarks/suite.py --multiresolution-only`` and ``benchmarks/path_independence.py``).
``--lines``: each line a study of its own (friction lines of 13 values from 0, and two lines
along the stop's gap), the iterations of its warm cases from the third on (the first two
cannot be retimed) both ways, and how many started retimed.
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
from multilatin.latin.engine import NumpyFields
from multilatin.study import predictors
from multilatin.study.plan import clear_operator_cache

STUDIES = {"B1 13 x 13 (main job)": ("b1", ["mu1=0:0.6:13", "mu2=0:0.6:13"]),
           "B3 13 x 13 x 5 positions": ("b3", ["mu1=0:0.6:13", "mu2=0:0.6:13",
                                               "xc=23:27:5", "rc=3"])}
LINES = [("b1", ["mu1=0.3", "mu2=0:0.6:13"]), ("b1", ["mu1=0.2", "mu2=0:0.6:13"]),
         ("b1", ["mu1=0.1", "mu2=0:0.6:13"]), ("b1", ["mu2=0.1", "mu1=0:0.6:13"]),
         ("b1", ["mu2=0.25", "mu1=0:0.6:13"]), ("b1-4", ["mu1=0.3", "mu2=0:0.6:13"]),
         ("b1-9", ["mu1=0.3", "mu2=0:0.6:13"]), ("b3", ["mu1=0.3", "mu2=0:0.6:13"]),
         # the stop's gap: the block slides further, not later (no retimed start)
         ("b1", ["mu1=0.1", "mu2=0.1", "gap=0.01:0.07:7"]),
         ("b1", ["mu1=0.3", "mu2=0.1", "gap=0.01:0.07:7"])]
ORIGINAL = predictors.retimed_fields
#: (case, step) rows the linear stage ran (settled leading steps are not run)
ROWS = [0]


def _count_rows() -> None:
    original = NumpyFields.linear_stage

    def counted(engine: NumpyFields, relaxation: np.ndarray) -> None:
        ROWS[0] += int((engine.w_hat.shape[1] - engine.first).sum())
        original(engine, relaxation)

    NumpyFields.linear_stage = counted  # type: ignore[method-assign]


def run(name: str, grid: list[str], retimed: bool) -> tuple[list[dict[str, Any]], float]:
    """The study's records in traversal order and its wall time (``ROWS`` counts on)."""
    predictors.retimed_fields = ORIGINAL if retimed else (lambda *args: None)  # type: ignore[assignment]
    try:
        clear_operator_cache()
        model = ml.load_model(name)
        with tempfile.TemporaryDirectory() as out:
            t0 = time.perf_counter()
            study = ml.run_study(model, ml.Grid.parse(grid), out=Path(out), progress=False)
            wall = time.perf_counter() - t0
    finally:
        predictors.retimed_fields = ORIGINAL
    return sorted(study.records, key=lambda r: r["number"]), wall


def worst_difference(a: list[dict[str, Any]], b: list[dict[str, Any]]) -> float:
    return max(abs(x["qoi"]["R_stop"] - y["qoi"]["R_stop"]) / max(abs(y["qoi"]["R_stop"]), 1.0)
               for x, y in zip(a, b, strict=True))


def studies(names: list[str], rounds: int) -> None:
    print("| study | start | iterations | (case, step) rows run | wall time (s): median "
          "(spread) | retimed starts | R_stop: largest difference |")
    print("|---|---|---|---|---|---|---|")
    for label in names:
        name, grid = STUDIES[label]
        run(name, grid, True)  # warm-up: imports, kernels
        times: dict[bool, list[float]] = {True: [], False: []}
        records: dict[bool, list[dict[str, Any]]] = {}
        rows: dict[bool, int] = {}
        for _ in range(rounds):
            for retimed in (False, True):
                ROWS[0] = 0
                records[retimed], wall = run(name, grid, retimed)
                times[retimed].append(wall)
                rows[retimed] = ROWS[0]
        difference = worst_difference(records[True], records[False])
        for retimed in (False, True):
            recs = records[retimed]
            print(f"| {label} | {'retimed' if retimed else 'as they are'} | "
                  f"{sum(r['iterations'] for r in recs)} | {rows[retimed]} | "
                  f"{statistics.median(times[retimed]):.2f} ({min(times[retimed]):.2f}–"
                  f"{max(times[retimed]):.2f}) | "
                  f"{sum('retimed' in r['start'] for r in recs)} | "
                  f"{difference:.1e} |", flush=True)


def lines() -> None:
    print("| model | line | warm cases from the third: as they are | retimed "
          "| retimed starts | R_stop: largest difference |")
    print("|---|---|---|---|---|---|")
    total = {False: 0, True: 0}
    for name, grid in LINES:
        records = {retimed: run(name, grid, retimed)[0] for retimed in (False, True)}
        counts = {k: [r["iterations"] for r in v[2:]] for k, v in records.items()}
        for k in total:
            total[k] += sum(counts[k])
        print(f"| {name} | {', '.join(grid)} | {sum(counts[False])} "
              f"({' '.join(map(str, counts[False]))}) | {sum(counts[True])} "
              f"({' '.join(map(str, counts[True]))}) | "
              f"{sum('retimed' in r['start'] for r in records[True])} | "
              f"{worst_difference(records[True], records[False]):.1e} |", flush=True)
    print(f"\nin all: {total[False]} as they are, {total[True]} retimed "
          f"({total[True] / total[False] - 1:+.0%})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--lines", action="store_true", help="single friction lines instead")
    parser.add_argument("--b3", action="store_true", help="B3's 845-case study too")
    args = parser.parse_args()
    if args.lines:
        lines()
        return
    _count_rows()
    names = list(STUDIES) if args.b3 else list(STUDIES)[:1]
    studies(names, args.rounds)


if __name__ == "__main__":
    main()
