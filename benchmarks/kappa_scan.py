"""The search direction's κ on every bundled model (session 38): iterations to the default
tolerance at κ = 0.1 … 10 (k = κ E / L, ``LatinOptions.kappa``; the default 0.5 was chosen
on B1), and the largest difference of each model's QoIs between the κ that converged and
a tight solve at the default κ — the converged answer must not depend on κ.

    python benchmarks/kappa_scan.py [--kappas 0.1 0.5 1 2 5] [--models b1 roller ...]
"""

from __future__ import annotations

import argparse

from rigid_balance import largest_difference  # this script's folder

import multilatin as ml
from multilatin.latin import LatinOptions, solve_latin

MODELS = ("b0", "b1", "b1-9", "b2", "b3", "punch", "slide", "lug", "roller", "lap")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--kappas", type=float, nargs="+", default=[0.1, 0.25, 0.5, 1, 2, 5,
                                                                      10])
    parser.add_argument("--models", nargs="+", default=list(MODELS))
    args = parser.parse_args()
    print("iterations to η < 1e-6 (— : not converged within 1 000); last column: the largest "
          "QoI difference over the κ that converged, against η < 1e-10 at κ = 0.5, "
          "relative to each QoI's largest magnitude\n")
    print("| model | " + " | ".join(f"κ = {k:g}" for k in args.kappas)
          + " | largest QoI difference |")
    print("|---|" + "---|" * (len(args.kappas) + 1))
    for name in args.models:
        assembly = ml.load_model(name).assemble({})
        tight = solve_latin(assembly, LatinOptions(tol=1e-10, max_iter=20000), check=False)
        cells, worst, where = [], 0.0, float("nan")
        for kappa in args.kappas:
            result = solve_latin(assembly, LatinOptions(kappa=kappa), check=False)
            cells.append(str(result.iterations) if result.converged else "—")
            difference = largest_difference(tight, result) if result.converged else 0.0
            if difference > worst:
                worst, where = difference, kappa
        print(f"| {name} | " + " | ".join(cells) + f" | {worst:.1e} (κ = {where:g}) |",
              flush=True)


if __name__ == "__main__":
    main()
