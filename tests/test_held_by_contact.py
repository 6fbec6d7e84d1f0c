"""A body held by friction alone (no prescribed displacement): solved where the load is in
equilibrium with the friction capacity, reported as "no equilibrium" (never an answer, exit
status 3) where it is not."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np
import pytest

import multilatin as ml
from multilatin.cli import main
from multilatin.latin.guards import DRIFT_WINDOW

MODEL = Path(__file__).parent / "data" / "block_on_flat.toml"
CAPACITY = 0.3 * 10.0 * 20.0  # μ p × width: 60 N


@pytest.fixture(scope="module")
def model() -> ml.Model:
    return ml.Model(ml.ModelSpec.from_toml(MODEL))


@pytest.mark.parametrize("q", [2.0, 5.9])
def test_friction_holds_the_block_below_its_capacity(model, q) -> None:
    result = model.solve({"q": q})
    reference = model.reference({"q": q})
    assert result.converged
    # the flat pushes back with the whole push (equilibrium of the block): exact
    assert result.qoi["R_flat"] == pytest.approx(-10.0 * q, rel=1e-4)
    assert reference.qoi["R_flat"] == pytest.approx(-10.0 * q, rel=1e-8)
    assert 10.0 * q < CAPACITY


@pytest.mark.parametrize("qoi_rtol", [None, 1e-3])
def test_no_equilibrium_beyond_the_capacity_is_found_early(model, qoi_rtol) -> None:
    """Under the QoI rule (the studies' default) too: its filter on η stops ("η < tol is no
    QoI accuracy") also held the drift check's verdict back until the cap (session 42)."""
    assert 10.0 * 6.5 > CAPACITY
    result = model.solve({"q": 6.5}, options=ml.LatinOptions(qoi_rtol=qoi_rtol), check=False)
    assert not result.converged
    assert result.failure.startswith("no equilibrium")
    # found by the drift check at its first look, not at the cap of 1000
    assert result.iterations == 2 * DRIFT_WINDOW


def test_no_equilibrium_beyond_the_capacity_is_reported_not_answered(model, capsys) -> None:
    assert 10.0 * 6.5 > CAPACITY
    with pytest.raises(ml.NotConvergedError, match="no equilibrium"):
        model.solve({"q": 6.5})
    with pytest.raises(ml.NotConvergedError):
        model.reference({"q": 6.5})
    assert main(["solve", str(MODEL), "--set", "q=6.5", "--json"]) == 3
    assert '"converged": false' in capsys.readouterr().out


def test_a_study_reaching_past_the_friction_capacity(tmp_path) -> None:
    """A user-style study (an X-FEM hole in a block pushed on a foundation) whose low
    frictions have no equilibrium at the last steps: those cases are flagged, their QoIs
    withheld, each found at the drift check's first look (200 iterations, not the cap of
    1 000 as before session 42 under the studies' QoI rule); the others equal the
    monolithic reference of the same meshes."""
    model = ml.Model(ml.ModelSpec.from_toml(MODEL.parent / "holed_block_on_foundation.toml"))
    grid = ml.Grid({"xc": [8.0, 10.0], "rc": [0.0, 2.0], "mu": [0.2, 0.6]})
    with pytest.warns(RuntimeWarning, match="did not converge"):
        study = ml.run_study(model, grid, out=tmp_path, progress=False)
    for record in study.mode_records("multiresolution"):
        mu = record["params"]
        if mu["mu"] * 200.0 < 90.0:  # the last push, 90 N, beyond μ × 200 N
            assert not record["converged"]
            assert record["iterations"] == 2 * DRIFT_WINDOW
            assert study.dataset["R_clampx"].sel(mode="multiresolution", **mu).isnull().all()
            continue
        assert record["converged"]
        reference = model.reference(mu, mesh="same")
        for name in ("R_clampx", "u_tr"):  # the QoI rule's bound: 1e-3 × max(|q|, 1 % …)
            exact = np.asarray(reference.qoi[name])
            assert record["qoi"][name] == pytest.approx(exact, rel=1e-3,
                                                        abs=1e-5 * np.abs(exact).max())


def test_no_equilibrium_names_the_steps_beyond_the_capacity() -> None:
    """The sliding block pushed by a traction that rises over the steps (factors 0.1 … 0.8
    of 20 T on its left face) against μ p × 20 = 60 N: at T = 4.5 steps 9 and 10 (63, 72 N)
    exceed it, steps 1–8 (up to 54 N) do not. The failure names them (before session 50
    it said "no equilibrium" for the whole history)."""
    text = (resources.files("multilatin") / "models" / "slide.toml").read_text()
    push = '''type = "mixed"
components = ["displacement", "force"]
value = [1.0, 0.0]               # u_x = push (mm), no vertical traction
factor = "push"'''
    factors = "push = [0, 0, 0.0002, 0.0004, 0.0006, 0.0008, 0.001, 0.002, 0.003, 0.004]"
    assert push in text and factors in text
    text = (text.replace(push, 'type = "force"\nvalue = [4.5, 0.0]\nfactor = "push"')
            .replace(factors, "push = [0, 0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8]"))
    text = text[:text.index('[[qoi]]\nname = "R_push"')] + text[
        text.index('[[qoi]]\nname = "u_right"'):]  # a reaction on a force boundary: none
    result = ml.Model(ml.ModelSpec.from_string(text, name="pushed")).solve(check=False)
    assert not result.converged
    assert result.failure.startswith("no equilibrium at step(s) 9, 10 (the other steps "
                                     "settled to ")
