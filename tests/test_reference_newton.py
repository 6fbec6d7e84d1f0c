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


#: a plate between a clamped base and a pressed block, pushed by its left face 18.7 µm,
#: then back to 5.6 and to −7.5 µm, then to 0 (``benchmarks/random_models.py --family stack``,
#: seed 4): the block rides on the plate, held sideways by friction alone, and the plate
#: slides on the base at steps 3–5, R_push = ±μ p w = ±0.479 × 10.36 × 35 N
STACK = """
[analysis]
hypothesis = "plane_stress"
[materials.soft]
E = 7e4
nu = 0.33
[materials.steel]
E = 2e5
nu = 0.3
[[bodies]]
name = "base"
x = [0.0, 50.0]
y = [0.0, 8.0]
elements = [20, 3]
split = [1, 1]
material = "steel"
[[bodies]]
name = "plate"
x = [0.0, 45.0]
y = [8.0, 14.0]
elements = [20, 3]
split = [1, 1]
material = "soft"
[[bodies]]
name = "block"
x = [0.0, 35.0]
y = [14.0, 24.0]
elements = [12, 4]
split = [2, 1]
material = "steel"
[[interfaces]]
between = ["base", "plate"]
type = "contact"
friction = 0.479
gap = 0.0
[[interfaces]]
between = ["plate", "block"]
type = "contact"
friction = 0.513
gap = 0.0
[history.factors]
press = [0.5, 1, 1, 1, 1, 1]
push = [0, 0, 1, 0.3, -0.4, 0]
[[boundary]]
name = "clamp"
face = "base.bottom"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "pressure"
face = "block.top"
type = "force"
value = [0.0, -10.36]
factor = "press"
[[boundary]]
name = "push"
face = "plate.left"
type = "mixed"
components = ["displacement", "force"]
value = [0.0187, 0.0]
factor = "push"

[[qoi]]
name = "R_push"
unit = "N"
type = "reaction"
boundary = "push"
component = "x"
[[qoi]]
name = "R_clamp_x"
unit = "N"
type = "reaction"
boundary = "clamp"
component = "x"
[[qoi]]
name = "u_block"
unit = "mm"
type = "displacement"
point = [35.0, 24.0]
component = "x"
"""


def test_a_block_riding_on_a_plate_pushed_back_and_forth_has_its_reference(
        tmp_path: Path) -> None:
    """Its first push cycled between slip sets (the block floating in the Jacobian) with
    every augmentation r and 300 iterations; the step is now reached in parts, each from
    the one before, the slips counted from the step before (the same discrete step)."""
    (tmp_path / "stack.toml").write_text(STACK)
    model = ml.load_model(tmp_path / "stack.toml")
    reference = model.reference()
    sliding = 0.479 * 10.36 * 35.0
    np.testing.assert_allclose(reference.qoi["R_push"][2:5], [sliding, -sliding, -sliding],
                               rtol=1e-8)
    latin = model.solve(options=ml.LatinOptions(tol=1e-10, max_iter=5000))
    for name in ("R_push", "R_clamp_x", "u_block"):
        np.testing.assert_allclose(latin.qoi[name], reference.qoi[name], rtol=1e-7,
                                   atol=1e-9 * np.abs(reference.qoi[name]).max())
    assert reference.unique and latin.unique


#: a holed strap dropped 1 µm onto a 10 times stiffer base, pressed, then pulled toward a
#: stop that it reaches at the last step (``benchmarks/random_models.py``, seed 44)
STRAP = """
[analysis]
hypothesis = "plane_strain"
thickness = 2.0
[materials.strap]
E = 200000.0
nu = 0.33
[materials.base]
E = 2000000.0
nu = 0.3
[[bodies]]
name = "base"
x = [0.0, 60.0]
y = [0.0, 10.0]
elements = [24, 4]
split = [2, 1]
material = "base"
[[bodies]]
name = "strap"
x = [5.0, 40.0]
y = [10.0, 18.0]
elements = [20, 4]
split = [1, 1]
material = "strap"
[[holes]]
name = "hole"
body = "strap"
shape = "circle"
centre = [10.74, 13.45]
radius = 1.64
[[interfaces]]
between = ["base", "strap"]
type = "contact"
friction = 0.46
gap = 0.001
[history.factors]
press = [0.5, 1.0, 1.0, 1.0]
pull = [0.0, 0.0, 0.5, 1.0]
[[boundary]]
name = "clamp"
face = "base.bottom"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "pressure"
face = "strap.top"
type = "force"
value = [0.0, -17.54]
factor = "press"
[[boundary]]
name = "pull"
face = "strap.left"
type = "force"
value = [35.69, 0.0]
factor = "pull"
[[boundary]]
name = "stop"
face = "strap.right"
type = "stop"
gap = 0.02
friction = 0.0
[[qoi]]
name = "R_stop"
unit = "N"
type = "reaction"
boundary = "stop"
component = "x"
[[qoi]]
name = "R_clamp_x"
unit = "N"
type = "reaction"
boundary = "clamp"
component = "x"
[[qoi]]
name = "u_corner"
unit = "mm"
type = "displacement"
point = [40.0, 18.0]
component = "x"
"""


def test_a_strap_dropped_onto_its_base_has_its_reference() -> None:
    """Its first step cycled at the augmentation r = E, in one part or in 4 or 16; with r =
    E / 10, which changes no equation (the residuals are exact), it converges. The same
    meshes (X-FEM hole) as LATIN's, which it equals at every step."""
    model = ml.Model(ml.ModelSpec.from_string(STRAP, name="strap"))
    reference = model.reference(mesh="same")
    latin = model.solve(options=ml.LatinOptions(tol=1e-10, max_iter=5000))
    np.testing.assert_allclose(reference.qoi["R_stop"][-1], -6.252, rtol=1e-6)
    for name in ("R_stop", "R_clamp_x", "u_corner"):
        np.testing.assert_allclose(latin.qoi[name], reference.qoi[name], rtol=1e-6,
                                   atol=1e-6 * np.abs(reference.qoi[name]).max())
