"""A warm start at zero load: the answer is zero, η (relative to the fields' size) stays
put while the fields decay, and the case ran to ``max_iter`` as not converged — a spun hub
at ω = 0 and no interference, started from ω = 500 rad/s in a study over ω from 0
(``examples/spinning_fit.py``), was NaN in the multiresolution study and solved in one
iteration cold. A case nothing loads now drops its warm start (``latin.guards.
drop_unloaded_starts``: one iteration); one whose fields vanish from their warm start (a
load far smaller than its neighbour's, or a zero the check misses) stops as "vanished"
(``latin.guards.VANISH``), and a study solves it again from zero (``study.starts.
set_aside``), as it does a warm start that did not converge for any reason."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import multilatin as ml
from multilatin.latin import LatinOptions, guards, solve_latin
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


def test_warm_starts_at_zero_and_at_a_vanishing_load(pressed: ml.Model,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    """From p = 10: at p = 0 the warm start is dropped (one iteration, R = 0 exactly) —
    kept (the check switched off), its fields fall below ``VANISH`` of their start within a
    few dozen iterations and the result says so; at p = 1e-6 (1e-7 of the start's load)
    they vanish too; at p = 1e-3 (1e-4, above ``VANISH``) the warm start converges to the
    cold answer."""
    options = LatinOptions()
    start = solve_latin(pressed.assemble({"p": 10.0}), options)
    fields = (start.interface.displacement_hat, start.interface.force_hat)
    zero = solve_latin(pressed.assemble({"p": 0.0}), options, initial=fields)
    assert zero.iterations == 1 and zero.qoi["R"] == 0.0
    tiny = solve_latin(pressed.assemble({"p": 1e-6}), options, initial=fields, check=False)
    assert not tiny.converged and tiny.failure.startswith("vanished")
    assert tiny.iterations < 200
    small = solve_latin(pressed.assemble({"p": 1e-3}), options, initial=fields)
    assert small.qoi["R"] == pytest.approx(0.02, rel=1e-5)
    assert 1e-3 / 10.0 > VANISH > 1e-6 / 10.0
    monkeypatch.setattr(guards, "unloaded", lambda local, bodies: np.zeros(1, dtype=bool))
    kept = solve_latin(pressed.assemble({"p": 0.0}), options, initial=fields, check=False)
    assert not kept.converged and kept.failure.startswith("vanished")


@pytest.mark.parametrize("batch, rolling", [(1, True), (3, True), (3, False)])
def test_a_study_solves_a_vanished_case_again_from_zero(
        pressed: ml.Model, tmp_path: Path, batch: int, rolling: bool) -> None:
    """Down p = 10, 5, 1e-6, 0: the case p = 1e-6 starts from p = 5, vanishes, and is
    solved again from zero (its record says why, its iterations count the warm attempt);
    p = 0 drops its warm start — one case at a time, in a rolling batch and in line batches
    alike. The study converges everywhere, both modes within the studies' accuracy of the
    closed form and of each other."""
    grid = Grid({"p": [10.0, 5.0, 1e-6, 0.0]})
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
    records = {r["params"]["p"]: r for r in study.mode_records("multiresolution")}
    assert records[1e-6]["start"] == "zero (not converged, vanished: the warm start was set aside)"
    assert records[1e-6]["iterations"] > 1
    assert records[0.0]["start"] == "zero (nothing loads it)"
    assert records[0.0]["iterations"] == 1
