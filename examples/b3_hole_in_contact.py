"""B3 — B1 with a hole in the centre block: R_stop against the hole's position along x,
each geometry's operators built once and its cases warm-started (paper §7.3), and the
deformed assembly with the contact status (paper fig. 16).

Run: ``python examples/b3_hole_in_contact.py --out results/gallery/b3``
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

import multilatin as ml


def run(out: Path | None = None, positions: tuple[float, ...] = (10.0, 25.0, 40.0),
        radius: float = 5.0) -> dict[str, Any]:
    model = ml.load_model("b3")
    grid = ml.Grid({"xc": positions, "rc": [radius]})
    study = ml.run_study(model, grid, out=out, progress=False)
    stop = study.dataset["R_stop"].sel(mode="multiresolution").values.ravel()
    if out is not None:
        from multilatin.io.plots import plot_deformed

        plot_deformed(model.solve({"xc": positions[len(positions) // 2], "rc": radius}),
                      out / "deformed.png")
    return {"xc": list(positions), "R_stop": np.asarray(stop).tolist(),
            "converged": [bool(r["converged"]) for r in study.records]}


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None)
    found = run(parser.parse_args().out)
    for xc, value in zip(found["xc"], found["R_stop"], strict=True):
        print(f"xc = {xc:g} mm: R_stop = {value:.3f} N")
