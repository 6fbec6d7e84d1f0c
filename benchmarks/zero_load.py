"""A warm start at zero load (session 52): the spun hub of ``examples/spinning_fit.py`` at
ω = 0 and no interference has the answer zero; started from its neighbour at ω = 500 rad/s,
η (relative to the fields' size) stayed at ~0.36 while the fields decayed, and the case ran
to the cap of 1 000 iterations, NaN in the multiresolution study (cold: one iteration).

    python benchmarks/zero_load.py

The study over ω ∈ {0, 500, 1000, 2000, 3000} rad/s × δ ∈ {0, 0.005, 0.01} mm, both
modes, three ways: as today (a case nothing loads drops its warm start,
``guards.drop_unloaded_starts``); without that drop (the warm start vanishes,
``guards.VANISH``, and the study solves the case again from zero, ``starts.set_aside``); and
as before session 52 (neither, and a warm start that did not converge kept). Per way and
mode: the cases that did not converge, the case (0, 0)'s start and iterations, the
iterations in all, and per QoI the largest difference between the modes
(``StudyResult.modes_within``). Needs gmsh (``pip install 'multilatin[reference]'``).
"""

from __future__ import annotations

import argparse
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


def _kept(result: ml.SolveResult, start_index: tuple[int, ...] | None) -> str | None:
    """``starts.set_aside`` before session 52: only answers that are not unique."""
    kept = start_index is None or not result.converged or result.unique
    return None if kept else "not unique"


def _none_unloaded(local: object, bodies: list[object]) -> np.ndarray:
    return np.zeros(len(bodies), dtype=bool)


def run(model: ml.Model, folder: Path, way: str) -> None:
    """The study, both modes, its table rows for ``way``."""
    clear_operator_cache()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        study = run_study(model, ml.Grid(GRID), modes=("multiresolution", "cold"),
                          out=folder, progress=False)
    for mode in ("multiresolution", "cold"):
        mine = study.mode_records(mode)
        zero = next(r for r in mine if r["params"] == {"omega": 0.0, "delta": 0.0})
        within = ("" if mode == "cold" else ", ".join(
            f"{name} {value:.1e}" for name, value in study.modes_within.items()))
        print(f"| {way} | {mode} | {sum(not r['converged'] for r in mine)} / {len(mine)} | "
              f"{zero['start']} | {zero['iterations']} | "
              f"{sum(r['iterations'] for r in mine)} | {within} |")


def main() -> None:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    ways = {"today": {}, "without the drop": {"unloaded": _none_unloaded},
            "before session 52": {"unloaded": _none_unloaded, "VANISH": 0.0,
                                  "set_aside": _kept}}
    print("| way | mode | not converged | case (0, 0): start | its iterations | iterations "
          "| modes within |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as folder:
        model = spinning_fit.load(Path(folder))
        for n, (way, patches) in enumerate(ways.items()):
            saved = {name: getattr(starts if name == "set_aside" else guards, name)
                     for name in patches}
            for name, value in patches.items():
                setattr(starts if name == "set_aside" else guards, name, value)
            try:
                run(model, Path(folder) / f"study{n}", way)
            finally:
                for name, value in saved.items():
                    setattr(starts if name == "set_aside" else guards, name, value)


if __name__ == "__main__":
    main()
