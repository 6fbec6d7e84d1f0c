"""Secant and parallelogram starts along hole positions (issue 16, ``study.predictors``)
against the nearest neighbour's start (``start="nearest"``, the paper's §6), side by side in
one process: per B3 study of hole positions, the multiresolution iterations, the study's
wall time, how many cases took a secant / parallelogram start, and R_stop's largest change
between the two; with ``--tight``, each study's worst R_stop error against η < 1e-10 solves
too.

    python benchmarks/extrapolated_starts.py
    python benchmarks/extrapolated_starts.py --tight
    python benchmarks/extrapolated_starts.py --frictions

``--frictions``: instead, the B1 13 × 13 friction study with the rules forced onto its
friction axes (``Case.axes`` patched; the parallelogram alone, then both), against the
default (no extrapolation there): why they stay on geometric axes.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
import warnings
from typing import Any

import multilatin as ml
from multilatin.latin import LatinOptions
from multilatin.study.plan import clear_operator_cache

STUDIES = {
    "5 x 5 positions": ["xc=23:27:5", "yc=73:77:5", "rc=3"],
    "xc line, 1 mm": ["xc=21:29:9", "rc=3"],
    "xc line, 2 mm": ["xc=20:30:6", "rc=3"],
    "yc line, 1 mm": ["yc=71:79:9", "rc=3"],
    "xc x 13 x 4 frictions": ["xc=23:27:5", "mu1=0:0.6:13", "mu2=0:0.6:4", "rc=3"],
}


def frictions() -> None:
    from multilatin.study import rolling, runner

    model = ml.load_model("b1")
    grid = ml.Grid.parse(["mu1=0:0.6:13", "mu2=0:0.6:13"])
    plan_study, secant_partner = runner.plan_study, rolling.secant_partner
    runs = {}
    print("| B1 13 x 13 | iterations | secant / parallelogram starts | R_stop change |")
    print("|---|---|---|---|")
    for label in ("default", "parallelogram on frictions", "both on frictions"):
        def forced(*args: Any, label: str = label, **kwargs: Any) -> Any:
            plan = plan_study(*args, **kwargs)
            if label == "default":
                return plan
            chains = tuple(tuple(dataclasses.replace(c, axes=(0, 1)) for c in chain)
                           for chain in plan.chains)
            return dataclasses.replace(plan, chains=chains)

        runner.plan_study = forced  # type: ignore[assignment]
        if label == "parallelogram on frictions":
            rolling.secant_partner = lambda *args, **kwargs: None  # type: ignore[assignment]
        try:
            clear_operator_cache()
            records = {r["number"]: r for r in ml.run_study(model, grid, progress=False).records}
        finally:
            runner.plan_study, rolling.secant_partner = plan_study, secant_partner
        runs[label] = records
        base = runs["default"]
        change = max(abs(r["qoi"]["R_stop"] - base[n]["qoi"]["R_stop"])
                     / max(abs(base[n]["qoi"]["R_stop"]), 1.0) for n, r in records.items())
        kinds = [sum(kind in r["start"] for r in records.values())
                 for kind in ("secant", "parallelogram")]
        print(f"| {label} | {sum(r['iterations'] for r in records.values())} | "
              f"{kinds[0]} / {kinds[1]} | {100 * change:.3f} % |", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tight", action="store_true",
                        help="also R_stop's worst error against tight solves (slow)")
    parser.add_argument("--only", nargs="*", default=None, help="studies by name")
    parser.add_argument("--frictions", action="store_true",
                        help="the B1 friction study with the rules forced on (module doc)")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    if args.frictions:
        frictions()
        return
    model = ml.load_model("b3")
    ml.run_study(model, ml.Grid.parse(["xc=25", "yc=75"]), progress=False)  # kernels
    print("| study | start | iterations | wall (s) | secant / parallelogram starts | R_stop "
          "change | worst R_stop error vs tight |")
    print("|---|---|---|---|---|---|---|")
    for name, items in STUDIES.items():
        if args.only and name not in args.only:
            continue
        grid = ml.Grid.parse(items)
        runs = {}
        for start in ("nearest", "neighbour"):
            clear_operator_cache()
            t0 = time.perf_counter()
            study = ml.run_study(model, grid, start=start, progress=False)
            runs[start] = (time.perf_counter() - t0,
                           {r["number"]: r for r in study.records})
        tight = {}
        if args.tight:
            options = LatinOptions(tol=1e-10, max_iter=5000)
            for number, record in runs["nearest"][1].items():
                tight[number] = model.solve(record["params"], options=options).qoi["R_stop"]
        base = runs["nearest"][1]
        for start in ("nearest", "neighbour"):
            wall, records = runs[start]
            change = max(abs(r["qoi"]["R_stop"] - base[n]["qoi"]["R_stop"])
                         / max(abs(base[n]["qoi"]["R_stop"]), 1.0) for n, r in records.items())
            error = (f"{100 * max(abs(r['qoi']['R_stop'] - tight[n]) / max(abs(tight[n]), 1.0) for n, r in records.items()):.3f} %"  # noqa: E501
                     if tight else "—")
            label = "nearest" if start == "nearest" else "extrapolated (default)"
            kinds = [sum(kind in r["start"] for r in records.values())
                     for kind in ("secant", "parallelogram")]
            print(f"| {name} | {label} | {sum(r['iterations'] for r in records.values())} | "
                  f"{wall:.2f} | {kinds[0]} / {kinds[1]} | {100 * change:.3f} % | {error} |",
                  flush=True)


if __name__ == "__main__":
    main()
