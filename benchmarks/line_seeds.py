"""Issue 16 (session 37): a study along one parameter (a line) from several seeds
(``study.rolling.seeded_line_starts``, the default since session 37) against one chain from
the line's first value (before) and against every case from zero, in one process.

One chain from the first value, each case from the one before, holds one case at a time
in the rolling batch; with k seeds (k = n // ``rolling.SEED_SPACING``: cases evenly spaced
along the line from zero, every other case from its neighbour one step nearer its seed) it
holds up to 2k. Per variant (``SEED_SPACING`` set for the run): multiresolution iterations,
the study's time and the gain against its cold cases (three runs, the variants alternated),
and R_stop's largest difference from the first variant's.

    python benchmarks/line_seeds.py [--model b1] [--spacings 6 4 2] [--repeat 3]
    python benchmarks/line_seeds.py --model b3 --grid xc=21:29:9 --spacings 4 2
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.parameters import Grid
from multilatin.study import rolling
from multilatin.study.plan import clear_operator_cache
from multilatin.study.runner import run_study

GRID = ["mu1=0.3", "mu2=0:0.6:13"]
#: a spacing no line reaches: one chain from the first value
ONE_CHAIN = 10**9


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="b1")
    parser.add_argument("--spacings", nargs="*", type=int, default=[6, 4, 2],
                        help="cases per seed (13 cases: 2, 3 and 6 seeds)")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--grid", nargs="*", default=GRID,
                        help="the line, as on the command line (default: the μ2 line)")
    args = parser.parse_args()
    model = ml.load_model(args.model)
    grid = Grid.parse(args.grid)
    n = max(grid.shape)  # the line's cases
    variants: list[tuple[str, int, str]] = [("one chain from the first value", ONE_CHAIN,
                                             "neighbour")]
    variants += [(f"{n // spacing} seeds (spacing {spacing}"
                  f"{', the default' if spacing == rolling.SEED_SPACING else ''})", spacing,
                  "neighbour") for spacing in args.spacings]
    variants += [("every case from zero (--start zero)", rolling.SEED_SPACING, "zero")]
    default = rolling.SEED_SPACING
    rows: dict[str, dict[str, Any]] = {label: {"times": [], "gains": []}
                                       for label, _, _ in variants}
    reference = None
    for _ in range(args.repeat):
        for label, spacing, start in variants:
            rolling.SEED_SPACING = spacing
            clear_operator_cache()  # each run as in a fresh process (``suite.py``)
            try:
                result = run_study(model, grid, modes=("multiresolution", "cold"),
                                   progress=False, start=start)
            finally:
                rolling.SEED_SPACING = default
            warm = sorted(result.mode_records("multiresolution"), key=lambda r: r["number"])
            cold = result.mode_records("cold")
            row = rows[label]
            row["times"].append(result.elapsed_s["multiresolution"])
            row["gains"].append(sum(r["wall_s"] for r in cold)
                                / result.elapsed_s["multiresolution"])
            row["iterations"] = sum(r["iterations"] for r in warm)
            values = np.array([r["qoi"]["R_stop"] for r in warm], dtype=float)
            reference = values if reference is None else reference
            row["difference"] = float(np.max(np.abs(values - reference)))
    print(f"{args.model} line ({' '.join(args.grid)}), {args.repeat} runs per variant\n")
    print("| start | iterations | study time (s) | gain | R_stop's largest difference (N) |")
    print("|---|---|---|---|---|")
    for label, row in rows.items():
        print(f"| {label} | {row['iterations']} | "
              f"{' / '.join(f'{t:.2f}' for t in row['times'])} | "
              f"{' / '.join(f'{g:.2f}' for g in row['gains'])} | {row['difference']:.3f} |")


if __name__ == "__main__":
    main()
