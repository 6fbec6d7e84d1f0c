"""The contact reference's Newton method where a body floats but for its contact: a plate
pressed on a wider base (nothing holds it sideways but friction), then pushed against a
stop 2 µm away. Its first Newton step from a closed contact at rest takes every pair as
open (λ − r g = 0 read as inactive): the plate floated in the Jacobian, the step was huge,
and the steps cycled at every friction. Since session 46 such a step is solved again with
the kink taken as active, where a pair at rest sticks; the equations are the same. Once
sliding, the stop takes the push less the friction, R_stop = 60 − μ 400 N, or nothing
while friction holds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import rectangle, write_gmsh_mesh

import multilatin as ml

MODEL = """
[analysis]
hypothesis = "plane_stress"
[parameters.mu]
default = 0.3
[materials.steel]
E = 2e5
nu = 0.3
[[substructures]]
name = "base"
x = [-5.0, 45.0]
y = [0.0, 10.0]
elements = [25, 5]
material = "steel"
[[substructures]]
name = "plate"
x = [0.0, 40.0]
y = [10.0, 30.0]
elements = [20, 10]
material = "steel"
[[interfaces]]
between = ["plate", "base"]
type = "contact"
friction = "mu"
[history.factors]
P = [5, 10, 10, 10, 10]
Q = [0, 0, 1, 2, 3]
[[boundary]]
name = "clamp"
face = "base.bottom"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "press"
face = "plate.top"
type = "force"
value = [0.0, -1.0]
factor = "P"
[[boundary]]
name = "push"
face = "plate.left"
type = "force"
value = [1.0, 0.0]
factor = "Q"
[[boundary]]
name = "stop"
face = "plate.right"
type = "stop"
gap = 0.002
[[qoi]]
name = "R_stop"
type = "reaction"
boundary = "stop"
component = "x"
scale = -1.0
[[qoi]]
name = "u_corner"
type = "displacement"
point = [40.0, 30.0]
component = "x"
"""


@pytest.mark.parametrize("mu", [0.05, 0.2])
def test_a_plate_floating_but_for_friction_has_its_reference(tmp_path: Path, mu: float
                                                             ) -> None:
    (tmp_path / "plate.toml").write_text(MODEL)
    model = ml.load_model(tmp_path / "plate.toml")
    reference = model.reference({"mu": mu})
    latin = model.solve({"mu": mu}, options=ml.LatinOptions(tol=1e-10, max_iter=5000))
    stop = np.maximum(np.array([0.0, 0.0, 20.0, 40.0, 60.0]) - mu * 400.0, 0.0)
    np.testing.assert_allclose(reference.qoi["R_stop"], stop, atol=1e-3)
    np.testing.assert_allclose(latin.qoi["R_stop"], stop, atol=1e-3)
    if mu == 0.2:  # friction holds it: one answer, the same from both solvers
        assert reference.unique and latin.unique
        np.testing.assert_allclose(latin.qoi["u_corner"], reference.qoi["u_corner"],
                                   rtol=1e-7)
    else:  # held by the stop and friction at once from step 4: both say so
        assert not reference.unique and not latin.unique


def test_the_same_plate_on_triangles_of_its_own_has_its_reference(tmp_path: Path) -> None:
    """The plate and the base meshed by gmsh (T3, 1.5 and 2 mm: the contact by mortar), at
    μ = 0.1: its first step cycled even with the kink active until a pair at rest counted
    as sticking in the step solved again."""
    write_gmsh_mesh(tmp_path / "plate.msh", rectangle(0.0, 10.0, 40.0, 20.0, "plate"), 1.5)
    write_gmsh_mesh(tmp_path / "base.msh", rectangle(-5.0, 0.0, 50.0, 10.0, "base"), 2.0)
    text = MODEL.replace('x = [-5.0, 45.0]\ny = [0.0, 10.0]\nelements = [25, 5]',
                         'mesh_file = "base.msh"')
    text = text.replace('x = [0.0, 40.0]\ny = [10.0, 30.0]\nelements = [20, 10]',
                        'mesh_file = "plate.msh"')
    assert text.count("mesh_file") == 2
    (tmp_path / "plate.toml").write_text(text)
    model = ml.load_model(tmp_path / "plate.toml")
    reference = model.reference({"mu": 0.1})
    latin = model.solve({"mu": 0.1}, options=ml.LatinOptions(tol=1e-10, max_iter=5000))
    np.testing.assert_allclose(reference.qoi["R_stop"], [0.0, 0.0, 0.0, 0.0, 20.0], atol=1e-3)
    np.testing.assert_allclose(latin.qoi["R_stop"], reference.qoi["R_stop"], atol=1e-6)
    assert not reference.unique and not latin.unique
