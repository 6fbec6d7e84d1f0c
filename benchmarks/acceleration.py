"""Acceleration of the LATIN fixed point at the default tolerance: relaxation against
Anderson mixing, measured side by side in one run (the default is the best of them).

    python benchmarks/acceleration.py

For b1, b1-4, b1-9 and b3 at (μ1, μ2) = (0.3, 0) and (0.1, 0.3): iterations to the default
tolerance and the iteration time (operators built once per model, outside the timing), for
relaxation ω = 0.9 (the default), Anderson mixing of depth 3, 5 and 10 (damped by ω = 0.9),
and separate normal / tangential search directions k_T = k_N / 2 and 2 k_N.
"""

from __future__ import annotations

import time

import multilatin as ml
from multilatin.latin import LatinOperators, solve_latin

CHOICES = {
    "relaxation ω 0.9": {},
    "Anderson 3": {"acceleration": "anderson", "anderson_depth": 3},
    "Anderson 5": {"acceleration": "anderson", "anderson_depth": 5},
    "Anderson 10": {"acceleration": "anderson", "anderson_depth": 10},
    "k_T = k_N / 2": {"tangential_ratio": 0.5},
    "k_T = 2 k_N": {"tangential_ratio": 2.0},
}


def main() -> None:
    print("Iterations to the default tolerance (iteration time in s)\n")
    print("| model | μ1, μ2 | " + " | ".join(CHOICES) + " |")
    print("|" + "---|" * (2 + len(CHOICES)))
    totals = dict.fromkeys(CHOICES, 0.0)
    for name in ("b1", "b1-4", "b1-9", "b3"):
        model = ml.load_model(name)
        for mu1, mu2 in ((0.3, 0.0), (0.1, 0.3)):
            assembly = model.assemble({"mu1": mu1, "mu2": mu2})
            cells = []
            for choice, settings in CHOICES.items():
                options = ml.LatinOptions(max_iter=5000, **settings)  # type: ignore[arg-type]
                operators = LatinOperators(assembly, options)
                solve_latin(assembly, operators=operators)  # warm caches
                t0 = time.perf_counter()
                result = solve_latin(assembly, operators=operators)
                elapsed = time.perf_counter() - t0
                totals[choice] += elapsed
                cells.append(f"{result.iterations} ({elapsed:.3f})")
            print(f"| {name} | {mu1:g}, {mu2:g} | " + " | ".join(cells) + " |", flush=True)
    print("| total time (s) | | " + " | ".join(f"{t:.2f}" for t in totals.values()) + " |")


if __name__ == "__main__":
    main()
