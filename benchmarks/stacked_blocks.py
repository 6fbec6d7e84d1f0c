"""Bodies that slide as one (session 51): B1 without its smooth wall, so that the top block
rides on the centre block, held to it by friction alone. Where the push reaches the bottom
contact's capacity with the stop still open, the pair is free to slide together while
neither block alone is; ``rigid_clusters.contact_unions`` searches such unions.

    python benchmarks/stacked_blocks.py --line            # μ1 ∈ {0.25, 0.3}: unions on/off
    python benchmarks/stacked_blocks.py --line 0.2,0.25,0.3,0.35
    python benchmarks/stacked_blocks.py --grid 13 --gap 0.2 [--tight]

``--line``: the study along μ1 ∈ {0.25, 0.3} (or the values given; μ2 = 0.3, gap 0.2),
both modes, with the unions searched and without (``MAX_UNIONS = 0``, the search before
session 51): u_A at step 10 of the case μ1 = 0.3 and whether it was flagged. ``--grid N``:
the N × N study over (μ1, μ2) ∈ [0, 0.6]², both modes; per QoI the largest difference
between the modes over the values both call determined, relative to max(|cold|, 1 % of the
QoI's largest |value| over the grid), the flagged cases, the gain. ``--tight``: every
unique case of both modes against an η < 1e-10 solve (relative to max(|tight|, 1 % of its
largest |value| over the steps)).
"""

from __future__ import annotations

import argparse
import tempfile
from importlib import resources
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.decomposition import rigid_clusters
from multilatin.latin import LatinOptions
from multilatin.study.plan import clear_operator_cache
from multilatin.study.runner import run_study

WALL = '''[[boundary]]
name = "wall"
face = "top.right"
type = "wall"           # smooth wall: u_x = 0, no friction
'''
QOIS = ("R_stop", "u_A", "p_B")


def stack_model() -> ml.Model:
    text = (resources.files("multilatin") / "models" / "b1.toml").read_text()
    assert WALL in text
    return ml.Model(ml.ModelSpec.from_string(text.replace(WALL, ""), name="stack"))


def _study(model: ml.Model, grid: ml.Grid) -> Any:
    clear_operator_cache()
    with tempfile.TemporaryDirectory() as out:
        return run_study(model, grid, modes=("multiresolution", "cold"), out=out,
                         progress=False)


def line(model: ml.Model, mu1: list[float]) -> None:
    grid = ml.Grid({"mu1": mu1, "mu2": [0.3], "gap": [0.2]})
    print("| search | mode | u_A at step 10 (mm), μ1 = 0.3 | flagged not unique |")
    print("|---|---|---|---|")
    for label, bound in (("clusters and their unions", rigid_clusters.MAX_UNIONS),
                         ("one cluster at a time (before)", 0)):
        saved = rigid_clusters.MAX_UNIONS
        rigid_clusters.MAX_UNIONS = bound
        rigid_clusters._GEOMETRIES.clear()
        try:
            data = _study(model, grid).dataset.sel(mu1=0.3, mu2=0.3, gap=0.2)
        finally:
            rigid_clusters.MAX_UNIONS = saved
            rigid_clusters._GEOMETRIES.clear()
        for mode in ("multiresolution", "cold"):
            one = data.sel(mode=mode)
            print(f"| {label} | {mode} | {float(one['u_A'].values[9]):.5f} | "
                  f"{'yes' if not bool(one['unique']) else 'no'} |")


def grid_study(model: ml.Model, n: int, gap: float, tight: bool) -> None:
    values = [float(v) for v in np.round(np.linspace(0.0, 0.6, n), 4)]
    study = _study(model, ml.Grid({"mu1": values, "mu2": values, "gap": [gap]}))
    data = study.dataset.sel(gap=gap)
    multi, cold = data.sel(mode="multiresolution"), data.sel(mode="cold")
    print(f"{n} x {n}, gap {gap}: flagged not unique {int((~multi['unique'].values).sum())}"
          f" / {multi['unique'].size}; gain {study.gains['gain']:.2f}, iterations "
          f"{int(multi['iterations'].sum())} / {int(cold['iterations'].sum())}")
    for name in QOIS:
        a, b = multi[name].values, cold[name].values
        both = multi[f"{name}_determined"].values & cold[f"{name}_determined"].values
        scale = np.maximum(np.abs(b), 0.01 * np.nanmax(np.abs(b)))
        diff = np.where(both, np.abs(a - b) / np.where(scale > 0, scale, 1.0), 0.0)
        print(f"  {name}: largest multiresolution-cold difference {np.nanmax(diff):.2e}")
    if not tight:
        return
    worst = dict.fromkeys(QOIS, 0.0)
    for mu1 in values:
        for mu2 in values:
            mu = {"mu1": mu1, "mu2": mu2, "gap": gap}
            reference = model.solve(mu, options=LatinOptions(tol=1e-10, max_iter=20000))
            for mode in ("multiresolution", "cold"):
                case = data.sel(mode=mode, mu1=mu1, mu2=mu2)
                if not bool(case["unique"]):
                    continue
                for name in QOIS:
                    exact = np.atleast_1d(np.asarray(reference.qoi[name], dtype=float))
                    value = np.atleast_1d(case[name].values)
                    determined = np.atleast_1d(case[f"{name}_determined"].values)
                    scale = np.maximum(np.abs(exact), 0.01 * np.abs(exact).max())
                    error = np.abs(value - exact) / np.where(scale > 0, scale, 1.0)
                    worst[name] = max(worst[name], float(error[determined].max(initial=0.0)))
    print("  against η < 1e-10, unique cases of both modes: "
          + ", ".join(f"{name} {error:.2e}" for name, error in worst.items()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--line", nargs="?", const="0.25,0.3", default=None,
                        help="comma-separated μ1 values, 0.3 among them")
    parser.add_argument("--grid", type=int, default=0)
    parser.add_argument("--gap", type=float, default=0.2)
    parser.add_argument("--tight", action="store_true")
    args = parser.parse_args()
    model = stack_model()
    if args.line:
        try:
            mu1 = [float(v) for v in args.line.split(",")]
        except ValueError:
            parser.error(f"--line: expected comma-separated numbers, got {args.line!r}")
        if 0.3 not in mu1:
            parser.error(f"--line: the μ1 values must include 0.3 (the case at the limit), "
                         f"got {args.line!r}")
        line(model, mu1)
    if args.grid:
        grid_study(model, args.grid, args.gap, args.tight)


if __name__ == "__main__":
    main()
