"""Secant starts along geometric grid lines (``multilatin.study.predictors``): which cases
take them, the extrapolation itself, that it starts closer to the answer than the nearest
neighbour on a line of hole positions, and that a study's answers do not move beyond the
requested accuracy."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

import multilatin as ml
from multilatin.latin import LatinOptions
from multilatin.study.plan import clear_operator_cache
from multilatin.study.predictors import (
    extrapolated_fields,
    parallelogram_partners,
    secant_fields,
    secant_partner,
    start_text,
)


def test_the_partner_is_one_step_beyond_along_a_geometric_axis_only() -> None:
    shape = (5, 4)
    assert secant_partner((3, 1), (2, 1), {0}, shape) == (1, 1)
    assert secant_partner((1, 1), (2, 1), {0}, shape) == (3, 1)
    assert secant_partner((0, 1), (1, 1), {0}, shape) == (2, 1)
    assert secant_partner((4, 1), (3, 1), {1}, shape) is None  # not a geometric axis
    assert secant_partner((3, 2), (2, 1), {0, 1}, shape) is None  # a diagonal step
    assert secant_partner((3, 1), (1, 1), {0}, shape) is None  # two steps
    assert secant_partner((1, 3), (1, 2), {1}, (5, 4)) == (1, 1)
    assert secant_partner((1, 0), (1, 1), {1}, (5, 4)) == (1, 2)
    assert secant_partner((1, 1), (1, 0), {1}, (5, 4)) is None  # beyond the grid
    assert secant_partner((1, 1), None, {1}, (5, 4)) is None


def test_the_secant_extrapolates_linearly_in_the_parameter_values() -> None:
    """Uneven values: t = (v − v_P) / (v_P − v_G); a field linear in v is reproduced."""
    grid = ml.Grid({"mu1": [0.3], "xc": [20.0, 21.0, 23.0]})
    slope, offset = np.arange(6.0).reshape(1, 3, 2), np.ones((1, 3, 2))

    def field(v: float) -> tuple[np.ndarray, np.ndarray]:
        return offset + v * slope, 2 * offset - v * slope

    got = secant_fields(grid, (0, 2), (0, 1), field(21.0), (0, 0), field(20.0))
    assert got is not None
    for a, b in zip(got, field(23.0), strict=True):
        assert np.allclose(a, b, rtol=1e-14)
    assert secant_fields(grid, (0, 2), (0, 1), field(21.0), (0, 0),
                         (np.ones((1, 4, 2)), np.ones((1, 4, 2)))) is None
    assert (start_text(grid, (0, 1), ((0, 0),), axes={1})
            == "mu1=0.3, xc=21 (secant with mu1=0.3, xc=20)")
    assert start_text(grid, None) == "zero"


def test_the_parallelogram_takes_the_line_beside_and_its_common_start() -> None:
    """C = (1, 3) from P = (0, 3): Q = (1, 2), R = (0, 2) where R started both P and Q (the
    middle line 0 from its centre 2 outward, line 1 from line 0); the fields ŝ_P + ŝ_Q − ŝ_R
    reproduce a field affine in both parameters."""
    parent = {(0, 2): None, (0, 3): (0, 2), (0, 1): (0, 2), (1, 2): (0, 2), (1, 3): (0, 3),
              (1, 1): (0, 1)}
    shape = (3, 5)
    assert parallelogram_partners((1, 3), (0, 3), {0, 1}, shape, parent) == ((1, 2), (0, 2))
    assert parallelogram_partners((1, 1), (0, 1), {0, 1}, shape, parent) == ((1, 2), (0, 2))
    assert parallelogram_partners((1, 2), (0, 2), {0, 1}, shape, parent) is None  # the centre
    assert parallelogram_partners((1, 3), (0, 3), {0}, shape, parent) is None  # b not geometric
    grid = ml.Grid({"xc": [24.0, 25.0, 26.0], "yc": [73.0, 74.0, 75.0, 76.0, 77.0]})

    def field(i: int, j: int) -> tuple[np.ndarray, np.ndarray]:
        x, y = grid["xc"][i], grid["yc"][j]
        return np.full((1, 2, 2), 2 * x - y), np.full((1, 2, 2), x + 3 * y)

    got = extrapolated_fields(grid, (1, 3), (0, 3), field(0, 3), ((1, 2), (0, 2)),
                              [field(1, 2), field(0, 2)])
    assert got is not None
    for a, b in zip(got, field(1, 3), strict=True):
        assert np.allclose(a, b, rtol=1e-14)
    assert "parallelogram with xc=25, yc=75; xc=24, yc=75" in start_text(
        grid, (0, 3), ((1, 2), (0, 2)))


def test_on_a_line_of_hole_positions_the_secant_starts_closer() -> None:
    """B3, the hole at xc = 23, 24, 25 mm: the secant of the first two converged answers is
    nearer the third's (Ŵ and F̂ of every step, relative) than the second's answer is."""
    model = ml.load_model("b3")
    answers = []
    for xc in (23.0, 24.0, 25.0):
        result = model.solve({"xc": xc}, options=LatinOptions(tol=1e-8, max_iter=3000))
        assert result.converged and result.interface is not None
        answers.append((result.interface.displacement_hat, result.interface.force_hat))
    grid = ml.Grid({"xc": [23.0, 24.0, 25.0]})
    secant = secant_fields(grid, (2,), (1,), answers[1], (0,), answers[0])
    assert secant is not None
    for k in range(2):
        target = answers[2][k]
        nearest = np.linalg.norm(answers[1][k] - target)
        assert np.linalg.norm(secant[k] - target) < 0.5 * nearest


def test_a_study_along_hole_positions_takes_secant_starts(tmp_path: Path) -> None:
    """B3, xc = 23 … 26 (a line from its first value on): the third and fourth cases start
    from the secant of the two cases before them, in the rolling batch and line by line
    alike (the same iterations); with ``start="nearest"`` none does, and R_stop agrees
    within 0.1 % (the study's accuracy)."""
    model = ml.load_model("b3")
    grid = ml.Grid.parse(["xc=23:26:4", "rc=3"])
    runs = {}
    for label, start, rolling in (("rolling", "neighbour", True),
                                  ("lines", "neighbour", False),
                                  ("nearest", "nearest", True)):
        clear_operator_cache()
        study = ml.run_study(model, grid, start=start, out=tmp_path / label, progress=False,
                             rolling=rolling)
        runs[label] = sorted(study.records, key=lambda r: r["number"])
    assert [("secant" in r["start"]) for r in runs["rolling"]] == [False, False, True, True]
    assert runs["rolling"][2]["start"] == "xc=24, rc=3 (secant with xc=23, rc=3)"
    assert [r["start"] for r in runs["lines"]] == [r["start"] for r in runs["rolling"]]
    assert [r["iterations"] for r in runs["lines"]] == [r["iterations"] for r in runs["rolling"]]
    assert not any("secant" in r["start"] for r in runs["nearest"])
    for secant, nearest in zip(runs["rolling"], runs["nearest"], strict=True):
        assert secant["converged"] and secant["unique"]
        assert secant["qoi"]["R_stop"] == pytest.approx(nearest["qoi"]["R_stop"], rel=1e-3)


def _both_starts(model: ml.Model, grid: ml.Grid, tmp_path: Path
                 ) -> dict[str, list[dict[str, Any]]]:
    """The study's records (in traversal order) with the default starts and the nearest."""
    runs = {}
    for start in ("neighbour", "nearest"):
        clear_operator_cache()
        study = ml.run_study(model, grid, start=start, out=tmp_path / start, progress=False)
        runs[start] = sorted(study.records, key=lambda r: r["number"])
    return runs


def test_a_grid_of_hole_positions_takes_parallelogram_starts(tmp_path: Path) -> None:
    """B3, 3 × 3 hole positions from the middle: the middle line from its centre, the other
    two lines from it; their outer cases (four) start from the parallelogram of their
    neighbour in the middle line, the centre of their own line and the middle line's
    centre, after their line's centre has converged; R_stop within 0.1 % of the nearest
    starts' answers."""
    model = ml.load_model("b3")
    grid = ml.Grid.parse(["xc=24:26:3", "yc=74:76:3", "rc=3"])
    runs = _both_starts(model, grid, tmp_path)
    kinds = [r["start"].split(" (")[-1].split(" ")[0] for r in runs["neighbour"]]
    assert kinds.count("parallelogram") == 4 and "secant" not in kinds
    for got, nearest in zip(runs["neighbour"], runs["nearest"], strict=True):
        assert got["converged"] and got["unique"]
        assert got["qoi"]["R_stop"] == pytest.approx(nearest["qoi"]["R_stop"], rel=1e-3)


def test_a_new_geometrys_cases_start_across_geometries(tmp_path: Path) -> None:
    """B3, two hole positions × 3 × 2 frictions (each geometry's cases together, as the
    traversal keeps them): the second geometry's lines after its first start from the
    parallelogram of their friction neighbour and the same frictions at the first geometry
    (four cases, ``across_geometries``); R_stop within 0.1 % of the nearest starts'."""
    from multilatin.study.predictors import across_geometries

    number = {(0, 0): 0, (0, 1): 1, (1, 1): 2, (1, 0): 3}
    assert across_geometries((1, 0), (1, 1), {0}, number) == ((0, 0), (0, 1))
    assert across_geometries((1, 1), (0, 1), {0}, number) is None  # a geometric step
    assert across_geometries((0, 1), (0, 0), {0}, number) is None  # nothing earlier
    model = ml.load_model("b3")
    grid = ml.Grid.parse(["xc=24:25:2", "mu1=0.4:0.6:3", "mu2=0.1,0.2", "rc=3"])
    runs = _both_starts(model, grid, tmp_path)
    across = [r for r in runs["neighbour"] if "parallelogram" in r["start"]]
    assert len(across) == 4
    for record in across:
        assert record["params"]["xc"] == 25.0 and "xc=24" in record["start"].split("with")[1]
    for got, nearest in zip(runs["neighbour"], runs["nearest"], strict=True):
        assert got["converged"] and got["unique"]
        assert got["qoi"]["R_stop"] == pytest.approx(nearest["qoi"]["R_stop"], rel=1e-3)


def test_a_case_beside_a_flagged_hole_position_starts_from_zero(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """B3, two hole positions × 2 × 2 frictions around μ1 + μ2 = 0.3 (a body at the
    friction limit: not unique at every position): at the second position the cases whose
    frictions were flagged at the first start from zero (``not_unique_beside``) instead of
    from a warm attempt set aside; fewer iterations, the same answers (R_stop within
    0.1 %), each flagged case still flagged. (The prediction from a friction neighbour's
    state, ``starts.at_limit``, is left out: it would start some of them from zero too.)"""
    from multilatin.study import starts
    from multilatin.study.predictors import not_unique_beside

    monkeypatch.setattr(starts, "at_limit",
                        lambda assemblies, ops, fields: [False] * len(assemblies))

    assert not_unique_beside((1, 2, 3), (0,), {(0, 2, 3)}) == (0, 2, 3)
    assert not_unique_beside((1, 2, 3), (0,), {(1, 1, 3), (3, 2, 3)}) is None  # μ; 2 steps
    assert not_unique_beside((1, 2, 3), (), {(0, 2, 3)}) is None
    model = ml.load_model("b3")
    grid = ml.Grid.parse(["xc=24:25:2", "mu1=0.1,0.15", "mu2=0.15,0.2", "rc=3"])
    runs = _both_starts(model, grid, tmp_path)
    set_aside = [r for r in runs["nearest"] if "set aside" in r["start"]]
    predicted = [r for r in runs["neighbour"] if r["params"]["xc"] == 25.0
                 and r["start"] == "zero" and not r["unique"]]
    assert len(predicted) >= 1 and len(set_aside) > len(
        [r for r in runs["neighbour"] if "set aside" in r["start"]])
    assert (sum(r["iterations"] for r in runs["neighbour"])
            < sum(r["iterations"] for r in runs["nearest"]))
    for got, nearest in zip(runs["neighbour"], runs["nearest"], strict=True):
        assert got["converged"] and got["unique"] == nearest["unique"]
        assert got["qoi"]["R_stop"] == pytest.approx(nearest["qoi"]["R_stop"], rel=1e-3)


def test_a_step_along_hole_positions_only_is_not_read_for_the_friction_limit() -> None:
    """``along_geometry``: the friction limit is read from a neighbour's state with the
    case's coefficients only where they can differ (a step along a friction axis);
    along hole positions alone ``not_unique_beside`` tells."""
    from multilatin.study.predictors import along_geometry

    assert along_geometry((1, 2, 3), (0, 2, 3), (0,))
    assert along_geometry((1, 2, 3), (0, 1, 3), (0, 1))
    assert not along_geometry((1, 2, 3), (1, 1, 3), (0,))  # a friction step
    assert not along_geometry((1, 2, 3), (0, 1, 3), (0,))  # geometry and friction
    assert along_geometry((1, 2, 3), (1, 2, 3), ())  # the same case: nothing differs
