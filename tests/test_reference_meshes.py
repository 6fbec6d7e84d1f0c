"""Which mesh the monolithic reference takes for a model with holes (``Model.reference``):
holes in structured rectangles are meshed again with the hole cut out (conforming),
whether the rectangle is a ``[[bodies]]`` entry or a ``[[substructures]]`` one; a hole in a
mesh file is not meshed again: ``auto`` solves the same meshes, ``conforming`` says why
not. Before session 46 both ended in "--split base: no body of that name in [[bodies]]"."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import rectangle, write_gmsh_mesh

import multilatin as ml

PLATE_ON_BASE = """
[analysis]
hypothesis = "plane_stress"
[parameters.xc]
default = 20.0
[materials.steel]
E = 2e5
nu = 0.3
[[substructures]]
name = "base"
x = [0.0, 40.0]
y = [0.0, 10.0]
elements = [16, 4]
material = "steel"
[[substructures]]
name = "plate"
PLATE
material = "steel"
[[holes]]
substructure = "plate"
centre = ["xc", 20.0]
radius = 4.0
[[interfaces]]
between = ["plate", "base"]
type = "contact"
friction = 0.5
[[boundary]]
name = "clamp"
face = "base.bottom"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "press"
face = "plate.top"
type = "force"
value = [0.0, -10.0]
[[boundary]]
name = "hold"
face = "plate.left"
type = "mixed"
components = ["displacement", "force"]
value = [0.0, 0.0]
[[qoi]]
name = "v_top"
type = "displacement"
point = [20.0, 30.0]
component = "y"
"""


def test_a_hole_in_a_structured_substructure_is_meshed_again(tmp_path: Path) -> None:
    (tmp_path / "plate.toml").write_text(PLATE_ON_BASE.replace(
        "PLATE", 'x = [0.0, 40.0]\ny = [10.0, 30.0]\nelements = [32, 16]'))
    model = ml.load_model(tmp_path / "plate.toml")
    conforming = model.reference(mesh="conforming")
    auto = model.reference()
    same = model.reference(mesh="same")
    assert auto.qoi["v_top"] == conforming.qoi["v_top"]
    # two discretisations of one hole: close, not equal
    assert float(conforming.qoi["v_top"]) == pytest.approx(float(same.qoi["v_top"]), rel=0.02)
    assert float(conforming.qoi["v_top"]) != float(same.qoi["v_top"])


def test_a_hole_in_a_mesh_file_is_not_meshed_again(tmp_path: Path) -> None:
    write_gmsh_mesh(tmp_path / "plate.msh", rectangle(0.0, 10.0, 40.0, 20.0, "plate"), 1.5)
    (tmp_path / "plate.toml").write_text(PLATE_ON_BASE.replace(
        "PLATE", 'mesh_file = "plate.msh"'))
    model = ml.load_model(tmp_path / "plate.toml")
    auto, same = model.reference({"xc": 18.0}), model.reference({"xc": 18.0}, mesh="same")
    np.testing.assert_array_equal(auto.qoi["v_top"], same.qoi["v_top"])
    latin = model.solve({"xc": 18.0}, options=ml.LatinOptions(tol=1e-10, max_iter=5000))
    assert float(latin.qoi["v_top"]) == pytest.approx(float(same.qoi["v_top"]), rel=1e-7)
    with pytest.raises(ml.ModelError, match="the hole of substructure 'plate' lies in a mesh "
                       "of its own"):
        model.reference({"xc": 18.0}, mesh="conforming")
