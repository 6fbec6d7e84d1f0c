"""Settled leading steps (``LatinOptions.settled_steps``) side by side with every step every
iteration (``settled_steps=0``), in one process, alternately: studies with ``run_study``'s
defaults (the QoI rule) and cold solves at the four pairs of ``convergence.py``. Prints per
row the wall times (median over ``--rounds``), the iterations, the share of the (case, step)
rows the linear stage ran, and the largest change of R_stop between the two.

    python benchmarks/settled_steps.py
    python benchmarks/settled_steps.py --rounds 3 --rows b1-study b3-frictions
    python benchmarks/settled_steps.py --potential
    python benchmarks/settled_steps.py --alone

Rows: ``b1-study`` the main job's study (B1 13 × 13), ``b3-frictions`` B3 13 × 13 frictions
at rc = 3 (one geometry of the 21 125-case study), ``b3-positions`` B3's 5 × 5 hole
positions, ``cold`` cold solves of b1, b1-9 and b3 at the four pairs (η < 1e-6).

``--potential``: what settling could save, read from outside the iteration (every step
iterated): the main job's chain of starts (the middle row μ1 = 0.3 from its middle along μ2,
the other rows from their neighbour toward it) solved warm, and every fourth case cold; per
solve, each step's change of s per iteration (after the linear stage) over the case's norm;
a leading step counts as settled from the iteration its change has stayed below δ for three
iterations. Prints the share of (case, step) rows iterated after that, and the largest
error a settled step keeps (its final value against the one it settled at).

``--alone``: whether marching step by step would beat the tail: B1 at three pairs, each step
t started from step t − 1's tightly converged fields (the earlier steps converged), the
iterations until it settles.
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOptions, solve_latin
from multilatin.latin.engine import NumpyFields
from multilatin.latin.operators import LatinOperators
from multilatin.study.plan import clear_operator_cache
from multilatin.study.runner import STUDY_QOI_RTOL

STUDIES = {
    "b1-study": ("b1", ["mu1=0:0.6:13", "mu2=0:0.6:13"]),
    "b3-frictions": ("b3", ["mu1=0:0.6:13", "mu2=0:0.6:13", "rc=3"]),
    "b3-positions": ("b3", ["xc=23:27:5", "yc=73:77:5"]),
}
PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]

#: (case, step) rows the linear stage ran, and of all rows
ROWS = [0, 0]


def _count_rows() -> None:
    original = NumpyFields.linear_stage

    def counted(engine: NumpyFields, relaxation: np.ndarray) -> None:
        ROWS[0] += int((engine.w_hat.shape[1] - engine.first).sum())
        ROWS[1] += engine.w_hat.shape[1] * engine.first.size
        original(engine, relaxation)

    NumpyFields.linear_stage = counted  # type: ignore[method-assign]


def study(row: str, factor: float) -> tuple[float, int, dict[Any, float]]:
    name, grid = STUDIES[row]
    clear_operator_cache()
    options = LatinOptions(qoi_rtol=STUDY_QOI_RTOL, settled_steps=factor)
    t0 = time.perf_counter()
    result = ml.run_study(ml.load_model(name), ml.Grid.parse(grid), options=options,
                          progress=False)
    wall = time.perf_counter() - t0
    answers = {tuple(sorted(r["params"].items())): r["qoi"]["R_stop"] for r in result.records}
    return wall, sum(r["iterations"] for r in result.records), answers


def cold(factor: float) -> tuple[float, int, dict[Any, float]]:
    wall, iterations, answers = 0.0, 0, {}
    for name in ("b1", "b1-9", "b3"):
        model = ml.load_model(name)
        options = LatinOptions(settled_steps=factor)
        ops = LatinOperators(model.assemble({"mu1": 0.3, "mu2": 0.3}), options)
        for mu1, mu2 in PAIRS:
            t0 = time.perf_counter()
            result = solve_latin(model.assemble({"mu1": mu1, "mu2": mu2}), options,
                                 operators=ops)
            wall += time.perf_counter() - t0
            iterations += result.iterations
            answers[name, mu1, mu2] = float(result.qoi["R_stop"])  # type: ignore[arg-type]
    return wall, iterations, answers


def potential(deltas: tuple[float, ...] = (1e-5, 1e-6, 1e-7)) -> None:
    model = ml.load_model("b1")
    options = LatinOptions(qoi_rtol=STUDY_QOI_RTOL, settled_steps=0.0)
    ops = LatinOperators(model.assemble({"mu1": 0.3, "mu2": 0.3}), options)
    k = ops.indicator_k
    values = [round(float(v), 2) for v in np.linspace(0.0, 0.6, 13)]
    order: list[tuple[tuple[int, int], tuple[int, int] | None]] = [((6, 6), None)]
    order += [((6, j), (6, j + 1)) for j in range(5, -1, -1)]
    order += [((6, j), (6, j - 1)) for j in range(7, 13)]
    order += [((i, j), (i + 1, j)) for i in range(5, -1, -1) for j in range(13)]
    order += [((i, j), (i - 1, j)) for i in range(7, 13) for j in range(13)]
    totals = {mode: {d: [0, 0, 0.0] for d in deltas} for mode in ("warm", "cold")}
    states: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = {}
    for (i, j), parent in order:
        assembly = model.assemble({"mu1": values[i], "mu2": values[j]})
        for mode in ("warm", "cold") if (i + j) % 4 == 0 else ("warm",):
            seen: list[tuple[np.ndarray, np.ndarray]] = []
            result = solve_latin(assembly, options, operators=ops, check=False,
                                 initial=states.get(parent) if mode == "warm" else None,
                                 observer=lambda _, __, w, f, seen=seen: seen.append(
                                     (w[0].copy(), f[0].copy())))
            if mode == "warm":
                assert result.interface is not None
                states[i, j] = (result.interface.displacement_hat,
                                result.interface.force_hat)
            w, f = np.array([x[0] for x in seen]), np.array([x[1] for x in seen])
            norm = np.sqrt((k * w ** 2 + f ** 2 / k).sum(axis=(1, 2, 3)))
            change = np.sqrt((k * np.diff(w, axis=0) ** 2 + np.diff(f, axis=0) ** 2 / k)
                             .sum(axis=(2, 3))) / norm[1:, None]
            n_iter, n_steps = w.shape[:2]
            for delta in deltas:
                settled_at, start = np.full(n_steps, n_iter), 3
                for t in range(n_steps):
                    calm = [i for i in range(start, n_iter) if (change[i - 3:i, t] < delta).all()]
                    if not calm:
                        break
                    settled_at[t] = start = calm[0]
                error = max((np.sqrt((k * (w[-1, t] - w[settled_at[t] - 1, t]) ** 2).sum()
                                     + ((f[-1, t] - f[settled_at[t] - 1, t]) ** 2 / k).sum())
                             / norm[-1] for t in range(n_steps) if settled_at[t] < n_iter),
                            default=0.0)
                total = totals[mode][delta]
                total[0] += int(settled_at.sum())
                total[1] += n_iter * n_steps
                total[2] = max(total[2], float(error))
    print("| solves | δ | rows iterated | largest error a settled step keeps |")
    print("|---|---|---|---|")
    for mode, rows in totals.items():
        for delta, (run, alls, error) in rows.items():
            print(f"| {mode} | {delta:g} | {run / alls:.3f} | {error:.1e} |")


def alone() -> None:
    model = ml.load_model("b1")
    options = LatinOptions()
    firsts: list[int] = []
    original = NumpyFields.settle

    def recorded(engine: NumpyFields, size: np.ndarray, bound: float) -> None:
        original(engine, size, bound)
        firsts.append(int(engine.first[0]))

    NumpyFields.settle = recorded  # type: ignore[method-assign]
    for mu1, mu2 in ((0.3, 0.1), (0.1, 0.3), (0.5, 0.2)):
        assembly = model.assemble({"mu1": mu1, "mu2": mu2})
        ops = LatinOperators(assembly, options)
        tight = solve_latin(assembly, LatinOptions(tol=1e-10), operators=ops)
        assert tight.interface is not None
        w, f = tight.interface.displacement_hat, tight.interface.force_hat
        firsts.clear()
        cold = solve_latin(assembly, options, operators=ops)
        counts = []
        for t in range(1, w.shape[0]):
            w0, f0 = w.copy(), f.copy()
            w0[t:], f0[t:] = w[t - 1], f[t - 1]
            firsts.clear()
            solve_latin(assembly, options, operators=ops, initial=(w0, f0), check=False)
            counts.append(next((i + 1 for i, first in enumerate(firsts) if first > t), None))
        print(f"b1 ({mu1}, {mu2}): cold {cold.iterations} iterations; step t from step t − 1's "
              f"answer settles after (None: not before the case stops) {counts}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rows", nargs="+", default=[*STUDIES, "cold"],
                        choices=[*STUDIES, "cold"])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--factor", type=float, default=LatinOptions().settled_steps)
    parser.add_argument("--potential", action="store_true")
    parser.add_argument("--alone", action="store_true")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    if args.potential or args.alone:
        potential() if args.potential else alone()
        return
    _count_rows()
    ml.run_study(ml.load_model("b1"), ml.Grid.parse(["mu1=0.1", "mu2=0.1:0.15:2"]),
                 progress=False)  # kernels
    print(f"| row | settled_steps | wall (s), median of {args.rounds} | iterations "
          "| rows run | largest R_stop change (N) |")
    print("|---|---|---|---|---|---|")
    for row in args.rows:
        runs: dict[float, list[tuple[float, int, dict[Any, float]]]] = {}
        shares: dict[float, float] = {}
        for _ in range(args.rounds):
            for factor in (0.0, args.factor):
                ROWS[:] = [0, 0]
                runs.setdefault(factor, []).append(
                    study(row, factor) if row in STUDIES else cold(factor))
                shares[factor] = ROWS[0] / max(ROWS[1], 1)
        base = runs[0.0][0][2]
        for factor, results in runs.items():
            change = max(abs(results[0][2][k] - base[k]) for k in base)
            print(f"| {row} | {factor:g} | {statistics.median(r[0] for r in results):.2f} | "
                  f"{results[0][1]} | {shares[factor]:.3f} | {change:.2e} |", flush=True)


if __name__ == "__main__":
    main()
