"""Interfaces on part of a side: substructures of different lengths joined where their sides
overlap (two blocks on a base of one substructure), with matching nodes on the shared part."""

from __future__ import annotations

from pathlib import Path

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
