"""The torch backend against the NumPy path, side by side in one run (issue 19).

    python benchmarks/gpu.py --device cuda            # on a GPU machine
    python benchmarks/gpu.py --device cpu             # the same code on PyTorch's CPU build
    python benchmarks/gpu.py --device cuda --full     # + the B3 21 125-case study

Every study runs with the study defaults (QoI stopping at 1e-3). Rows:

- one b3 solve at (μ1, μ2) = (0.35, 0.25), NumPy and torch (operators built beforehand);
- B1 13 × 13 frictions, B3 5 × 5 hole positions and B3 3 positions × 4 × 4 frictions,
  each as
  - the project's CPU path: NumPy, multiresolution from the nearest neighbour,
    ``--cpu-workers`` Dask processes (2: the project's 2-core machines);
  - NumPy in this process and torch on ``--device`` with the same strategy — from the
    neighbour a grid line per batch (B1), and from zero in one wide batch (``--start
    zero``: all 169 frictions of B1; all 25 geometries of B3 on torch, which batches
    geometries, one per batch on NumPy) — so that "vs NumPy" compares equal computations
    (on the mixed B3 grid, torch's multiresolution is a wavefront across geometries and
    NumPy's a line per batch: equal strategy, other batches);
- with ``--full``, the B3 21 125-case study on torch with the study's default start
  (``study.defaults``: geometry waves on several processes, from zero on one), or
  ``--full-start zero,neighbour``: from zero
  in batches of ``--full-batch`` cases (25 geometries × 169 frictions by default), then in
  geometry waves (a wave one batch, chunked by the device's memory); the NumPy
  figure is docs/performance.md's 2-worker run (28 min; running it here would take as long).
  With ``--full-workers 0,4``: in this process, then on a local Dask cluster of 4 processes
  sharing the GPU (each with its share of its memory, its batches as many and 4 × narrower:
  their host work — assembly, set-up, free motions, records — side by side on 4 cores while
  the GPU serves them in turn; each batch a task handed to the next free process, or with
  ``4:chains`` each process a chain of batches), the R_stop difference from the first such
  run, the device's peak memory over all processes (``torch.cuda.mem_get_info`` sampled
  every 0.1 s), and when the batches came back.

Columns: wall time, cases/s, iterations in all, the peak memory (CUDA's allocator on a GPU;
the process's peak RSS on the CPU), the largest relative R_stop difference from NumPy with
the same strategy, and the largest relative R_stop error against tight solves (η < 1e-9).
"""

from __future__ import annotations

import argparse
import contextlib
import math
import resource
import tempfile
import threading
import time
from dataclasses import replace
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOptions, solve_latin, solve_latin_batch
from multilatin.latin.options import STUDY_QOI_RTOL
from multilatin.study.defaults import count_geometries, study_defaults
from multilatin.study.plan import clear_operator_cache, plan_study

B1_GRID = ["mu1=0:0.6:13", "mu2=0:0.6:13"]
B3_POSITIONS = ["xc=23:27:5", "yc=73:77:5", "rc=3"]
B3_MIXED = ["xc=23:27:3", "mu1=0:0.6:4", "mu2=0:0.6:4"]
B3_FULL = ["mu1=0:0.6:13", "mu2=0:0.6:13", "xc=23:27:5", "yc=73:77:5", "rc=1:5:5"]
TIGHT = LatinOptions(tol=1e-9, max_iter=5000)
#: the --full study's starts: row label and run_study's arguments
FULL_STARTS = {"zero": ("zero", {"start": "zero"}),
               "neighbour": ("neighbour (geometry waves)", {"start": "neighbour"}),
               "default": ("the study's default start", {})}


def peak_memory(torch: Any, device: str) -> str:
    if device.startswith("cuda"):
        return f"{torch.cuda.max_memory_allocated() / 2**20:.0f} MiB (device)"
    return f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB (RSS)"


class DevicePeak:
    """The device's peak used memory over all its processes (CUDA contexts included),
    sampled every 0.1 s while the ``with`` block runs."""

    def __init__(self, torch: Any, device: str) -> None:
        self.torch, self.device, self.peak = torch, device, 0
        self._stop = threading.Event()

    def _sample(self) -> None:
        while not self._stop.wait(0.1):
            free, total = self.torch.cuda.mem_get_info(self.torch.device(self.device))
            self.peak = max(self.peak, total - free)

    def __enter__(self) -> DevicePeak:
        self._thread = threading.Thread(target=self._sample, daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()

    def text(self) -> str:
        return f"{self.peak / 2**30:.1f} GiB (device, all processes)"


def study(model: ml.Model, grid: list[str], options: LatinOptions, **kwargs: Any
          ) -> tuple[float, np.ndarray, int, str]:
    """Wall time, R_stop over the grid (grid order), iterations in all, and where the time
    went from the records: the cases' set-up (assembly, operators, starts), their solves
    (the iterations, results, re-solves), the rest (records, store, the kernels' first
    load)."""
    clear_operator_cache()
    with tempfile.TemporaryDirectory() as folder:
        t0 = time.perf_counter()
        result = ml.run_study(model, ml.Grid.parse(grid), options=options, out=folder,
                              progress=False, **kwargs)
        wall = time.perf_counter() - t0
    iterations = sum(r["iterations"] for r in result.records)
    setup = sum(r["setup_s"] for r in result.records)
    cases = sum(r["wall_s"] for r in result.records)
    split = (f"  where the {wall:.1f} s went: set-up (assembly, operators, starts) "
             f"{setup:.1f} s, solves {cases - setup:.1f} s, records, store and the rest "
             f"{wall - cases:.1f} s")
    workers = kwargs.get("workers", 0)
    if workers:  # the processes' time side by side, and when their batches came back
        done = sorted({r["elapsed_s"] for r in result.records})
        split = (f"  the {workers} processes' time in their batches: set-up {setup:.1f} s, "
                 f"solves {cases - setup:.1f} s ({cases / workers:.1f} s each on average); "
                 f"{len(done)} batches came back from {done[0]:.1f} s to {done[-1]:.1f} s "
                 f"after the start (wall {wall:.1f} s)")
    return wall, np.asarray(result.dataset["R_stop"].values, dtype=float), iterations, split


def tight_values(model: ml.Model, grid: list[str]) -> np.ndarray:
    """R_stop of every case at η < 1e-9 (NumPy, one batch per geometry), in grid order."""
    parsed = ml.Grid.parse(grid)
    cases = plan_study(model, parsed).cases
    results = solve_latin_batch([model.assemble(case.mu) for case in cases], TIGHT)
    out = np.zeros([len(v) for v in parsed.values()])
    for case, result in zip(cases, results, strict=True):
        out[case.index] = result.qoi["R_stop"]
    return out


def relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a - b) / np.maximum(np.abs(a), 1e-12)))


def against_reference(path: str, values: np.ndarray) -> str:
    """R_stop of the --full study against a study.nc of the same grid from the CPU path
    (NumPy; any starts): the largest relative difference over the cases whose answer is
    unique, and apart over those at the friction limit (not unique: either answer holds)."""
    import xarray as xr

    with xr.open_dataset(path) as reference:
        expected = np.asarray(reference["R_stop"].values, dtype=float).reshape(-1)
        unique = np.asarray(reference["unique"].values, dtype=bool).reshape(-1)
        converged = np.asarray(reference["converged"].values, dtype=bool).reshape(-1)
    got = values.reshape(-1)
    if got.size != expected.size:
        return f"  {path}: {expected.size} cases, not this study's {got.size}"
    difference = np.abs(got - expected) / np.maximum(np.abs(expected), 1e-12)
    kept = unique & converged & np.isfinite(got)
    limit = ~unique & converged & np.isfinite(got)
    return (f"  R_stop against the CPU path ({path}): over the {kept.sum()} unique cases the "
            f"largest relative difference {difference[kept].max():.1e} (99.9 % of them "
            f"≤ {np.quantile(difference[kept], 0.999):.1e}, {np.sum(difference[kept] > 2e-3)} "
            f"above 2e-3, twice the QoI tolerance); {limit.sum()} cases at the friction "
            f"limit (either answer holds) up to {difference[limit].max(initial=0):.1e}; "
            f"{np.sum(~np.isfinite(got))} without an answer here")


def row(workload: str, path: str, wall: float, cases: int, iterations: int, memory: str,
        same: float | None, tight: np.ndarray | None, values: np.ndarray | None) -> None:
    def text(x: float | None) -> str:
        return "—" if x is None else f"{x:.1e}"
    error = None if tight is None or values is None else relative(tight, values)
    print(f"| {workload} | {path} | {wall:.2f} | {cases / wall:.1f} | {iterations} | "
          f"{memory} | {text(same)} | {text(error)} |", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default="cuda")
    parser.add_argument("--cpu-workers", type=int, default=2)
    parser.add_argument("--threads", type=int, default=2,
                        help="PyTorch's CPU threads (with --device cpu)")
    parser.add_argument("--full", action="store_true", help="also the 21 125-case study")
    parser.add_argument("--full-batch", type=int, default=4225)
    parser.add_argument("--full-rc", default="1:5:5",
                        help="the hole radii of the --full study (e.g. 3: one fifth of it, "
                             "4 225 cases)")
    parser.add_argument("--full-start", default="default",
                        help="the --full study's starts, in this order: zero, neighbour "
                             "(geometry waves) and/or default (the study's choice, "
                             "study.defaults: geometry waves on several processes, from "
                             "zero on one)")
    parser.add_argument("--full-workers", default="0",
                        help="the --full study's processes, in this order (0: this one; W: "
                             "a local Dask cluster of W, batches W × narrower, each batch "
                             "a task; W:chains: each process a chain of batches)")
    parser.add_argument("--full-reference",
                        help="a study.nc of the --full grid from the CPU path (e.g. "
                             "benchmarks/b3_full_study.py's), for R_stop side by side")
    parser.add_argument("--fuse", action="store_true",
                        help="torch rows with the compiled local stage (LatinOptions.fuse); "
                             "its compilation happens in the warm-up solves, not the rows")
    parser.add_argument("--only", help="the study workloads whose name starts so "
                                           "(e.g. 'B3 3', or 'B1,B3 5'); the b3 solve "
                                           "always runs")
    parser.add_argument("--no-tight", action="store_true",
                        help="skip the tight reference solves (the last column)")
    parser.add_argument("--torch-only", action="store_true",
                        help="the study rows on torch alone (no NumPy rows beside them)")
    parser.add_argument("--compact-below", type=float,
                        help="this process's batches compact at this fraction of active rows "
                             "(torch_engine.COMPACT_BELOW, default 0.5; fewer CUDA graph "
                             "captures for more idle rows); the --full study's Dask "
                             "processes keep the default")
    args = parser.parse_args()
    if not set(args.full_start.split(",")) <= set(FULL_STARTS):
        parser.error(f"--full-start: expected zero, neighbour and/or default, got "
                     f"{args.full_start!r}")
    import torch

    from multilatin.latin import torch_engine

    if args.compact_below is not None:
        if not 0.0 < args.compact_below <= 1.0:
            parser.error(f"--compact-below: expected a fraction in (0, 1], got "
                         f"{args.compact_below}")
        torch_engine.COMPACT_BELOW = args.compact_below
    torch.set_num_threads(args.threads)
    name = (torch.cuda.get_device_name(args.device) if args.device.startswith("cuda")
            else f"CPU, {args.threads} PyTorch threads")
    print(f"torch {torch.__version__} on {args.device} ({name})"
          f"{', fused local stage' if args.fuse else ''}, batches compact at "
          f"{torch_engine.COMPACT_BELOW:g} of their rows active\n")
    print("| workload | path | wall (s) | cases/s | iterations | peak memory | "
          "R_stop vs NumPy, same strategy | R_stop vs tight |")
    print("|---|---|---|---|---|---|---|---|")
    numpy_options = LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    device_options = replace(numpy_options, backend="torch", device=args.device,
                             fuse=args.fuse)
    b1, b3 = ml.load_model("b1"), ml.load_model("b3")
    if args.fuse:  # compile for both models and for batches of one and of several cases
        for model in (b1, b3):
            t0 = time.perf_counter()
            for count in (1, 2):
                solve_latin_batch([model.assemble()] * count, replace(device_options,
                                                                      max_iter=3),
                                  check=False)
            print(f"compiled the fused local stage for {model.name} in "
                  f"{time.perf_counter() - t0:.0f} s\n")

    assembly = b3.assemble({"mu1": 0.35, "mu2": 0.25})
    ops = ml.LatinOperators(assembly, numpy_options)
    reference = None
    for label, options in (("NumPy", numpy_options), (f"torch {args.device}", device_options)):
        solve_latin(assembly, replace(options, max_iter=3), operators=ops, check=False)
        if args.device.startswith("cuda"):
            torch.cuda.synchronize()
        t0 = time.perf_counter()
        result = solve_latin(assembly, options, operators=ops)
        wall = time.perf_counter() - t0
        value = np.array([result.qoi["R_stop"]])
        same = None if reference is None else relative(reference, value)
        reference = value if reference is None else reference
        row("b3 solve", label, wall, 1, result.iterations,
            peak_memory(torch, args.device) if "torch" in label else "—", same, None, None)

    # the starts named: on a CUDA device a study starts from zero unless told
    runs = [("B1 13 × 13", b1, B1_GRID, [("neighbour, batch 13", {"batch": 13,
                                                                   "start": "neighbour"}),
                                          ("zero, batch 169", {"batch": 169,
                                                               "start": "zero"})]),
            ("B3 5 × 5 positions", b3, B3_POSITIONS, [("zero, batch 25", {"batch": 25,
                                                                           "start": "zero"})]),
            ("B3 3 positions × 4 × 4", b3, B3_MIXED,
             [("neighbour (torch: wavefront), batch 1000", {"batch": 1000,
                                                             "start": "neighbour"}),
              ("zero, batch 1000", {"batch": 1000, "start": "zero"})])]
    if args.only:
        runs = [run for run in runs if any(run[0].startswith(prefix)
                                           for prefix in args.only.split(","))]
    for workload, model, grid, variants in runs:
        cases = int(np.prod([len(v) for v in ml.Grid.parse(grid).values()]))
        tight = None if args.no_tight else tight_values(model, grid)
        if not args.torch_only:
            wall, values, iterations, _ = study(model, grid, numpy_options,
                                                workers=args.cpu_workers)
            row(workload, f"NumPy, neighbour, {args.cpu_workers} workers", wall, cases,
                iterations, "—", None, tight, values)
        for label, kwargs in variants:
            numpy_values = None
            if not args.torch_only:
                wall, numpy_values, iterations, _ = study(model, grid, numpy_options, **kwargs)
                row(workload, f"NumPy, {label}", wall, cases, iterations, "—", None, tight,
                    numpy_values)
            if args.device.startswith("cuda"):
                torch.cuda.reset_peak_memory_stats()
            wall, values, iterations, _ = study(model, grid, device_options, **kwargs)
            row(workload, f"torch {args.device}, {label}", wall, cases, iterations,
                peak_memory(torch, args.device),
                None if numpy_values is None else relative(numpy_values, values), tight,
                values)

    if args.full:
        full = [*B3_FULL[:-1], f"rc={args.full_rc}"]
        n_full = int(np.prod([len(v) for v in ml.Grid.parse(full).values()]))
        for label, kwargs in (FULL_STARTS[name] for name in args.full_start.split(",")):
            first = None
            for item in args.full_workers.split(","):
                workers, _, schedule = item.partition(":")
                workers, schedule = int(workers), schedule or "waves"
                batch = args.full_batch
                if workers:  # each process's chain in as many batches as one process's
                    batch = math.ceil(math.ceil(n_full / workers) / math.ceil(n_full / batch))
                on_gpu = args.device.startswith("cuda")
                if on_gpu:
                    torch.cuda.reset_peak_memory_stats()
                sampler = DevicePeak(torch, args.device) if on_gpu else None
                with sampler or contextlib.nullcontext():
                    wall, values, iterations, split = study(
                        b3, full, device_options, batch=batch, workers=workers,
                        schedule=schedule, **kwargs)
                memory = (f"{peak_memory(torch, args.device)}; {sampler.text()}"
                          if sampler is not None and not workers else
                          sampler.text() if sampler is not None else "—")
                where = (f"{workers} Dask processes ({schedule})" if workers else
                         "this process")
                if not kwargs:  # the default: which start it chose
                    label = "default: " + study_defaults(
                        device_options, batch, None, workers, n_full,
                        count_geometries(b3, ml.Grid.parse(full), device_options))[1]
                row(f"B3 {n_full} cases", f"torch {args.device}, {label}, batch {batch}, "
                    f"{where}", wall, values.size, iterations, memory,
                    None if first is None else relative(first, values), None, None)
                first = values if first is None else first
                print(split, flush=True)
                if args.full_reference:
                    print(against_reference(args.full_reference, values), flush=True)

if __name__ == "__main__":
    main()
