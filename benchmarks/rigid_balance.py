"""Issue 15 (session 36): the rigid balance (``LatinOptions.rigid_balance``) side by side
with today's default, in one process.

After every local stage, the rigid motions each free cluster of substructures can make are
solved for so that ŝ is in equilibrium on them (``latin.rigid_balance``). Cold solves at
the four pairs of ``benchmarks/convergence.py`` for b1, b1-9 and b3, to the default
tolerance (η < 1e-6) and under the studies' QoI rule: iterations, time and R_stop's error
against a tight solve (η < 1e-10, without the balance), relative; with ``--studies``, the
main job's B1 13 × 13 study and B3's 5 × 5 hole positions, multiresolution and cold,
iterations and time (each case's time summed for the cold side), R_stop's largest
difference between the two; with ``--models``, the other bundled models at their defaults.

    python benchmarks/rigid_balance.py [--models b1 b1-9 b3] [--studies] [--bundled]
    python benchmarks/rigid_balance.py --models --studies     # the studies alone
    python benchmarks/rigid_balance.py --models --accuracy    # B1 13 x 13 against tight
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.decomposition.result import SolveResult
from multilatin.latin import LatinOperators, LatinOptions, solve_latin
from multilatin.latin.options import STUDY_QOI_RTOL
from multilatin.parameters import Grid
from multilatin.study.runner import run_study

PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]
STUDIES = {"B1 13 × 13": ("b1", ["mu1=0:0.6:13", "mu2=0:0.6:13"]),
           "B3 5 × 5 positions": ("b3", ["xc=23:27:5", "yc=73:77:5", "rc=3"])}


def balance(on: bool, rtol: float | None = None) -> LatinOptions:
    """The default's options (``on`` False) or the rigid balance's."""
    return LatinOptions(rigid_balance=on, qoi_rtol=rtol)


def pairs(models: list[str], labels: tuple[str, str] = ("default", "rigid balance"),
          options: Callable[[bool, float | None], LatinOptions] = balance,
          setting: Callable[[bool], AbstractContextManager[Any]] = nullcontext) -> None:
    """Cold solves at ``PAIRS``, to η < 1e-6 and under the QoI rule, in two variants side
    by side (``options`` and ``setting`` for each: False, then True): iterations, time and
    R_stop's error against a tight solve of the default, relative."""
    print(f"| model | μ1, μ2 | rule | {labels[0]}: iterations, time (s), R_stop error "
          f"| {labels[1]} |")
    print("|---|---|---|---|---|")
    for name in models:
        model = ml.load_model(name)
        for mu1, mu2 in PAIRS:
            assembly = model.assemble({"mu1": mu1, "mu2": mu2})
            operators = LatinOperators(assembly, LatinOptions())
            tight = solve_latin(assembly, LatinOptions(tol=1e-10, max_iter=20000),
                                operators=operators)
            exact = float(tight.qoi["R_stop"])
            for rule, rtol in (("η < 1e-6", None), ("QoI rule", STUDY_QOI_RTOL)):
                cells = []
                for on in (False, True):
                    start = time.perf_counter()
                    with setting(on):
                        result = solve_latin(assembly, options(on, rtol),
                                             operators=operators, check=False)
                    seconds = time.perf_counter() - start
                    error = abs(float(result.qoi["R_stop"]) - exact) / max(abs(exact), 1.0)
                    cells.append(f"{result.iterations}, {seconds:.3f}, {error:.1e}")
                print(f"| {name} | {mu1}, {mu2} | {rule} | {cells[0]} | {cells[1]} |",
                      flush=True)


#: the bundled models besides B1 and B3, at their defaults
BUNDLED = ("b0", "b2", "punch", "slide", "lug", "roller")


def largest_difference(first: SolveResult, second: SolveResult) -> float:
    """The largest difference of two results' QoIs, relative to each QoI's largest
    magnitude in ``first``."""
    return max(float(np.max(np.abs(np.ravel(second.qoi[q]) - np.ravel(first.qoi[q]))))
               / max(float(np.max(np.abs(first.qoi[q]))), 1e-12) for q in first.qoi)


def bundled(labels: tuple[str, str] = ("default", "rigid balance"),
            options: Callable[[bool, float | None], LatinOptions] = balance,
            setting: Callable[[bool], AbstractContextManager[Any]] = nullcontext) -> None:
    """The other bundled models at their defaults in the two variants (as ``pairs``):
    iterations, time, and the largest difference of their QoIs."""
    print(f"\n| model | {labels[0]}: iterations, time (s) | {labels[1]} | largest QoI "
          "difference (relative) |")
    print("|---|---|---|---|")
    for name in BUNDLED:
        model = ml.load_model(name)
        assembly = model.assemble({})
        operators = LatinOperators(assembly, LatinOptions())
        results, cells = [], []
        for on in (False, True):
            start = time.perf_counter()
            with setting(on):
                result = solve_latin(assembly, options(on, None), operators=operators,
                                     check=False)
            cells.append(f"{result.iterations}, {time.perf_counter() - start:.3f}")
            results.append(result)
        worst = largest_difference(results[0], results[1])
        print(f"| {name} | {cells[0]} | {cells[1]} | {worst:.1e} |", flush=True)


def studies() -> None:
    print("\n| study | default: multiresolution iterations, time (s); cold iterations, "
          "Σ time (s) | rigid balance | R_stop's largest difference (N) |")
    print("|---|---|---|---|")
    for label, (name, spec) in STUDIES.items():
        model = ml.load_model(name)
        grid = Grid.parse(spec)
        cells, values = [], []
        for on in (False, True):
            options = LatinOptions(rigid_balance=on, qoi_rtol=STUDY_QOI_RTOL)
            result = run_study(model, grid, options=options,
                               modes=("multiresolution", "cold"), progress=False)
            warm, cold = result.mode_records("multiresolution"), result.mode_records("cold")
            cells.append(f"{sum(r['iterations'] for r in warm)}, "
                         f"{result.elapsed_s['multiresolution']:.2f}; "
                         f"{sum(r['iterations'] for r in cold)}, "
                         f"{sum(r['wall_s'] for r in cold):.2f}")
            values.append(np.array([r["qoi"]["R_stop"] if r["converged"] else np.nan
                                    for r in warm + cold], dtype=float))
        difference = float(np.nanmax(np.abs(values[1] - values[0])))
        print(f"| {label} | {cells[0]} | {cells[1]} | {difference:.3f} |", flush=True)


def accuracy() -> None:
    """The B1 13 × 13 study with the balance, both modes under the studies' QoI rule:
    R_stop's largest error over the unique cases against η < 1e-10 solves (without it)."""
    model = ml.load_model("b1")
    options = LatinOptions(rigid_balance=True, qoi_rtol=STUDY_QOI_RTOL)
    result = run_study(model, Grid.parse(["mu1=0:0.6:13", "mu2=0:0.6:13"]), options=options,
                       modes=("multiresolution", "cold"), progress=False)
    operators = None
    tight: dict[tuple[float, float], float] = {}
    print("\n| B1 13 × 13 with the balance, QoI rule | R_stop's largest error (unique "
          "cases) | at (μ1, μ2) |")
    print("|---|---|---|")
    for mode in ("multiresolution", "cold"):
        worst, where = 0.0, None
        for record in result.mode_records(mode):
            key = (record["params"]["mu1"], record["params"]["mu2"])
            if key not in tight:
                assembly = model.assemble(record["params"])
                operators = operators or LatinOperators(assembly, LatinOptions())
                tight[key] = float(solve_latin(assembly, LatinOptions(tol=1e-10, max_iter=20000),
                                               operators=operators).qoi["R_stop"])
            error = abs(record["qoi"]["R_stop"] - tight[key]) / max(abs(tight[key]), 1.0)
            if record["unique"] and error > worst:
                worst, where = error, key
        print(f"| {mode} | {worst:.2e} | {where} |", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="*", default=["b1", "b1-9", "b3"])
    parser.add_argument("--studies", action="store_true")
    parser.add_argument("--bundled", action="store_true")
    parser.add_argument("--accuracy", action="store_true",
                        help="the B1 13 x 13 study's R_stop against tight solves")
    args = parser.parse_args()
    ml.load_model("b1").solve()  # warm-up: imports, kernels
    if args.models:
        pairs(args.models)
    if args.bundled:
        bundled()
    if args.studies:
        studies()
    if args.accuracy:
        accuracy()


if __name__ == "__main__":
    main()
