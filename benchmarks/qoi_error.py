"""The QoI error estimate of every LATIN result (``multilatin.latin.tracking``) against the
true error, |QoI at the tolerance − QoI of a tight solve (η < 1e-10)|, over a grid of cases
and several tolerances; prints a markdown table.

    python benchmarks/qoi_error.py --model b1 --count 7
    python benchmarks/qoi_error.py --model b0 --splits 10x1 5x1 4x2 20x2
    python benchmarks/qoi_error.py --model b1-9 --count 5 --oscillation   # session 34's lead

An entry is one QoI at one load step of one case. "bound" counts the entries where the
estimate is at least the true error, among those whose true error is above the floor
1e-6 × the QoI's largest magnitude over the grid (a QoI that is zero to that accuracy has no
relative error to bound); ratio = estimate / true error over the same entries.
``--oscillation``: with the sharper estimate of damped oscillations on
(``tracking.OSCILLATION``; measured in session 34, not adopted).
"""

from __future__ import annotations

import argparse
import itertools

import numpy as np

import multilatin as ml

FLOOR = 1e-6


def compare(pairs: list[tuple[ml.SolveResult, ml.SolveResult]]) -> dict[str, float]:
    """Bound count and ratio statistics of (result, tight result) pairs, all QoIs."""
    names = list(pairs[0][0].qoi)
    scale = {n: max(float(np.max(np.abs(t.qoi[n]))) for _, t in pairs) for n in names}
    ratios, misses, below = [], 0, 0
    for result, tight in pairs:
        for name in names:
            error = result.qoi_error[name]
            if error is None:
                continue
            true = np.abs(np.atleast_1d(result.qoi[name]) - np.atleast_1d(tight.qoi[name]))
            estimate = np.atleast_1d(error)
            counted = true > FLOOR * max(scale[name], 1e-300)
            below += int(np.sum(~counted))
            misses += int(np.sum(estimate[counted] < true[counted]))
            ratios.extend((estimate[counted] / true[counted]).tolist())
    r = np.array(ratios)
    return {"entries": float(r.size), "misses": float(misses), "below_floor": float(below),
            "min": float(r.min()), "median": float(np.median(r)),
            "p90": float(np.percentile(r, 90)), "max": float(r.max())}


def cases(model: ml.Model, count: int, splits: list[str]) -> list[dict[str, object]]:
    if splits:
        return [{"split": {"beam": tuple(int(v) for v in s.split("x"))}} for s in splits]
    names = [n for n in ("mu1", "mu2") if n in model.parameters]
    values = np.linspace(0.0, 0.6, count)
    return [{"mu": dict(zip(names, combo, strict=True))}
            for combo in itertools.product(values, repeat=len(names))]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="b1")
    parser.add_argument("--count", type=int, default=7, help="values per friction coefficient")
    parser.add_argument("--splits", nargs="*", default=[], help="B0 decompositions, e.g. 10x1")
    parser.add_argument("--tols", nargs="*", type=float, default=[1e-4, 1e-5, 3e-6, 1e-6])
    parser.add_argument("--oscillation", action="store_true",
                        help="tracking.OSCILLATION on (session 34's lead, not adopted)")
    args = parser.parse_args()
    if args.oscillation:
        from multilatin.latin import tracking

        tracking.OSCILLATION = True
    model = ml.load_model(args.model)
    tight_options = ml.LatinOptions(tol=1e-10, max_iter=10000)
    runs = cases(model, args.count, args.splits)
    tight = [model.solve(options=tight_options, **run) for run in runs]  # type: ignore[arg-type]
    print(f"{args.model}, {len(runs)} cases: the estimate against the true error")
    print("| η < | entries | bound | below the floor | ratio min | median | 90 % | max |")
    print("|---|---|---|---|---|---|---|---|")
    for tol in args.tols:
        options = ml.LatinOptions(tol=tol)
        pairs = [(model.solve(options=options, **run), t)  # type: ignore[arg-type]
                 for run, t in zip(runs, tight, strict=True)]
        s = compare(pairs)
        print(f"| {tol:g} | {s['entries']:.0f} | {s['entries'] - s['misses']:.0f} | "
              f"{s['below_floor']:.0f} | {s['min']:.2f} | {s['median']:.2f} | {s['p90']:.1f} | "
              f"{s['max']:.3g} |")


if __name__ == "__main__":
    main()
