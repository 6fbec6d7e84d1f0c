"""Experiment (issue 15, item 1, session 35): one contact pair per node where two pieces of
a contact interface meet at a cross point, as the monolithic reference has it.

Where the centre|top contact of b1-9 and b3 is cut into pieces by the perfect interfaces
between substructures, the pieces' end points at a cross point are two contact pairs at the
same node pair; the slowest mode of b1-9 and b3 at (0.1, 0.3) lives there (one piece at its
friction cone, the other sticking; docs/convergence.md). Here the contact local stage sees
each such group of pairs as one: it runs on the group's weighted means of W and F (on both
sides), every pair of the group takes the group's F̂, and each its own Ŵ on its own search
direction, Ŵ_i = W_i + (F̂ − F_i) / k_i. At the fixed point (W and F equal across the group,
as the perfect interfaces tie the nodes) this is the monolithic reference's contact law on
the summed pair. Adopted (``latin.cross_points``, ``MERGE``); this compares it with each pair
on its own (``MERGE = False``, the rule before), cold solves at the four pairs of
``benchmarks/convergence.py``: iterations to the default tolerance (η < 1e-6) and, with
``--qoi``, to the studies' QoI rule; R_stop's error against a tight solve (η < 1e-10) with
each pair on its own, relative.

    python benchmarks/merged_cross_points.py [--models b1-4 b1-9 b3] [--qoi]
"""

from __future__ import annotations

import argparse

import multilatin as ml
from multilatin.latin import LatinOperators, LatinOptions, cross_points, solve_latin
from multilatin.latin.options import STUDY_QOI_RTOL

PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=["b1-4", "b1-9", "b3"])
    parser.add_argument("--qoi", action="store_true", help="the studies' QoI rule as well")
    args = parser.parse_args()
    rules = [("η < 1e-6", LatinOptions())]
    if args.qoi:
        rules.append(("QoI rule", LatinOptions(qoi_rtol=STUDY_QOI_RTOL)))
    tight = LatinOptions(tol=1e-10, max_iter=20000)
    saved = cross_points.MERGE
    print("| model | μ1, μ2 | rule | groups | each pair on its own: iterations, R_stop error "
          "| merged: iterations, R_stop error |")
    print("|---|---|---|---|---|---|")
    try:
        for name in args.models:
            model = ml.load_model(name)
            for mu1, mu2 in PAIRS:
                assembly = model.assemble({"mu1": mu1, "mu2": mu2})
                operators = LatinOperators(assembly, LatinOptions())
                cross_points.MERGE = False
                exact = float(solve_latin(assembly, tight, operators=operators).qoi["R_stop"])
                for label, options in rules:
                    cells = []
                    for merge in (False, True):
                        cross_points.MERGE = merge
                        result = solve_latin(assembly, options, operators=operators,
                                             check=False)
                        error = abs(float(result.qoi["R_stop"]) - exact) / max(abs(exact), 1.0)
                        cells.append(f"{result.iterations}"
                                     f"{'' if result.converged else ' (not converged)'}, "
                                     f"{error:.1e}")
                    groups = cross_points.cross_point_groups(operators.points)[0].shape[0]
                    print(f"| {name} | {mu1:g}, {mu2:g} | {label} | {groups} | {cells[0]} | "
                          f"{cells[1]} |", flush=True)
    finally:
        cross_points.MERGE = saved


if __name__ == "__main__":
    main()
