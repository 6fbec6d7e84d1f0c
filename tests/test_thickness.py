"""Parts of other thicknesses joined by LATIN interfaces (session 44). LATIN's interface
forces are per unit length (a traction times its side's thickness; the interface weights
are lengths), so a perfect pair balances as F_a = −F_b whatever the two thicknesses, and the
search direction is κ E t / L. Before, the fields were tractions of one thickness: two
plates of 3 and 1 mm had no fixed point (η stalled at 0.38) and were refused. Checked against
the monolithic reference (which assembles each part with its own thickness), a closed form
(a block that slides: R = μ N), and an exact scaling (one thickness t everywhere: the same
iterations, forces × t)."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import meshio
import numpy as np
import pytest
from test_held_stops import assert_qois_equal

import multilatin as ml
from multilatin.latin import LatinOptions

PLATES = '''
[analysis]
hypothesis = "plane_stress"
[materials.steel]
E = 2e5
nu = 0.3
[[substructures]]
name = "thick"
x = [0.0, 20.0]
y = [0.0, 10.0]
elements = [4, 2]
material = "steel"
thickness = 3.0
[[substructures]]
name = "thin"
x = [20.0, 40.0]
y = [0.0, 10.0]
elements = [4, 2]
material = "steel"
thickness = 1.0
[[interfaces]]
between = ["thick", "thin"]
type = "{kind}"
{friction}
[[boundary]]
name = "clamp"
face = "thick.left"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "pull"
face = "thin.right"
type = "force"
value = [{pull}, 5.0]
[[qoi]]
name = "u_end"
type = "displacement"
point = [40.0, 5.0]
component = "x"
[[qoi]]
name = "v_end"
type = "displacement"
point = [40.0, 10.0]
component = "y"
[[qoi]]
name = "R_x"
type = "reaction"
boundary = "clamp"
component = "x"
'''

BLOCK = '''
[analysis]
hypothesis = "plane_stress"
[materials.steel]
E = 2e5
nu = 0.3
[materials.alu]
E = 7e4
nu = 0.33
[[bodies]]
name = "foundation"
x = [0.0, 40.0]
y = [0.0, 10.0]
elements = [8, 2]
split = [2, 1]
material = "steel"
thickness = 3.0
[[bodies]]
name = "block"
x = [10.0, 30.0]
y = [10.0, 20.0]
elements = [4, 2]
material = "alu"
thickness = 1.5
[[interfaces]]
between = ["foundation", "block"]
type = "contact"
friction = 0.3
[history.factors]
press = [1.0, 1.0, 1.0, 1.0]
push = [0.0, 1.0, 2.0, 3.0]
[[boundary]]
name = "clamp"
face = "foundation.bottom"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "press"
face = "block.top"
type = "force"
value = [0.0, -10.0]
factor = "press"
[[boundary]]
name = "push"
face = "block.left"
type = "mixed"
components = ["displacement", "force"]
value = [0.001, 0.0]
factor = "push"
[[qoi]]
name = "R_push"
type = "reaction"
boundary = "push"
component = "x"
[[qoi]]
name = "p"
type = "contact_pressure"
between = ["foundation", "block"]
segment = [10.0, 30.0]
[[qoi]]
name = "u_top"
type = "displacement"
point = [20.0, 20.0]
component = "y"
'''


def _relative(a: object, b: object) -> float:
    x, y = np.atleast_1d(np.asarray(a, dtype=float)), np.atleast_1d(np.asarray(b, dtype=float))
    return float(np.abs(x - y).max() / max(np.abs(y).max(), 1e-30))


@pytest.mark.parametrize("kind", ["perfect", "contact"])
@pytest.mark.parametrize("kappa", [0.5, 2.0])
def test_plates_of_other_thicknesses_equal_the_reference(kind: str, kappa: float) -> None:
    """Two plates of 3 and 1 mm end to end, glued and pulled, or in contact and pushed (it
    stays closed and sticks: the shear 5 MPa is below 0.2 × 100 MPa): every QoI equals the
    monolithic reference, at two search directions."""
    pull = 100.0 if kind == "perfect" else -100.0
    model = ml.Model(ml.ModelSpec.from_string(PLATES.format(
        kind=kind, pull=pull, friction="friction = 0.2" if kind == "contact" else ""),
        name="plates"))
    reference = model.reference()
    result = model.solve(options=LatinOptions(kappa=kappa, tol=1e-10, max_iter=3000))
    assert result.converged
    assert_qois_equal(result, reference, 1e-6)
    # the clamp takes the load: 100 MPa over the thin plate's 10 mm × 1 mm
    assert reference.qoi["R_x"] == pytest.approx(-10.0 * pull, rel=1e-9)
    assert result.qoi["R_x"] == pytest.approx(-10.0 * pull, rel=1e-6)


@pytest.mark.parametrize("kappa", [0.5, 2.0])
def test_a_block_of_another_thickness_slides_at_mu_n(kappa: float) -> None:
    """A block of 1.5 mm pressed by 10 MPa on a foundation of 3 mm, its left face pushed
    until it slides: R_push = μ N = 0.3 × 10 × 20 × 1.5 = 90 N once sliding; the mean
    contact pressure is the pressing traction, 10 MPa (a force per area, not per length)."""
    model = ml.Model(ml.ModelSpec.from_string(BLOCK, name="block"))
    reference = model.reference()
    result = model.solve(options=LatinOptions(kappa=kappa, tol=1e-10, max_iter=3000))
    assert_qois_equal(result, reference, 1e-6)
    assert result.qoi["R_push"][-1] == pytest.approx(90.0, rel=1e-6)
    assert result.qoi["p"][0] == pytest.approx(10.0, rel=1e-6)


def test_one_thickness_everywhere_scales_the_forces_only() -> None:
    """B1 at 2.5 mm against 1 mm: the same iterations and displacements, forces × 2.5."""
    text = (resources.files("multilatin") / "models" / "b1.toml").read_text()
    assert text.count("thickness = 1.0") == 1
    one = ml.load_model("b1").solve({"mu1": 0.1, "mu2": 0.3})
    thick = ml.Model(ml.ModelSpec.from_string(text.replace("thickness = 1.0", "thickness = 2.5"),
                                              name="b1")).solve({"mu1": 0.1, "mu2": 0.3})
    assert thick.iterations == one.iterations
    assert _relative(thick.qoi["R_stop"], 2.5 * np.asarray(one.qoi["R_stop"])) < 1e-9
    assert _relative(thick.qoi["u_A"], one.qoi["u_A"]) < 1e-9
    assert _relative(thick.qoi["p_B"], one.qoi["p_B"]) < 1e-9  # a pressure: per area


def test_the_contact_output_is_per_area(tmp_path: Path) -> None:
    """The VTK contact points carry tractions and areas of the part's thickness."""
    model = ml.Model(ml.ModelSpec.from_string(BLOCK, name="block"))
    result = model.solve(options=LatinOptions(tol=1e-10, max_iter=3000))
    from multilatin.io.output import write_vtk

    write_vtk(result, tmp_path)
    contact = meshio.read(tmp_path / "block_contact_step001.vtu")
    area = contact.point_data["area"]
    pressure = contact.point_data["pressure"]
    assert area.sum() == pytest.approx(20.0 * 1.5, rel=1e-9)  # the thinner side: the block
    assert (pressure * area).sum() / area.sum() == pytest.approx(10.0, rel=1e-6)
