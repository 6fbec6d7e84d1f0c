"""The QoI stopping rule's state condition (``iteration.state_settled``, session 20): a case
stops on its QoIs' estimated errors only once the state's own remaining change, η / (1 − ρ),
is below ``qoi_rtol`` too. Cold solves with and without it (the condition replaced by
"always settled"), ``qoi_rtol`` = 1e-3, against tight solves (η < 1e-10).

    python benchmarks/state_guard.py [--models b1 b1-r b1-9 b3]
    python benchmarks/state_guard.py --bundled lug roller b2 slide punch b0

``--bundled``: models solved once at their default parameters; every QoI's worst error
against the tight solve, relative to max(|value|, 1 % of its largest magnitude) as the
stopping rule reads it.

``b1-r`` is B1 with R_stop its only quantity of interest (a user studying R_stop's
response): its R_stop stalls while the centre block still slides. Prints a Markdown table:
iterations, η at the stop, R_stop's error and its estimate, with and without the condition.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import multilatin as ml
from multilatin.latin import iteration

PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]


def load(name: str) -> ml.Model:
    if name != "b1-r":
        return ml.load_model(name)
    text = (Path(ml.__file__).parent / "models" / "b1.toml").read_text(encoding="utf-8")
    head, *blocks = text.split("[[qoi]]")
    kept = [b for b in blocks if 'name = "R_stop"' in b]
    return ml.Model(ml.ModelSpec.from_string(head + "[[qoi]]" + kept[0], name="b1-r"))


def _without(state: object, active: np.ndarray, counts: object, rtol: float,
             window: int = 0) -> np.ndarray:
    return np.ones(active.size, dtype=bool)


def bundled(names: list[str], options: ml.LatinOptions) -> None:
    guarded = iteration.state_settled
    print("| model | condition | iterations | η at the stop | worst QoI error |")
    print("|---|---|---|---|---|")
    for name in names:
        model = ml.load_model(name)
        tight = model.solve(options=ml.LatinOptions(tol=1e-10, max_iter=20000))
        for label, rule in (("with", guarded), ("without", _without)):
            iteration.state_settled = rule  # type: ignore[assignment]
            try:
                result = model.solve(options=options)
            finally:
                iteration.state_settled = guarded  # type: ignore[assignment]
            errors = {}
            for qoi, value in tight.qoi.items():
                exact = np.atleast_1d(np.asarray(value, dtype=float))
                got = np.atleast_1d(np.asarray(result.qoi[qoi], dtype=float))
                scale = np.maximum(np.abs(exact), 1e-2 * np.abs(exact).max())
                errors[qoi] = float(np.max(np.abs(got - exact)
                                           / np.where(scale > 0, scale, 1.0)))
            worst = max(errors, key=lambda q: errors[q])
            print(f"| {name} | {label} | {result.iterations} | {result.indicator:.1e} | "
                  f"{100 * errors[worst]:.3f} % ({worst}) |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=["b1", "b1-r", "b1-9", "b3"])
    parser.add_argument("--bundled", nargs="*", default=None,
                        help="bundled models at their default parameters instead")
    args = parser.parse_args()
    guarded = iteration.state_settled
    options = ml.LatinOptions(qoi_rtol=1e-3)
    if args.bundled is not None:
        bundled(args.bundled, options)
        return
    print("| model | (μ1, μ2) | condition | iterations | η at the stop | R_stop error | "
          "its estimate |")
    print("|---|---|---|---|---|---|---|")
    for name in args.models:
        model = load(name)
        for mu1, mu2 in PAIRS:
            mu = {"mu1": mu1, "mu2": mu2}
            exact = float(model.solve(mu, options=ml.LatinOptions(tol=1e-10, max_iter=10000)
                                      ).qoi["R_stop"])  # type: ignore[arg-type]
            for label, rule in (("with", guarded), ("without", None)):
                iteration.state_settled = rule or (  # type: ignore[assignment]
                    lambda state, active, counts, rtol, window=0: np.ones(active.size, dtype=bool))
                try:
                    result = model.solve(mu, options=options)
                finally:
                    iteration.state_settled = guarded  # type: ignore[assignment]
                value = float(result.qoi["R_stop"])  # type: ignore[arg-type]
                estimate = result.qoi_error["R_stop"]
                print(f"| {name} | ({mu1:g}, {mu2:g}) | {label} | {result.iterations} | "
                      f"{result.indicator:.1e} | {100 * abs(value - exact) / abs(exact):.3f} % | "
                      + (f"{100 * estimate / abs(exact):.3f} % |"  # type: ignore[operator]
                         if estimate is not None else "— |"))


if __name__ == "__main__":
    main()
