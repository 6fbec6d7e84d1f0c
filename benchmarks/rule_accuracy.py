"""Does the studies' QoI rule keep its promise on every bundled model? (session 49)

Each model's small grid run as a study, both modes (multiresolution and cold) under the
studies' rule (``qoi_rtol`` = 1e-3), every QoI at every step it reports against a tight
solve of the same case (η < 1e-10, from zero): the error relative to max(|tight value|, 1 %
of the QoI's largest magnitude in that case) — the rule's own bound —, how many entries are
off by more than 0.1 %, and how many estimates lie below their error (errors above 1e-6 of
that scale). A value the discrete problem does not determine (a body free to move in the
tight solve: ``SolveResult.qoi_determined``) is counted apart. ``--details``: every entry
off by more than 0.1 %. ``--trace MODEL QOI STEP``: one case (``--set``) stopped at the
iterations given (``max_iter``), the QoI's error at that step against the monolithic
reference, its estimate, η and the state's remaining change.

    python benchmarks/rule_accuracy.py [--models punch slide lap ...] [--details]
    python benchmarks/rule_accuracy.py --growing off     # the estimate before session 61
    python benchmarks/rule_accuracy.py --trace roller Q 2 --set mu=0.5 shift=0.02 \
        --iterations 120 240 12
"""

from __future__ import annotations

import argparse
import itertools
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOptions, tracking
from multilatin.latin.options import STUDY_QOI_RTOL

#: per model, a small grid (the defaults elsewhere)
GRIDS: dict[str, dict[str, list[float]]] = {
    "b1-9": {"mu1": [0.0, 0.15, 0.3, 0.45, 0.6], "mu2": [0.0, 0.15, 0.3, 0.45, 0.6]},
    "b3": {"xc": [23.0, 25.0, 27.0], "yc": [73.0, 75.0, 77.0], "rc": [3.0]},
    "punch": {"mu": [0.1, 0.3, 0.5], "position": [10.0, 20.0, 30.0, 40.0]},
    "slide": {"mu": [0.1, 0.2, 0.3, 0.4, 0.5], "stiffness_ratio": [1.0, 10.0, 1000.0]},
    "lap": {"mu": [0.1, 0.2, 0.3, 0.4], "p": [20.0, 50.0, 80.0]},
    "lug": {"mu": [0.1, 0.2, 0.3]},
    "roller": {"mu": [0.1, 0.3, 0.5], "shift": [0.02, 0.04, 0.06]},
}
FLOOR = 1e-6
#: print every entry off by more than 0.1 % (``--details``)
DETAILS = False


def ruled_study(model: ml.Model, grid: ml.Grid, kappa: float) -> Any:
    """The study's dataset, both modes under the studies' rule at ``kappa``."""
    with tempfile.TemporaryDirectory() as out:
        study = ml.run_study(model, grid, options=LatinOptions(kappa=kappa,
                                                               qoi_rtol=STUDY_QOI_RTOL),
                             modes=("multiresolution", "cold"), out=Path(out),
                             progress=False)
        return study.dataset.load()


def model_row(name: str, kappa: float = 0.5) -> str:
    model = ml.load_model(name)
    grid = ml.Grid(GRIDS[name])
    start = time.perf_counter()
    data = ruled_study(model, grid, kappa)
    names = [q.name for q in model.assemble().qois]
    entries = above = below = undetermined = 0
    worst, where = 0.0, ""
    offenders: list[str] = []
    axes = list(GRIDS[name])
    for values in itertools.product(*(GRIDS[name][axis] for axis in axes)):
        mu = dict(zip(axes, values, strict=True))
        tight = model.solve(mu, options=LatinOptions(tol=1e-10, max_iter=20000))
        # the values the discrete problem does not determine (a body free to move:
        # ``SolveResult.qoi_determined``), counted apart
        determined = tight.qoi_determined
        for mode in ("multiresolution", "cold"):
            case = data.sel(mode=mode, **mu)
            for qoi in names:
                exact = np.atleast_1d(np.asarray(tight.qoi[qoi], dtype=float))
                value = np.atleast_1d(case[qoi].values)
                estimate = np.atleast_1d(case[f"{qoi}_err"].values)
                scale = np.maximum(np.abs(exact), 1e-2 * np.abs(exact).max())
                error = np.abs(value - exact)
                relative = error / np.where(scale > 0, scale, 1.0)
                free = ~np.atleast_1d(np.asarray(determined[qoi], dtype=bool))
                if free.any():
                    undetermined += int(np.sum(free & (relative > 1e-3)))
                    relative = np.where(free, 0.0, relative)
                    error = np.where(free, 0.0, error)
                entries += exact.size
                above += int(np.sum(relative > 1e-3))
                below += int(np.sum((error > FLOOR * np.abs(exact).max()) & (error > estimate)))
                for step in np.flatnonzero(relative > 1e-3):
                    offenders.append(
                        f"    {mode} ({', '.join(f'{v:g}' for v in values)}) {qoi} step "
                        f"{step + 1}: {value[step]:.6g} against {exact[step]:.6g} (scale "
                        f"{scale[step]:.3g}), estimate {estimate[step]:.3g}, "
                        f"{int(case['iterations'])} iterations, unique "
                        f"{bool(case['unique'])}")
                if relative.max() > worst:
                    step = int(np.argmax(relative))
                    worst = float(relative.max())
                    where = (f"{mode} ({', '.join(f'{v:g}' for v in values)}), {qoi}"
                             + (f" step {step + 1}" if exact.size > 1 else ""))
    iterations = {m: int(data["iterations"].sel(mode=m).sum())
                  for m in ("multiresolution", "cold")}
    for line in offenders if DETAILS else []:
        print(line)
    return (f"| {name} | {grid.size} | {iterations['multiresolution']} / {iterations['cold']} "
            f"| {entries} | {above} | {worst:.1e} ({where}) | {below} | {undetermined} | "
            f"{time.perf_counter() - start:.0f} s |")


def trace(name: str, qoi: str, step: int, mu: dict[str, float],
          iterations: range, kappa: float = 0.5) -> None:
    """One case under the rule, then stopped at ``iterations`` (``max_iter``): the QoI's
    error at ``step`` against the monolithic reference, its estimate, η, η's rate over
    10 iterations and the state's remaining change."""
    model = ml.load_model(name)
    exact = float(np.atleast_1d(model.reference(mu).qoi[qoi])[step - 1])
    ruled = model.solve(mu, options=LatinOptions(kappa=kappa, qoi_rtol=STUDY_QOI_RTOL))
    print(f"{name} {mu}: under the rule {ruled.iterations} iterations, {qoi} at step {step} "
          f"{float(np.atleast_1d(ruled.qoi[qoi])[step - 1]) - exact:+.4g} off, estimate "
          f"{np.atleast_1d(ruled.qoi_error[qoi])[step - 1]:.3g}\n")
    print("| iteration | η | rate over 10 | error | estimate | state's remaining change |")
    print("|---|---|---|---|---|---|")
    for n in iterations:
        result = model.solve(mu, options=LatinOptions(kappa=kappa, max_iter=n, tol=1e-14),
                             check=False)
        value = float(np.atleast_1d(result.qoi[qoi])[step - 1])
        estimate = result.qoi_error.get(qoi)
        shown = ("—" if estimate is None or np.atleast_1d(estimate)[step - 1] is None
                 else f"{np.atleast_1d(estimate)[step - 1]:.3g}")
        history = np.asarray(result.history)
        print(f"| {n} | {history[-1]:.2e} | {(history[-1] / history[-11]) ** 0.1:.4f} | "
              f"{value - exact:+.4g} | {shown} | {result.state_change:.1e} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--models", nargs="+", default=list(GRIDS), choices=list(GRIDS))
    parser.add_argument("--details", action="store_true",
                        help="every entry off by more than 0.1 %%, before its model's row")
    parser.add_argument("--kappa", type=float, default=0.5, help="the studies' κ")
    parser.add_argument("--growing", choices=["on", "off"], default="on",
                        help="tracking.GROWING_CHECK (off: as before session 61)")
    parser.add_argument("--trace", nargs=3, metavar=("MODEL", "QOI", "STEP"))
    parser.add_argument("--set", nargs="*", default=[], metavar="NAME=VALUE")
    parser.add_argument("--iterations", nargs=3, type=int, default=[120, 240, 12],
                        metavar=("FIRST", "LAST", "EVERY"))
    args = parser.parse_args()
    tracking.GROWING_CHECK = args.growing == "on"
    if args.trace:
        first, last, every = args.iterations
        trace(args.trace[0], args.trace[1], int(args.trace[2]),
              {k: float(v) for k, v in (item.split("=") for item in args.set)},
              range(first, last + 1, every), args.kappa)
        return
    global DETAILS
    DETAILS = args.details
    print("| model | cases | iterations (multiresolution / cold) | entries | off by > 0.1 % "
          "| worst | estimates below their error | undetermined entries off by > 0.1 % | "
          "time |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name in args.models:
        print(model_row(name, args.kappa), flush=True)


if __name__ == "__main__":
    main()
