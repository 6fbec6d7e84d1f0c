"""A body held by friction alone (no prescribed displacement): solved where the load is in
equilibrium with the friction capacity, reported as "no equilibrium" (never an answer, exit
status 3) where it is not."""

from __future__ import annotations

from pathlib import Path

import pytest

import multilatin as ml
from multilatin.cli import main

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
    assert result.iterations <= 300  # found by the drift check, not at the cap of 1000


def test_no_equilibrium_beyond_the_capacity_is_reported_not_answered(model, capsys) -> None:
    assert 10.0 * 6.5 > CAPACITY
    with pytest.raises(ml.NotConvergedError, match="no equilibrium"):
        model.solve({"q": 6.5})
    with pytest.raises(ml.NotConvergedError):
        model.reference({"q": 6.5})
    assert main(["solve", str(MODEL), "--set", "q=6.5", "--json"]) == 3
    assert '"converged": false' in capsys.readouterr().out
