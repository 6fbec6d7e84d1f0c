"""Reduced-rank extrapolation against relaxation alone (``LatinOptions.acceleration``,
issue 15; docs/convergence.md): iterations and the time of the iterations only (operators
built once and reused), the two alternated four times in one process, the best of the
last three.

    python benchmarks/rre.py
    python benchmarks/rre.py --models b3
    python benchmarks/rre.py --models lug roller punch b2     # at their default parameters
    python benchmarks/rre.py --slide      # the slide model against its reference, κ 0.1–2
"""

from __future__ import annotations

import argparse

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOperators, LatinOptions, solve_latin

PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]
ACCELERATIONS = ("relaxation", "rre")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=["b1", "b1-4", "b1-9", "b3"])
    parser.add_argument("--slide", action="store_true",
                        help="the slide model at two stiffness ratios and five κ instead")
    args = parser.parse_args()
    if args.slide:
        slide()
        return
    print("| model | μ1, μ2 | relaxation: iterations, ms | rre: iterations, ms | "
          "time ratio rre / relaxation | ms per iteration, relaxation / rre |")
    print("|---|---|---|---|---|---|")
    for name in args.models:
        model = ml.load_model(name)
        has_pairs = {"mu1", "mu2"} <= set(model.parameters)
        for mu1, mu2 in PAIRS if has_pairs else [(np.nan, np.nan)]:
            assembly = model.assemble({"mu1": mu1, "mu2": mu2} if has_pairs else {})
            ops = LatinOperators(assembly, LatinOptions())
            times: dict[str, list[float]] = {a: [] for a in ACCELERATIONS}
            iterations: dict[str, int] = {}
            for _ in range(4):
                for acceleration in ACCELERATIONS:
                    result = solve_latin(assembly, LatinOptions(acceleration=acceleration),
                                         operators=ops)
                    times[acceleration].append(1e3 * result.timings["iterations"])
                    iterations[acceleration] = result.iterations
            best = {a: min(t[1:]) for a, t in times.items()}
            per = {a: best[a] / iterations[a] for a in ACCELERATIONS}
            case = f"{mu1:g}, {mu2:g}" if has_pairs else "defaults"
            print(f"| {name} | {case} | {iterations['relaxation']}, "
                  f"{best['relaxation']:.1f} | {iterations['rre']}, {best['rre']:.1f} | "
                  f"{best['rre'] / best['relaxation']:.2f} | {per['relaxation']:.3f} / "
                  f"{per['rre']:.3f} |", flush=True)


def slide() -> None:
    """Iterations to the default tolerance and R_push's worst relative error over the steps
    against the monolithic reference (docs/convergence.md's slide tables)."""
    model = ml.load_model("slide")
    print("| E_foundation / E_block | κ | relaxation: iterations (error) | rre |")
    print("|---|---|---|---|")
    for ratio in (1.0, 1000.0):
        mu = {"stiffness_ratio": ratio}
        reference = np.asarray(model.reference(mu).qoi["R_push"])
        for kappa in (0.1, 0.25, 0.5, 1.0, 2.0):
            cells = []
            for acceleration in ACCELERATIONS:
                result = model.solve(mu, options=LatinOptions(kappa=kappa,
                                                              acceleration=acceleration),
                                     check=False)
                r_push = np.asarray(result.qoi["R_push"])
                error = np.max(np.abs(r_push - reference) / np.abs(reference))
                flag = "" if result.converged else " (not converged)"
                cells.append(f"{result.iterations}{flag} ({error:.1e})")
            print(f"| {ratio:g} | {kappa:g} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
