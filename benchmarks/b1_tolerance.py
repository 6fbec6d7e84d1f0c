"""R_stop's error against the LATIN indicator η, to choose the default tolerance.

    python benchmarks/b1_tolerance.py
    python benchmarks/b1_tolerance.py --models b1 --grid   # the 13 x 13 study grid (~25 min)

For each model and friction pair, R_stop at η < tol is compared with the tightly converged
value (η < 1e-9). Prints a Markdown table (the worst error over the cases per tolerance).
"""

from __future__ import annotations

import argparse

import multilatin as ml

CASES = [(0.0, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.0), (0.6, 0.6)]
TOLERANCES = [1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--models", nargs="+", default=["b1", "b1-4", "b1-9"])
    parser.add_argument("--grid", action="store_true",
                        help="every (μ1, μ2) of the 13 x 13 study grid instead of five cases")
    args = parser.parse_args()
    values = [round(0.05 * i, 2) for i in range(13)]
    cases = [(a, b) for a in values for b in values] if args.grid else CASES
    header = "| model | μ1, μ2 | R_stop (η < 1e-9) | " + " | ".join(
        f"η < {t:g}" for t in TOLERANCES) + " |"
    print("Error of R_stop in N (iterations) at each tolerance:\n")
    print(header)
    print("|" + "---|" * (3 + len(TOLERANCES)))
    worst = dict.fromkeys(TOLERANCES, 0.0)
    worst_rel = dict.fromkeys(TOLERANCES, 0.0)
    for name in args.models:
        model = ml.load_model(name)
        for mu1, mu2 in cases:
            mu = {"mu1": mu1, "mu2": mu2}
            exact = model.solve(mu, options=ml.LatinOptions(tol=1e-9, max_iter=20000))
            r_exact = float(exact.qoi["R_stop"])  # type: ignore[arg-type]
            cells = []
            for tol in TOLERANCES:
                res = model.solve(mu, options=ml.LatinOptions(tol=tol, max_iter=20000))
                err = abs(float(res.qoi["R_stop"]) - r_exact)  # type: ignore[arg-type]
                worst[tol] = max(worst[tol], err)
                worst_rel[tol] = max(worst_rel[tol], err / max(r_exact, 1.0))
                cells.append(f"{err:.3g} ({res.iterations})")
            print(f"| {name} | {mu1:g}, {mu2:g} | {r_exact:.3f} | " + " | ".join(cells) + " |")
    print("| worst | | | " + " | ".join(f"{worst[t]:.3g} N" for t in TOLERANCES) + " |")
    print("| worst relative (N / max(R_stop, 1 N)) | | | " +
          " | ".join(f"{worst_rel[t]:.2g}" for t in TOLERANCES) + " |")


if __name__ == "__main__":
    main()
