"""README stays true: its model file is a valid model whose answer matches the monolithic
reference, its Python example runs, CI runs its test command, and it stays a short user
README (the measurement tables live in docs/)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import multilatin as ml

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")


def _blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", README, re.S)


def test_readme_model_file_solves_and_matches_the_reference() -> None:
    (text,) = _blocks("toml")
    model = ml.Model(ml.ModelSpec.from_string(text, name="readme"))
    latin, reference = model.solve(), model.reference()
    assert latin.converged
    assert latin.qoi["v_tip"] == pytest.approx(reference.qoi["v_tip"], rel=1e-3)
    assert model.units["v_tip"] == "mm"


def test_readme_python_example_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (code,) = _blocks("python")
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {}
    exec(compile(code, "README.md", "exec"), namespace)  # noqa: S102
    study = namespace["study"]
    assert isinstance(study, ml.StudyResult) and not study.failed
    assert (tmp_path / "results" / "line" / "study.nc").exists()


def test_readme_gmsh_example_runs_and_matches_the_reference(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("gmsh")
    (code,) = _blocks("py")
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {}
    exec(compile(code, "README.md", "exec"), namespace)  # noqa: S102
    result, reference = namespace["result"], namespace["reference"]
    assert isinstance(result, ml.SolveResult) and isinstance(reference, ml.SolveResult)
    assert result.converged
    assert result.qoi["u_punch"] == pytest.approx(reference.qoi["u_punch"], rel=1e-4)
    assert (tmp_path / "plate.msh").exists()


def test_ci_runs_the_readme_test_command_and_the_readme_is_short() -> None:
    commands = [b.strip() for b in _blocks("bash") if b.strip().startswith("python3 -m pip")]
    test_command = next(c for c in commands if "pytest" in c)
    assert test_command in (ROOT / ".ci" / "run").read_text()
    assert len(README.encode()) < 10_000


def test_readme_study_commands_plan_on_valid_grids() -> None:
    """Every ``multilatin study`` line of README names a grid its model accepts: each
    geometry of it is built (``plan_study``, nothing solved), so a hole that would cross a
    substructure's boundary fails here, not in a reader's terminal."""
    from multilatin.study.plan import plan_study

    lines = [line.split("#")[0] for block in _blocks("bash")
             for line in block.replace("\\\n", " ").splitlines()
             if line.startswith("multilatin study ")]
    assert len(lines) >= 3
    for line in lines:
        words = line.split()
        grid = ml.Grid.parse([words[i + 1] for i, w in enumerate(words) if w == "--grid"])
        plan_study(ml.load_model(words[2]), grid)
