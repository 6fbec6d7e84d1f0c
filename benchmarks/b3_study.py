"""B3 position study, cold against multiresolution (paper table 2, §7.3).

    python benchmarks/b3_study.py

rc = 3, xc ∈ {23, …, 27}, yc ∈ {73, …, 77}, μ1 = 0.35, μ2 = 0.25: 25 computations, each new
hole position rebuilding only the holed substructure's operators and starting from the nearest
converged position. Both modes run in the same process, one after the other. Prints table 2:
per position, iterations and time normalised by the first cold computation (paper: 0.17–0.24
after the first), then the gains (paper 4.4).
"""

from __future__ import annotations

import tempfile

import multilatin as ml
from multilatin.parameters import Grid
from multilatin.study.runner import run_study

PAPER_GAIN = 4.4


def main() -> None:
    grid = Grid.parse(["xc=23:27:5", "yc=73:77:5", "rc=3"])
    with tempfile.TemporaryDirectory() as folder:
        result = run_study(ml.load_model("b3"), grid, modes=("multiresolution", "cold"),
                           out=folder, progress=False)
    warm = {(r["params"]["xc"], r["params"]["yc"]): r
            for r in result.mode_records("multiresolution")}
    cold = result.mode_records("cold")
    unit = cold[0]["wall_s"]
    print("Table 2: rc = 3; iterations (time / first cold computation), multiresolution\n")
    print("| yc \\ xc | " + " | ".join(f"{x:g}" for x in grid["xc"]) + " |")
    print("|---" * (len(grid["xc"]) + 1) + "|")
    for y in reversed(list(grid["yc"])):
        cells = [f"{warm[(x, y)]['iterations']} ({warm[(x, y)]['wall_s'] / unit:.2f})"
                 for x in grid["xc"]]
        print(f"| {y:g} | " + " | ".join(cells) + " |")
    gains = result.gains or {}
    print(f"\ncold: {sum(r['iterations'] for r in cold)} iterations, "
          f"{sum(r['wall_s'] for r in cold):.2f} s; multiresolution: "
          f"{sum(r['iterations'] for r in warm.values())} iterations, "
          f"{result.elapsed_s['multiresolution']:.2f} s")
    print(f"gain {gains['gain']:.2f} (paper's definition {gains['paper_gain']:.2f}; warm starts "
          f"alone {gains['warm_start_gain']:.2f}); paper {PAPER_GAIN}")


if __name__ == "__main__":
    main()
