"""The torch backend against the NumPy path, side by side in one run (issue 19).

    python benchmarks/gpu.py --device cuda            # on a GPU machine
    python benchmarks/gpu.py --device cpu             # the same code on PyTorch's CPU build
    python benchmarks/gpu.py --device cuda --full     # + the B3 21 125-case study

For each workload: the NumPy path (with Numba; a single solve in this process, studies
with ``--cpu-workers`` Dask processes, 2 by default as on the project's 2-core machines)
and the torch backend on ``--device`` (its studies in this process), with the study
defaults (QoI stopping at 1e-3):

- one b3 solve at (μ1, μ2) = (0.35, 0.25);
- the B1 13 × 13 friction study: torch with multiresolution (``--start neighbour``, a grid
  line per batch) and with every case from zero in one batch (``--start zero``);
- the B3 5 × 5 hole positions (25 geometries, one case each);
- with ``--full``, the B3 21 125-case study on torch from zero, a geometry per batch (the
  NumPy figure is docs/performance.md's 2-worker run; running it here takes about 28 min).

Prints wall time, cases/s, iterations, the peak device memory (CUDA's allocator; on the CPU
the process's peak RSS) and the largest relative R_stop difference from the NumPy path.
"""

from __future__ import annotations

import argparse
import resource
import tempfile
import time
from dataclasses import replace
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOptions, solve_latin
from multilatin.latin.options import STUDY_QOI_RTOL
from multilatin.study.plan import clear_operator_cache

B1_GRID = ["mu1=0:0.6:13", "mu2=0:0.6:13"]
B3_POSITIONS = ["xc=23:27:5", "yc=73:77:5", "rc=3"]
B3_FULL = ["mu1=0:0.6:13", "mu2=0:0.6:13", "xc=23:27:5", "yc=73:77:5", "rc=1:5:5"]


def peak_memory(torch: Any, device: str) -> str:
    if device.startswith("cuda"):
        return f"{torch.cuda.max_memory_allocated() / 2**20:.0f} MiB (device)"
    return f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB (RSS)"


def study(model: ml.Model, grid: list[str], options: LatinOptions, **kwargs: Any
          ) -> tuple[float, np.ndarray, int]:
    """Wall time, R_stop over the grid and iterations in all, of a multiresolution study."""
    clear_operator_cache()
    with tempfile.TemporaryDirectory() as folder:
        t0 = time.perf_counter()
        result = ml.run_study(model, ml.Grid.parse(grid), options=options, out=folder,
                              progress=False, **kwargs)
        wall = time.perf_counter() - t0
    iterations = sum(r["iterations"] for r in result.records)
    return wall, np.asarray(result.dataset["R_stop"].values, dtype=float), iterations


def row(name: str, path: str, wall: float, cases: int, iterations: int, memory: str,
        difference: float | None) -> None:
    diff = "—" if difference is None else f"{difference:.1e}"
    print(f"| {name} | {path} | {wall:.2f} | {cases / wall:.1f} | {iterations} | {memory} "
          f"| {diff} |", flush=True)


def relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b) / np.maximum(np.abs(a), 1e-12)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default="cuda")
    parser.add_argument("--cpu-workers", type=int, default=2)
    parser.add_argument("--threads", type=int, default=2,
                        help="PyTorch's CPU threads (with --device cpu)")
    parser.add_argument("--full", action="store_true", help="also the 21 125-case study")
    parser.add_argument("--skip-numpy", action="store_true",
                        help="the torch rows only (e.g. a second GPU run)")
    args = parser.parse_args()
    import torch

    torch.set_num_threads(args.threads)
    name = (torch.cuda.get_device_name(args.device) if args.device.startswith("cuda")
            else f"CPU, {args.threads} PyTorch threads")
    print(f"torch {torch.__version__} on {args.device} ({name}); NumPy path: one process for "
          f"a solve, {args.cpu_workers} Dask workers for studies\n")
    print("| workload | path | wall (s) | cases/s | iterations | peak memory | "
          "R_stop vs NumPy |")
    print("|---|---|---|---|---|---|---|")
    numpy_options = LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    device_options = replace(numpy_options, backend="torch", device=args.device)
    b1, b3 = ml.load_model("b1"), ml.load_model("b3")

    # one b3 solve (operators built in both; a first short solve warms the kernels up)
    assembly = b3.assemble({"mu1": 0.35, "mu2": 0.25})
    reference = None
    for label, options in (("NumPy", numpy_options), (args.device, device_options)):
        if label == "NumPy" and args.skip_numpy:
            continue
        solve_latin(assembly, replace(options, max_iter=3), check=False)
        t0 = time.perf_counter()
        result = solve_latin(assembly, options)
        wall = time.perf_counter() - t0
        value = np.array([result.qoi["R_stop"]])
        reference = value if reference is None else reference
        row("b3 solve", label, wall, 1, result.iterations,
            peak_memory(torch, args.device) if label != "NumPy" else "—",
            None if label == "NumPy" else relative(reference, value))

    runs: list[tuple[str, ml.Model, list[str], list[tuple[str, dict[str, Any]]]]] = [
        ("B1 13 × 13", b1, B1_GRID,
         [("neighbour, batch 13", {"batch": 13}),
          ("zero, batch 169", {"batch": 169, "start": "zero"})]),
        ("B3 5 × 5 positions", b3, B3_POSITIONS, [("neighbour", {"batch": 16})]),
    ]
    for workload, model, grid, variants in runs:
        cases = int(np.prod([len(v) for v in ml.Grid.parse(grid).values()]))
        reference = None
        if not args.skip_numpy:
            wall, values, iterations = study(model, grid, numpy_options,
                                             workers=args.cpu_workers)
            reference = values
            row(workload, f"NumPy, {args.cpu_workers} workers", wall, cases, iterations, "—",
                None)
        for label, kwargs in variants:
            if args.device.startswith("cuda"):
                torch.cuda.reset_peak_memory_stats()
            wall, values, iterations = study(model, grid, device_options, **kwargs)
            row(workload, f"{args.device}, {label}", wall, cases, iterations,
                peak_memory(torch, args.device),
                None if reference is None else relative(reference, values))

    if args.full:
        if args.device.startswith("cuda"):
            torch.cuda.reset_peak_memory_stats()
        wall, values, iterations = study(b3, B3_FULL, device_options, batch=169,
                                         start="zero")
        row("B3 21 125 cases", f"{args.device}, zero, batch 169", wall, values.size,
            iterations, peak_memory(torch, args.device), None)


if __name__ == "__main__":
    main()
