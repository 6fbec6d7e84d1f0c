"""Experiment (issue 15, item 1, session 55): the stop points of a cross point run as one.

With B1's stop at gap 0 the centre block's whole right side presses on the stop from step
1, and where a perfect interface between its substructures ends on the stop ((50, 75) in
b1-4; (50, 66.7) and (50, 83.3) in b1-9) two stop points sit at one node. The discrete
problem sees only their sum and the local stage splits it freely (docs/convergence.md,
session 55: b1-9 warm-started from gap 0.01 stalls for 120 iterations while the split
drifts). Here, around the library's NumPy local stage, such a group runs on its weighted
means of W and F; every point takes the group's F̂ and its own Ŵ_i = W_i + (F̂ − F_i) / k_i,
as session 35 does for the contact pairs of a cross point (``cross_points``). Prototype,
NumPy path only (the compiled kernels off). Prints, at gap 0, μ1 = 0.3: the iterations of
a cold solve and of one warm-started from gap 0.01 under the studies' rule, and of an
η < 1e-10 solve, with R_stop's relative errors against it.

    python benchmarks/merged_stops.py [--models b1-4 b1-9] [--plain]
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOperators, LatinOptions, kernels, solve_latin
from multilatin.latin.engine import NumpyFields

LIBRARY_STAGE = NumpyFields.local_stage


def stop_groups(fields: Any) -> list[np.ndarray]:
    """The stop points that share a position, per position (two or more)."""
    points = fields.ops.points
    by_position: dict[tuple[float, ...], list[int]] = {}
    for p in fields.local.stops.tolist():
        by_position.setdefault(tuple(np.round(points.coords[p], 9)), []).append(p)
    return [np.array(g) for g in by_position.values() if len(g) > 1]


def merged_local_stage(fields: Any) -> None:
    """The library's local stage with each stop group on its weighted means."""
    groups = stop_groups(fields)
    w0, f0 = fields.w.copy(), fields.f.copy()
    weights = fields.ops.points.weights
    k = fields.ops.search_direction.reshape(-1, 2)
    fields.w, fields.f = np.array(fields.w), np.array(fields.f)
    for group in groups:
        share = weights[group] / weights[group].sum()
        fields.w[:, :, group] = np.einsum("p,ctpd->ctd", share, w0[:, :, group])[:, :, None]
        fields.f[:, :, group] = np.einsum("p,ctpd->ctd", share, f0[:, :, group])[:, :, None]
    LIBRARY_STAGE(fields)
    fields.w, fields.f = w0, f0
    for group in groups:
        fields.w_hat[:, :, group] = (w0[:, :, group]
                                     + (fields.f_hat[:, :, group] - f0[:, :, group]) / k[group])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--models", nargs="+", default=["b1-4", "b1-9"])
    parser.add_argument("--plain", action="store_true", help="the library's stage alone")
    args = parser.parse_args()
    kernels._compile()
    for name in kernels._KERNELS:  # the NumPy local stage, which the wrapper wraps
        setattr(kernels, name, None)
    if not args.plain:
        NumpyFields.local_stage = merged_local_stage  # type: ignore[method-assign]
    options = LatinOptions(qoi_rtol=1e-3)
    for name in args.models:
        model = ml.load_model(name)
        for mu2 in (0.15, 0.3):
            target = model.assemble({"gap": 0.0, "mu2": mu2})
            operators = LatinOperators(target, options)
            cold = solve_latin(target, options, operators=operators)
            neighbour = model.assemble({"gap": 0.01, "mu2": mu2})
            start = solve_latin(neighbour, options,
                                operators=LatinOperators(neighbour, options)).interface
            assert start is not None
            warm = solve_latin(target, options, operators=operators,
                               initial=(start.displacement_hat, start.force_hat))
            tight = solve_latin(target, LatinOptions(tol=1e-10, max_iter=5000),
                                operators=operators)
            exact = tight.qoi["R_stop"]
            print(f"{name} μ2 = {mu2}: cold {cold.iterations} "
                  f"({abs(cold.qoi['R_stop'] - exact) / exact:.1e}), warm from gap 0.01 "
                  f"{warm.iterations} ({abs(warm.qoi['R_stop'] - exact) / exact:.1e}), "
                  f"η < 1e-10 {tight.iterations}, R_stop {exact:.6f} N", flush=True)


if __name__ == "__main__":
    main()
