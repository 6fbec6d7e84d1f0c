"""Convergence of cold LATIN solves, today's default side by side with candidate options
(issue 15: the slow tail).

    python benchmarks/convergence.py                                   # the default alone
    python benchmarks/convergence.py --variant kappa=1 --variant acceleration=anderson
    python benchmarks/convergence.py --models b1 --pairs 0.3,0 0.1,0.3 --variant kappa=1
    python benchmarks/convergence.py --models lug roller punch slide --variant micro_stiffening=1

For each model and friction pair, and for the default ``LatinOptions`` and each variant
(``name=value`` overrides of ``LatinOptions`` fields, several joined by ``;``), one cold solve
to the default tolerance: iterations, time, the tail rate (the per-iteration factor of η
fitted over the last 30 iterations, a least-squares line through log η), and R_stop's error
against a tight solve (η < 1e-9, default options) of the same discretisation. Everything in
one run, one process, after a warm-up. Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOptions

MODELS = ["b1", "b1-4", "b1-9", "b3"]
PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]
TIGHT = 1e-9


def tail_rate(history: np.ndarray, window: int = 30) -> float:
    """exp of the slope of log η over the last ``window`` iterations."""
    tail = np.log(np.maximum(history[-window:], 1e-300))
    if tail.size < 3:
        return float("nan")
    slope = np.polyfit(np.arange(tail.size), tail, 1)[0]
    return float(np.exp(slope))


def parse_variant(text: str) -> dict[str, object]:
    fields = {f.name: f.type for f in dataclasses.fields(LatinOptions)}
    out: dict[str, object] = {}
    for item in text.split(";"):
        name, _, value = item.partition("=")
        name = name.strip()
        if name not in fields:
            raise SystemExit(f"--variant {text!r}: unknown option {name!r}")
        default = getattr(LatinOptions(), name)
        out[name] = (value.strip() if isinstance(default, str) else
                     value.strip().lower() in ("1", "true", "yes") if isinstance(default, bool)
                     else None if value.strip().lower() == "none"
                     else float(value) if default is None  # an optional number (qoi_rtol)
                     else type(default)(float(value)))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--models", nargs="+", default=MODELS)
    parser.add_argument("--pairs", nargs="+", default=[f"{a},{b}" for a, b in PAIRS])
    parser.add_argument("--variant", action="append", default=[],
                        help="LatinOptions overrides, e.g. 'kappa=1' or 'kappa=1;relaxation=0.8'")
    args = parser.parse_args()
    pairs = [tuple(float(v) for v in p.split(",")) for p in args.pairs]
    variants = {"default": LatinOptions()}
    for text in args.variant:
        variants[text] = dataclasses.replace(LatinOptions(), **parse_variant(text))
    ml.load_model("b1").solve({"mu1": 0.3, "mu2": 0.0})  # warm-up: imports, kernels
    print("| model | μ1, μ2 | options | iterations | time (s) | tail rate | "
          "R_stop − tight (N) | relative |")
    print("|---|---|---|---|---|---|---|---|")
    for name in args.models:
        model = ml.load_model(name)
        # a model without B1's frictions (lug, roller, punch, slide, …): its defaults once,
        # the error column on its first QoI
        cases = ([{"mu1": a, "mu2": b} for a, b in pairs] if "mu1" in model.parameters
                 and "mu2" in model.parameters else [{}])
        for mu in cases:
            tight = model.solve(mu, options=LatinOptions(tol=TIGHT, max_iter=50_000))
            qoi = "R_stop" if "R_stop" in tight.qoi else next(iter(tight.qoi))
            reference = float(np.max(np.abs(tight.qoi[qoi])))  # type: ignore[arg-type]
            where = f"{mu['mu1']:g}, {mu['mu2']:g}" if mu else f"defaults ({qoi})"
            for label, options in variants.items():
                start = time.perf_counter()
                result = model.solve(mu, options=options, check=False)
                elapsed = time.perf_counter() - start
                error = float(np.max(np.abs(np.asarray(result.qoi[qoi], dtype=float)
                                            - np.asarray(tight.qoi[qoi], dtype=float))))
                if qoi == "R_stop":
                    error = float(result.qoi["R_stop"]) - float(tight.qoi["R_stop"])  # type: ignore[arg-type]
                mark = "" if result.converged else " (not converged)"
                print(f"| {name} | {where} | {label} | {result.iterations}{mark} | "
                      f"{elapsed:.3f} | {tail_rate(result.history):.3f} | {error:+.3f} | "
                      f"{abs(error) / max(abs(reference), 1.0):.1e} |", flush=True)

if __name__ == "__main__":
    main()
