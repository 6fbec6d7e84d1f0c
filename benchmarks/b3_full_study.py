"""B3 with all five parameters: 13 × 13 × 5 × 5 × 5 = 21 125 computations (paper §7.3, gain 5.2).

    python benchmarks/b3_full_study.py --out b3-full --workers 2 [--sample 60] [--seed 0]
        [--eta-only]

Both the study and the cold sample stop each case as ``run_study`` does by default (its
QoIs' estimated errors below ``STUDY_QOI_RTOL``, or η < tol before), the same rule for both
modes; ``--eta-only`` stops on η < tol alone (``LatinOptions()``, the rule before issue 16).

1. Runs the multiresolution study over μ1, μ2 ∈ {0, …, 0.6}, xc ∈ {23, …, 27},
   yc ∈ {73, …, 77}, rc ∈ {1, …, 5} with ``--workers`` processes (one chain each), or resumes
   it from ``--out`` (the study's own wall time is what its journal records: a resumed study
   adds the times of its runs).
2. Solves a seeded random sample of the same cases cold, one at a time in this process (own
   operators, from zero: the study's cold mode), and estimates the time of every case cold
   as 21 125 × the sample's mean, with a 95 % interval. Running all 21 125 cold would take
   about two hours.
3. Prints the wall time, the gain (Σ cold / the study's wall time; also at equal cores, Σ cold
   / workers, since the cold cases could run on the same workers), iterations, peak memory
   per process, and checks the study's R_stop against the cold solves of the sample.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOptions
from multilatin.latin.options import STUDY_QOI_RTOL
from multilatin.parameters import Grid
from multilatin.study.plan import plan_study, run_case
from multilatin.study.runner import run_study

GRID = ["mu1=0:0.6:13", "mu2=0:0.6:13", "xc=23:27:5", "yc=73:77:5", "rc=1:5:5"]
PAPER_GAIN = 5.2
TARGET_WALL_S = 5 * 60  # issue 16, on 2 cores
TARGET_GAIN = 10


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="the study's folder (resumed if present)")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--sample", type=int, default=60, help="cold cases to time")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--existing", action="store_true",
                        help="read the finished study in --out (its journal) instead of "
                             "running or resuming it; only the cold sample is computed")
    parser.add_argument("--eta-only", action="store_true",
                        help="stop on η < tol alone (no QoI stopping), study and sample")
    args = parser.parse_args()

    model = ml.load_model("b3")
    grid = Grid.parse(GRID)
    options = LatinOptions() if args.eta_only else LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    if args.existing:
        journal = Path(args.out) / "cases.jsonl"
        records = [r for r in map(json.loads, journal.read_text().splitlines())
                   if r["mode"] == "multiresolution"]
        wall = max(r["elapsed_s"] for r in records)
    else:
        result = run_study(model, grid, options=options, out=args.out, workers=args.workers,
                           progress=True, command="benchmarks/b3_full_study.py")
        records = result.mode_records("multiresolution")
        wall = result.elapsed_s["multiresolution"]

    plan = plan_study(model, grid, options)
    rng = np.random.default_rng(args.seed)
    chosen = rng.choice(len(plan.cases), size=min(args.sample, len(plan.cases)),
                        replace=False)
    by_number = {r["number"]: r for r in records}
    cold_times, cold_iterations, deviations = [], [], []
    for number in sorted(chosen):
        case = plan.cases[number]
        t0 = time.perf_counter()
        record, _ = run_case(model, grid, case, "cold", options, None)
        cold_times.append(time.perf_counter() - t0)
        cold_iterations.append(record["iterations"])
        warm = by_number[case.number]["qoi"]["R_stop"]
        cold = record["qoi"]["R_stop"]
        deviations.append(abs(warm - cold) / max(abs(cold), 200.0))

    n = len(records)
    mean = float(np.mean(cold_times))
    half_width = 1.96 * float(np.std(cold_times, ddof=1)) / math.sqrt(len(cold_times))
    total_cold = n * mean
    low, high = n * (mean - half_width), n * (mean + half_width)
    iterations = [r["iterations"] for r in records]
    peak = max(r.get("peak_rss_mb", float("nan")) for r in records)
    converged = sum(bool(r["converged"]) for r in records)
    print(f"\nB3, five parameters: {n} cases, {args.workers} worker(s)\n")
    print("| quantity | value | target / paper |")
    print("|---|---|---|")
    print(f"| multiresolution wall time | {wall:.0f} s ({wall / 60:.1f} min) | "
          f"≤ {TARGET_WALL_S / 60:.0f} min |")
    print(f"| Σ cold, estimated from {len(cold_times)} random cases | {total_cold:.0f} s "
          f"(95 %: {low:.0f}–{high:.0f} s) | |")
    print(f"| gain = Σ cold / wall | {total_cold / wall:.1f} ({low / wall:.1f}–"
          f"{high / wall:.1f}) | ≥ {TARGET_GAIN} (paper {PAPER_GAIN}) |")
    workers = max(args.workers, 1)
    print(f"| gain at equal cores = Σ cold / {workers} / wall | "
          f"{total_cold / workers / wall:.1f} | |")
    print(f"| iterations per case, multiresolution / cold sample | "
          f"{np.mean(iterations):.0f} / {np.mean(cold_iterations):.0f} | |")
    print(f"| time per case, multiresolution (wall / cases) / cold | "
          f"{1e3 * wall / n:.0f} ms / {1e3 * mean:.0f} ms | |")
    print(f"| peak memory per process | {peak:.0f} MiB | |")
    print(f"| converged | {converged} of {n} | all |")
    print(f"| R_stop, study vs cold on the sample (max, relative or / 200 N) | "
          f"{max(deviations):.1e} | |")


if __name__ == "__main__":
    main()
