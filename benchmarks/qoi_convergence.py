"""How many LATIN iterations the quantities of interest really need, against what the
stopping rules spend (issue 15 / 16): per case, the first iteration from which every QoI
stays within ``--rtol`` of its tightly converged value (η < 1e-11), beside the iterations
to η < tol and to the studies' QoI stopping (``qoi_rtol``); prints markdown tables.

    python benchmarks/qoi_convergence.py                       # b1: six cold cases, a warm line
    python benchmarks/qoi_convergence.py --models b1 b1-9 b3 --no-line
    python benchmarks/qoi_convergence.py --no-line --where 80  # where the error sits
    python benchmarks/qoi_convergence.py --corner-stiffening 1 # as before session 14

"Within" uses the QoI stopping's own scale: |q − q_tight| ≤ rtol · max(|q_tight|, 1 % of
the largest |q| the iteration took), at every load step it reports. The warm line is the B1 μ2 line
at μ1 = 0.3 as a study runs it: each case from the previous case's result of the same
stopping rule (the QoI stopping's).
"""

from __future__ import annotations

import argparse

import numpy as np

import multilatin as ml
from multilatin.decomposition.assembly import Assembly
from multilatin.latin import LatinOperators, engine, solve_latin
from multilatin.latin.options import STUDY_QOI_RTOL
from multilatin.latin.solver import IterationObserver
from multilatin.latin.tracking import qoi_functionals

COLD = ((0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15), (0.05, 0.0), (0.1, 0.25))
TRACE: list[np.ndarray] = []
#: ``LatinOptions`` fields every solve here takes (``--corner-stiffening``)
CHOICES: dict[str, float] = {}


def _record_qoi() -> None:
    """Keep every iteration's tracked QoIs (the solver computes them for its estimate)."""
    original = engine.NumpyFields.qoi_values

    def recorded(self: engine.NumpyFields) -> np.ndarray:
        values = original(self)
        TRACE.append(values[0].copy())
        return values

    engine.NumpyFields.qoi_values = recorded  # type: ignore[method-assign]


def first_within(trace: np.ndarray, tight: np.ndarray, rtol: float,
                 reported: np.ndarray) -> int:
    """First iteration (from 1) from which every QoI at every step it reports stays within
    rtol of max(|q_tight|, 1 % of the largest |q| the iteration took), as the QoI stopping."""
    seen = np.where(reported, np.abs(trace), 0.0).max(axis=(0, 2))[:, None]
    scale = np.maximum(np.abs(tight), 1e-2 * seen)
    outside = (np.abs(trace - tight) > rtol * scale) & reported
    bad = np.flatnonzero(np.any(outside, axis=(1, 2)))
    return int(bad[-1] + 2) if bad.size else 1


def solve(assembly: Assembly, ops: LatinOperators, options: ml.LatinOptions,
          initial: tuple[np.ndarray, np.ndarray] | None = None,
          observer: IterationObserver | None = None) -> tuple[ml.SolveResult, np.ndarray]:
    TRACE.clear()
    result = solve_latin(assembly, options, operators=ops, initial=initial, check=False,
                         observer=observer)
    return result, np.array(TRACE)


def row(assembly: Assembly, ops: LatinOperators, rtol: float,
        initial: tuple[np.ndarray, np.ndarray] | None, look_at: int | None = None
        ) -> tuple[list[int], ml.SolveResult, str]:
    """The table's numbers, the QoI-stopped result (the next warm case's start) and, with
    ``look_at``, where the error sits after that many iterations (``where``)."""
    states: list[tuple[np.ndarray, np.ndarray]] = []

    def keep(n: int, active: np.ndarray, w: np.ndarray, f: np.ndarray) -> None:
        if n == look_at:
            states.append((w[0].copy(), f[0].copy()))

    tight, tight_trace = solve(assembly, ops,
                               ml.LatinOptions(tol=1e-11, max_iter=20000, **CHOICES), initial)
    _, trace = solve(assembly, ops, ml.LatinOptions(tol=1e-13, max_iter=300, **CHOICES),
                     initial, keep if look_at else None)
    by_eta = solve(assembly, ops, ml.LatinOptions(**CHOICES), initial)[0]
    by_qoi = solve(assembly, ops, ml.LatinOptions(qoi_rtol=rtol, **CHOICES), initial)[0]
    reported = qoi_functionals(ops, assembly, ops.points).reported(assembly.n_steps)
    numbers = [first_within(trace, tight_trace[-1], rtol, reported), by_eta.iterations,
               by_qoi.iterations]
    return numbers, by_qoi, where(assembly, ops, states[0], tight) if states else ""


def where(assembly: Assembly, ops: LatinOperators, state: tuple[np.ndarray, np.ndarray],
          tight: ml.SolveResult) -> str:
    """The interface points carrying most of s − s_tight in ``state`` = (W, F) (in the
    indicator's norm, ∫ k W·W + k⁻¹ F·F), and the load steps."""
    assert tight.interface is not None
    pts, k = ops.points, ops.indicator_k
    (w, f), exact = state, tight.interface
    error = (pts.weights[:, None] * (k * (w - exact.displacement) ** 2
                                     + (f - exact.force) ** 2 / k)).sum(axis=2)
    share = error / error.sum()
    per_point = share.sum(axis=0)
    top = np.argsort(-per_point)[:4]
    steps = np.argsort(-share.sum(axis=1))[:3] + 1
    return ("; ".join(f"({pts.coords[p][0]:.1f}, {pts.coords[p][1]:.1f}) "
                      f"{assembly.interfaces[pts.interface[p]].name} {per_point[p]:.0%}"
                      for p in top) + f"; steps {', '.join(map(str, steps))}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=["b1"])
    parser.add_argument("--rtol", type=float, default=STUDY_QOI_RTOL)
    parser.add_argument("--no-line", action="store_true", help="cold cases only")
    parser.add_argument("--where", type=int, metavar="N",
                        help="also where the cold cases' error sits after N iterations")
    parser.add_argument("--corner-stiffening", type=float,
                        default=ml.LatinOptions().corner_stiffening)
    args = parser.parse_args()
    CHOICES["corner_stiffening"] = args.corner_stiffening
    _record_qoi()
    print(f"QoIs within {args.rtol:g} of η < 1e-11 | stopped at η < {ml.LatinOptions().tol:g}"
          f" | stopped on qoi_rtol {args.rtol:g} | corner_stiffening "
          f"{args.corner_stiffening:g}")
    print("\n| model | case | start | QoIs within | η stop | QoI stop |\n|---|---|---|---|---|---|")
    for name in args.models:
        model = ml.load_model(name)
        ops = None
        results = {}
        for mu1, mu2 in COLD:
            assembly = model.assemble({"mu1": mu1, "mu2": mu2})
            ops = ops or LatinOperators(assembly, ml.LatinOptions(**CHOICES))
            numbers, results[(mu1, mu2)], place = row(assembly, ops, args.rtol, None,
                                                      args.where)
            print(f"| {name} | ({mu1:g}, {mu2:g}) | cold | " + " | ".join(map(str, numbers))
                  + " |" + (f" {place} |" if place else ""), flush=True)
        if args.no_line or name != "b1":
            continue
        result = results[(0.3, 0.0)]  # the line's first case: the cold (0.3, 0) above
        for mu2 in np.round(np.linspace(0.05, 0.6, 12), 2):
            assert result.interface is not None and ops is not None
            start = (result.interface.displacement_hat, result.interface.force_hat)
            assembly = model.assemble({"mu1": 0.3, "mu2": float(mu2)})
            numbers, result, _ = row(assembly, ops, args.rtol, start)
            print(f"| {name} | (0.3, {mu2:g}) | warm | " + " | ".join(map(str, numbers))
                  + " |", flush=True)


if __name__ == "__main__":
    main()
