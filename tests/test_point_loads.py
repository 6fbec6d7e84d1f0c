"""Point loads (``[[point_load]]``): a force at a point, as nodal forces N_a(point) F on
the cell that holds it. Checked: three point loads at the nodes of a loaded face are the
same discrete problem as the face's uniform traction (its consistent nodal loads), in the
reference and in LATIN; a load inside a cell is carried whole by the clamp; LATIN equals
the reference at two κ and on both backends; a point on a contact between two bodies must
name its body."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import has_torch

import multilatin as ml
from multilatin.errors import ModelError

#: a cantilever 100 x 10 mm (two substructures, cells of 5 mm) clamped at x = 0; its tip
#: face loaded by a uniform traction q (MPa), or by the point loads that replace it
BEAM = """
[parameters.q]
default = 2.0
[materials.m]
E = 2e5
nu = 0.3
[[bodies]]
name = "beam"
x = [0.0, 100.0]
y = [0.0, 10.0]
elements = [20, 2]
split = [2, 1]
material = "m"
[history.factors]
ramp = [0.5, 1.0]
[[boundary]]
name = "clamp"
face = "beam.left"
type = "displacement"
value = [0.0, 0.0]
[[qoi]]
name = "v_tip"
type = "displacement"
point = [100.0, 5.0]
component = "y"
[[qoi]]
name = "v_mid"
type = "displacement"
point = [50.0, 10.0]
component = "y"
[[qoi]]
name = "R_y"
type = "reaction"
boundary = "clamp"
component = "y"
[[qoi]]
name = "s_xx"
type = "stress"
point = [12.5, 7.5]
component = "xx"
"""

TRACTION = """
[[boundary]]
name = "tip"
face = "beam.right"
type = "force"
value = [0.0, "-q"]
factor = "ramp"
"""


def _points(loads: list[tuple[float, float, str]]) -> str:
    return "".join(f'\n[[point_load]]\nname = "p{i}"\npoint = [{x}, {y}]\n'
                   f'value = [0.0, "{value}"]\nfactor = "ramp"\n'
                   for i, (x, y, value) in enumerate(loads))


def _model(extra: str) -> ml.Model:
    return ml.Model(ml.ModelSpec.from_string(BEAM + extra, name="beam"))


def test_point_loads_at_a_face_s_nodes_are_its_traction() -> None:
    """q on the tip face (10 mm, two cells) is 2.5 q, 5 q and 2.5 q N at its three nodes:
    the same answers, in the reference exactly and in LATIN within its tolerance."""
    traction = _model(TRACTION)
    points = _model(_points([(100.0, 0.0, "-2.5 * q"), (100.0, 5.0, "-5 * q"),
                             (100.0, 10.0, "-2.5 * q")]))
    reference = traction.reference()
    assert np.asarray(reference.qoi["R_y"]) == pytest.approx([10.0, 20.0], rel=1e-10)
    for name, values in points.reference().qoi.items():
        assert np.asarray(values) == pytest.approx(np.asarray(reference.qoi[name]),
                                                   rel=1e-10), name
    for model in (traction, points):
        latin = model.solve(options=ml.LatinOptions(tol=1e-10))
        for name, values in latin.qoi.items():
            assert np.asarray(values) == pytest.approx(np.asarray(reference.qoi[name]),
                                                       rel=1e-6), name


def test_a_load_inside_a_cell_is_carried_whole_by_the_clamp() -> None:
    """A force of (3, −7) N at (62.3, 3.1), inside a cell: the clamp's reaction is its
    opposite exactly (equilibrium); LATIN equals the reference at two κ, on both backends,
    its QoIs recovered or read from the interface fields."""
    text = BEAM.replace('name = "R_y"\ntype = "reaction"\nboundary = "clamp"\n'
                        'component = "y"\n', 'name = "R_y"\ntype = "reaction"\n'
                        'boundary = "clamp"\ncomponent = "y"\n[[qoi]]\nname = "R_x"\n'
                        'type = "reaction"\nboundary = "clamp"\ncomponent = "x"\n')
    extra = ('\n[[point_load]]\nname = "pin"\npoint = [62.3, 3.1]\nvalue = [3.0, -7.0]\n'
             'factor = "ramp"\n')
    model = ml.Model(ml.ModelSpec.from_string(text + extra, name="beam"))
    reference = model.reference()
    assert np.asarray(reference.qoi["R_x"]) == pytest.approx([-1.5, -3.0], rel=1e-10)
    assert np.asarray(reference.qoi["R_y"]) == pytest.approx([3.5, 7.0], rel=1e-10)
    for backend in ["numpy"] + (["torch"] if has_torch() else []):
        for kappa in (0.5, 2.0):
            for recover in (True, False):
                latin = model.solve(options=ml.LatinOptions(
                    tol=1e-10, kappa=kappa, backend=backend, recover_displacements=recover))
                for name, values in latin.qoi.items():
                    assert np.asarray(values) == pytest.approx(
                        np.asarray(reference.qoi[name]), rel=1e-6), name


#: two blocks in frictional contact at y = 10, the lower one clamped
STACK = """
[materials.m]
E = 2e5
nu = 0.3
[[bodies]]
name = "base"
x = [0.0, 20.0]
y = [0.0, 10.0]
elements = [4, 2]
material = "m"
[[bodies]]
name = "block"
x = [0.0, 20.0]
y = [10.0, 20.0]
elements = [4, 2]
material = "m"
[[interfaces]]
between = ["base", "block"]
type = "contact"
friction = 0.3
[[boundary]]
name = "clamp"
face = "base.bottom"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "side"
face = "block.left"
type = "mixed"
components = ["displacement", "force"]
value = [0.0, 0.0]
[[qoi]]
name = "R"
type = "reaction"
boundary = "clamp"
component = "y"
"""


def test_a_point_on_a_contact_names_its_body() -> None:
    """A point on the contact between two bodies is refused until its body is named; on
    the block, it presses the block on the base, whose clamp carries it whole."""
    load = '\n[[point_load]]\nname = "press"\npoint = [10.0, 10.0]\nvalue = [0.0, -50.0]\n'
    with pytest.raises(ModelError, match=r"point_load\[0\] \('press'\)\.point: \[10.0, "
                                         r"10.0\] lies on .*add body = 'base'"):
        ml.ModelSpec.from_string(STACK + load, name="stack")
    model = ml.Model(ml.ModelSpec.from_string(STACK + load + 'body = "block"\n',
                                              name="stack"))
    assert model.assemble().point_loads[0].substructure == "block"
    reference, latin = model.reference(), model.solve(options=ml.LatinOptions(tol=1e-9))
    assert reference.qoi["R"] == pytest.approx(50.0, rel=1e-10)
    assert latin.qoi["R"] == pytest.approx(50.0, rel=1e-6)


@pytest.mark.parametrize(("extra", "message"), [
    ('[[point_load]]\npoint = [150.0, 5.0]\nvalue = [0.0, 1.0]\n',
     "point_load[0] ('point_load0').point: [150.0, 5.0] lies in no substructure"),
    ('[[point_load]]\npoint = [50.0, 5.0]\nvalue = [1.0]\n',
     "point_load[0] ('point_load0').value"),
    ('[[point_load]]\npoint = [50.0, 5.0]\nvalue = [0.0, 1.0]\nfactor = "push"\n',
     "point_load[0] ('point_load0').factor: 'push' is not a load factor"),
    ('[[point_load]]\npoint = [50.0, 5.0]\nvalue = [0.0, 1.0]\nforce = 3\n',
     "point_load[0]: unknown field 'force'"),
])
def test_a_bad_point_load_names_its_field(extra: str, message: str) -> None:
    with pytest.raises(ModelError) as info:
        ml.ModelSpec.from_string(BEAM + extra, name="beam")
    assert message in str(info.value)


def test_show_lists_the_point_loads(tmp_path: Path,
                                   capsys: pytest.CaptureFixture[str]) -> None:
    from multilatin.cli import main

    path = tmp_path / "beam.toml"
    path.write_text(BEAM + _points([(100.0, 5.0, "-q")]))
    assert main(["show", str(path)]) == 0
    assert "p0: (0, -2) × factor 'ramp' at (100, 5) of beam[1,0]" in capsys.readouterr().out
