"""Interfaces on part of a side: substructures of different lengths joined where their sides
overlap (two blocks on a base of one substructure), with matching nodes on the shared part."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import multilatin as ml

TIGHT = ml.LatinOptions(tol=1e-10, max_iter=10000)
DATA = Path(__file__).parent / "data"

PATCH = """
[materials.m]
E = 1000.0
nu = 0.25
[[substructures]]
name = "base"
x = [0.0, 20.0]
y = [0.0, 4.0]
elements = [10, 2]
material = "m"
[[substructures]]
name = "left"
x = [0.0, 8.0]
y = [4.0, 12.0]
elements = [4, 4]
material = "m"
[[substructures]]
name = "right"
x = [8.0, 20.0]
y = [4.0, 12.0]
elements = [6, 4]
material = "m"
[[boundary]]
name = "roller_bottom"
face = "base.bottom"
type = "mixed"
components = ["force", "displacement"]
value = [0.0, 0.0]
[[boundary]]
name = "roller_left"
face = "base.left"
type = "mixed"
components = ["displacement", "force"]
value = [0.0, 0.0]
[[boundary]]
name = "roller_left_block"
face = "left.left"
type = "mixed"
components = ["displacement", "force"]
value = [0.0, 0.0]
[[boundary]]
name = "press_left"
face = "left.top"
type = "force"
value = [0.0, -5.0]
[[boundary]]
name = "press_right"
face = "right.top"
type = "force"
value = [0.0, -5.0]
[[qoi]]
name = "ux"
type = "displacement"
point = [20.0, 12.0]
component = "x"
[[qoi]]
name = "uy"
type = "displacement"
point = [20.0, 12.0]
component = "y"
"""


def test_the_shorter_sides_make_interfaces_on_part_of_the_base() -> None:
    model = ml.Model(ml.ModelSpec.from_toml(DATA / "two_blocks_on_a_base.toml"))
    joined = {itf.name: itf for itf in model.assemble().interfaces if len(itf.sides) == 2}
    assert joined["base|left"].sides[0].segment == (4.0, 14.0)
    assert joined["base|right"].sides[0].segment == (14.0, 26.0)
    assert joined["base|right"].kind == "contact"
    assert joined["left|right"].sides[0].segment is None


def test_uniform_compression_is_exact_through_partial_sides() -> None:
    """Patch test: σ_yy = −5 everywhere, u_x = ν 5 x / E, u_y = −5 y / E exactly."""
    result = ml.Model(ml.ModelSpec.from_string(PATCH, name="patch")).solve(options=TIGHT)
    assert result.converged
    assert result.qoi["ux"] == pytest.approx(0.25 * 5.0 * 20.0 / 1000.0, rel=1e-8)
    assert result.qoi["uy"] == pytest.approx(-5.0 * 12.0 / 1000.0, rel=1e-8)


def test_blocks_in_contact_on_part_of_a_side_equal_the_reference() -> None:
    model = ml.Model(ml.ModelSpec.from_toml(DATA / "two_blocks_on_a_base.toml"))
    latin, reference = model.solve(options=TIGHT), model.reference()
    assert latin.qoi["u_top"] == pytest.approx(reference.qoi["u_top"], rel=1e-6)
    # the clamp carries both presses: p × (10 + 12) mm
    assert latin.qoi["R_clamp"] == pytest.approx(220.0, rel=1e-8)
    assert reference.qoi["R_clamp"] == pytest.approx(220.0, rel=1e-8)


@pytest.mark.parametrize(("position", "mu"), [(8.0, 0.5), (30.0, 0.3)])
def test_the_bundled_punch_equals_the_reference_and_slides_at_the_closed_form(
        position: float, mu: float) -> None:
    """``punch``: contact on part of the plate's top side, the punch near the plate's end
    and in the middle. Every step (stick, partial slip, full slip) equal to the monolithic
    contact reference; once it slides, R_push = μ p × 10 (the punch's width)."""
    model = ml.load_model("punch")
    mu_set = {"position": position, "mu": mu}
    latin, reference = model.solve(mu_set, options=TIGHT), model.reference(mu_set)
    for name in ("R_push", "u_plate", "p_mean"):
        np.testing.assert_allclose(latin.qoi[name], reference.qoi[name], rtol=1e-6,
                                   atol=1e-6 * np.max(np.abs(reference.qoi[name])))
    sliding = mu * 20.0 * 10.0
    assert latin.qoi["R_push"][-1] == pytest.approx(sliding, rel=1e-6)
    assert latin.qoi["R_push"][2] < 0.9 * sliding  # the first push steps stick
    np.testing.assert_allclose(latin.qoi["p_mean"][1:], 20.0, rtol=1e-6)


@pytest.mark.parametrize("start", ["neighbour", "zero"])
def test_a_study_moving_the_punch_across_a_substructure_boundary(tmp_path: Path,
                                                                  start: str) -> None:
    """At x = 30 the punch stands on both halves of the plate (two contact interfaces), at
    x = 8 on one: a converged neighbour's fields do not fit, so such a case starts from zero
    (it was a crash), and batches group the cases whose interfaces match."""
    model = ml.load_model("punch")
    grid = ml.Grid({"position": [8.0, 30.0], "mu": [0.3, 0.5]})
    result = ml.run_study(model, grid, out=tmp_path / start, progress=False, start=start)
    assert not result.failed
    starts = {tuple(r["params"].values()): r["start"] for r in result.records}
    assert starts[(30.0, 0.3)] == "zero" and starts[(30.0, 0.5)] in ("zero", "position=30, mu=0.3")
    final = result.dataset["R_push"].sel(mode="multiresolution").isel(step=-1).values
    np.testing.assert_allclose(final, [[60.0, 100.0], [60.0, 100.0]], rtol=2e-3)
