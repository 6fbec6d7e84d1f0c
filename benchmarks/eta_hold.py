"""How long a case that stops on η alone is held after a sliding jump (issue 15; session
46, measured, not adopted: docs/convergence.md).

    python benchmarks/eta_hold.py [--holds 15,10,0]

With QoI stopping a case never stops within ``iteration.RECENT`` (15) iterations of a jump
(``sliding``): the take-back check runs one window later, and the QoIs' estimates must read
iterates after the jump. With η alone the same hold applies (``iteration.ETA_JUMP_HOLD``);
this measures shorter ones on the bundled models where a jump comes shortly before the
stop: iterations to η < 1e-6, the largest error of any QoI at any step against an η < 1e-11
solve (relative to the QoI's largest magnitude), and how many reported estimates
(``SolveResult.qoi_error``, every QoI and step) are below their true error. Within
``RECENT`` iterations of a jump a stop also needs η_F below η's own bound
(``guards.forces_unsettled``); the moved block of ``tests/test_large_displacement.py`` is
in the table for that: R_base against the unmoved reference.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOptions, iteration

CASES: list[tuple[str, dict[str, float], float]] = [
    ("b0", {}, 0.5), ("b2", {}, 0.5), ("punch", {}, 0.5), ("lug", {}, 0.5),
    ("slide", {}, 0.2), ("slide", {}, 0.5), ("slide", {}, 1.0), ("slide", {}, 2.0),
    ("b1-9", {"mu1": 0.3, "mu2": 0.15}, 0.5), ("b3", {"mu1": 0.35, "mu2": 0.25}, 0.5),
    ("b3", {"mu1": 0.3, "mu2": 0.15}, 0.5)]
MOVED = Path(__file__).resolve().parents[1] / "tests" / "data" / "block_on_moved_foundation.toml"


def _row(model: ml.Model, mu: dict[str, float], kappa: float, tight: ml.SolveResult
         ) -> str:
    result = model.solve(mu, options=LatinOptions(kappa=kappa), check=False)
    worst, below, entries = 0.0, 0, 0
    for name, value in result.qoi.items():
        exact = np.atleast_1d(np.asarray(tight.qoi[name], dtype=float))
        error = np.abs(np.atleast_1d(np.asarray(value, dtype=float)) - exact)
        estimate = np.atleast_1d(np.asarray(result.qoi_error[name], dtype=float))
        worst = max(worst, float(error.max() / max(np.abs(exact).max(), 1e-300)))
        below += int(np.sum(estimate < error))
        entries += error.size
    return f"{result.iterations}, {worst:.1e}, {below} of {entries}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--holds", default="15,10,0")
    holds = [int(h) for h in parser.parse_args().holds.split(",")]
    print("| model | parameters | κ | " + " | ".join(
        f"hold {h}: iterations, worst error, estimates below it" for h in holds) + " |")
    print("|---|---|---|" + "---|" * len(holds))
    for name, mu, kappa in CASES:
        model = ml.load_model(name)
        tight = model.solve(mu, options=LatinOptions(tol=1e-11, max_iter=5000), check=False)
        cells = []
        for hold in holds:
            iteration.ETA_JUMP_HOLD = hold
            cells.append(_row(model, mu, kappa, tight))
        iteration.ETA_JUMP_HOLD = iteration.RECENT
        shown = ", ".join(f"{k} = {v:g}" for k, v in mu.items()) or "defaults"
        print(f"| {name} | {shown} | {kappa:g} | " + " | ".join(cells) + " |", flush=True)
    moved = ml.Model(ml.ModelSpec.from_toml(MOVED))
    unmoved = float(moved.reference({"q": 2.9, "shift": 0.0}).qoi["R_base"][-1])
    cells = []
    for hold in holds:
        iteration.ETA_JUMP_HOLD = hold
        result = moved.solve({"q": 2.9, "shift": 100.0}, check=False)
        cells.append(f"{result.iterations}, R_base "
                     f"{abs(float(result.qoi['R_base'][-1]) / unmoved - 1.0):.1e} off")
    iteration.ETA_JUMP_HOLD = iteration.RECENT
    print("| moved block | q = 2.9, shift = 100 | 0.5 | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
