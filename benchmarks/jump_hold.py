"""Issue 15/16 (session 37): two rules around the sliding extrapolation's jumps, side by
side with the rules off, in one process.

- ``iteration.JUMP_HOLD``: with QoI stopping, a case whose QoIs' estimates would fall
  below their bounds within ``iteration.RECENT`` iterations (at the indicator's rate over
  the last window) does not jump — a jump holds a case that long.
- ``iteration.ESTIMATE_AFTER_JUMPS``: a leading load step that settles within ``RECENT``
  iterations of a jump keeps an estimate read after the jump alone.

Cold solves at the four pairs of ``benchmarks/convergence.py`` (b1, b1-4, b1-9, b3), to
η < 1e-6 and under the studies' QoI rule: iterations and R_stop's error against a tight
solve (η < 1e-10), relative; the b1 μ2 line's warm starts from tight neighbours
(``--warm``); the studies (``--studies``: B1 13 × 13, B1 μ2 line, B3 5 × 5 positions,
multiresolution and cold iterations, the study's time, R_stop's largest difference between
the columns); R_stop's largest error against tight solves over the unique cases of the B1
13 × 13 and B3 5 × 5 studies with the rules on (``--accuracy``); the other bundled
models (``--bundled``).

    python benchmarks/jump_hold.py [--models b1 b1-4 b1-9 b3] [--warm] [--studies]
    python benchmarks/jump_hold.py --models --accuracy
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
from rigid_balance import bundled, pairs  # this script's folder

import multilatin as ml
from multilatin.latin import LatinOperators, LatinOptions, iteration, solve_latin
from multilatin.latin.options import STUDY_QOI_RTOL
from multilatin.parameters import Grid
from multilatin.study.runner import run_study

STUDIES = {"B1 13 × 13": ("b1", ["mu1=0:0.6:13", "mu2=0:0.6:13"]),
           "B1 μ2 line": ("b1", ["mu1=0.3", "mu2=0:0.6:13"]),
           "B3 5 × 5 positions": ("b3", ["xc=23:27:5", "yc=73:77:5", "rc=3"])}
TIGHT = LatinOptions(tol=1e-10, max_iter=20000)
LABELS = ("rules off", "rules on")


@contextmanager
def rules(on: bool) -> Iterator[None]:
    """Both rules on or off for the duration."""
    saved = iteration.JUMP_HOLD, iteration.ESTIMATE_AFTER_JUMPS
    iteration.JUMP_HOLD = iteration.ESTIMATE_AFTER_JUMPS = on
    try:
        yield
    finally:
        iteration.JUMP_HOLD, iteration.ESTIMATE_AFTER_JUMPS = saved


def relative(value: float, exact: float) -> float:
    return abs(value - exact) / max(abs(exact), 1.0)


def defaults(on: bool, rtol: float | None = None) -> LatinOptions:
    """The options of both columns: the rules are module switches (``rules``)."""
    return LatinOptions(qoi_rtol=rtol)


def warm() -> None:
    """b1 along μ2 at μ1 = 0.3, each case from its tight neighbour μ2 − 0.05."""
    model = ml.load_model("b1")
    print("\n| b1 μ1 = 0.3, warm from μ2 − 0.05 (tight) | rules off: iterations, R_stop "
          "error | rules on |")
    print("|---|---|---|")
    previous = None
    operators = None
    for mu2 in np.round(np.arange(0.0, 0.61, 0.05), 2):
        assembly = model.assemble({"mu1": 0.3, "mu2": float(mu2)})
        operators = operators or LatinOperators(assembly, LatinOptions())
        tight = solve_latin(assembly, TIGHT, operators=operators)
        if previous is not None:
            cells = []
            for on in (False, True):
                with rules(on):
                    result = solve_latin(assembly, LatinOptions(qoi_rtol=STUDY_QOI_RTOL),
                                         operators=operators, check=False, initial=previous)
                cells.append(f"{result.iterations}, "
                             f"{relative(float(result.qoi['R_stop']), float(tight.qoi['R_stop'])):.1e}")
            print(f"| μ2 = {mu2:g} | {cells[0]} | {cells[1]} |", flush=True)
        assert tight.interface is not None
        previous = (tight.interface.displacement_hat, tight.interface.force_hat)


def studies(repeat: int) -> None:
    print("\n| study | rules off: multiresolution iterations, time (s); cold iterations | "
          "rules on | R_stop's largest difference (N) |")
    print("|---|---|---|---|")
    for label, (name, spec) in STUDIES.items():
        model = ml.load_model(name)
        grid = Grid.parse(spec)
        times: dict[bool, list[float]] = {False: [], True: []}
        its: dict[bool, tuple[int, int]] = {}
        values = {}
        for _ in range(repeat):
            for on in (False, True):  # alternated
                with rules(on):
                    result = run_study(model, grid,
                                       options=LatinOptions(qoi_rtol=STUDY_QOI_RTOL),
                                       modes=("multiresolution", "cold"), progress=False)
                warm_records = result.mode_records("multiresolution")
                cold_records = result.mode_records("cold")
                times[on].append(result.elapsed_s["multiresolution"])
                its[on] = (sum(r["iterations"] for r in warm_records),
                           sum(r["iterations"] for r in cold_records))
                values[on] = np.array([r["qoi"]["R_stop"] if r["converged"] else np.nan
                                       for r in warm_records + cold_records], dtype=float)
        cells = [f"{its[on][0]}, {' / '.join(f'{t:.2f}' for t in times[on])}; {its[on][1]}"
                 for on in (False, True)]
        difference = float(np.nanmax(np.abs(values[True] - values[False])))
        print(f"| {label} | {cells[0]} | {cells[1]} | {difference:.3f} |", flush=True)


def accuracy() -> None:
    """R_stop's largest error over the unique cases against tight solves, rules on."""
    print("\n| study, rules on, QoI rule | mode | R_stop's largest error (unique cases) "
          "| at |")
    print("|---|---|---|---|")
    for label in ("B1 13 × 13", "B3 5 × 5 positions"):
        name, spec = STUDIES[label]
        model = ml.load_model(name)
        with rules(True):
            result = run_study(model, Grid.parse(spec),
                               options=LatinOptions(qoi_rtol=STUDY_QOI_RTOL),
                               modes=("multiresolution", "cold"), progress=False)
        tight: dict[tuple[float, ...], float] = {}
        operators: dict[tuple[float, ...], LatinOperators] = {}
        for mode in ("multiresolution", "cold"):
            worst, where = 0.0, None
            for record in result.mode_records(mode):
                key = tuple(float(v) for v in record["params"].values())
                if key not in tight:
                    assembly = model.assemble(record["params"])
                    geometry = tuple(float(record["params"].get(p, 0.0))
                                     for p in ("xc", "yc", "rc"))
                    if geometry not in operators:
                        operators[geometry] = LatinOperators(assembly, LatinOptions())
                    tight[key] = float(solve_latin(assembly, TIGHT,
                                                   operators=operators[geometry]
                                                   ).qoi["R_stop"])
                error = relative(float(record["qoi"]["R_stop"]), tight[key])
                if record["unique"] and error > worst:
                    worst, where = error, record["params"]
            print(f"| {label} | {mode} | {worst:.2e} | {where} |", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="*", default=["b1", "b1-4", "b1-9", "b3"])
    parser.add_argument("--warm", action="store_true")
    parser.add_argument("--studies", action="store_true")
    parser.add_argument("--repeat", type=int, default=3, help="study runs per column")
    parser.add_argument("--accuracy", action="store_true")
    parser.add_argument("--bundled", action="store_true")
    args = parser.parse_args()
    start = time.perf_counter()
    ml.load_model("b1").solve()  # warm-up: imports, kernels
    if args.models:
        pairs(args.models, LABELS, defaults, rules)
    if args.warm:
        warm()
    if args.studies:
        studies(args.repeat)
    if args.accuracy:
        accuracy()
    if args.bundled:
        bundled(LABELS, defaults, rules)
    print(f"\n({time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()
