"""Settled leading steps (``LatinOptions.settled_steps``) side by side with every step every
iteration (``settled_steps=0``), in one process, alternately: studies with ``run_study``'s
defaults (the QoI rule) and cold solves at the four pairs of ``convergence.py``. Prints per
row the wall times (median over ``--rounds``), the iterations, the share of the (case, step)
rows the linear stage ran, and the largest change of R_stop between the two.

    python benchmarks/settled_steps.py
    python benchmarks/settled_steps.py --rounds 3 --rows b1-study b3-frictions

Rows: ``b1-study`` the main job's study (B1 13 × 13), ``b3-frictions`` B3 13 × 13 frictions
at rc = 3 (one geometry of the 21 125-case study), ``b3-positions`` B3's 5 × 5 hole
positions, ``cold`` cold solves of b1, b1-9 and b3 at the four pairs (η < 1e-6).
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOptions, solve_latin
from multilatin.latin.engine import NumpyFields
from multilatin.latin.operators import LatinOperators
from multilatin.study.plan import clear_operator_cache
from multilatin.study.runner import STUDY_QOI_RTOL

STUDIES = {
    "b1-study": ("b1", ["mu1=0:0.6:13", "mu2=0:0.6:13"]),
    "b3-frictions": ("b3", ["mu1=0:0.6:13", "mu2=0:0.6:13", "rc=3"]),
    "b3-positions": ("b3", ["xc=23:27:5", "yc=73:77:5"]),
}
PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]

#: (case, step) rows the linear stage ran, and of all rows
ROWS = [0, 0]


def _count_rows() -> None:
    original = NumpyFields.linear_stage

    def counted(engine: NumpyFields, relaxation: np.ndarray) -> None:
        ROWS[0] += int((engine.w_hat.shape[1] - engine.first).sum())
        ROWS[1] += engine.w_hat.shape[1] * engine.first.size
        original(engine, relaxation)

    NumpyFields.linear_stage = counted  # type: ignore[method-assign]


def study(row: str, factor: float) -> tuple[float, int, dict[Any, float]]:
    name, grid = STUDIES[row]
    clear_operator_cache()
    options = LatinOptions(qoi_rtol=STUDY_QOI_RTOL, settled_steps=factor)
    t0 = time.perf_counter()
    result = ml.run_study(ml.load_model(name), ml.Grid.parse(grid), options=options,
                          progress=False)
    wall = time.perf_counter() - t0
    answers = {tuple(sorted(r["params"].items())): r["qoi"]["R_stop"] for r in result.records}
    return wall, sum(r["iterations"] for r in result.records), answers


def cold(factor: float) -> tuple[float, int, dict[Any, float]]:
    wall, iterations, answers = 0.0, 0, {}
    for name in ("b1", "b1-9", "b3"):
        model = ml.load_model(name)
        options = LatinOptions(settled_steps=factor)
        ops = LatinOperators(model.assemble({"mu1": 0.3, "mu2": 0.3}), options)
        for mu1, mu2 in PAIRS:
            t0 = time.perf_counter()
            result = solve_latin(model.assemble({"mu1": mu1, "mu2": mu2}), options,
                                 operators=ops)
            wall += time.perf_counter() - t0
            iterations += result.iterations
            answers[name, mu1, mu2] = float(result.qoi["R_stop"])  # type: ignore[arg-type]
    return wall, iterations, answers


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rows", nargs="+", default=[*STUDIES, "cold"],
                        choices=[*STUDIES, "cold"])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--factor", type=float, default=LatinOptions().settled_steps)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    _count_rows()
    ml.run_study(ml.load_model("b1"), ml.Grid.parse(["mu1=0.1", "mu2=0.1:0.15:2"]),
                 progress=False)  # kernels
    print(f"| row | settled_steps | wall (s), median of {args.rounds} | iterations "
          "| rows run | largest R_stop change (N) |")
    print("|---|---|---|---|---|---|")
    for row in args.rows:
        runs: dict[float, list[tuple[float, int, dict[Any, float]]]] = {}
        shares: dict[float, float] = {}
        for _ in range(args.rounds):
            for factor in (0.0, args.factor):
                ROWS[:] = [0, 0]
                runs.setdefault(factor, []).append(
                    study(row, factor) if row in STUDIES else cold(factor))
                shares[factor] = ROWS[0] / max(ROWS[1], 1)
        base = runs[0.0][0][2]
        for factor, results in runs.items():
            change = max(abs(results[0][2][k] - base[k]) for k in base)
            print(f"| {row} | {factor:g} | {statistics.median(r[0] for r in results):.2f} | "
                  f"{results[0][1]} | {shares[factor]:.3f} | {change:.2e} |", flush=True)


if __name__ == "__main__":
    main()
