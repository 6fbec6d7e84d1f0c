"""Experiment (issue 15, item 1, sessions 55–56): the stop points of a cross point run as one.

With B1's stop at gap 0 the centre block's whole right side presses on the stop from step
1, and where a perfect interface between its substructures ends on the stop ((50, 75) in
b1-4; (50, 66.7) and (50, 83.3) in b1-9 and b3) two stop points sit at one node. The
discrete problem sees only their sum and the local stage split it freely (docs/convergence.md,
session 55: b1-9 warm-started from gap 0.01 stalled for 120 iterations while the split
drifted). Adopted in session 56 (``latin.cross_points.MERGE_STOPS``, ``stop_groups``): such a
group runs on its weighted means of W and F inside the pointwise contact stage (in the
two-scale direction's inner passes, on their shifted forces and D); every point takes the
group's F̂ and its own Ŵ_i = W_i + (F̂ − F_i) / k_i. This compares it with each stop point on
its own (the rule before), the library's compiled path: at ``--gap`` (default 0), μ1 =
0.3, μ2 = 0.15 / 0.3, the iterations of a cold solve and of one warm-started from
``--gap`` + 0.01 under the studies' QoI rule, and of an η < 1e-10 solve, with R_stop's
relative errors against the tight solve with each stop on its own. ``--pairs``: instead, at
the model's own gap, cold solves at the four pairs of ``benchmarks/convergence.py`` under
η < 1e-6 and the QoI rule. ``--moving``: where the warm-started case of the first model at
μ2 = 0.15 still moves, the points whose F̂ changes most between iterations 90 and 150.

    python benchmarks/merged_stops.py [--models b1-4 b1-9 b3] [--gap 0] [--pairs | --moving]
"""

from __future__ import annotations

import argparse

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOperators, LatinOptions, cross_points, solve_latin
from multilatin.latin.options import STUDY_QOI_RTOL

PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--models", nargs="+", default=["b1-4", "b1-9", "b3"])
    parser.add_argument("--gap", type=float, default=0.0, help="the stop's gap [mm]")
    parser.add_argument("--pairs", action="store_true", help="the four pairs, cold")
    parser.add_argument("--moving", action="store_true", help="where a warm case moves")
    args = parser.parse_args()
    if args.pairs:
        return four_pairs(args.models)
    if args.moving:
        return moving(args.models[0], args.gap)
    options = LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    tight_options = LatinOptions(tol=1e-10, max_iter=5000)
    print("| model | μ2 | rule | cold (R_stop error) | warm from gap + 0.01 | η < 1e-10 |")
    print("|---|---|---|---|---|---|")
    saved = cross_points.MERGE_STOPS
    try:
        for name in args.models:
            model = ml.load_model(name)
            for mu2 in (0.15, 0.3):
                target = model.assemble({"gap": args.gap, "mu1": 0.3, "mu2": mu2})
                neighbour = model.assemble({"gap": args.gap + 0.01, "mu1": 0.3, "mu2": mu2})
                exact = None
                for merge in (False, True):
                    cross_points.MERGE_STOPS = merge
                    operators = LatinOperators(target, options)
                    tight = solve_latin(target, tight_options, operators=operators)
                    exact = float(tight.qoi["R_stop"]) if exact is None else exact
                    cold = solve_latin(target, options, operators=operators)
                    start = solve_latin(neighbour, options).interface
                    assert start is not None
                    warm = solve_latin(target, options, operators=operators,
                                       initial=(start.displacement_hat, start.force_hat))
                    errors = [abs(float(r.qoi["R_stop"]) - exact) / abs(exact)
                              for r in (cold, warm, tight)]
                    rule = "merged" if merge else "each on its own"
                    print(f"| {name} | {mu2} | {rule} | {cold.iterations} ({errors[0]:.1e}) | "
                          f"{warm.iterations} ({errors[1]:.1e}) | {tight.iterations} "
                          f"({errors[2]:.1e}) |", flush=True)
    finally:
        cross_points.MERGE_STOPS = saved


def four_pairs(models: list[str]) -> None:
    """Cold solves at the four pairs, at each model's own gap, each stop on its own and
    merged: iterations to η < 1e-6 and to the QoI rule, R_stop's relative error."""
    rules = [LatinOptions(), LatinOptions(qoi_rtol=STUDY_QOI_RTOL)]
    print("| model | μ1, μ2 | each on its own: η < 1e-6, QoI rule (R_stop error) | merged |")
    print("|---|---|---|---|")
    saved = cross_points.MERGE_STOPS
    try:
        for name in models:
            model = ml.load_model(name)
            for mu1, mu2 in PAIRS:
                assembly = model.assemble({"mu1": mu1, "mu2": mu2})
                cells, exact = [], None
                for merge in (False, True):
                    cross_points.MERGE_STOPS = merge
                    operators = LatinOperators(assembly, LatinOptions())
                    if exact is None:
                        exact = float(solve_latin(assembly, LatinOptions(tol=1e-10, max_iter=5000),
                                            operators=operators).qoi["R_stop"])
                    runs = [solve_latin(assembly, rule, operators=operators) for rule in rules]
                    cells.append(", ".join(
                        f"{r.iterations} ({abs(float(r.qoi['R_stop']) - exact) / abs(exact):.1e})"
                        for r in runs))
                print(f"| {name} | {mu1}, {mu2} | {cells[0]} | {cells[1]} |", flush=True)
    finally:
        cross_points.MERGE_STOPS = saved


def moving(name: str, gap: float) -> None:
    """The points whose F̂ moves most (largest change over steps and components) between
    iterations 90 and 150 of the case at ``gap``, μ2 = 0.15, warm-started from gap + 0.01."""
    model = ml.load_model(name)
    options = LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    target = model.assemble({"gap": gap, "mu2": 0.15})
    operators = LatinOperators(target, options)
    start = solve_latin(model.assemble({"gap": gap + 0.01, "mu2": 0.15}), options).interface
    assert start is not None
    fields = []
    for cap in (90, 150):
        result = solve_latin(target, LatinOptions(qoi_rtol=STUDY_QOI_RTOL, max_iter=cap),
                             operators=operators, check=False,
                             initial=(start.displacement_hat, start.force_hat))
        assert result.interface is not None
        fields.append(result.interface.force_hat)
    change = np.abs(fields[1] - fields[0]).max(axis=(0, 2))
    points = operators.points
    for p in np.argsort(change)[::-1][:8]:
        print(f"point {p} at {np.round(points.coords[p], 2).tolist()} (substructure "
              f"{points.substructure[p]}): F̂ moved by {change[p]:.2e} N")


if __name__ == "__main__":
    main()
