"""Multiresolution on the torch backend, side by side in one run: every case from zero, the
grid lines' wavefront (``StudyPlan.wavefront``: the k-th friction line of every geometry
together, each case from its geometry's line k − 1) and the geometry waves
(``StudyPlan.geometry_waves``, the default since session 39: the middle geometry from
zero, then each geometry from the same frictions one hole step away).

    python benchmarks/geometry_waves.py [--device cpu] [--grid mu1=0:0.6:4 mu2=0:0.6:4 \\
        xc=24:26:3 yc=74:76:3 rc=3]

Per start: the wall time, the batches, the iterations (in all, per case, the largest), and
R_stop's largest relative difference from the study from zero (each within the studies'
QoI tolerance of the tight answer). Iterations are the device's too; wall times on a
shared CPU are noisy and on PyTorch's CPU build say little about a GPU (docs/gpu.md).
"""

from __future__ import annotations

import argparse
import contextlib
import tempfile
import time
from unittest import mock

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOptions
from multilatin.study.plan import StudyPlan, clear_operator_cache

GRID = ["mu1=0:0.6:4", "mu2=0:0.6:4", "xc=24:26:3", "yc=74:76:3", "rc=3"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--grid", nargs="+", default=GRID)
    args = parser.parse_args()
    model = ml.load_model("b3")
    grid = ml.Grid.parse(args.grid)
    options = LatinOptions(qoi_rtol=1e-3, backend="torch", device=args.device)
    print(f"B3, {grid.size} cases ({' '.join(args.grid)}), torch on {args.device}\n")
    print("| start | wall (s) | batches | iterations | a case | largest | R_stop vs zero |")
    print("|---|---|---|---|---|---|---|")
    reference = None
    for label, start, lines in (("zero", "zero", False), ("lines' wavefront", "neighbour", True),
                                ("geometry waves", "neighbour", False)):
        clear_operator_cache()
        order = (mock.patch.object(StudyPlan, "geometry_waves", lambda self, chain: [])
                 if lines else contextlib.nullcontext())  # no waves: the lines' wavefront
        with tempfile.TemporaryDirectory() as folder, order:
            t0 = time.perf_counter()
            result = ml.run_study(model, grid, options=options, out=folder, progress=False,
                                  start=start, batch=100_000)
            wall = time.perf_counter() - t0
        iterations = np.array([r["iterations"] for r in result.records])
        values = np.asarray(result.dataset["R_stop"].values, dtype=float).ravel()
        batches = len({r["elapsed_s"] for r in result.records})
        if reference is None:
            reference, versus = values, "—"
        else:
            kept = np.abs(reference) > 1e-9
            versus = f"{np.max(np.abs(values - reference)[kept] / np.abs(reference[kept])):.1e}"
        print(f"| {label} | {wall:.1f} | {batches} | {iterations.sum()} | "
              f"{iterations.mean():.1f} | {iterations.max()} | {versus} |", flush=True)


if __name__ == "__main__":
    main()
