"""R_stop's error against the LATIN indicator η, to choose the default tolerance.

    python benchmarks/b1_tolerance.py                      # five cases, b1 / b1-4 / b1-9
    python benchmarks/b1_tolerance.py --models b1 --grid   # the 13 x 13 study grid (~5 min)
    python benchmarks/b1_tolerance.py --grid --kappa 1     # the same at another κ
    python benchmarks/b1_tolerance.py --grid --no-sliding  # without the sliding extrapolation
    python benchmarks/b1_tolerance.py --models b1 --grid --acceleration rre

For each model and friction pair, R_stop at η < tol (a cold solve) is compared with the
tightly converged value (η < 1e-9). The cases of a tolerance are solved as batches
(``solve_latin_batch``, the same answers as one by one). Prints a Markdown table per case
(five cases) or a summary per tolerance (grid): the worst error, and the cases whose
R_stop is off by more than 0.1 % (where R_stop > 200 N; below, the worst error in N).
"""

from __future__ import annotations

import argparse

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOperators, solve_latin_batch

CASES = [(0.0, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.0), (0.6, 0.6)]
TOLERANCES = [1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 5e-6, 3e-6, 1e-6]
EXACT = 1e-9


def solve(model: ml.Model, cases: list[tuple[float, float]], tol: float, kappa: float = 0.5,
          sliding: bool = True, acceleration: str = "relaxation"
          ) -> tuple[np.ndarray, np.ndarray]:
    """R_stop and iterations of every case, cold, at η < tol."""
    assemblies = [model.assemble({"mu1": a, "mu2": b}) for a, b in cases]
    options = ml.LatinOptions(tol=tol, max_iter=20000, kappa=kappa,
                              extrapolate_sliding=sliding, acceleration=acceleration)
    operators = LatinOperators(assemblies[0], options)
    r_stop, iterations = [], []
    for start in range(0, len(assemblies), 13):
        for result in solve_latin_batch(assemblies[start:start + 13], options, operators):
            r_stop.append(float(result.qoi["R_stop"]))  # type: ignore[arg-type]
            iterations.append(result.iterations)
    return np.array(r_stop), np.array(iterations)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--models", nargs="+", default=["b1", "b1-4", "b1-9"])
    parser.add_argument("--grid", action="store_true",
                        help="every (μ1, μ2) of the 13 x 13 study grid instead of five cases")
    parser.add_argument("--kappa", type=float, default=ml.LatinOptions().kappa,
                        help="search direction κ of the solves at each tolerance (the tight "
                             "reference solve keeps the default)")
    parser.add_argument("--no-sliding", action="store_true",
                        help="without the extrapolation of steady slidings (as before "
                             "issue 15's LatinOptions.extrapolate_sliding)")
    parser.add_argument("--acceleration", default=ml.LatinOptions().acceleration,
                        help="LatinOptions.acceleration of the solves at each tolerance")
    args = parser.parse_args()
    values = [round(0.05 * i, 2) for i in range(13)]
    cases = [(a, b) for a in values for b in values] if args.grid else CASES
    for name in args.models:
        model = ml.load_model(name)
        exact, _ = solve(model, cases, EXACT)
        table = {tol: solve(model, cases, tol, args.kappa, not args.no_sliding,
                           args.acceleration)
                 for tol in TOLERANCES}
        large = exact > 200.0
        if not args.grid:
            print(f"\n{name}: error of R_stop in N (iterations) at each tolerance\n")
            print("| μ1, μ2 | R_stop (η < 1e-9) | " + " | ".join(
                f"η < {t:g}" for t in TOLERANCES) + " |")
            print("|" + "---|" * (2 + len(TOLERANCES)))
            for c, (mu1, mu2) in enumerate(cases):
                cells = [f"{abs(table[t][0][c] - exact[c]):.3g} ({table[t][1][c]})"
                         for t in TOLERANCES]
                print(f"| {mu1:g}, {mu2:g} | {exact[c]:.3f} | " + " | ".join(cells) + " |")
        print(f"\n{name}, {len(cases)} cases: R_stop against η < 1e-9\n")
        print("| η < | worst relative error (R_stop > 200 N) | at (μ1, μ2) | cases above 0.1 % "
              "| worst error where R_stop ≤ 200 N | mean iterations | max iterations |")
        print("|---|---|---|---|---|---|---|")
        for tol in TOLERANCES:
            r_stop, iterations = table[tol]
            error = np.abs(r_stop - exact)
            relative = np.where(large, error / np.maximum(exact, 1.0), 0.0)
            worst = int(np.argmax(relative))
            small = error[~large].max() if (~large).any() else 0.0
            print(f"| {tol:g} | {100 * relative[worst]:.3f} % | {cases[worst][0]:g}, "
                  f"{cases[worst][1]:g} | {int(np.sum(relative > 1e-3))} | {small:.3g} N | "
                  f"{iterations.mean():.0f} | {iterations.max()} |")


if __name__ == "__main__":
    main()
