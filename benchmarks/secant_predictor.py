"""Experiment (issue 16, predictors): start a warm case from the secant extrapolation of its
two nearest converged neighbours along a grid line, ŝ = ŝ1 + t (ŝ1 − ŝ2) with t from the
parameter values, instead of from the nearest one (paper §6).

    python benchmarks/secant_predictor.py

1. The B1 μ2 line (μ1 = 0.3), case after case: iterations per case with the nearest
   neighbour, the secant, and the secant put on Γ by a local stage; η < 3e-6 and the
   studies' QoI stopping.
2. The B1 13 × 13 study (``run_study``, its default options, line batches: each grid line
   from the previous one), with ``starts.case_start`` replaced by the secant where a
   second neighbour two steps away along the same axis is retained.
Measured (docs/convergence.md): better on the μ2 line with QoI stopping, worse with η alone
and on the 13 × 13 study; not adopted.
"""

from __future__ import annotations

import tempfile
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.decomposition.interfaces import with_contact_data
from multilatin.latin import LatinOperators, LatinOptions, solve_latin
from multilatin.latin.local_stage import LocalStage
from multilatin.latin.options import STUDY_QOI_RTOL
from multilatin.study import plan, starts

Fields = tuple[np.ndarray, np.ndarray]


def line(mu1: float = 0.3) -> None:
    model = ml.load_model("b1")
    values = np.round(np.linspace(0.0, 0.6, 13), 2)
    print("| stopping | start | iterations per case (μ2 = 0 … 0.6) | total |")
    print("|---|---|---|---|")
    for qoi_rtol in (None, STUDY_QOI_RTOL):
        options = LatinOptions(qoi_rtol=qoi_rtol)
        ops = LatinOperators(model.assemble({"mu1": mu1, "mu2": 0.0}), options)
        for start_from in ("nearest", "secant", "secant + local stage"):
            done: list[Fields] = []
            iterations = []
            for mu2 in values:
                assembly = model.assemble({"mu1": mu1, "mu2": float(mu2)})
                start: Fields | None = done[-1] if done else None
                if len(done) >= 2 and start_from != "nearest":
                    start = (2 * done[-1][0] - done[-2][0], 2 * done[-1][1] - done[-2][1])
                    if start_from.endswith("local stage"):
                        points = with_contact_data(ops.points, assembly)
                        local = LocalStage([assembly], [points], ops.search_direction,
                                           macro_only=ops.macro_only)
                        w_hat, f_hat = local(start[0][None], start[1][None])
                        start = (w_hat[0], f_hat[0])
                result = solve_latin(assembly, options, operators=ops, initial=start)
                assert result.interface is not None
                done.append((result.interface.displacement_hat, result.interface.force_hat))
                iterations.append(result.iterations)
            label = "η < 3e-6" if qoi_rtol is None else f"qoi_rtol {qoi_rtol:g}"
            print(f"| {label} | {start_from} | {', '.join(map(str, iterations))} | "
                  f"{sum(iterations)} |", flush=True)


def study() -> None:
    model = ml.load_model("b1")
    grid = ml.Grid.parse(["mu1=0:0.6:13", "mu2=0:0.6:13"])
    values = [np.asarray(grid[name], dtype=float) for name in grid]
    nearest = starts.case_start

    def secant(grid_: ml.Grid, state: plan.ChainState, case: plan.Case, assembly: Any,
               ops: LatinOperators, limit: bool = True) -> starts.Start:
        index, initial, extra = nearest(grid_, state, case, assembly, ops, limit)
        if index is None or initial is None or extra:
            return index, initial, extra
        step = [a - b for a, b in zip(case.index, index, strict=True)]
        if sum(abs(s) for s in step) != 1:
            return index, initial, extra
        axis = next(i for i, s in enumerate(step) if s)
        second = tuple(b - s for b, s in zip(index, step, strict=True))
        if second not in state.retained:
            return index, initial, extra
        other = state.retained[second]
        v = values[axis]
        t = (v[case.index[axis]] - v[index[axis]]) / (v[index[axis]] - v[second[axis]])
        return index, (initial[0] + t * (initial[0] - other[0]),
                       initial[1] + t * (initial[1] - other[1])), (second,)

    print("\n| B1 13 x 13 study, multiresolution (line batches) | iterations | max per case "
          "| R_stop change against the nearest-neighbour start |")
    print("|---|---|---|---|")
    reference = None
    for label, start in (("nearest neighbour", nearest), ("secant", secant)):
        starts.case_start = start  # type: ignore[assignment]
        try:
            with tempfile.TemporaryDirectory() as folder:
                # line batches: the rolling batch fixes its starts before the chain runs
                result = ml.run_study(model, grid, modes=("multiresolution",), out=folder,
                                      progress=False, rolling=False)
        finally:
            starts.case_start = nearest
        data = result.dataset.sel(mode="multiresolution")
        iterations = data["iterations"].values
        r_stop = data["R_stop"].values
        reference = r_stop if reference is None else reference
        change = np.nanmax(np.abs(r_stop - reference) / np.maximum(np.abs(reference), 1.0))
        print(f"| {label} | {int(iterations.sum())} | {int(iterations.max())} | "
              f"{100 * change:.3f} % |", flush=True)


if __name__ == "__main__":
    line()
    study()
