"""``type = "stress"`` quantities of interest: σ_xx, σ_yy, σ_xy at a point (D B u in the
cell that holds it). Exact on a patch test in every solver, LATIN equal to the monolithic
solution of the same mesh around a level-set hole, Kirsch's concentration where the mesh
resolves it, the same values in a study (where QoIs are functionals of the interface
fields) as in direct solves, and clear errors for bad input."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np
import pytest

import multilatin as ml

PATCH = """
[materials.steel]
E = 2e5
nu = 0.3
[[bodies]]
name = "plate"
x = [0.0, 20.0]
y = [0.0, 10.0]
elements = [8, 4]
split = [2, 2]
material = "steel"
[[boundary]]
name = "left"
face = "plate.left"
type = "mixed"
components = ["displacement", "force"]
value = [0.0, 0.0]
[[boundary]]
name = "bottom"
face = "plate.bottom"
type = "mixed"
components = ["force", "displacement"]
value = [0.0, 0.0]
[[boundary]]
name = "right"
face = "plate.right"
type = "force"
value = [3.0, 0.0]
[[boundary]]
name = "top"
face = "plate.top"
type = "force"
value = [0.0, 5.0]
"""

#: points inside a cell, on an edge between substructures, at their cross point, near a corner
POINTS = [(7.3, 2.2), (10.0, 3.1), (10.0, 5.0), (19.9, 9.9)]


def _patch(tmp_path: Path) -> ml.Model:
    qois = "".join(
        f'[[qoi]]\nname = "s{c}_{i}"\ntype = "stress"\npoint = [{x}, {y}]\ncomponent = "{c}"\n'
        for i, (x, y) in enumerate(POINTS) for c in ("xx", "yy", "xy"))
    (tmp_path / "patch.toml").write_text(PATCH + qois)
    return ml.load_model(tmp_path / "patch.toml")


def test_the_patch_test_is_exact_at_every_point_in_every_solver(tmp_path: Path) -> None:
    """Biaxial tension 3 and 5 MPa on a plate of four substructures: the stress is (3, 5,
    0) everywhere, read in a cell, on an interface and at a cross point, by LATIN, the
    reference and the PyTorch backend."""
    model = _patch(tmp_path)
    expected = {"xx": 3.0, "yy": 5.0, "xy": 0.0}
    for result in (model.solve({}, options=ml.LatinOptions(tol=1e-12, max_iter=2000)),
                   model.solve({}, options=ml.LatinOptions(tol=1e-12, max_iter=2000,
                                                           backend="torch")),
                   model.reference({})):
        for name, value in result.qoi.items():
            assert value == pytest.approx(expected[name[1:3]], abs=1e-8), (result.method, name)


def _holed_plate(tmp_path: Path) -> ml.Model:
    """B2 (a 3 × 3 mm plate in tension, 0.1 MPa, a hole of radius 0.3 mm by level set on
    cells of 0.1 mm) with stresses at the hole's side (0.01 mm from its edge), at 2r from its
    centre, far from it, and a shear stress beside it."""
    text = (resources.files("multilatin") / "models" / "b2.toml").read_text()
    text += "".join(
        f'[[qoi]]\nname = "{name}"\ntype = "stress"\npoint = [{x}, {y}]\n'
        f'component = "{c}"\nunit = "MPa"\n'
        for name, x, y, c in (("s_edge", 1.81, 1.5, "yy"), ("s_2r", 2.1, 1.5, "yy"),
                              ("s_far", 2.95, 2.95, "yy"), ("t_beside", 1.9, 1.9, "xy")))
    (tmp_path / "holed.toml").write_text(text)
    return ml.load_model(tmp_path / "holed.toml")


def _last(value: object) -> float:
    return float(np.asarray(value).ravel()[-1])


def test_latin_equals_the_same_mesh_reference_around_a_hole(tmp_path: Path) -> None:
    """Around a level-set hole (cut cells), LATIN's stresses equal the monolithic solution of
    the same mesh; σ_yy at 2r is Kirsch's 1.219 σ within 5 % (measured +2.7 %: the plate's
    finite width, W = 5 D) and the conforming mesh's within 1 % (0.6 %); far from the hole
    it is the applied 0.1 MPa within 0.1 %."""
    model = _holed_plate(tmp_path)
    latin = model.solve({}, options=ml.LatinOptions(tol=1e-10))
    same = model.reference({}, mesh="same")
    for name in latin.qoi:
        if name.startswith(("s_", "t_")):
            assert _last(latin.qoi[name]) == pytest.approx(_last(same.qoi[name]), rel=1e-7,
                                                           abs=1e-12), name
    sigma, ratio = 0.1, 0.3 / 0.6
    kirsch = sigma * (1.0 + 0.5 * ratio ** 2 + 1.5 * ratio ** 4)
    assert _last(latin.qoi["s_2r"]) == pytest.approx(kirsch, rel=0.05)
    conforming = model.reference({}, mesh="conforming")
    assert _last(latin.qoi["s_2r"]) == pytest.approx(_last(conforming.qoi["s_2r"]), rel=0.01)
    assert _last(latin.qoi["s_far"]) == pytest.approx(sigma, rel=1e-3)


def test_a_study_reads_stresses_as_direct_solves_do(tmp_path: Path) -> None:
    """In a study the QoIs are functionals of the interface fields, estimated and stopped
    on: over hole radii and positions, the study's stresses equal tight direct solves
    within the study's accuracy (its QoI rule: 1e-3 of each QoI's size), and its error
    estimates bound the difference."""
    model = _holed_plate(tmp_path)
    study = ml.run_study(model, ml.Grid.parse(["rc=0.1:0.3:3", "xc=1.4,1.5"]))
    for record in study.mode_records("multiresolution"):
        tight = model.solve(record["params"], options=ml.LatinOptions(tol=1e-10))
        for name in ("s_edge", "s_2r", "t_beside"):
            error = abs(_last(record["qoi"][name]) - _last(tight.qoi[name]))
            assert error <= 1e-3 * max(abs(_last(tight.qoi[name])), 0.01 * 0.1) + 1e-12
            assert error <= _last(record["qoi_error"][name]) + 1e-12, (record["params"], name)


@pytest.mark.parametrize("change, message", [
    ('component = "yy"', r"qoi\[1\] \('s_edge'\)\.component: expected 'xx' or 'yy' or 'xy'"),
    ('point = [1.81, 1.5]', r"qoi\[1\] \('s_edge'\)\.point: \[1\.6, 1\.5\] lies in a hole"),
])
def test_bad_stress_qois_are_refused_with_the_field(tmp_path: Path, change: str,
                                                    message: str) -> None:
    _holed_plate(tmp_path)
    text = (tmp_path / "holed.toml").read_text()
    wrong = 'component = "x"' if "component" in change else "point = [1.6, 1.5]"
    (tmp_path / "holed.toml").write_text(text.replace(change, wrong, 1))
    with pytest.raises(ml.ModelError, match=message):
        ml.load_model(tmp_path / "holed.toml")
