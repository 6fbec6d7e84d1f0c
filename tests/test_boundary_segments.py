"""Boundary conditions on part of a face (``segment`` on ``[[boundary]]``, session 45): a
load over a patch of a face, and on the free parts of a face partly covered by a contact.
Checked against the monolithic reference of the same discrete problem and against the
resultants; overlaps, ends between nodes and segments past the face are refused."""

from __future__ import annotations

import numpy as np
import pytest

import multilatin as ml
from multilatin.latin import LatinOptions

PATCH = """
[parameters.a]
default = 10.0
[materials.steel]
E = 2e5
nu = 0.3
[[bodies]]
name = "plate"
x = [0.0, 40.0]
y = [0.0, 10.0]
elements = [16, 4]
split = [2, 1]
material = "steel"
[[boundary]]
name = "clamp"
face = "plate.bottom"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "patch"
face = "plate.top"
segment = ["a", "a + 15"]
type = "force"
value = [2.0, -8.0]
[[qoi]]
name = "R_y"
type = "reaction"
boundary = "clamp"
component = "y"
[[qoi]]
name = "R_x"
type = "reaction"
boundary = "clamp"
component = "x"
[[qoi]]
name = "v_corner"
type = "displacement"
point = [40.0, 10.0]
component = "y"
"""

BESIDE = """
[materials.steel]
E = 2e5
nu = 0.3
[[bodies]]
name = "base"
x = [0.0, 40.0]
y = [0.0, 10.0]
elements = [16, 4]
material = "steel"
[[bodies]]
name = "block"
x = [10.0, 30.0]
y = [10.0, 20.0]
elements = [8, 4]
material = "steel"
[[interfaces]]
between = ["base", "block"]
type = "contact"
friction = 0.3
[[boundary]]
name = "clamp"
face = "base.bottom"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "press"
face = "block.top"
type = "force"
value = [1.0, -10.0]
[[boundary]]
name = "right_part"
face = "base.top"
segment = [30.0, 40.0]
type = "force"
value = [0.0, -5.0]
[[boundary]]
name = "left_part"
face = "base.top"
segment = [0, 10]
type = "displacement"
value = [0.0, -0.001]
[[qoi]]
name = "R"
type = "reaction"
boundary = "clamp"
component = "y"
[[qoi]]
name = "R_left"
type = "reaction"
boundary = "left_part"
component = "y"
[[qoi]]
name = "R_right"
type = "reaction"
boundary = "right_part"
component = "y"
[[qoi]]
name = "p"
type = "contact_pressure"
between = ["base", "block"]
segment = [10, 30]
"""

#: a stop, a pressure, a smooth wall, a held part and a push, each on part of a face
KINDS = """
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
[history.factors]
f = [0.5, 1.0, 1.0]
g = [0.0, 0.0, 1.0]
[[boundary]]
name = "stop"
face = "block.bottom"
segment = [5, 15]
type = "stop"
gap = 0.0005
friction = 0.3
[[boundary]]
name = "left_hold"
face = "block.left"
segment = [0, 5]
type = "mixed"
components = ["displacement", "force"]
value = [0.0, 0.0]
[[boundary]]
name = "press"
face = "block.top"
segment = [2.5, 17.5]
type = "pressure"
value = 20.0
factor = "f"
[[boundary]]
name = "wall"
face = "block.right"
segment = [0, 7.5]
type = "wall"
[[boundary]]
name = "push"
face = "block.left"
segment = [5, 10]
type = "force"
value = [5.0, 0.0]
factor = "g"
[[qoi]]
name = "Rs_x"
type = "reaction"
boundary = "stop"
component = "x"
[[qoi]]
name = "Rs_y"
type = "reaction"
boundary = "stop"
component = "y"
[[qoi]]
name = "Rw_x"
type = "reaction"
boundary = "wall"
component = "x"
[[qoi]]
name = "Rl_x"
type = "reaction"
boundary = "left_hold"
component = "x"
[[qoi]]
name = "v"
type = "displacement"
point = [0.0, 10.0]
component = "y"
"""


def _close(result: ml.SolveResult, reference: ml.SolveResult, rel: float) -> None:
    scale = max(float(np.abs(v).max()) for v in reference.qoi.values())
    for name, value in reference.qoi.items():
        assert np.asarray(result.qoi[name]) == pytest.approx(np.asarray(value),
                                                             abs=rel * scale), name


@pytest.mark.parametrize("start", [10.0, 5.0])
def test_a_load_over_part_of_a_face(start: float) -> None:
    """8 N/mm down and 2 N/mm along over 15 mm of the top, across the two substructures'
    sides (start 10: [10, 25]) or within one and onto the other's first nodes."""
    model = ml.Model(ml.ModelSpec.from_string(PATCH, name="patch"))
    result = model.solve({"a": start}, options=LatinOptions(tol=1e-10))
    reference = model.reference({"a": start})
    assert reference.qoi["R_y"] == pytest.approx(8.0 * 15.0, rel=1e-9)
    assert reference.qoi["R_x"] == pytest.approx(-2.0 * 15.0, rel=1e-9)
    _close(result, reference, 1e-7)
    whole = ml.Model(ml.ModelSpec.from_string(
        PATCH.replace('segment = ["a", "a + 15"]\n', ""), name="whole"))
    assert whole.reference().qoi["R_y"] == pytest.approx(8.0 * 40.0, rel=1e-9)


def test_a_study_over_the_patch_position_is_right_at_every_case(tmp_path) -> None:
    """The segment's position changes the interface points: a geometric parameter, each
    position its own operators (a reused operator would answer for another patch)."""
    model = ml.Model(ml.ModelSpec.from_string(PATCH, name="patch"))
    study = ml.run_study(model, ml.Grid({"a": [0.0, 5.0, 10.0]}), out=tmp_path,
                         progress=False)
    assert tuple(study.plan.geometric) == ("a",)
    for record in study.mode_records("multiresolution"):
        reference = model.reference(record["params"])
        assert record["qoi"]["v_corner"] == pytest.approx(reference.qoi["v_corner"],
                                                          rel=2e-3)


@pytest.mark.parametrize("kappa", [0.5, 2.0])
def test_the_free_parts_of_a_face_beside_a_contact(kappa: float) -> None:
    """A block pressed on a base: the base's top beside it takes a force on [30, 40] and a
    prescribed displacement on [0, 10], whose end node is the contact's end node."""
    model = ml.Model(ml.ModelSpec.from_string(BESIDE, name="beside"))
    reference = model.reference()
    assert reference.qoi["R_right"] == pytest.approx(-50.0, rel=1e-9)
    assert reference.qoi["R"] == pytest.approx(200.0 + 50.0 - reference.qoi["R_left"],
                                               rel=1e-9)
    assert reference.qoi["p"] == pytest.approx(10.0, rel=1e-6)
    result = model.solve(options=LatinOptions(kappa=kappa, tol=1e-10, max_iter=3000))
    _close(result, reference, 1e-7)


@pytest.mark.parametrize(("change", "message"), [
    (("segment = [30.0, 40.0]", "segment = [25.0, 40.0]"),
     r"side 'top' of 'base' already belongs to an interface or another boundary condition "
     r"over \[10, 30\]; its free parts are \[0, 10\] and \[30, 40\]: choose a segment"),
    (("segment = [0, 10]\n", ""),  # the whole face: before session 45 no way out
     r"over \[10, 30\], \[30, 40\]; its free parts are \[0, 10\]: give segment"),
    (("segment = [30.0, 40.0]", "segment = [31.0, 40.0]"),
     r"segment: 31 is not a node of side 'top' of 'base' \(its nearest nodes are at 30 "
     r"and 32.5\)"),
    (("segment = [30.0, 40.0]", "segment = [30.0, 45.0]"),
     r"segment: \[30, 45\] reaches past the face, which spans \[0, 40\]"),
    (("segment = [30.0, 40.0]", "segment = [40.0, 30.0]"),
     r"segment: expected \[start, end\] with start < end, got \[40, 30\]"),
])
def test_segments_that_cannot_be_are_refused(change: tuple[str, str], message: str) -> None:
    text = BESIDE.replace(*change)
    assert text != BESIDE
    with pytest.raises(ml.ModelError, match=message):
        ml.ModelSpec.from_string(text, name="bad")


def test_show_says_where_each_condition_acts(tmp_path, capsys) -> None:
    """``multilatin show`` lists the boundary conditions with the sides, and the parts of
    sides, they act on."""
    from multilatin.cli import main

    path = tmp_path / "patch.toml"
    path.write_text(PATCH)
    assert main(["show", str(path)]) == 0
    out = capsys.readouterr().out
    assert "clamp: displacement (0, 0) on plate[0,0].bottom, plate[1,0].bottom" in out
    assert "patch: traction (2, -8) on plate[0,0].top [10, 20], plate[1,0].top [20, 25]" in out
    assert main(["show", "b1"]) == 0
    out = capsys.readouterr().out
    assert "stop: rigid stop, gap 0.04, friction 0 on centre.right" in out
    assert "push: traction (1, 0) × factor 'P2' on centre.left" in out


def test_every_kind_of_condition_on_part_of_a_face() -> None:
    """A block on a frictional stop under 10 of its 20 mm, pressed by 20 MPa over 15 mm,
    beside a smooth wall over part of its right face and held over part of its left,
    then pushed over another part: the stop carries the pressure's 300 N, the x reactions
    balance the push, LATIN = the reference at every step."""
    model = ml.Model(ml.ModelSpec.from_string(KINDS, name="kinds"))
    reference = model.reference()
    assert reference.qoi["Rs_y"][-1] == pytest.approx(20.0 * 15.0, rel=1e-9)
    balance = (reference.qoi["Rs_x"][-1] + reference.qoi["Rw_x"][-1]
               + reference.qoi["Rl_x"][-1] + 5.0 * 5.0)
    assert abs(balance) < 1e-6 * 300.0
    result = model.solve(options=LatinOptions(tol=1e-10, max_iter=3000))
    _close(result, reference, 1e-7)
