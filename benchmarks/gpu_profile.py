"""Where a torch iteration's time goes (issue 19): launch-bound or compute-bound.

    python benchmarks/gpu_profile.py --device cuda
    python benchmarks/gpu_profile.py --device cpu --b3-positions 2     # a quick look here

For each batch — B1's 169 frictions, and B3's hole positions × 169 frictions (25 positions:
4 225 cases, the batch of the 21 125-case study) — all from zero: ``--iterations``
iterations timed (after a warm-up of 3), split into linear stage, macro problem and local
stage (on a GPU, where the whole iteration is one graph, all but the first iteration's
time is the local stage's: ``torch_engine.FUSED_DEVICES``); then the same iterations
under ``torch.profiler``: the kernels (on a GPU) or ATen operations (on the CPU) per
iteration, and the device's busy time per iteration against the wall time (a GPU busy a
small share of the wall is waiting for Python's launches).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOptions, solve_latin_batch


def batch(model: ml.Model, positions: list[tuple[float, float]]) -> tuple[list[Any], list[Any]]:
    """Assemblies and operators: every (μ1, μ2) of the 13 × 13 grid at each position."""
    frictions = [(a, b) for a in np.linspace(0, 0.6, 13) for b in np.linspace(0, 0.6, 13)]
    assemblies, operators = [], []
    for xc, yc in positions:
        geometry = {} if model.name == "b1" else {"xc": xc, "yc": yc, "rc": 3.0}
        ops = ml.LatinOperators(model.assemble(geometry), LatinOptions())
        for mu1, mu2 in frictions:
            assemblies.append(model.assemble({**geometry, "mu1": mu1, "mu2": mu2}))
            operators.append(ops)
    return assemblies, operators


def profile(label: str, assemblies: list[Any], operators: list[Any], options: LatinOptions,
            iterations: int, torch: Any) -> None:
    cuda = options.device.startswith("cuda")
    run = replace(options, max_iter=iterations, tol=1e-30)
    solve_latin_batch(assemblies, replace(run, max_iter=3), operators=operators, check=False)
    if cuda:
        torch.cuda.synchronize()
        torch.cuda.reset_peak_memory_stats()
    t0 = time.perf_counter()
    result = solve_latin_batch(assemblies, run, operators=operators, check=False)[0]
    wall = time.perf_counter() - t0
    t = result.timings
    n = result.iterations
    memory = (f", peak {torch.cuda.max_memory_allocated() / 2**30:.1f} GiB" if cuda else "")
    print(f"{label}: {len(assemblies)} cases, {n} iterations in {t['iterations']:.2f} s "
          f"({1e3 * t['per_iteration']:.1f} ms each: linear {1e3 * t['linear_stage'] / n:.1f}, "
          f"macro {1e3 * t['macro_problem'] / n:.1f}, local {1e3 * t['local_stage'] / n:.1f}); "
          f"set-up + recovery {wall - t['iterations']:.2f} s{memory}", flush=True)

    from torch.profiler import ProfilerActivity
    activities = [ProfilerActivity.CPU] + ([ProfilerActivity.CUDA] if cuda else [])
    with torch.profiler.profile(activities=activities) as prof:
        t0 = time.perf_counter()
        result = solve_latin_batch(assemblies, run, operators=operators, check=False)[0]
        wall = time.perf_counter() - t0
    n = result.iterations
    events = prof.key_averages()
    if cuda:
        kernels = sum(e.count for e in events if e.device_type.name == "CUDA")
        busy = sum(e.self_device_time_total for e in events if e.device_type.name == "CUDA")
        print(f"  profiled: {kernels / n:.0f} kernels per iteration, device busy "
              f"{busy / 1e3 / n:.1f} ms per iteration of {1e3 * result.timings['per_iteration']:.1f} "
              f"(wall with the profiler {wall:.2f} s)", flush=True)
    else:
        ops = sum(e.count for e in events if e.key.startswith("aten::"))
        print(f"  profiled: {ops / n:.0f} ATen operations per iteration "
              f"(wall with the profiler {wall:.2f} s)", flush=True)
    table = events.table(sort_by="self_cuda_time_total" if cuda else "self_cpu_time_total",
                         row_limit=12)
    print(table, flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default="cuda")
    parser.add_argument("--iterations", type=int, default=20)
    parser.add_argument("--b3-positions", type=int, default=25,
                        help="hole positions in the B3 batch (of the 5 × 5 grid)")
    args = parser.parse_args()
    import torch

    options = LatinOptions(backend="torch", device=args.device)
    b1, b3 = ml.load_model("b1"), ml.load_model("b3")
    profile("B1 13 × 13 frictions", *batch(b1, [(0.0, 0.0)]), options, args.iterations, torch)
    grid = [(x, y) for x in np.linspace(23, 27, 5) for y in np.linspace(73, 77, 5)]
    t0 = time.perf_counter()
    assemblies, operators = batch(b3, grid[:args.b3_positions])
    print(f"(B3 batch assembled, operators of {args.b3_positions} positions built, in "
          f"{time.perf_counter() - t0:.1f} s)")
    profile(f"B3 {args.b3_positions} positions × 169 frictions", assemblies, operators,
            options, args.iterations, torch)


if __name__ == "__main__":
    main()
