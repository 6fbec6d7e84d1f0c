"""A per-load-step state guard for the QoI rule, measured (session 49; not in the library).

The rule's state condition (``iteration.state_settled``) asks the whole state's remaining
change, η / (1 − ρ), below ``qoi_rtol``. A small early step (the roller's preload step 2,
whose Q is 0.7 % of its largest value) can still change by 1 % of itself then, and its QoI
with it (docs/tolerance.md, "The rule on every bundled model"). This prototype asks the same
of every load step on its own: η_t = ‖s_t − ŝ_t‖ / ½(‖s_t‖ + ‖ŝ_t‖) per step, its rate
over the window, η_t / (1 − ρ_t) ≤ ``qoi_rtol`` at every step, on top of the library's
condition. Cold single solves only (the per-step history is kept for case 0 of a batch of
one), under the studies' rule, against tight solves (η < 1e-10): iterations and every QoI's
worst error relative to max(|value|, 1 % of its largest magnitude).

    python benchmarks/step_guard.py [--cases roller:mu=0.5,shift=0.02 b1:mu1=0.3,mu2=0.15 ...]
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.latin import engine as engine_module
from multilatin.latin import iteration
from multilatin.latin.options import STUDY_QOI_RTOL
from multilatin.latin.tracking import WINDOW

CASES = ["roller:mu=0.5,shift=0.02", "roller:mu=0.3,shift=0.04", "b1:mu1=0.3,mu2=0.0",
         "b1:mu1=0.1,mu2=0.3", "b1:mu1=0.35,mu2=0.25", "b1:mu1=0.3,mu2=0.15",
         "b1-9:mu1=0.1,mu2=0.3", "b3:", "lap:mu=0.25,p=20", "punch:", "slide:"]

#: per iteration, the per-step relative η of the one case being solved
HISTORY: list[np.ndarray] = []
ON = False


def _step_etas(engine: Any) -> np.ndarray:
    w, f, w_hat, f_hat = engine.fields()
    dw = engine.displacement_weight.reshape(w.shape[2:])
    fw = engine.force_weight.reshape(f.shape[2:])

    def squares(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return (dw * a * a).sum(axis=(2, 3)) + (fw * b * b).sum(axis=(2, 3))

    gap = np.sqrt(squares(w - w_hat, f - f_hat))
    size = 0.5 * (np.sqrt(squares(w, f)) + np.sqrt(squares(w_hat, f_hat)))
    return np.asarray(np.where(size > 0, gap / np.where(size > 0, size, 1.0), 0.0))[0]


def install() -> None:
    indicator = engine_module.NumpyFields.indicator
    library_guard = iteration.state_settled

    def recording(self: Any) -> Any:
        out = indicator(self)
        HISTORY.append(_step_etas(self))
        return out

    def guarded(state: Any, active: np.ndarray, counts: Any, rtol: Any,
                window: int = WINDOW) -> np.ndarray:
        settled = library_guard(state, active, counts, rtol, window)
        if not ON or len(HISTORY) <= window or not np.size(active):
            return settled
        now, before = HISTORY[-1], HISTORY[-1 - window]
        with np.errstate(divide="ignore", invalid="ignore"):
            rate = np.where(before > 0, (now / np.where(before > 0, before, 1.0))
                            ** (1.0 / window), 0.0)
        remaining = (now / (1.0 - np.clip(np.nan_to_num(rate, nan=0.999), 0.0, 0.999)))[None]
        bound = np.broadcast_to(np.asarray(rtol, dtype=float), np.shape(active))
        return np.asarray(settled & (np.all(remaining <= bound[:, None], axis=1)))

    engine_module.NumpyFields.indicator = recording  # type: ignore[method-assign]
    iteration.state_settled = guarded  # type: ignore[assignment]


def worst_error(result: ml.SolveResult, tight: ml.SolveResult) -> tuple[float, str]:
    worst, where = 0.0, ""
    for name, exact_value in tight.qoi.items():
        exact = np.atleast_1d(np.asarray(exact_value, dtype=float))
        value = np.atleast_1d(np.asarray(result.qoi[name], dtype=float))
        scale = np.maximum(np.abs(exact), 1e-2 * np.abs(exact).max())
        relative = np.abs(value - exact) / np.where(scale > 0, scale, 1.0)
        if relative.max() > worst:
            worst = float(relative.max())
            where = name + (f" step {int(np.argmax(relative)) + 1}" if exact.size > 1 else "")
    return worst, where


def main() -> None:
    global ON
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", nargs="+", default=CASES)
    args = parser.parse_args()
    install()
    print("| case | library: iterations, worst error | per-step guard too |")
    print("|---|---|---|")
    for spec in args.cases:
        name, _, pairs = spec.partition(":")
        mu = {k: float(v) for k, v in (p.split("=") for p in pairs.split(",") if p)}
        model = ml.load_model(name)
        tight = model.solve(mu, options=ml.LatinOptions(tol=1e-10, max_iter=20000))
        cells = []
        for on in (False, True):
            ON = on
            HISTORY.clear()
            result = model.solve(mu, options=ml.LatinOptions(qoi_rtol=STUDY_QOI_RTOL))
            error, where = worst_error(result, tight)
            cells.append(f"{result.iterations}, {error:.1e} ({where})")
        print(f"| {spec} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
