"""Units from the model file to every output a reader opens: study.nc attributes, table.csv
and qoi.csv headers, plot axes (through the same labels), report.html, ``show``."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest
import xarray as xr

import multilatin as ml
from multilatin.cli import main
from multilatin.parameters import label


def test_labels_say_the_unit_and_dimensionless_reads_as_a_dash() -> None:
    assert label("R_stop", "N") == "R_stop [N]"
    assert label("mu1", "1") == "mu1 [–]"
    assert label("free", "") == "free"


def test_a_unit_that_is_not_a_short_text_is_refused_with_its_field() -> None:
    text = (Path(ml.__file__).parent / "models" / "b0.toml").read_text()
    bad = text.replace('unit = "mm"', "unit = 3", 1)
    assert bad != text
    with pytest.raises(ml.ModelError, match=r"qoi\[0\] \('v_tip'\)\.unit: expected a short text"):
        ml.ModelSpec.from_string(bad)


def test_study_outputs_carry_the_units(tmp_path: Path) -> None:
    model = ml.load_model("b1")
    assert model.units["R_stop"] == "N" and model.units["mu2"] == "1"
    grid = ml.Grid({"mu1": [0.3], "mu2": [0.1, 0.2]})
    study = ml.run_study(model, grid, out=tmp_path, progress=False)
    from multilatin.study.report import write_study_outputs

    write_study_outputs(study, tmp_path)
    with xr.open_dataset(tmp_path / "study.nc", engine="scipy") as stored:
        assert stored["R_stop"].attrs["units"] == "N"
        assert stored["u_A"].attrs["units"] == "mm"
        assert stored["mu2"].attrs["units"] == "1"
        assert stored["wall_s"].attrs["units"] == "s"
    with (tmp_path / "table.csv").open(encoding="utf-8") as stream:
        header = next(csv.reader(stream))
    assert "R_stop [N]" in header and "mu2 [–]" in header
    assert "R_stop [N]" in (tmp_path / "report.html").read_text(encoding="utf-8")


def test_solve_outputs_carry_the_units(tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                       ) -> None:
    assert main(["solve", "b0", "--out", str(tmp_path)]) == 0
    with (tmp_path / "qoi.csv").open(encoding="utf-8") as stream:
        assert next(csv.reader(stream)) == ["step", "v_tip [mm]", "R_clamp [N]"]
    assert " mm" in capsys.readouterr().out
    assert main(["show", "b1"]) == 0
    shown = capsys.readouterr().out
    assert "mu1 = 0.3 [–]" in shown and "R_stop [N]" in shown


def test_a_study_of_quantities_over_the_load_steps_tabulates_their_last_step(
        tmp_path: Path) -> None:
    """The slide's QoIs are lists over the load steps: table.csv, the summary and the
    response figures carry each at its last step (they carried none of them before), and
    the value is study.nc's and the closed form's — the block slides, R_push = μ p × 20 mm."""
    from multilatin.study.report import summary_lines, write_study_outputs

    study = ml.run_study(ml.load_model("slide"), ml.Grid({"mu": [0.2, 0.4], "p": [10.0]}),
                         out=tmp_path, progress=False)
    paths = write_study_outputs(study, tmp_path)
    with (tmp_path / "table.csv").open(encoding="utf-8") as stream:
        rows = list(csv.DictReader(stream))
    with xr.open_dataset(tmp_path / "study.nc", engine="scipy") as stored:
        last = stored["R_push"].sel(mode="multiresolution", p=10.0).isel(step=-1)
        for row in rows:
            mu = float(row["mu [–]"])
            value = float(row["R_push at step 10 [N]"])
            assert value == float(last.sel(mu=mu))
            assert value == pytest.approx(mu * 10.0 * 20.0, rel=1e-3)
            assert float(row["R_push_err at step 10 [N]"]) >= 0.0
    assert tmp_path / "response_R_push.png" in paths
    assert any("R_push ≤ " in line and "N (any step)" in line for line in summary_lines(study))


def test_response_figures_mark_the_cases_whose_answer_is_not_unique(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """B1 at (0.2, 0.1) is at the friction limit (``decomposition.uniqueness``): its R_stop
    is one of several, and the response curve marks it — there and nowhere else."""
    import matplotlib.figure

    from multilatin.study.report import plot_response

    study = ml.run_study(ml.load_model("b1"), ml.Grid({"mu1": [0.15, 0.2, 0.25],
                                                       "mu2": [0.1]}),
                         out=tmp_path, progress=False)
    unique = study.dataset["unique"].sel(mode="multiresolution").squeeze().values
    assert list(unique) == [True, False, True]
    marked: dict[str, list[tuple[float, float]]] = {}

    def savefig(self: matplotlib.figure.Figure, path: Path, **kwargs: object) -> None:
        for line in self.axes[0].get_lines():
            if line.get_label() == "not unique":
                marked[Path(path).name] = list(zip(line.get_xdata(), line.get_ydata(),
                                                   strict=True))

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", savefig)
    plot_response(study.dataset, tmp_path, "multiresolution")
    r_stop = float(study.dataset["R_stop"].sel(mode="multiresolution", mu1=0.2).squeeze())
    assert marked["response_R_stop.png"] == [(0.2, r_stop)]
    assert set(marked) == {"response_R_stop.png", "response_u_A.png", "response_p_B.png"}


def test_small_multiples_mark_the_cases_whose_answer_is_not_unique_in_their_panel(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Over three parameters the maps are one panel per hole position: each marks the
    friction pairs at the limit in its own panel (μ1 + μ2 = 0.3 here, at both positions)."""
    import matplotlib.figure

    from multilatin.study.report import plot_response

    study = ml.run_study(ml.load_model("b3"), ml.Grid({"mu1": [0.15, 0.2], "mu2": [0.1, 0.15],
                                                       "xc": [24.0, 26.0]}),
                         out=tmp_path, progress=False)
    flagged = ~study.dataset["unique"].sel(mode="multiresolution")
    assert int(flagged.sum()) == 4
    marked: dict[str, list[set[tuple[float, float]]]] = {}

    def savefig(self: matplotlib.figure.Figure, path: Path, **kwargs: object) -> None:
        marked[Path(path).name] = [
            {(float(x), float(y)) for line in ax.get_lines()
             if line.get_label() == "not unique"
             for x, y in zip(line.get_xdata(), line.get_ydata(), strict=True)}
            for ax in self.axes if ax.get_visible() and ax.get_title()]

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", savefig)
    plot_response(study.dataset, tmp_path, "multiresolution")
    assert marked["response_R_stop.png"] == [{(0.15, 0.15), (0.2, 0.1)}] * 2
