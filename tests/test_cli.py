"""The command-line contract other tools rely on."""

import json
import subprocess
import sys

import meshio
import numpy as np
import pytest

from multilatin.cli import main

KEYS = {"converged", "iterations", "indicator", "wall_s", "qoi"}


def run_json(capsys, *argv):
    status = main(list(argv))
    out = capsys.readouterr().out
    return status, json.loads(out)


def test_solve_and_reference_json_share_keys(capsys):
    status, solved = run_json(capsys, "solve", "b0", "--json", "--tol", "1e-9")
    assert status == 0
    status_ref, ref = run_json(capsys, "reference", "b0", "--json")
    assert status_ref == 0
    assert KEYS <= set(solved) and KEYS <= set(ref)
    assert solved["converged"] is True and solved["indicator"] < 1e-9
    assert solved["qoi"]["v_tip"] == pytest.approx(ref["qoi"]["v_tip"], rel=1e-6)


def test_set_changes_the_parameter(capsys):
    _, base = run_json(capsys, "reference", "b0", "--json")
    _, doubled = run_json(capsys, "reference", "b0", "--json", "--set", "P=200")
    assert doubled["params"] == {"P": 200.0}
    assert doubled["qoi"]["v_tip"] == pytest.approx(2 * base["qoi"]["v_tip"], rel=1e-10)


def test_not_converged_exits_3_and_says_so(capsys):
    status = main(["solve", "b0", "--json", "--max-iter", "3"])
    captured = capsys.readouterr()
    assert status == 3
    assert json.loads(captured.out)["converged"] is False
    assert "did not converge" in captured.err


def test_out_writes_vtk_plot_and_tables(tmp_path, capsys):
    assert main(["solve", "b0", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "convergence.png").stat().st_size > 1000
    assert (tmp_path / "qoi.csv").read_text().startswith("step,v_tip [mm],R_clamp [N]")
    pvd = (tmp_path / "vtk" / "b0.pvd").read_text()
    assert pvd.count("<DataSet") == 1  # one step, every substructure in one file
    mesh = meshio.read(tmp_path / "vtk" / "b0_step001.vtu")
    assert mesh.points.shape == (10 * 81, 3)  # each substructure its own points
    assert np.unique(mesh.cell_data["substructure"][0]).size == 10
    tip = np.argmin(np.abs(mesh.points[:, 0] - 200) + np.abs(mesh.points[:, 1] - 10))
    result = json.loads((tmp_path / "result.json").read_text())
    assert mesh.point_data["displacement"][tip, 1] == pytest.approx(result["qoi"]["v_tip"],
                                                                    rel=1e-9)
    assert "von_mises" in mesh.cell_data
    # strains beside stresses: plane stress, σ = D ε cell by cell
    e, nu = 2e5, 0.3
    exx, eyy = mesh.cell_data["strain_xx"][0], mesh.cell_data["strain_yy"][0]
    np.testing.assert_allclose(mesh.cell_data["stress_xx"][0], e / (1 - nu**2) * (exx + nu * eyy),
                               rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(mesh.cell_data["stress_xy"][0],
                               e / (1 + nu) * mesh.cell_data["strain_xy"][0], rtol=1e-9, atol=1e-9)


def test_console_script_is_installed():
    out = subprocess.run([sys.executable, "-m", "multilatin.cli", "models"],
                         capture_output=True, text=True, check=True).stdout
    assert out.startswith("b0:")


def test_b1_figures_and_reference_overlay(tmp_path, capsys):
    status = main(["solve", "b1", "--set", "mu1=0.1", "--set", "mu2=0.3", "--json",
                   "--with-reference", "--out", str(tmp_path)])
    data = json.loads(capsys.readouterr().out)
    assert status == 0
    assert len(data["qoi"]["u_A"]) == 15 and len(data["qoi"]["p_B"]) == 15
    assert isinstance(data["qoi"]["R_stop"], float)
    assert data["qoi"]["R_stop"] == pytest.approx(data["reference"]["qoi"]["R_stop"], rel=5e-3)
    for name in ("deformed.png", "history.png", "convergence.png"):
        assert (tmp_path / name).stat().st_size > 10_000
    assert (tmp_path / "vtk" / "b1.pvd").read_text().count("<DataSet") == 2 * 15
    # the contact tractions as interface fields: on the stop's points they sum to R_stop
    contact = meshio.read(tmp_path / "vtk" / "b1_contact_step015.vtu")
    stop = np.abs(contact.point_data["normal"][:, 0]) > 0.5
    total = np.sum(contact.point_data["pressure"][stop] * contact.point_data["area"][stop])
    assert total == pytest.approx(data["qoi"]["R_stop"], rel=1e-9)
    status = contact.point_data["status"]
    assert set(np.unique(status)) <= {0.0, 1.0, 2.0} and (status == 2.0).any()
    assert np.all(np.abs(contact.point_data["pressure"][status == 0.0]) < 1e-6)
    # the displacement jump: where the stop presses, the face stands at the gap (0.04 mm)
    jump = contact.point_data["displacement_jump"][:, :2]
    pressed = stop & (contact.point_data["pressure"] > 1e-3)
    along = np.einsum("pd,pd->p", jump, contact.point_data["normal"][:, :2])
    assert pressed.any() and along[pressed] == pytest.approx(-0.04, abs=1e-6)
    tangent = np.column_stack([-contact.point_data["normal"][:, 1],
                               contact.point_data["normal"][:, 0]])
    assert contact.point_data["slip"] == pytest.approx(np.einsum("pd,pd->p", jump, tangent))


def test_vtk_has_no_orphan_points_where_a_hole_removed_cells(tmp_path):
    assert main(["solve", "b2", "--set", "rc=0.5", "--out", str(tmp_path)]) == 0
    mesh = meshio.read(tmp_path / "vtk" / "b2_step001.vtu")
    used = np.unique(np.concatenate([block.data.ravel() for block in mesh.cells]))
    assert used.size == mesh.points.shape[0]
    assert mesh.cell_data["material_fraction"][0].min() > 0.0


def test_contact_status_partitions_the_contact_points():
    """With μ1 = μ2 = 0.6 friction holds the centre block (R_stop = 0): the lower interface
    sticks everywhere in the last push step (micro-slip only near the wall-held corner of
    the upper one); with μ = 0 every contact point slides."""
    import multilatin as ml
    from multilatin.io.plots import contact_status

    model = ml.load_model("b1")
    for mu, expect_slip in ((0.6, False), (0.0, True)):
        result = model.solve({"mu1": mu, "mu2": mu})
        status = contact_status(result, step=14)
        total = sum(len(v) for v in status.values())
        frictional = [i for i in result.assembly.interfaces if i.kind == "contact"]
        n_points = sum(result.assembly.substructures[i.sides[0].substructure].mesh.nx + 1
                       for i in frictional) + 25  # + the stop's side
        assert total == n_points
        lower = status["slip"][np.isclose(status["slip"][:, 1], 50.0)]
        if expect_slip:
            # every point slides, but at the corners the stop holds — (50, 50) and, with the
            # wall-held top block, (50, 100) — whose slip increment is at the classification
            # threshold (the stop's point and the contact pair's, both at the corner)
            stuck = status["stick"]
            corners = np.isclose(stuck, [50.0, 50.0]).all(axis=1) | np.isclose(
                stuck, [50.0, 100.0]).all(axis=1)
            assert len(stuck) <= 3 and corners.all()
            assert len(lower) + len(stuck) >= 25
        else:
            assert len(lower) == 0 and len(status["stick"]) > 10 * len(status["slip"])


def test_study_json_contract_and_outputs(capsys, tmp_path):
    status, data = run_json(capsys, "study", "b1", "--grid", "mu1=0.3", "--grid", "mu2=0,0.2",
                            "--compare", "--json", "--out", str(tmp_path))
    assert status == 0
    assert {"cases", "wall_s", "gain", "paper_gain"} <= set(data)
    assert [c["params"] for c in data["cases"]] == [{"mu1": 0.3, "mu2": 0.0},
                                                   {"mu1": 0.3, "mu2": 0.2}]
    for case in data["cases"]:
        assert {"params", "iterations", "wall_s", "converged", "qoi"} <= set(case)
        assert case["converged"] is True and case["qoi"]["R_stop"] > 200
    assert data["gain"] > 0
    report = (tmp_path / "report.html").read_text()
    assert "multilatin study b1 --grid mu1=0.3" in report and "data:image/png" in report
    assert "no geometric parameter: every case reuses the same operators" in report
    assert "[]" not in report and "()" not in report  # no Python reprs
    assert (tmp_path / "response_R_stop.png").stat().st_size > 10_000
    assert (tmp_path / "table.csv").read_text().count("\n") == 3


@pytest.mark.parametrize("argv, field", [
    (["--grid", "mu2=0:0.6:0"], "mu2"),
    (["--grid", "friction=0.1"], "friction"),
    (["--grid", "mu1=0.1,-0.2"], "mu1"),
    (["--grid", "mu1=0.1", "--set", "mu1=0.2"], "mu1"),
])
def test_study_bad_input_exits_2_naming_the_field(capsys, tmp_path, argv, field):
    status = main(["study", "b1", *argv, "--out", str(tmp_path / "s")])
    assert status == 2
    assert field in capsys.readouterr().err
    assert not (tmp_path / "s").exists()


def test_study_with_an_extrapolation_stops_on_eta_alone_and_says_so(capsys, caplog, tmp_path):
    """A study's QoI rule needs the relaxation: with --acceleration rre and no --qoi-rtol the
    cases stop on η alone (a warning says so, the estimates are absent); asked for both, the
    error names qoi_rtol and the way out."""
    from multilatin.cli import _latin_options, build_parser
    from multilatin.latin.options import STUDY_QOI_RTOL

    parser = build_parser()
    assert _latin_options(parser.parse_args(["study", "b1"])).qoi_rtol == STUDY_QOI_RTOL
    assert _latin_options(parser.parse_args(["solve", "b1"])).qoi_rtol is None
    given = parser.parse_args(["study", "b1", "--acceleration", "rre", "--qoi-rtol", "none"])
    assert _latin_options(given).qoi_rtol is None
    with caplog.at_level("WARNING", logger="multilatin"):
        status, data = run_json(capsys, "study", "slide", "--grid", "mu=0.2,0.3",
                                "--acceleration", "rre", "--json", "--out", str(tmp_path / "a"))
    assert status == 0
    assert "stop on eta < 1e-06 alone" in caplog.text
    assert [c["converged"] for c in data["cases"]] == [True, True]
    assert all(c["qoi"]["R_push"][-1] == pytest.approx(20 * 10 * c["params"]["mu"], rel=1e-4)
               for c in data["cases"])  # sliding at the end: R = μ p 20
    status = main(["study", "slide", "--grid", "mu=0.2", "--acceleration", "rre",
                   "--qoi-rtol", "1e-3", "--out", str(tmp_path / "b")])
    assert status == 2
    err = capsys.readouterr().err
    assert "qoi_rtol" in err and "--qoi-rtol none" in err


def test_version_help_defaults_and_verbose_after_the_command(capsys):
    """`--version`; `--help` shows the solver's defaults; `-v` before or after the command."""
    import multilatin as ml
    from multilatin.cli import build_parser

    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    assert capsys.readouterr().out.strip() == f"multilatin {ml.__version__}"
    with pytest.raises(SystemExit):
        main(["solve", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    defaults = ml.LatinOptions()
    for option, value in (("--kappa", defaults.kappa), ("--tol", defaults.tol),
                          ("--max-iter", defaults.max_iter)):
        assert f"{option} {option[2:].upper().replace('-', '_')}" in text
        assert f"(default: {value})" in text
    parser = build_parser()
    assert parser.parse_args(["solve", "b0", "-v"]).verbose == 1
    assert parser.parse_args(["-v", "solve", "b0"]).verbose == 1
    assert parser.parse_args(["study", "b0", "-vv"]).verbose == 2
    assert parser.parse_args(["models"]).verbose == 0


def test_log_lines_name_the_case_and_the_kernel_warm_up_is_quiet(caplog, tmp_path):
    """-v's per-solve lines say which case; the study's two-iteration kernel warm-up does
    not log a "NOT converged" line."""
    import logging

    import multilatin as ml

    with caplog.at_level(logging.INFO, logger="multilatin"):
        ml.load_model("b0").solve({"P": 150.0})
    assert any("b0 (P=150): converged after" in r.getMessage() for r in caplog.records)
    caplog.clear()
    with caplog.at_level(logging.INFO, logger="multilatin"):
        ml.run_study(ml.load_model("b1"), ml.Grid.parse(["mu1=0.3", "mu2=0,0.2"]),
                     out=tmp_path / "study", progress=False)
    messages = [r.getMessage() for r in caplog.records]
    assert any("mu1=0.3, mu2=0.2): converged after" in m for m in messages)
    assert not any("NOT converged" in m for m in messages)
