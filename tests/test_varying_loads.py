"""Boundary values that vary along the face: expressions of the point's coordinates x and
y (and the parameters). Tractions take their consistent load (exact resultant and moment
when linear). Checked against closed forms in both solvers: the displacement patch test
(a linear field prescribed on every face), a dam face under hydrostatic pressure (the
resultant γ H² / 2), and a beam bent by a linear traction (beam theory under refinement),
LATIN equal to the reference; bad expressions are refused with the field and the point."""

from __future__ import annotations

from pathlib import Path

import pytest

import multilatin as ml
from multilatin.cli import main

PATCH = """
[parameters.eps]
default = 1e-3
[materials.steel]
E = 2e5
nu = 0.3
[[bodies]]
name = "block"
x = [0.0, 20.0]
y = [0.0, 10.0]
elements = [6, 4]
split = [2, 2]
material = "steel"
""" + "".join(f"""[[boundary]]
name = "{side}"
face = "block.{side}"
type = "displacement"
value = ["eps * x", "-0.3 * eps * y"]
""" for side in ("left", "right", "bottom", "top")) + """[[qoi]]
name = "sxx"
type = "stress"
point = [7.7, 3.3]
component = "xx"
[[qoi]]
name = "syy"
type = "stress"
point = [10.0, 5.0]
component = "yy"
[[qoi]]
name = "u"
type = "displacement"
point = [13.1, 6.2]
component = "x"
"""


def test_a_linear_displacement_on_every_face_gives_the_uniform_stress(tmp_path: Path) -> None:
    """u = (ε x, −ν ε y) prescribed on the four faces (plane stress): uniaxial stress E ε
    everywhere, the displacement ε x inside, in LATIN (four substructures) and the
    reference."""
    (tmp_path / "patch.toml").write_text(PATCH)
    model = ml.load_model(tmp_path / "patch.toml")
    for result in (model.solve({}, options=ml.LatinOptions(tol=1e-12, max_iter=3000)),
                   model.reference({})):
        assert result.qoi["sxx"] == pytest.approx(2e5 * 1e-3, rel=1e-8)
        assert result.qoi["syy"] == pytest.approx(0.0, abs=1e-6)
        assert result.qoi["u"] == pytest.approx(1e-3 * 13.1, rel=1e-9)


DAM = """
[parameters.gamma]
default = 2.0
[materials.concrete]
E = 3e4
nu = 0.2
[[bodies]]
name = "dam"
x = [0.0, 4.0]
y = [0.0, 10.0]
elements = [2, 6]
split = [1, 2]
material = "concrete"
[[boundary]]
name = "base"
face = "dam.bottom"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "water"
face = "dam.left"
type = "pressure"
value = "gamma * (10 - y)"
[[qoi]]
name = "Rx"
type = "reaction"
boundary = "base"
component = "x"
"""


def test_hydrostatic_pressure_has_the_resultant_of_its_triangle(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Water γ (H − y) on a dam's face of height 10 on six cells: the base holds γ H² / 2
    = 100 N per unit thickness exactly (the consistent load of a linear pressure; the
    lumped one gives the same resultant), in both solvers; `show` prints the expression."""
    (tmp_path / "dam.toml").write_text(DAM)
    model = ml.load_model(tmp_path / "dam.toml")
    for result in (model.solve({}, options=ml.LatinOptions(tol=1e-10)), model.reference({})):
        assert result.qoi["Rx"] == pytest.approx(-100.0, rel=1e-9)
    assert main(["show", str(tmp_path / "dam.toml")]) == 0
    assert "water: pressure gamma * (10 - y) on dam[0,0].left, dam[0,1].left" \
        in capsys.readouterr().out


BEAM = """
[materials.steel]
E = 2e5
nu = 0.3
[[bodies]]
name = "beam"
x = [0.0, 100.0]
y = [0.0, 10.0]
elements = [NX, NY]
split = [4, 1]
material = "steel"
[[boundary]]
name = "clamp"
face = "beam.left"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "moment"
face = "beam.right"
type = "force"
value = ["10 * (y - 5) / 5", 0.0]
[[qoi]]
name = "v_tip"
type = "displacement"
point = [100.0, 5.0]
component = "y"
"""


def test_a_beam_bent_by_a_linear_traction_converges_to_beam_theory(tmp_path: Path) -> None:
    """A linear traction of ±10 MPa on the end of a 100 × 10 mm beam is a moment M = 10 ×
    10² / 6: v_tip = M L² / 2 E I = 0.05 mm. The reference converges to it (measured 3.1 %
    on 40 × 4 cells, 0.9 % on 80 × 8; the lumped load's moment, 12.5 % too large on four
    cells, gave 9 % too much); LATIN on four substructures equals it."""
    errors = []
    for nx, ny in ((40, 4), (80, 8)):
        (tmp_path / "beam.toml").write_text(BEAM.replace("NX, NY", f"{nx}, {ny}"))
        model = ml.load_model(tmp_path / "beam.toml")
        reference = float(model.reference({}).qoi["v_tip"])  # type: ignore[arg-type]
        errors.append(abs(reference / -0.05 - 1.0))
        if nx == 40:
            latin = model.solve({}, options=ml.LatinOptions(tol=1e-10))
            assert latin.qoi["v_tip"] == pytest.approx(reference, rel=1e-8)
    assert errors[0] < 0.04 and errors[1] < errors[0] / 2.5


@pytest.mark.parametrize("value, message", [
    ('["sqrt(y - 5)", 0.0]', r"boundary\[1\] \('moment'\)\.value at \(100, 0\): .*"
                              r"sqrt\(y - 5\).*cannot be evaluated"),
    ('["x * y", "1 / (y - 10)"]', r"boundary\[1\] \('moment'\)\.value at \(100, 10\): .*"
                                  "divides by zero"),
])
def test_an_expression_that_fails_at_a_node_names_the_field_and_the_point(
        tmp_path: Path, value: str, message: str) -> None:
    (tmp_path / "beam.toml").write_text(
        BEAM.replace("NX, NY", "8, 2").replace('["10 * (y - 5) / 5", 0.0]', value))
    with pytest.raises(ml.ModelError, match=message):
        ml.load_model(tmp_path / "beam.toml").assemble({})


def test_a_parameter_named_as_a_coordinate_is_refused_where_it_is_ambiguous(
        tmp_path: Path) -> None:
    (tmp_path / "beam.toml").write_text("[parameters.y]\ndefault = 1.0\n"
                                        + BEAM.replace("NX, NY", "8, 2"))
    with pytest.raises(ml.ModelError, match=r"boundary\[1\] \('moment'\)\.value: .* names "
                                            "the coordinate 'y', which is also a parameter"):
        ml.load_model(tmp_path / "beam.toml").assemble({})
