"""How many iterations the studies' QoI rule spends beyond what the tight answer says each
case needs (issue 16): cold solves of B1's 13 x 13 grid (or B3's 5 x 5 positions) under
``qoi_rtol`` = 1e-3, each QoI recorded at every iteration the rule reads, against η < 1e-10
solves of the same cases.

    python benchmarks/oracle_stop.py              # B1 13 x 13
    python benchmarks/oracle_stop.py --model b3   # B3 5 x 5 hole positions
    python benchmarks/oracle_stop.py --oscillation   # also with the oscillations' estimate
    python benchmarks/oracle_stop.py --model b3 --trace 12   # one case iteration by iteration

Per case the *oracle stop* is the first iteration from which every QoI at every step stays
within the rule's bound, 1e-3 x max(|q*|, 1 % of its largest magnitude), of the tight
value q* until the case stopped. The rule reads its estimates from iteration 15 on
(``iteration.WINDOW`` + 5), so the oracle is floored there too. Printed: the iterations the
rule took, the oracle's, the excess per case, and the cases stopped while some QoI was
still outside its bound (an estimate that did not bound its error). ``--oscillation``: then
also with the sharper estimate of damped oscillations (``tracking.OSCILLATION``, measured
and not adopted in session 34). ``--trace N``: case N of the grid (b3: 12 is (25, 75)) alone,
at every iteration the rule reads: R_stop's last increment, the largest estimate and the
largest true error over the reported entries, each over its bound.
"""

from __future__ import annotations

import argparse
import warnings
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOptions, iteration, solve_latin_batch, tracking

GRIDS = {"b1": [{"mu1": a, "mu2": b} for a in np.round(np.linspace(0.0, 0.6, 13), 10)
                for b in np.round(np.linspace(0.0, 0.6, 13), 10)],
         "b3": [{"xc": x, "yc": y} for x in range(23, 28) for y in range(73, 78)]}
CHUNK = 32
RTOL, FLOOR = 1e-3, 0.01


def recorded_solves(model: ml.Model, cases: list[dict[str, float]]
                    ) -> tuple[list[int], dict[int, dict[int, np.ndarray]],
                               dict[int, np.ndarray]]:
    """Each case's iterations under the QoI rule, its QoIs (q, t) at every iteration the
    rule read them (``iteration.qoi_settled`` wrapped) and which of them it reports (the
    rule reads those alone: a QoI of the last step, every step of a history)."""
    seen: dict[int, dict[int, np.ndarray]] = {}
    reported: dict[int, np.ndarray] = {}
    offset = [0]
    original = iteration.qoi_settled

    def recording(state: Any, active: np.ndarray, counts: np.ndarray, rtol: float,
                  *rest: Any, **named: Any) -> Any:
        values = state.qoi_recent[active, (counts - 1) % iteration.RECENT]
        for case, count, value in zip(active, counts, values, strict=True):
            seen.setdefault(offset[0] + int(case), {})[int(count)] = value.copy()
            reported[offset[0] + int(case)] = np.array(state.qoi_reported[case])
        return original(state, active, counts, rtol, *rest, **named)

    iteration.qoi_settled = recording
    stops: list[int] = []
    try:
        for lo in range(0, len(cases), CHUNK):
            offset[0] = lo
            results = solve_latin_batch([model.assemble(c) for c in cases[lo:lo + CHUNK]],
                                        LatinOptions(qoi_rtol=RTOL), check=False)
            stops.extend(r.iterations for r in results)
    finally:
        iteration.qoi_settled = original
    return stops, seen, reported


def tight_qois(model: ml.Model, cases: list[dict[str, float]]) -> list[dict[str, Any]]:
    out: list[dict[str, Any]] = []
    for lo in range(0, len(cases), CHUNK):
        out.extend(r.qoi for r in solve_latin_batch(
            [model.assemble(c) for c in cases[lo:lo + CHUNK]],
            LatinOptions(tol=1e-10, max_iter=5000), check=False))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--model", choices=sorted(GRIDS), default="b1")
    parser.add_argument("--trace", type=int, default=None, help="one case's iterations")
    parser.add_argument("--oscillation", action="store_true",
                        help="then with tracking.OSCILLATION on (session 34, not adopted)")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    model, cases = ml.load_model(args.model), GRIDS[args.model]
    if args.trace is not None:
        if not 0 <= args.trace < len(cases):
            parser.error(f"--trace: a case number from 0 to {len(cases) - 1}, got {args.trace}")
        trace(model, cases[args.trace])
        return
    tight = tight_qois(model, cases)
    report(args.model, model, cases, tight, "as it is")
    if args.oscillation:
        tracking.OSCILLATION = True
        try:
            report(args.model, model, cases, tight, "oscillations' estimate")
        finally:
            tracking.OSCILLATION = False


def trace(model: ml.Model, case: dict[str, float]) -> None:
    """``--trace``: the rule's reading of one case, each over the entry's bound."""
    reference = tight_qois(model, [case])[0]
    original = iteration.qoi_settled
    rows: list[str] = []

    def traced(state: Any, active: np.ndarray, counts: np.ndarray, rtol: float,
               *rest: Any, **named: Any) -> Any:
        settled = original(state, active, counts, rtol, *rest, **named)
        if len(active):
            a, n = int(active[0]), int(counts[0])
            order = (n + np.arange(iteration.RECENT)) % iteration.RECENT
            series, eta = state.qoi_recent[a, order], state.eta_recent[a, order]
            values = series[-1]
            bound = rtol * np.maximum(np.abs(values), iteration.QOI_FLOOR
                                      * state.qoi_scale[a].max(axis=0)[:, None])
            shown = state.qoi_reported[a]
            estimate = tracking.error_estimates(series, eta[:, None, None])
            exact = np.array([np.broadcast_to(np.asarray(q, dtype=float), values.shape[1:])
                              for q in reference.values()])
            step = np.flatnonzero(shown[0])[-1]  # R_stop (the first QoI): its reported step
            last = (series[-1, 0, step] - series[-2, 0, step]) / bound[0, step]
            rows.append(f"| {n} | {last:+.2f} | "
                        f"{np.where(shown, estimate / bound, 0.0).max():.2f} | "
                        f"{np.where(shown, np.abs(values - exact) / bound, 0.0).max():.2f} | "
                        f"{eta[-1]:.1e} |")
        return settled

    iteration.qoi_settled = traced
    try:
        result = solve_latin_batch([model.assemble(case)], LatinOptions(qoi_rtol=RTOL),
                                   check=False)[0]
    finally:
        iteration.qoi_settled = original
    print(f"{case}: {result.iterations} iterations under qoi_rtol = {RTOL:g}")
    print("| iteration | R_stop's last increment / bound | largest estimate / bound | "
          "largest true error / bound | η |")
    print("|---|---|---|---|---|")
    print("\n".join(rows))


def report(name: str, model: ml.Model, cases: list[dict[str, float]],
           tight: list[dict[str, Any]], label: str) -> None:
    stops, seen, reported = recorded_solves(model, cases)
    oracle, early = [], 0
    for c, stop in enumerate(stops):
        counts = sorted(seen.get(c, {}))
        if not counts:  # stopped on η before the rule read anything
            oracle.append(stop)
            continue
        values = np.array([seen[c][n] for n in counts])  # (n, q, t)
        reference = np.array([np.broadcast_to(np.asarray(q, dtype=float), values.shape[2:])
                              for q in tight[c].values()])
        scale = np.where(reported[c], np.abs(reference), 0.0).max(axis=1, keepdims=True)
        bound = RTOL * np.maximum(np.abs(reference), FLOOR * scale)
        inside = np.all((np.abs(values - reference) <= bound) | ~reported[c], axis=(1, 2))
        outside = np.flatnonzero(~inside)
        if outside.size and outside[-1] == len(counts) - 1:
            early += 1  # still outside at its stop
            oracle.append(stop)
            ratio = np.where(reported[c], np.abs(values[-1] - reference) / bound, 0.0)
            q, t = np.unravel_index(int(np.argmax(ratio)), ratio.shape)
            print(f"  stopped outside: {cases[c]}, {list(tight[c])[q]} at step {t + 1}, "
                  f"{ratio.max():.2f} x its bound")
        else:
            oracle.append(counts[outside[-1] + 1] if outside.size else counts[0])
    excess = np.array(stops) - np.array(oracle)
    print(f"{name} ({label}), {len(cases)} cold cases under qoi_rtol = {RTOL:g}: "
          f"{sum(stops)} iterations; the oracle's {sum(oracle)} "
          f"({100 * (1 - sum(oracle) / sum(stops)):.1f} % fewer); excess per case median "
          f"{np.median(excess):g}, largest {excess.max()}; stopped with a QoI still outside "
          f"its bound: {early}", flush=True)


if __name__ == "__main__":
    main()
