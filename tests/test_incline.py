"""Frictional contact on an inclined face, against statics: a block on a 20° slope (two
gmsh meshes of their own, the contact between two named straight faces whose meshes do not
match), pressed by a vertical traction on its lid, then pushed up the slope by a
prescribed horizontal displacement of its back face (free vertically). Once it slides, the
push is R = P tan(θ + φ) with tan φ = μ: the slope's force N n + μ N t (t up the slope)
balances P and R. Exact for the discrete problem too (every contact point slips the same
way along the same normal), so both solvers must give it to their tolerance."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import write_gmsh_mesh

import multilatin as ml

pytest.importorskip("gmsh")

SLOPE = math.radians(20.0)
LENGTH, HEEL, START, END, LID = 60.0, 10.0, 20.0, 40.0, 40.0  # mm
PRESSURE = 10.0  # MPa on the lid: P = 10 × 20 × 1 = 200 N

MODEL = """
[analysis]
hypothesis = "plane_strain"
[parameters.mu]
default = 0.3
min = 0.0
[materials.steel]
E = 2e5
nu = 0.3
[[substructures]]
name = "base"
mesh_file = "base.msh"
material = "steel"
[[substructures]]
name = "block"
mesh_file = "block.msh"
material = "steel"
[[interfaces]]
between = ["block.sole", "base.slope"]
type = "contact"
friction = "mu"
[history.factors]
P = [10, 10, 10, 10]
U = [0, 0.02, 0.04, 0.06]
[[boundary]]
name = "clamp"
face = "base.bottom"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "load"
face = "block.lid"
type = "force"
value = [0.0, -1.0]
factor = "P"
[[boundary]]
name = "push"
face = "block.back"
type = "mixed"
components = ["displacement", "force"]
value = [1.0, 0.0]
factor = "U"
[[qoi]]
name = "R_push"
type = "reaction"
boundary = "push"
component = "x"
[[qoi]]
name = "R_load"
type = "reaction"
boundary = "load"
component = "y"
"""


def _height(x: float) -> float:
    return HEEL + x * math.tan(SLOPE)


def _polygon(gmsh: Any, corners: list[tuple[float, float]], groups: dict[str, list[int]],
             surface: str) -> None:
    """A polygon whose edges i (from corner i to i + 1) are named as ``groups`` says."""
    occ = gmsh.model.occ
    points = [occ.addPoint(x, y, 0.0) for x, y in corners]
    lines = [occ.addLine(points[i], points[(i + 1) % len(points)]) for i in range(len(points))]
    face = occ.addPlaneSurface([occ.addCurveLoop(lines)])
    occ.synchronize()
    for name, edges in groups.items():
        gmsh.model.addPhysicalGroup(1, [lines[i] for i in edges], name=name)
    gmsh.model.addPhysicalGroup(2, [face], name=surface)


@pytest.fixture(scope="module")
def incline(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("incline")
    base = [(0.0, 0.0), (LENGTH, 0.0), (LENGTH, _height(LENGTH)), (0.0, _height(0.0))]
    block = [(START, _height(START)), (END, _height(END)), (END, LID), (START, LID)]
    write_gmsh_mesh(folder / "base.msh",
                    lambda gmsh: _polygon(gmsh, base, {"slope": [2]}, "base"), 2.0)
    write_gmsh_mesh(folder / "block.msh", lambda gmsh: _polygon(
        gmsh, block, {"sole": [0], "lid": [2], "back": [3]}, "block"), 1.5)
    (folder / "incline.toml").write_text(MODEL)
    return folder / "incline.toml"


def _statics(mu: float) -> float:
    load = PRESSURE * (END - START)
    return load * math.tan(SLOPE + math.atan(mu))


@pytest.mark.parametrize("mu", [0.0, 0.3])
def test_a_block_pushed_up_a_slope_needs_p_tan_theta_plus_phi(incline: Path, mu: float
                                                                ) -> None:
    model = ml.load_model(incline)
    reference = model.reference({"mu": mu})
    push = np.asarray(reference.qoi["R_push"])
    np.testing.assert_allclose(push[1:], _statics(mu), rtol=1e-9)  # sliding: statics
    np.testing.assert_allclose(reference.qoi["R_load"], -PRESSURE * (END - START), rtol=1e-12)
    for kappa in (0.5, 2.0):  # the converged answer does not depend on the direction
        latin = model.solve({"mu": mu}, options=ml.LatinOptions(kappa=kappa, tol=1e-10,
                                                                max_iter=3000))
        assert latin.converged
        np.testing.assert_allclose(latin.qoi["R_push"], push, rtol=1e-7)
    if mu > 0.0:  # before the push, friction holds part of the slope's pull
        assert 0.0 < push[0] < _statics(0.0)


def test_a_slope_steeper_than_the_friction_angle_has_no_equilibrium(incline: Path) -> None:
    """Without the push: at μ = 0.5 > tan 20° the block stays (the slope carries the whole
    load); at μ = 0.3 < tan 20° nothing holds it, and both solvers say so instead of
    answering."""
    text = incline.read_text()
    free = text[:text.index('[[boundary]]\nname = "push"')] + text[text.index("[[qoi]]"):]
    free = free.replace('[[qoi]]\nname = "R_push"\ntype = "reaction"\nboundary = "push"\n'
                        'component = "x"\n', "")
    (incline.parent / "free.toml").write_text(free.replace("U = [0, 0.02, 0.04, 0.06]\n", ""))
    model = ml.load_model(incline.parent / "free.toml")
    held = model.solve({"mu": 0.5})
    np.testing.assert_allclose(held.qoi["R_load"], -PRESSURE * (END - START), rtol=1e-12)
    with pytest.raises(ml.NotConvergedError, match="no equilibrium"):
        model.solve({"mu": 0.3})
    with pytest.raises(ml.NotConvergedError):
        model.reference({"mu": 0.3})
