"""The small-sliding range (``decomposition.sliding_extent``): contact pairs are set facing
in the undeformed configuration, so a pressed pair that slips more than half its cell no
longer joins the points that touch. Such answers were given silently before session 47 (B1
with a gap of 10 mm: the centre block slides 10 mm, a fifth of its contact, on pairs that
still face as at rest); now both solvers report it, the CLI and the study say so."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import multilatin as ml
from multilatin.cli import main
from multilatin.decomposition.sliding_extent import SLIP_LIMIT


def _pushed_block(tmp_path: Path, push: float) -> ml.Model:
    """The bundled ``slide`` with its left face pushed by up to ``push`` mm: a block of 20
    mm on cells of 1.25 mm, sliding once its friction (60 N) is used."""
    text = (resources.files("multilatin") / "models" / "slide.toml").read_text().replace(
        "push = [0, 0, 0.0002, 0.0004, 0.0006, 0.0008, 0.001, 0.002, 0.003, 0.004]",
        f"push = [0, 0, 0.0002, 0.0004, 0.0006, 0.0008, 0.001, 0.002, 0.003, {push}]")
    (tmp_path / "pushed.toml").write_text(text)
    return ml.load_model(tmp_path / "pushed.toml")


@pytest.mark.parametrize("push", [0.3, 1.0])
def test_a_slide_beyond_half_a_cell_is_reported_with_its_rigid_slip(tmp_path: Path,
                                                                    push: float) -> None:
    """Once the block slides, its bottom moves with the pushed face less the block's own
    strain (micrometres): the slip read is the push to 1 %. Half a cell is 0.625 mm (0.3125
    at the contact's ends): 0.3 mm stays inside, 1 mm is reported, by both solvers, at the
    last step and the contact between the block and the foundation."""
    model = _pushed_block(tmp_path, push)
    latin = model.solve({})
    reference = model.reference({})
    if push < 0.3125:
        assert latin.large_slips == () and reference.large_slips == ()
        return
    for result in (latin, reference):
        (slip,) = result.large_slips
        assert set(slip.bodies) == {"foundation", "block"} and slip.step == 10
        assert slip.slip == pytest.approx(push, rel=0.01)
        assert slip.slip > SLIP_LIMIT * slip.cell
        assert slip.length == pytest.approx(20.0)
    assert latin.large_slips[0].point == reference.large_slips[0].point
    assert latin.to_json_dict()["large_slips"] == [latin.large_slips[0].describe()]


def test_bundled_defaults_stay_in_the_small_sliding_range() -> None:
    """B1 at its default gap (0.04 mm) and the punch slip a few hundredths of a cell."""
    for name in ("b1", "punch"):
        assert ml.load_model(name).solve({}).large_slips == ()


def test_cli_and_study_report_large_slips(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    """B1 with a gap of 1 mm slides 1.01 mm on cells of 2.08 mm (1.04 at the pushed end):
    the CLI prints it, a study flags the case in its summary and in study.nc, and not the
    case at the default gap."""
    assert main(["solve", "b1", "--set", "gap=1"]) == 0
    printed = capsys.readouterr().out
    assert printed.count("LARGE SLIP: step 15: the contact") == 2
    assert main(["study", "b1", "--grid", "gap=0.04,1", "--out", str(tmp_path / "s"),
                 "--no-progress"]) == 0
    assert "LARGE SLIP: 1 case(s)" in capsys.readouterr().out
    with xr.open_dataset(tmp_path / "s" / "study.nc") as data:
        np.testing.assert_array_equal(data["small_sliding"].values, [[True, False]])
