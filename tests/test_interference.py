"""Interference fits: a negative ``gap`` on a contact (or a stop) is an overlap at rest that
the contact pushes apart from the first step (refused before session 47). Closed forms: a
column of two blocks held between rigid faces (uniaxial stress, exact on Q4), a bar pressed
by a stop set inside it (the same), and Lamé's shrink fit of two rings (plane strain), to
which the reference converges at order 2; LATIN equals the reference, on the NumPy and the
PyTorch backends, and a study over the interference gives forces linear in it."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import write_gmsh_ring

import multilatin as ml

#: the press fit of the gallery (examples/press_fit.py): two blocks in a column overlapping
#: by δ, then the upper one pushed sideways (no push at step 1)
PRESS_FIT = Path(__file__).parents[1] / "examples" / "press_fit.toml"


def _column() -> ml.Model:
    return ml.load_model(PRESS_FIT)



def test_a_column_with_an_interference_is_compressed_as_the_closed_form() -> None:
    """Blocks of 10 and 20 mm overlapping by δ between two faces held vertically: a uniform
    stress σ = δ / (10 / E + 20 / E), exact on Q4 cells; the same at μ = 0.3 (one material:
    the lateral strains agree, nothing slips); LATIN (NumPy, PyTorch) = reference."""
    model = _column()
    sigma = 0.001 / (10.0 / 2e5 + 20.0 / 2e5)
    for mu in (0.0, 0.3):
        for result in (model.solve({"mu": mu}, options=ml.LatinOptions(tol=1e-10)),
                       model.solve({"mu": mu}, options=ml.LatinOptions(tol=1e-10,
                                                                        backend="torch")),
                       model.reference({"mu": mu})):
            assert result.qoi["p"][0] == pytest.approx(sigma, rel=1e-8)
            assert result.qoi["R_hold"][0] == pytest.approx(-20.0 * sigma, rel=1e-8)


def test_a_study_over_the_interference_is_linear_in_it() -> None:
    """The answer is linear in δ (no contact opens): the study's forces (warm starts from
    one interference to the next) are δ times the one of unit δ, within its accuracy."""
    model = _column()
    study = ml.run_study(model, ml.Grid.parse(["delta=0.0005:0.002:4"]))
    for record in study.mode_records("multiresolution"):
        delta = record["params"]["delta"]
        assert record["qoi"]["p"][0] == pytest.approx(delta / (30.0 / 2e5), rel=1e-3)


def test_a_stop_set_inside_a_bar_presses_it_by_the_interference(tmp_path: Path) -> None:
    """A bar of 40 mm (two substructures) clamped at its left end, a frictionless stop δ
    inside its right end: uniaxial compression, R = E δ / L × 10 mm exactly."""
    text = """
[parameters.delta]
default = 0.002
[materials.steel]
E = 2e5
nu = 0.3
[[bodies]]
name = "bar"
x = [0.0, 40.0]
y = [0.0, 10.0]
elements = [16, 4]
split = [2, 1]
material = "steel"
[[boundary]]
name = "clamp"
face = "bar.left"
type = "mixed"
components = ["displacement", "force"]
value = [0.0, 0.0]
[[boundary]]
name = "pin"
face = "bar.bottom"
type = "mixed"
components = ["force", "displacement"]
value = [0.0, 0.0]
[[boundary]]
name = "stop"
face = "bar.right"
type = "stop"
gap = "-delta"
[[qoi]]
name = "R_stop"
type = "reaction"
boundary = "stop"
component = "x"
"""
    (tmp_path / "bar.toml").write_text(text)
    model = ml.load_model(tmp_path / "bar.toml")
    for result in (model.solve({}, options=ml.LatinOptions(tol=1e-10)), model.reference({})):
        assert result.qoi["R_stop"] == pytest.approx(-2e5 * 0.002 / 40.0 * 10.0, rel=1e-8)


def test_a_shrink_fit_of_two_rings_converges_to_lame(tmp_path: Path) -> None:
    """Rings 5–10 and 10–20 mm meshed apart (quarter model, mortar along the arc), the
    inner one δ = 0.01 mm too large: Lamé's interface pressure in plane strain, p = δ /
    ((1 + ν) b / E × (((1 − 2ν) b² + c²) / (c² − b²) + ((1 − 2ν) b² + a²) / (b² − a²))) =
    69.23 MPa. The reference converges to it at order ~2 (measured 1.3 % → 0.34 %); LATIN
    equals the reference (the outer radial displacement to 1e-8; the mean pressure to
    1e-3, split differently at the arcs' ends held on both sides by the symmetry)."""
    pytest.importorskip("gmsh")
    a, b, c, young, nu, delta = 5.0, 10.0, 20.0, 210_000.0, 0.3, 0.01
    lame = delta / ((1 + nu) * b / young * (((1 - 2 * nu) * b**2 + c**2) / (c**2 - b**2)
                                           + ((1 - 2 * nu) * b**2 + a**2) / (b**2 - a**2)))
    rings = (Path(__file__).parent / "data" / "rings.toml").read_text()
    text = rings.replace("friction = 0.2", f"friction = 0.2\ngap = {-delta}")
    text = text.replace('[[boundary]]\nname = "p"\nface = "inner.bore"\ntype = "pressure"\n'
                        'value = 100.0\n', "")
    assert "inner.bore" not in text
    (tmp_path / "rings.toml").write_text(text)
    errors = []
    for size in (1.0, 0.5):
        write_gmsh_ring(tmp_path / "inner.msh", a, b, size, ("bore", "rim"))
        write_gmsh_ring(tmp_path / "outer.msh", b, c, 1.6 * size, ("seat", None))
        model = ml.load_model(tmp_path / "rings.toml")
        reference = model.reference()
        errors.append(abs(reference.qoi["p_c"] / lame - 1.0))
        if size == 1.0:
            latin = model.solve(options=ml.LatinOptions(tol=1e-9, max_iter=20000))
            assert latin.converged
            assert latin.qoi["u_out"] == pytest.approx(reference.qoi["u_out"], rel=1e-8)
            assert latin.qoi["p_c"] == pytest.approx(reference.qoi["p_c"], rel=1e-3)
    assert errors[0] < 0.02 and errors[1] < errors[0] / 3.0 and errors[1] < 5e-3


def test_a_press_fit_holds_sideways_up_to_its_friction() -> None:
    """The column's block pushed sideways by a prescribed displacement of its left face:
    the push's force rises while the press fit sticks, then stays at its holding capacity
    μ N = 0.3 × 133.3 N = 40 N once it slides; LATIN at two κ equals the reference (the
    gallery's press_fit study checks the capacity over δ and μ)."""
    model = _column()
    capacity = 0.3 * 20.0 * 0.001 / (30.0 / 2e5)
    reference = model.reference({"mu": 0.3})
    assert reference.qoi["R_push"][0] == pytest.approx(0.0, abs=1e-9)
    assert 0.5 * capacity < reference.qoi["R_push"][1] < capacity
    assert reference.qoi["R_push"][2:] == pytest.approx([capacity] * 4, rel=1e-9)
    for kappa in (0.5, 2.0):
        latin = model.solve({"mu": 0.3}, options=ml.LatinOptions(kappa=kappa))
        assert latin.converged and latin.unique
        assert latin.qoi["R_push"] == pytest.approx(reference.qoi["R_push"], rel=1e-5,
                                                    abs=1e-6 * capacity)


def test_show_lists_each_contact_with_its_friction_and_interference(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``multilatin show`` gives each pair of bodies in contact its law, an interference as
    such, and the pieces a split cuts it into (b1-9: three per contact)."""
    from multilatin.cli import main

    assert main(["show", str(PRESS_FIT)]) == 0
    assert "contacts:\n  base|block: friction 0.3, gap -0.001 (an interference of 0.001)\n" \
        in capsys.readouterr().out
    assert main(["show", "b1-9"]) == 0
    assert "  bottom|centre: friction 0.3, gap 0 (3 interfaces)\n" in capsys.readouterr().out
