"""The performance suite (issue 6): where the time goes, and the studies against cold and
against the reference solver, all measured in one run on this machine.

    python benchmarks/suite.py            # everything (about 15 minutes on 2 cores)
    python benchmarks/suite.py --quick    # the solver table and the B1 μ2 line only
    python benchmarks/suite.py --multiresolution-only [--runs 3]   # part 3 alone

1. Solver, for b1, b1-9 and b3 at (μ1, μ2) = (0.3, 0) and (0.1, 0.3): iterations and time of
   a cold solve to the default tolerance (operators + iterations), the time per iteration
   split into local stage, substructure (micro) problems and macro problem, and the
   monolithic reference solver on the same case (b3: on its conforming mesh).
2. Studies, each run cold (every case standalone, from zero) and with multiresolution
   (batched grid lines, warm starts, operators reused) in the same process; the
   multiresolution study case by case (``batch=1``) too; and the reference solver run one
   case at a time on the same grid: B1 μ2 line (μ1 = 0.3), B1 13 x 13, B3 5 x 5 hole
   positions at rc = 3 (paper table 2). ``--quick`` runs the μ2 line only, and times the
   reference on 4 of its cases.
3. Multiresolution at equal accuracy (issue 16), side by side with the paper: the B1 μ2
   line (b1 and b1-4, μ1 = 0.3), B1 13 x 13 and B3's 5 x 5 hole positions, each run
   ``--runs`` times with both modes under the same stopping rule (the studies' default):
   the gain's median and spread, the paper's definition, the iteration ratio, the warm
   cases' iterations after a line's first, and R_stop's worst error in either mode
   against η < 1e-9 solves of every case (|ΔR| / max(|R|, 1 N)), with issue 16's targets.
   (The 21 125-case study: ``benchmarks/b3_full_study.py``.)
Peak memory is the process's resident peak so far (it only grows).
Everything runs after a warm-up (imports, Numba kernels loaded or compiled), whose time is
printed first.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOperators, kernels, solve_latin
from multilatin.parameters import Grid
from multilatin.study.plan import clear_operator_cache
from multilatin.study.records import peak_memory_mb
from multilatin.study.runner import run_study

SOLVER_CASES = [(0.3, 0.0), (0.1, 0.3)]
STUDIES = {
    "B1 μ2 line (b1, μ1 = 0.3)": ("b1", ["mu1=0.3", "mu2=0:0.6:13"]),
    "B1 13 x 13 (b1)": ("b1", ["mu1=0:0.6:13", "mu2=0:0.6:13"]),
    "B3 5 x 5 positions (b3, rc = 3)": ("b3", ["xc=23:27:5", "yc=73:77:5"]),
}


def warm_up() -> float:
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as folder:
        run_study(ml.load_model("b1"), Grid.parse(["mu1=0.3", "mu2=0,0.05"]),
                  modes=("multiresolution", "cold"), out=folder, progress=False)
    ml.load_model("b3").solve()
    return time.perf_counter() - t0


def solver_table() -> None:
    print("\n## Solver: cold solves to the default tolerance, and the reference\n")
    print("| model | μ1, μ2 | iterations | operators (s) | iterations (s) | per iteration (ms) "
          "| local (ms) | micro (ms) | macro (ms) | LATIN solve (s) | reference (s) | "
          "reference / LATIN | R_stop LATIN | R_stop reference |")
    print("|" + "---|" * 14)
    for name in ("b1", "b1-9", "b3"):
        model = ml.load_model(name)
        for mu1, mu2 in SOLVER_CASES:
            assembly = model.assemble({"mu1": mu1, "mu2": mu2})
            t0 = time.perf_counter()
            operators = LatinOperators(assembly, ml.LatinOptions())
            t_operators = time.perf_counter() - t0
            result = solve_latin(assembly, operators=operators)
            t_latin = time.perf_counter() - t0
            t0 = time.perf_counter()
            reference = model.reference({"mu1": mu1, "mu2": mu2})
            t_reference = time.perf_counter() - t0
            timing = result.timings
            n = result.iterations
            micro = timing["linear_stage"] - timing["macro_problem"]
            print(f"| {name} | {mu1:g}, {mu2:g} | {n} | {t_operators:.3f} | "
                  f"{timing['iterations']:.3f} | {1e3 * timing['per_iteration']:.2f} | "
                  f"{1e3 * timing['local_stage'] / n:.3f} | {1e3 * micro / n:.3f} | "
                  f"{1e3 * timing['macro_problem'] / n:.3f} | {t_latin:.3f} | "
                  f"{t_reference:.2f} | {t_reference / t_latin:.1f} | "
                  f"{result.qoi['R_stop']:.2f} | {reference.qoi['R_stop']:.2f} |")
    print(f"\npeak memory so far: {peak_memory_mb():.0f} MiB")


def study_row(title: str, name: str, grid_text: list[str], reference_cases: int | None
              ) -> list[Any]:
    model = ml.load_model(name)
    grid = Grid.parse(grid_text)
    with tempfile.TemporaryDirectory() as folder:
        clear_operator_cache()
        both = run_study(model, grid, modes=("multiresolution", "cold"), out=folder,
                         progress=False)
    with tempfile.TemporaryDirectory() as folder:
        clear_operator_cache()
        one_by_one = run_study(model, grid, out=folder, progress=False, batch=1)
    warm, cold = both.mode_records("multiresolution"), both.mode_records("cold")
    gains = both.gains or {}
    study_s = both.elapsed_s["multiresolution"]
    # the reference, one case at a time on the same grid (or on its first cases)
    cases = [r["params"] for r in warm][:reference_cases]
    t0 = time.perf_counter()
    for params in cases:
        model.reference(params)
    t_reference = (time.perf_counter() - t0) * len(warm) / len(cases)
    estimated = "" if len(cases) == len(warm) else f" (from {len(cases)} cases)"
    converged = all(r["converged"] for r in both.records + one_by_one.records)
    return [title, len(warm), f"{study_s:.2f}",
            f"{one_by_one.elapsed_s['multiresolution']:.2f}",
            f"{sum(r['wall_s'] for r in cold):.2f}", f"{gains['gain']:.2f}",
            f"{gains['paper_gain']:.2f}",
            f"{sum(r['iterations'] for r in warm)} / {sum(r['iterations'] for r in cold)}",
            f"{t_reference:.1f}{estimated}", f"{t_reference / study_s:.1f}",
            f"{peak_memory_mb():.0f}", "yes" if converged else "NO"]


def studies_table(quick: bool) -> None:
    print("\n## Studies: multiresolution against cold and against the reference\n")
    print("| study | cases | multiresolution (s) | case by case, batch = 1 (s) | "
          "Σ cold (s) | gain | paper's definition | iterations multires / cold | "
          "reference one by one (s) | reference / multiresolution | peak memory (MiB) | "
          "converged |")
    print("|" + "---|" * 12)
    for title, (name, grid_text) in STUDIES.items():
        if quick and "line" not in title:
            continue
        row = study_row(title, name, grid_text, 4 if quick else None)
        print("| " + " | ".join(str(cell) for cell in row) + " |", flush=True)


#: issue 16's studies: model, grid, the paper's gain, the target gain
MULTIRESOLUTION = {
    "B1 μ2 line (b1, μ1 = 0.3)": ("b1", ["mu1=0.3", "mu2=0:0.6:13"], 3.56, 5.0),
    "B1-4 μ2 line (b1-4, μ1 = 0.3)": ("b1-4", ["mu1=0.3", "mu2=0:0.6:13"], 3.28, 4.5),
    "B1 13 x 13 (b1)": ("b1", ["mu1=0:0.6:13", "mu2=0:0.6:13"], 4.4, 10.0),
    "B3 5 x 5 positions (b3, rc = 3)": ("b3", ["xc=23:27:5", "yc=73:77:5"], 4.4, 5.0),
}
#: issue 16: a line's warm cases after its first in at most this many iterations (paper 3–12)
WARM_TARGET = 15


def _worst_error(records: list[dict[str, Any]], tight: dict[int, float]) -> float:
    return max(abs(r["qoi"]["R_stop"] - tight[r["number"]]) / max(abs(tight[r["number"]]), 1.0)
               for r in records)


def multiresolution_table(runs: int) -> None:
    print(f"\n## Multiresolution at equal accuracy (issue 16), {runs} run(s) each\n")
    print("| study | cases | gain, median (spread) | paper's definition | iterations multires / "
          "cold (ratio) | warm cases after a line's first: median / max iterations | "
          "R_stop worst error vs tight: multires / cold | paper | target | met |")
    print("|" + "---|" * 10)
    for title, (name, grid_text, paper, target) in MULTIRESOLUTION.items():
        grid = Grid.parse(grid_text)
        results = []
        for _ in range(runs):  # each run as in a fresh process: nothing kept from the last
            model = ml.load_model(name)
            with tempfile.TemporaryDirectory() as folder:
                clear_operator_cache()
                results.append(run_study(model, grid, modes=("multiresolution", "cold"),
                                         out=folder, progress=False))
        warm, cold = results[0].mode_records("multiresolution"), results[0].mode_records("cold")
        tight = {r["number"]: model.solve(r["params"], options=ml.LatinOptions(
            tol=1e-9, max_iter=4000)).qoi["R_stop"] for r in warm}
        gains = sorted((r.gains or {})["gain"] for r in results)
        papers = sorted((r.gains or {})["paper_gain"] for r in results)
        median = float(np.median(gains))
        n_warm, n_cold = (sum(r["iterations"] for r in records) for records in (warm, cold))
        after_first = ([r["iterations"] for r in warm if r["start"] != "zero"]
                       if "line" in title else [])
        warm_cell = (f"{np.median(after_first):.0f} / {max(after_first)}" if after_first
                     else "—")
        met = median >= target and (not after_first or max(after_first) <= WARM_TARGET)
        print(f"| {title} | {len(warm)} | {median:.2f} ({gains[0]:.2f}–{gains[-1]:.2f}) | "
              f"{np.median(papers):.2f} | {n_warm} / {n_cold} ({n_cold / n_warm:.2f}) | "
              f"{warm_cell} | {100 * _worst_error(warm, tight):.3f} % / "
              f"{100 * _worst_error(cold, tight):.3f} % | {paper} | ≥ {target:g}"
              f"{f', warm ≤ {WARM_TARGET}' if after_first else ''} | "
              f"{'yes' if met else 'no'} |", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--multiresolution-only", action="store_true",
                        help="part 3 alone (issue 16's table)")
    parser.add_argument("--runs", type=int, default=3,
                        help="runs of each study in part 3 (the gain's median and spread)")
    args = parser.parse_args()
    print(f"warm-up (imports, Numba kernels): {warm_up():.1f} s; "
          f"compiled local stage: {kernels.contact_and_stops is not None}")
    np.set_printoptions(precision=3)
    if not args.multiresolution_only:
        solver_table()
        studies_table(args.quick)
    if not args.quick:
        multiresolution_table(args.runs)


if __name__ == "__main__":
    main()
