"""The gallery's scripts (``examples/``, shown in the docs) run, and their answers hold
against something independent: the monolithic solution, a conforming mesh, a closed form,
beam theory."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path
from types import ModuleType

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _example(name: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(f"gallery_{name}", EXAMPLES / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def test_b0_cantilever_equals_the_monolithic_solution_and_beam_theory(tmp_path: Path) -> None:
    found = _example("b0_cantilever").run(tmp_path, split=(5, 1))
    assert found["v_tip"] == pytest.approx(found["v_tip_reference"], rel=1e-5)
    assert found["v_tip"] == pytest.approx(found["v_tip_timoshenko"], rel=0.02)
    assert (tmp_path / "vtk" / "b0.pvd").exists() and (tmp_path / "deformed.png").exists()


def test_slide_reaches_the_closed_form_push_force(tmp_path: Path) -> None:
    module = _example("slide_block")
    pushes = module.run(tmp_path, ratios=(1.0, 1000.0))
    for values in pushes.values():
        assert values[-1] == pytest.approx(module.MU * module.PRESSURE * module.WIDTH, rel=1e-3)
    assert (tmp_path / "slide.png").exists()


def test_the_lap_joints_friction_loop_follows_the_reference(tmp_path: Path) -> None:
    """Pulled, pushed back and pulled again: every step within 0.1 N of the monolithic
    reference (the default tolerance; tight agreement is ``tests/test_lap_joint.py``'s), the
    turns at ±μ p A, and an unloading that is not the loading (the path matters)."""
    module = _example("lap_joint")
    found = module.run(tmp_path)
    slip = module.MU * module.PRESSURE * module.AREA
    assert max(abs(a - b) for a, b in zip(found["F_pull"], found["F_pull_reference"],
                                          strict=True)) < 0.1
    assert found["F_pull_reference"][4] == pytest.approx(slip, rel=1e-9)
    assert found["F_pull_reference"][12] == pytest.approx(-slip, rel=1e-9)
    # at zero pull on the way back the joint holds a negative force, not the first step's
    assert found["F_pull_reference"][8] < -0.4 * slip < found["F_pull_reference"][0]
    assert (tmp_path / "lap.png").exists()


def test_press_fit_holds_up_to_its_closed_form_capacity(tmp_path: Path) -> None:
    module = _example("press_fit")
    found = module.run(tmp_path, deltas=2, frictions=(0.1, 0.3))
    for pushes, expected in zip(found["R_push"], found["closed_form"], strict=True):
        assert pushes == pytest.approx(expected, rel=1e-3)  # the study's QoI rule
    assert (tmp_path / "press_fit.png").exists()


def test_a_spinning_fit_loses_its_pressure_as_the_closed_form(tmp_path: Path) -> None:
    """The study over ω: the fit's pressure within 1.5 % of its value at rest of the closed
    form (the meshes' share: 1 % at rest, the reference's too) at every speed, none once
    the fit is open (ω > ω_s), and the separation where the closed form puts it."""
    pytest.importorskip("gmsh")
    module = _example("spinning_fit")
    found = module.run(tmp_path, speeds=6)
    at_rest = found["closed_form"][0]
    for omega, value, exact in zip(found["omega"], found["p_fit"], found["closed_form"],
                                   strict=True):
        assert abs(value - exact) < 0.015 * at_rest
        if omega > 1.02 * found["omega_s"]:
            assert value == 0.0
        elif omega < 0.98 * found["omega_s"]:
            assert value > 0.0
    assert (tmp_path / "spinning_fit.png").exists()


def test_an_axisymmetric_fit_is_pushed_out_at_its_grip(tmp_path: Path) -> None:
    """The study over δ and μ: the push-out force is μ times the fit's own normal
    resultant p̄ 2π b h within the study's QoI rule, and within 1 % + μ × 10 % of the
    closed form with Lamé's pressure (the friction holds the parts' different axial
    strains, which raises the pressure: 1.0 / 1.9 / 2.8 % at μ = 0.1 / 0.2 / 0.3)."""
    module = _example("push_out")
    found = module.run(tmp_path, deltas=2, frictions=(0.1, 0.3))
    for i, delta in enumerate(found["delta"]):
        for j, mu in enumerate(found["mu"]):
            push, pressure = found["R_push"][i][j], found["p_fit"][i][j]
            grip = mu * pressure * 2 * math.pi * module.SEAT * module.HEIGHT
            assert push == pytest.approx(grip, rel=2e-3)
            closed = module.push_out_force(delta, mu)
            assert closed < push < closed * (1.01 + 0.1 * mu)
    assert (tmp_path / "push_out.png").exists()


def test_punch_slides_at_the_closed_form_and_matches_the_reference(tmp_path: Path) -> None:
    module = _example("punch_position")
    pushes = module.run(tmp_path, positions=(6.0, 30.0), checked=6.0)
    sliding = module.MU * module.PRESSURE * module.WIDTH
    for position in ("6", "30"):
        assert pushes[position][-1] == pytest.approx(sliding, rel=1e-3)
    for latin, reference in zip(pushes["6"], pushes["reference"], strict=True):
        assert latin == pytest.approx(reference, rel=1e-3)
    assert pushes["6"][1] > 2 * pushes["30"][1]  # the plate's end makes the stick phase stiffer
    assert (tmp_path / "punch.png").exists()


def test_b1_friction_line_agrees_cold_warm_and_with_the_newton_reference(tmp_path: Path) -> None:
    found = _example("b1_friction_line").run(tmp_path, count=5)
    for warm, cold in zip(found["R_stop_multiresolution"], found["R_stop_cold"], strict=True):
        assert warm == pytest.approx(cold, rel=1e-3, abs=0.05)
    mu2, reference = found["reference"]
    assert mu2 == pytest.approx(0.15)
    assert found["R_stop_multiresolution"][1] == pytest.approx(reference, rel=1e-3)
    assert (tmp_path / "table.csv").exists() and (tmp_path / "report.html").exists()


def test_b1_response_surface_read_between_grid_points_converges_to_direct_solves() -> None:
    """R_stop interpolated in study.nc between the grid's points against direct solves at
    the same random parameter sets: the error falls as the grid is refined (measured 39 N
    on 5 × 5, 12.6 N on 7 × 7, 2.5 N on 13 × 13, over a range of 1 500 N)."""
    example = _example("b1_response_surface")
    coarse, finer = (example.run(count=count, checks=6) for count in (5, 7))
    assert coarse["largest_error"] < 0.05 * coarse["range"]
    assert finer["largest_error"] < coarse["largest_error"] / 2.0
    assert [row[:2] for row in coarse["rows"]] == [row[:2] for row in finer["rows"]]


def test_b2_hole_by_level_set_matches_the_conforming_mesh(tmp_path: Path) -> None:
    pytest.importorskip("gmsh")
    found = _example("b2_plate_hole").run(tmp_path, radii=(0.0, 0.3))
    assert found["u_A_xfem"][0] == pytest.approx(0.3, rel=1e-5)  # no hole: σ L / E
    for xfem, conforming in zip(found["u_A_xfem"], found["u_A_conforming"], strict=True):
        assert xfem == pytest.approx(conforming, rel=1e-3)
    assert found["u_A_xfem"][1] > found["u_A_xfem"][0]
    assert (tmp_path / "b2_radius.png").exists()


def test_b3_warm_started_hole_positions_equal_standalone_solves(tmp_path: Path) -> None:
    import multilatin as ml

    found = _example("b3_hole_in_contact").run(tmp_path, positions=(10.0, 40.0))
    assert all(found["converged"])
    model = ml.load_model("b3")
    for xc, value in zip(found["xc"], found["R_stop"], strict=True):
        alone = float(model.solve({"xc": xc, "rc": 5.0}).qoi["R_stop"])
        assert value == pytest.approx(alone, rel=1e-3)
    assert (tmp_path / "deformed.png").exists()


def test_hertz_contact_converges_to_the_closed_form_and_latin_equals_the_reference(
        tmp_path: Path) -> None:
    """A cylinder on a plate, meshed by gmsh, its curved face joined to the plate's
    non-matching mesh by mortar contact: under refinement near the contact the half-width
    and the peak pressure converge to Hertz's (within the model's own O((a/R)²) ≈ 1 %: a
    finite plate, a = R / 10), and LATIN equals the monolithic reference."""
    pytest.importorskip("gmsh")
    module = _example("hertz_contact")
    rows = module.run(sizes=(0.2, 0.1, 0.05), solver="reference", out=tmp_path)
    a_errors = [abs(row["a_error"]) for row in rows]
    p0_errors = [abs(row["p0_error"]) for row in rows]
    assert a_errors[0] > a_errors[1] > a_errors[2] and a_errors[2] < 0.015
    assert p0_errors[0] > p0_errors[1] > p0_errors[2] and p0_errors[2] < 0.01
    assert (tmp_path / "hertz.png").exists()
    latin = module.run(sizes=(0.1,), solver="latin")[0]
    assert latin["a"] == pytest.approx(rows[1]["a"], rel=1e-12)
    assert latin["p0"] == pytest.approx(rows[1]["p0"], rel=1e-5)


def test_roller_stick_zone_follows_cattaneo_mindlin_and_slides_at_mu_p() -> None:
    """The bundled roller (gmsh meshes, curved face, mortar contact with friction): the stick
    zone's half-width within 0.03 a of Cattaneo–Mindlin's at every shifted step that
    sticks, Q = μ P once it slides, LATIN = the monolithic reference."""
    module = _example("roller_mindlin")
    latin = module.run("latin")
    reference = module.run("reference")
    assert any(row["ratio"] < 0.5 for row in latin) and latin[-1]["ratio"] == pytest.approx(1.0)
    for row, ref in zip(latin, reference, strict=True):
        if row["ratio"] < 0.99:
            assert abs(row["c_over_a"] - row["mindlin"]) < 0.03
        else:
            assert row["Q"] == pytest.approx(module.MU * row["P"], rel=1e-6)
        assert row["Q"] == pytest.approx(ref["Q"], rel=1e-6)
        assert row["c_over_a"] == pytest.approx(ref["c_over_a"], abs=1e-12)


def test_lug_latin_equals_the_reference_and_friction_stiffens_the_joint() -> None:
    """The bundled lug (gmsh meshes, frictional contact between two named curved faces that
    do not match): LATIN equals the monolithic reference; friction raises the pull force
    and lowers the pressure on the axis."""
    module = _example("lug_bearing")
    latin = module.run((0.0, 0.4))
    reference = module.run((0.0, 0.4), solver="reference")
    for row, ref in zip(latin, reference, strict=True):
        assert row["F"] == pytest.approx(ref["F"], rel=1e-6)
        assert row["p_axis"] == pytest.approx(ref["p_axis"], rel=1e-5)
    assert latin[1]["F"] > latin[0]["F"] and latin[1]["p_axis"] < latin[0]["p_axis"]
