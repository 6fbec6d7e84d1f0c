"""A warm start at zero load (session 52): the spun hub of ``examples/spinning_fit.py`` at
ω = 0 and no interference has the answer zero; started from its neighbour at ω = 500 rad/s,
η (relative to the fields' size) stayed at ~0.36 while the fields decayed, and the case ran
to the cap of 1 000 iterations, NaN in the multiresolution study (cold: one iteration).

    python benchmarks/zero_load.py [--before]

The study over ω ∈ {0, 500, 1000, 2000, 3000} rad/s × δ ∈ {0, 0.005, 0.01} mm, both
modes: per mode the cases that did not converge, the case (0, 0)'s start and iterations,
the iterations in all, and the largest difference between the modes over every QoI value
(relative to max(|cold|, 1 % of the QoI's largest |value|)). ``--before``: without the
vanishing check (``VANISH = 0``) and with a warm start that did not converge kept (the
behaviour before session 52). Needs gmsh (``pip install 'multilatin[reference]'``).
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

import multilatin as ml
from multilatin.latin import guards
from multilatin.study import starts
from multilatin.study.plan import clear_operator_cache
from multilatin.study.runner import run_study

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples"))
import spinning_fit  # noqa: E402

GRID = {"omega": [0.0, 500.0, 1000.0, 2000.0, 3000.0], "delta": [0.0, 0.005, 0.01]}
QOIS = ("p_fit", "u_out")


def _before(result: ml.SolveResult, start_index: tuple[int, ...] | None) -> str | None:
    """``starts.set_aside`` before session 52: only answers that are not unique."""
    kept = start_index is None or not result.converged or result.unique
    return None if kept else "not unique"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", action="store_true",
                        help="no vanishing check, failed warm starts kept (before session 52)")
    args = parser.parse_args()
    if args.before:
        guards.VANISH = 0.0
        starts.set_aside = _before
    with tempfile.TemporaryDirectory() as folder:
        model = spinning_fit.load(Path(folder))
        clear_operator_cache()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            study = run_study(model, ml.Grid(GRID), modes=("multiresolution", "cold"),
                              out=Path(folder) / "study", progress=False)
        records = [json.loads(line) for line in
                   (Path(folder) / "study" / "cases.jsonl").read_text().splitlines()]
    data = study.dataset
    print("| mode | not converged | case (0, 0): start | its iterations | iterations |")
    print("|---|---|---|---|---|")
    for mode in ("multiresolution", "cold"):
        mine = [r for r in records if r["mode"] == mode]
        zero = next(r for r in mine if r["params"] == {"omega": 0.0, "delta": 0.0})
        print(f"| {mode} | {sum(not r['converged'] for r in mine)} / {len(mine)} | "
              f"{zero['start']} | {zero['iterations']} | "
              f"{sum(r['iterations'] for r in mine)} |")
    for name in QOIS:
        warm = data[name].sel(mode="multiresolution").values
        cold = data[name].sel(mode="cold").values
        scale = np.maximum(np.abs(cold), 0.01 * np.nanmax(np.abs(cold)))
        gap = np.abs(warm - cold) / np.where(scale > 0, scale, 1.0)
        missing = int(np.isnan(gap).sum())
        print(f"{name}: modes within {np.nanmax(gap):.1e}"
              + (f", {missing} value(s) NaN" if missing else ""))


if __name__ == "__main__":
    main()
