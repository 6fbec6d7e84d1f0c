"""When a QoI error estimate can be trusted: at a loose ``tol`` (η-stopped solves) a QoI
can stall while the state still moves, and an estimate read from the QoI's own increments
misses the change that has not begun. Every result reports the state's remaining change
η / (1 − ρ) (``SolveResult.state_change``) and withholds its QoI estimates above
``tracking.SETTLED`` (session 21). This benchmark solves a model's grid at several ``tol``
and compares R_stop's estimate, computed as if every state had settled, with its true
error against a tight solve (η < 1e-10).

    python benchmarks/estimate_trust.py [--model b1] [--count 7]
        [--tols 1e-5 1e-4 3e-4 1e-3 1.5e-3 3e-3]

Prints a Markdown table per tol: the cases where R_stop ≠ 0 (counted), its largest error,
the estimates below their error (with the worst ratio error / estimate) and the range of
the state's change; then, over all tols, the state changes of the estimates that held and
of those that did not.
"""

from __future__ import annotations

import argparse
import itertools

import numpy as np

import multilatin as ml
from multilatin.latin import solver
from multilatin.latin.tracking import SETTLED

TIGHT = ml.LatinOptions(tol=1e-10, max_iter=10000)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--model", default="b1")
    parser.add_argument("--count", type=int, default=7, help="grid values per friction")
    parser.add_argument("--tols", type=float, nargs="+",
                        default=[1e-5, 1e-4, 3e-4, 1e-3, 1.5e-3, 3e-3])
    args = parser.parse_args()
    model = ml.load_model(args.model)
    solver.SETTLED = np.inf  # every estimate computed, to compare it with its error
    values = np.linspace(0.0, 0.6, args.count)
    rows: list[tuple[float, float, float, float]] = []  # tol, error, estimate, change
    for a, b in itertools.product(values, values):
        mu = {"mu1": float(a), "mu2": float(b)}
        exact = float(model.solve(mu, options=TIGHT).qoi["R_stop"])  # type: ignore[arg-type]
        if exact == 0.0:
            continue  # a stuck block: R_stop is exactly zero at every tol
        for tol in args.tols:
            result = model.solve(mu, options=ml.LatinOptions(tol=tol))
            estimate = result.qoi_error["R_stop"]
            if estimate is None:
                continue
            error = abs(float(result.qoi["R_stop"]) - exact) / abs(exact)  # type: ignore[arg-type]
            rows.append((tol, error, float(estimate) / abs(exact),  # type: ignore[arg-type]
                         result.state_change))
    print(f"{args.model}, {args.count} x {args.count} grid, R_stop ≠ 0; relative to R_stop; "
          f"SETTLED = {SETTLED:g}\n")
    print("| tol | cases | largest error | estimates below their error (worst ×) "
          "| state change | withheld |")
    print("|---|---|---|---|---|---|")
    for tol in args.tols:
        at = [r for r in rows if r[0] == tol]
        if not at:
            continue
        below = [r for r in at if r[2] < r[1]]
        worst = max((r[1] / r[2] for r in below), default=0.0)
        changes = np.array([r[3] for r in at])
        print(f"| {tol:g} | {len(at)} | {max(r[1] for r in at):.1e} | {len(below)}"
              f"{f' (×{worst:.1f})' if below else ''} | {changes.min():.1e} – "
              f"{changes.max():.1e} | {int(np.sum(changes > SETTLED))} |")
    held = [r[3] for r in rows if r[2] >= r[1]]
    missed = [r[3] for r in rows if r[2] < r[1]]
    print(f"\nestimates that held: {len(held)}, {sum(c <= SETTLED for c in held)} of them at "
          f"a state change ≤ SETTLED; below their error: {len(missed)}, state change "
          + (f"{min(missed):.1e} – {max(missed):.1e}" if missed else "-"))


if __name__ == "__main__":
    main()
