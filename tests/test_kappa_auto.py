"""``--kappa auto`` (session 38): a study's search direction chosen on its central case,
the κ of 0.5, 1, 2, … that converges there from zero in the fewest iterations under the
study's stopping rule (``study.kappa.choose_kappa``). The answer does not depend on κ; the
iterations do, and by model."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import multilatin as ml
from multilatin.cli import main
from multilatin.latin import LatinOptions
from multilatin.latin.options import STUDY_QOI_RTOL
from multilatin.study.kappa import choose_kappa

STUDY = LatinOptions(qoi_rtol=STUDY_QOI_RTOL)


def test_b1_keeps_the_default_and_the_roller_climbs() -> None:
    """B1: κ = 1 capped at one iteration fewer than 0.5 fails, and the climb stops there;
    below, 0.25 wins the central case (0.3, 0.3) but not the corner (0.6, 0.6), and the
    default is kept (session 49: at 0.25 the B1 13 × 13 study takes 4 956 iterations, at
    0.5 4 362); the roller's curved contact wants a stiffer direction and takes less than
    half the iterations with it."""
    corners = [{"mu1": 0.6, "mu2": 0.6}, {"mu1": 0.0, "mu2": 0.0}]
    b1 = choose_kappa(ml.load_model("b1"), {"mu1": 0.3, "mu2": 0.3}, STUDY, others=corners)
    assert b1.kappa == 0.5 and list(b1.iterations)[:2] == [0.5, 1.0]
    assert b1.iterations[1.0] is None
    assert b1.proposed == 0.25 and b1.checked[-1][0] == corners[0]
    assert b1.checked[-1][2] is None and "0.5 kept" in b1.describe()
    roller = choose_kappa(ml.load_model("roller"), None, STUDY)
    at_default = roller.iterations[0.5]
    assert roller.kappa > 0.5 and at_default is not None
    assert roller.iterations[roller.kappa] is not None
    assert 2 * roller.iterations[roller.kappa] < at_default  # type: ignore[operator]
    assert "kappa auto: " in roller.describe()


def test_a_study_runs_at_the_chosen_kappa_and_says_so(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["study", "lug", "--grid", "mu=0.1,0.2,0.3", "--kappa", "auto", "--json",
                 "--out", str(tmp_path), "--no-progress"]) == 0
    data = json.loads(capsys.readouterr().out)
    chosen = data["kappa_auto"]
    assert chosen["params"] == {"mu": 0.2}  # the grid's central case
    assert chosen["kappa"] in (0.1, 0.25, 0.5, 1.0, 2.0, 5.0, 10.0)
    stored = json.loads((tmp_path / "study.json").read_text())
    assert stored["identity"]["options"]["kappa"] == chosen["kappa"]
    # the same command again resumes the study: the same case, the same choice
    assert main(["study", "lug", "--grid", "mu=0.1,0.2,0.3", "--kappa", "auto",
                 "--out", str(tmp_path), "--no-progress"]) == 0
    assert f"kappa auto: {chosen['kappa']:g} " in capsys.readouterr().out


def test_kappa_auto_is_refused_for_one_solve(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["solve", "b0", "--kappa", "auto"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --kappa auto: chooses the search direction of a study")


def test_a_central_case_with_no_equilibrium_keeps_the_default_and_says_why() -> None:
    """Every κ fails where the central case has no equilibrium (the holed block pushed
    past μ × 200 N): the default is kept, and the line says that none converged rather
    than "no fewer" (session 42)."""
    model = ml.Model(ml.ModelSpec.from_toml(Path(__file__).parent / "data"
                                            / "holed_block_on_foundation.toml"))
    choice = choose_kappa(model, {"xc": 10.0, "rc": 2.0, "mu": 0.4}, STUDY)
    assert choice.kappa == STUDY.kappa
    assert set(choice.iterations.values()) == {None}
    line = choice.describe()
    assert "0.5: not converged" in line and "none converged: the default kept" in line
    assert "no fewer" not in line


def test_a_central_case_with_no_equilibrium_hands_over_to_another_case(tmp_path, capsys) -> None:
    """Where no κ converges on the central case, the next case is read (the CLI: the
    grid's corner of last values, then of first values), and the line names the case
    skipped; the study runs at the κ measured there (session 43)."""
    path = Path(__file__).parent / "data" / "holed_block_on_foundation.toml"
    model = ml.Model(ml.ModelSpec.from_toml(path))
    choice = choose_kappa(model, {"xc": 10.0, "rc": 2.0, "mu": 0.4}, STUDY,
                          others=[{"xc": 10.0, "rc": 2.0, "mu": 0.8}])
    assert choice.skipped == [{"xc": 10.0, "rc": 2.0, "mu": 0.4}]
    assert choice.params == {"xc": 10.0, "rc": 2.0, "mu": 0.8}
    assert choice.iterations[0.5] is not None
    line = choice.describe()
    assert ("no kappa converged at (xc=10, rc=2, mu=0.4); iterations from zero at (xc=10, "
            "rc=2, mu=0.8)") in line
    assert main(["study", str(path), "--grid", "mu=0.2,0.4,0.8", "--set", "xc=10",
                 "--set", "rc=2", "--kappa", "auto", "--json", "--no-progress",
                 "--out", str(tmp_path / "s")]) in (0, 3)
    data = json.loads(capsys.readouterr().out)
    assert data["kappa_auto"]["skipped"] == [{"mu": 0.4}]
    assert data["kappa_auto"]["params"] == {"mu": 0.8}
