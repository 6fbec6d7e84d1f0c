"""Iterations to η < 1e-4 / 3e-5 / 1e-5 against the search direction κ and the relaxation ω
for b1, b1-4, b1-9 (k = κ E / L, L the smaller side of the body).

    python benchmarks/b1_search_direction.py            # two processes
"""

from __future__ import annotations

import argparse
from concurrent.futures import ProcessPoolExecutor

import numpy as np

import multilatin as ml

TOLERANCES = (1e-4, 3e-5, 1e-5)


def count(job: tuple[str, tuple[float, float], float, float, str, int, float]) -> str:
    name, (mu1, mu2), kappa, omega, acceleration, depth, ratio = job
    result = ml.load_model(name).solve(
        {"mu1": mu1, "mu2": mu2},
        options=ml.LatinOptions(tol=min(TOLERANCES), max_iter=600, kappa=kappa,
                                relaxation=omega, acceleration=acceleration,
                                anderson_depth=depth, tangential_ratio=ratio),
        check=False)
    hits = [np.flatnonzero(result.history < t) for t in TOLERANCES]
    return " / ".join(str(h[0] + 1) if h.size else "> 600" for h in hits)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--kappa", type=float, nargs="+", default=[0.35, 0.5, 0.7])
    parser.add_argument("--relaxation", type=float, nargs="+", default=[0.8, 0.9, 0.95])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--acceleration", default="relaxation", choices=["relaxation", "anderson"])
    parser.add_argument("--depth", type=int, default=3, help="Anderson depth")
    parser.add_argument("--tangential-ratio", type=float, default=1.0,
                        help="k_T / k_N on contact interfaces")
    args = parser.parse_args()
    settings = [(k, w) for w in args.relaxation for k in args.kappa]
    rows = [(name, mu) for name in ("b1", "b1-4", "b1-9") for mu in ((0.1, 0.3), (0.3, 0.0))]
    jobs = [(name, mu, k, w, args.acceleration, args.depth, args.tangential_ratio)
            for name, mu in rows
            for k, w in settings]
    with ProcessPoolExecutor(args.workers) as pool:
        cells = list(pool.map(count, jobs))
    print("| model | μ1, μ2 | " + " | ".join(f"κ {k:g}, ω {w:g}" for k, w in settings) + " |")
    print("|" + "---|" * (2 + len(settings)))
    for r, (name, mu) in enumerate(rows):
        row = cells[r * len(settings):(r + 1) * len(settings)]
        print(f"| {name} | {mu[0]:g}, {mu[1]:g} | " + " | ".join(row) + " |")


if __name__ == "__main__":
    main()
