"""A warm start at zero load: the answer is zero, η (relative to the fields' size) stays
put while the fields decay, and the case ran to ``max_iter`` as not converged — a spun hub
at ω = 0 and no interference, started from ω = 500 rad/s in a study over ω from 0
(``examples/spinning_fit.py``), was NaN in the multiresolution study and solved in one
iteration cold. The case now stops as "vanished" (``latin.guards.VANISH``) and a study
solves it again from zero (``study.starts.set_aside``), as it does a warm start that did not
converge for any reason."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import multilatin as ml
from multilatin.latin import LatinOptions, solve_latin
from multilatin.latin.guards import VANISH
from multilatin.latin.options import STUDY_QOI_RTOL
from multilatin.parameters import Grid
from multilatin.study.runner import run_study

PRESSED = '''
[parameters.p]
default = 10.0
min = 0.0
unit = "MPa"

[materials.steel]
E = 2e5
nu = 0.3

[[bodies]]
name = "block"
x = [0.0, 20.0]
y = [0.0, 10.0]
elements = [8, 4]
split = [2, 1]
material = "steel"

[[boundary]]
name = "clamp"
face = "block.bottom"
type = "displacement"
value = [0.0, 0.0]

[[boundary]]
name = "press"
face = "block.top"
type = "pressure"
value = "p"

[[qoi]]
name = "R"
type = "reaction"
boundary = "clamp"
component = "y"
unit = "N"
'''


@pytest.fixture(scope="module")
def pressed() -> ml.Model:
    """A block of two substructures, clamped below, pressed by p on its 20 mm top:
    R = 20 p N per mm of thickness."""
    return ml.Model(ml.ModelSpec.from_string(PRESSED, name="pressed"))


def test_a_warm_start_at_zero_load_stops_as_vanished(pressed: ml.Model) -> None:
    """From p = 10 to p = 0 the fields fall below ``VANISH`` of their start within a few
    dozen iterations, and the result says so; from zero the answer is exact at once; a
    small load (1e-4 of the start's, above ``VANISH``) still converges from the warm start
    to the cold answer."""
    options = LatinOptions()
    start = solve_latin(pressed.assemble({"p": 10.0}), options)
    fields = (start.interface.displacement_hat, start.interface.force_hat)
    warm = solve_latin(pressed.assemble({"p": 0.0}), options, initial=fields, check=False)
    assert not warm.converged and warm.failure.startswith("vanished")
    assert warm.iterations < 200
    cold = solve_latin(pressed.assemble({"p": 0.0}), options)
    assert cold.iterations == 1 and cold.qoi["R"] == 0.0
    small = solve_latin(pressed.assemble({"p": 1e-3}), options, initial=fields)
    assert small.qoi["R"] == pytest.approx(0.02, rel=1e-5)
    assert 1e-3 / 10.0 > VANISH


@pytest.mark.parametrize("batch, rolling", [(1, True), (3, True), (3, False)])
def test_a_study_solves_a_vanished_case_again_from_zero(
        pressed: ml.Model, tmp_path: Path, batch: int, rolling: bool) -> None:
    """Down p = 10, 5, 0 the last case starts from p = 5, vanishes, and is solved again
    from zero (its record says why, its iterations count the warm attempt), one case at a
    time, in a rolling batch and in line batches alike; the study converges everywhere, both
    modes within the studies' accuracy of the closed form."""
    grid = Grid({"p": [10.0, 5.0, 0.0]})
    study = run_study(pressed, grid, modes=("multiresolution", "cold"), out=tmp_path,
                      progress=False, batch=batch, rolling=rolling)
    data = study.dataset
    assert bool(data["converged"].all())
    for mode in ("multiresolution", "cold"):  # the studies' accuracy, against R = 20 p
        np.testing.assert_allclose(data["R"].sel(mode=mode).values, 20.0 * np.array(grid["p"]),
                                   rtol=STUDY_QOI_RTOL, atol=0.0)
    assert set(study.modes_within) == {"R"}
    assert study.modes_within["R"] <= 2 * STUDY_QOI_RTOL
    assert study.to_json_dict()["modes_within"] == study.modes_within
    records = [json.loads(line) for line in (tmp_path / "cases.jsonl").read_text().splitlines()]
    zero = next(r for r in records if r["mode"] == "multiresolution" and r["params"]["p"] == 0)
    assert zero["start"] == "zero (not converged, vanished: the warm start was set aside)"
    assert zero["iterations"] > 1
