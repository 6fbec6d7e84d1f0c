"""The macro correction scaled (issue 15, session 48): W̃ᴹ = ω L⁻¹ (F_dᴹ − Π F) instead of
L⁻¹ (…) (eq. [14]–[15]). At a fixed point s = ŝ the correction vanishes whatever ω, so the
answer is the same; the question is whether a larger step on the macro modes (B1's slowest
is the centre block's rigid slide, a macro mode) speeds the tail. Cold solves at
``benchmarks/convergence.py``'s four pairs, to η < 1e-6 and under the studies' QoI rule:
iterations ("!" not converged within 3 000 or stopped as a failure) and R_stop's error
against an η < 1e-10 solve.

    python benchmarks/macro_scaling.py [--models b1] [--omegas 0.8 1 1.1 1.5 2]
"""

from __future__ import annotations

import argparse

import multilatin as ml
from multilatin.latin import LatinOptions, solve_latin
from multilatin.latin.operators import LatinOperators
from multilatin.latin.options import STUDY_QOI_RTOL

PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=["b1"])
    parser.add_argument("--omegas", type=float, nargs="+", default=[0.8, 1.0, 1.1, 1.5, 2.0])
    args = parser.parse_args()
    print("| model | μ1, μ2 | " + " | ".join(f"ω = {w:g}: η, QoI rule" for w in args.omegas)
          + " |\n|---|---|" + "---|" * len(args.omegas))
    for name in args.models:
        model = ml.load_model(name)
        for mu1, mu2 in PAIRS:
            assembly = model.assemble({"mu1": mu1, "mu2": mu2})
            tight = solve_latin(assembly, LatinOptions(tol=1e-10, max_iter=5000)).qoi["R_stop"]
            cells = []
            for omega in args.omegas:
                runs = []
                for qoi_rtol in (None, STUDY_QOI_RTOL):
                    options = LatinOptions(max_iter=3000, qoi_rtol=qoi_rtol)
                    ops = LatinOperators(assembly, options)
                    ops.homogenised_inverse = omega * ops.homogenised_inverse
                    result = solve_latin(assembly, options, operators=ops, check=False)
                    error = abs(result.qoi["R_stop"] - tight) / max(abs(tight), 1.0)
                    runs.append(f"{result.iterations}{'' if result.converged else '!'} "
                                f"({error:.1e})")
                cells.append(", ".join(runs))
            print(f"| {name} | {mu1:g}, {mu2:g} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
