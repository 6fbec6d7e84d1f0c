"""B1 — a response surface from a study: R_stop over (μ1, μ2) on a grid, read between its
points by interpolating study.nc with xarray, and checked against direct solves at random
parameter sets the grid does not hold.

Run: ``python examples/b1_response_surface.py --out results/gallery/b1-surface``
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

import multilatin as ml


def run(out: Path | None = None, count: int = 13, checks: int = 12,
        seed: int = 0) -> dict[str, Any]:
    """The study over a ``count`` × ``count`` grid of (μ1, μ2) ∈ [0, 0.6]², then R_stop
    interpolated (bilinear, ``xarray.Dataset.interp``) at ``checks`` random parameter sets
    against a direct solve of each."""
    model = ml.load_model("b1")
    space = ml.ParameterSpace(model.parameters, {"mu1": (0.0, 0.6), "mu2": (0.0, 0.6)})
    study = ml.run_study(model, space.sample_uniformly(count), out=out, progress=False)
    surface = study.dataset["R_stop"].sel(mode="multiresolution")
    rng = np.random.default_rng(seed)
    rows = []
    for mu1, mu2 in rng.uniform(0.0, 0.6, size=(checks, 2)):
        read = float(surface.interp(mu1=mu1, mu2=mu2))
        solved = float(np.ravel(model.solve({"mu1": mu1, "mu2": mu2}).qoi["R_stop"])[-1])
        rows.append((float(mu1), float(mu2), read, solved))
    errors = [abs(read - solved) for _, _, read, solved in rows]
    return {"rows": rows, "largest_error": max(errors),
            "range": float(surface.max() - surface.min())}


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None)
    found = run(parser.parse_args().out)
    print("   mu1    mu2   interpolated (N)   solved (N)")
    for mu1, mu2, read, solved in found["rows"]:
        print(f"{mu1:6.3f} {mu2:6.3f} {read:14.2f} {solved:14.2f}")
    print(f"largest error {found['largest_error']:.2f} N over a range of "
          f"{found['range']:.0f} N")
