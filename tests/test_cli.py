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
    assert (tmp_path / "qoi.csv").read_text().startswith("step,v_tip,R_clamp")
    pvd = (tmp_path / "vtk" / "b0.pvd").read_text()
    assert pvd.count("<DataSet") == 10
    mesh = meshio.read(tmp_path / "vtk" / "beam_9_0__step001.vtu")
    assert mesh.points.shape == (81, 3)
    tip = np.argmin(np.abs(mesh.points[:, 0] - 200) + np.abs(mesh.points[:, 1] - 10))
    result = json.loads((tmp_path / "result.json").read_text())
    assert mesh.point_data["displacement"][tip, 1] == pytest.approx(result["qoi"]["v_tip"],
                                                                    rel=1e-9)
    assert "von_mises" in mesh.cell_data


def test_console_script_is_installed():
    out = subprocess.run([sys.executable, "-m", "multilatin.cli", "models"],
                         capture_output=True, text=True, check=True).stdout
    assert out.startswith("b0:")
