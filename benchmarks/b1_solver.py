"""B1: LATIN iterations and time against the monolithic semi-smooth Newton reference.

    python benchmarks/b1_solver.py

For b1, b1-4, b1-9 at (μ1, μ2) = (0.3, 0) and (0.1, 0.3): iterations to η < 1e-3, 1e-4,
1e-5 and the default tolerance (one solve at the default tolerance, read off its
history), time per iteration, the cold solve's wall time (setup included), and the
reference solver's time on the same case, measured side by side. The paper's iteration
counts (one and four substructures per body, "to 1e-5" in its own indicator) are shown for
comparison.
"""

from __future__ import annotations

import time

import numpy as np

import multilatin as ml

PAPER = {"b1": "25", "b1-4": "33", "b1-9": "–"}


def first_below(history: np.ndarray, tol: float) -> str:
    hits = np.flatnonzero(history < tol)
    return str(hits[0] + 1) if hits.size else f"> {history.size}"


def main() -> None:
    default = ml.LatinOptions().tol
    print(f"| model | μ1, μ2 | η < 1e-3 | η < 1e-4 | η < 1e-5 | η < {default:g} (default) | "
          "paper | "
          "per iteration (ms) | LATIN cold solve (s) | reference (s) | reference / LATIN | "
          "R_stop LATIN | R_stop reference |")
    print("|" + "---|" * 13)
    for name in ("b1", "b1-4", "b1-9"):
        model = ml.load_model(name)
        for mu1, mu2 in ((0.3, 0.0), (0.1, 0.3)):
            mu = {"mu1": mu1, "mu2": mu2}
            model.solve(mu)  # warm caches (imports, allocator) before timing
            t0 = time.perf_counter()
            latin = model.solve(mu)
            t_latin = time.perf_counter() - t0
            t0 = time.perf_counter()
            reference = model.reference(mu)
            t_ref = time.perf_counter() - t0
            print(f"| {name} | {mu1:g}, {mu2:g} | {first_below(latin.history, 1e-3)} | "
                  f"{first_below(latin.history, 1e-4)} | {first_below(latin.history, 1e-5)} | "
                  f"{latin.iterations} | "
                  f"{PAPER[name]} | {1e3 * latin.timings['per_iteration']:.2f} | "
                  f"{t_latin:.2f} | {t_ref:.2f} | {t_ref / t_latin:.2f} | "
                  f"{latin.qoi['R_stop']:.2f} | {reference.qoi['R_stop']:.2f} |")


if __name__ == "__main__":
    main()
