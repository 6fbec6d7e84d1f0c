"""Reduced-rank extrapolation against relaxation alone (``LatinOptions.acceleration``,
issue 15; docs/convergence.md): iterations and the time of the iterations only (operators
built once and reused), the two alternated four times in one process, the best of the
last three.

    python benchmarks/rre.py
    python benchmarks/rre.py --models b3
"""

from __future__ import annotations

import argparse

import multilatin as ml
from multilatin.latin import LatinOperators, LatinOptions, solve_latin

PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]
ACCELERATIONS = ("relaxation", "rre")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=["b1", "b1-4", "b1-9", "b3"])
    args = parser.parse_args()
    print("| model | μ1, μ2 | relaxation: iterations, ms | rre: iterations, ms | "
          "time ratio rre / relaxation | ms per iteration, relaxation / rre |")
    print("|---|---|---|---|---|---|")
    for name in args.models:
        model = ml.load_model(name)
        for mu1, mu2 in PAIRS:
            assembly = model.assemble({"mu1": mu1, "mu2": mu2})
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
            print(f"| {name} | {mu1:g}, {mu2:g} | {iterations['relaxation']}, "
                  f"{best['relaxation']:.1f} | {iterations['rre']}, {best['rre']:.1f} | "
                  f"{best['rre'] / best['relaxation']:.2f} | {per['relaxation']:.3f} / "
                  f"{per['rre']:.3f} |", flush=True)


if __name__ == "__main__":
    main()
