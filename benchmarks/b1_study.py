"""B1 parametric studies, cold against multiresolution, side by side with the paper.

    python benchmarks/b1_study.py            # table 1 (b1, b1-4) and the b1 13 x 13 study
    python benchmarks/b1_study.py --quick    # table 1 only

Table 1 (paper §7.1): μ1 = 0.3, μ2 = 0, 0.05, ..., 0.6; iterations and time per computation
normalised by the first cold computation, with multiresolution (each case started from its
converged neighbour, operators reused), for one and four substructures per body. Every
study runs both modes in the same process, one after the other (``--compare``): the gain is
the sum of the cold times over the multiresolution study's time; the paper's own definition
(cases x the first cold time / the study's time) is printed beside it.
"""

from __future__ import annotations

import argparse
import tempfile

import multilatin as ml
from multilatin.parameters import Grid
from multilatin.study.plan import clear_operator_cache
from multilatin.study.runner import StudyResult, run_study

PAPER_ITERATIONS = {
    "b1": [25, 12, 11, 10, 9, 8, 7, 6, 4, 4, 3, 3, 3],
    "b1-4": [33, 16, 14, 14, 13, 12, 10, 7, 5, 4, 4, 3, 4],
}
PAPER_GAIN = {"b1": 3.56, "b1-4": 3.28, "b1 13x13": 4.4}


def study(name: str, grid: Grid) -> StudyResult:
    clear_operator_cache()  # each study builds its own operators
    with tempfile.TemporaryDirectory() as folder:
        return run_study(ml.load_model(name), grid, modes=("multiresolution", "cold"),
                         out=folder, progress=False)


def table1() -> None:
    grid = Grid.parse(["mu1=0.3", "mu2=0:0.6:13"])
    results = {name: study(name, grid) for name in ("b1", "b1-4")}
    print("Table 1: μ1 = 0.3; iterations (time / first cold computation)\n")
    print("| μ2 | b1 multiresolution | b1 cold | paper b1 | b1-4 multiresolution | b1-4 cold | "
          "paper b1-4 |")
    print("|---|---|---|---|---|---|---|")
    rows = {name: (r.mode_records("multiresolution"), r.mode_records("cold"))
            for name, r in results.items()}
    units = {name: cold[0]["wall_s"] for name, (_, cold) in rows.items()}
    for i, mu2 in enumerate(grid["mu2"]):
        cells = [f"{mu2:g}"]
        for name in ("b1", "b1-4"):
            warm, cold = rows[name]
            cells += [f"{warm[i]['iterations']} ({warm[i]['wall_s'] / units[name]:.2f})",
                      f"{cold[i]['iterations']} ({cold[i]['wall_s'] / units[name]:.2f})",
                      str(PAPER_ITERATIONS[name][i])]
        print("| " + " | ".join(cells) + " |")
    cells = ["total"]
    for name in ("b1", "b1-4"):
        warm, cold = rows[name]
        cells += [f"{sum(r['iterations'] for r in warm)} "
                  f"({results[name].elapsed_s['multiresolution'] / units[name]:.2f})",
                  f"{sum(r['iterations'] for r in cold)} "
                  f"({sum(r['wall_s'] for r in cold) / units[name]:.2f})",
                  f"{sum(PAPER_ITERATIONS[name])}"]
    print("| " + " | ".join(cells) + " |")
    print()
    for name, result in results.items():
        print_gains(name, result)


def print_gains(name: str, result: StudyResult) -> None:
    gains = result.gains or {}
    print(f"{name}: study {result.elapsed_s['multiresolution']:.2f} s, cold "
          f"{sum(r['wall_s'] for r in result.mode_records('cold')):.2f} s: gain "
          f"{gains['gain']:.2f} (paper's definition {gains['paper_gain']:.2f}; warm starts "
          f"alone {gains['warm_start_gain']:.2f}; iterations ratio "
          f"{gains['iterations_ratio']:.2f}); paper {PAPER_GAIN[name]}")


def full_grid() -> None:
    result = study("b1", Grid.parse(["mu1=0:0.6:13", "mu2=0:0.6:13"]))
    print_gains("b1 13x13", result)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--quick", action="store_true", help="table 1 only")
    args = parser.parse_args()
    # warm-up: imports and the compiled kernels load once per process, not in a study's time
    study("b1", Grid.parse(["mu1=0.3", "mu2=0,0.05"]))
    table1()
    if not args.quick:
        full_grid()


if __name__ == "__main__":
    main()
