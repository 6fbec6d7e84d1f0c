"""B1 — three stacked blocks with frictional contact and a rigid stop: the stop force R_stop
along a line of the friction coefficient μ2, multiresolution against cold solves (paper
§7.1, table 1), and one case against the independent Newton reference.

Run: ``python examples/b1_friction_line.py --out results/gallery/b1``
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

import multilatin as ml


def run(out: Path | None = None, count: int = 13, mu1: float = 0.3) -> dict[str, Any]:
    model = ml.load_model("b1")
    grid = ml.Grid({"mu1": [mu1], "mu2": np.linspace(0.0, 0.6, count)})
    study = ml.run_study(model, grid, modes=("multiresolution", "cold"), out=out,
                         progress=False)
    if out is not None:
        from multilatin.study.report import write_study_outputs

        write_study_outputs(study, out)  # table.csv, response and iteration plots, report.html
    stop = study.dataset["R_stop"]
    warm = stop.sel(mode="multiresolution").values.ravel()
    cold = stop.sel(mode="cold").values.ravel()
    mu2 = float(grid["mu2"][count // 4])  # on the sloped part of the response
    reference = model.reference({"mu1": mu1, "mu2": mu2}).qoi["R_stop"]
    return {"mu2": list(grid["mu2"]), "R_stop_multiresolution": warm.tolist(),
            "R_stop_cold": cold.tolist(), "gains": study.gains,
            "reference": (mu2, float(np.ravel(reference)[-1]))}


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None)
    found = run(parser.parse_args().out)
    for mu2, warm, cold in zip(found["mu2"], found["R_stop_multiresolution"],
                               found["R_stop_cold"], strict=True):
        print(f"mu2 = {mu2:.2f}: R_stop = {warm:9.3f} N (cold {cold:9.3f} N)")
    print(f"reference at mu2 = {found['reference'][0]:.2f}: {found['reference'][1]:.3f} N")
    print(f"gains: {found['gains']}")
