"""Which part a displacement QoI reads (session 44). A point on the boundary between two
parts that are not joined by a perfect interface — a contact that slides or opens — has two
displacements; the QoI used to read the first part listed, silently: the bundled ``slide``
reported the foundation's corner as "the block's lower right corner". Such a point now needs
``body`` (or ``substructure``), and a point of a mesh file is read in the cells that hold it,
not the first part whose extent does (a pin inside a lug's bore)."""

from __future__ import annotations

from importlib import resources

import numpy as np
import pytest

import multilatin as ml
from multilatin.cli import main
from multilatin.latin import LatinOptions

TWO_BODIES = '''
[materials.steel]
E = 2e5
nu = 0.3
[[bodies]]
name = "foundation"
x = [0.0, 40.0]
y = [0.0, 10.0]
elements = [8, 2]
split = [2, 1]
material = "steel"
[[bodies]]
name = "block"
x = [10.0, 30.0]
y = [10.0, 20.0]
elements = [4, 2]
material = "steel"
[[interfaces]]
between = ["foundation", "block"]
type = "{kind}"
friction = 0.3
[[boundary]]
name = "clamp"
face = "foundation.bottom"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "press"
face = "block.top"
type = "force"
value = [1.0, -50.0]
[[qoi]]
name = "u"
type = "displacement"
point = {point}
component = "x"
{extra}
'''


def _spec(kind: str = "contact", point: str = "[20.0, 10.0]", extra: str = "") -> ml.ModelSpec:
    text = TWO_BODIES.format(kind=kind, point=point, extra=extra)
    if kind != "contact":
        text = text.replace("friction = 0.3\n", "")
    return ml.ModelSpec.from_string(text, name="two")


def _node_x(result: ml.SolveResult, body: str, point: tuple[float, float]) -> float:
    """x displacement (last step) of ``body``'s node at ``point``."""
    for sub in result.assembly.substructures:
        if sub.body != body:
            continue
        at = np.flatnonzero(np.all(np.isclose(sub.mesh.nodes, point), axis=1))
        if at.size:
            return float(result.displacements[sub.name][-1, at[0], 0])
    raise AssertionError(f"no node of {body} at {point}")


def test_the_slide_model_reads_the_block_not_the_foundation() -> None:
    """Once the block slides its corner moves with the push, 1e-3 mm a step, while the
    foundation's point stays: the QoI is the block's (before: the foundation's, 1.17e-4 mm
    against the block's 3.7e-3 mm at the last step), in LATIN and in the reference."""
    model = ml.load_model("slide")
    result = model.solve(options=LatinOptions(tol=1e-8))
    reference = model.reference()
    block = _node_x(reference, "block", (20.0, 10.0))
    foundation = _node_x(reference, "foundation", (20.0, 10.0))
    assert block > 10.0 * foundation > 0.0  # the two sides of the point differ
    assert reference.qoi["u_right"][-1] == pytest.approx(block, rel=1e-12)
    assert result.qoi["u_right"][-1] == pytest.approx(block, rel=1e-6)


def test_a_point_on_a_contact_needs_a_body() -> None:
    with pytest.raises(ml.ModelError, match=r"qoi\[0\] \('u'\)\.point: \[20\.0, 10\.0\] lies on "
                       r"'block', 'foundation\[0,0\]', 'foundation\[1,0\]'.*add body = 'block'"):
        _spec()
    # named, each side is read: the block's friction is pulled sideways on the foundation
    results = {body: ml.Model(_spec(extra=f'body = "{body}"')).reference()
               for body in ("block", "foundation")}
    for body, result in results.items():
        assert result.qoi["u"] == pytest.approx(_node_x(result, body, (20.0, 10.0)), rel=1e-12)
    # inside a part, or on a perfect interface (here between the foundation's two halves,
    # and between the two bodies when joined perfectly), no name is needed
    ml.Model(_spec(point="[20.0, 5.0]")).assemble()
    ml.Model(_spec(kind="perfect")).assemble()


@pytest.mark.parametrize(("extra", "message"), [
    ('body = "beam"', r"qoi\[0\] \('u'\)\.body: no body named 'beam'"),
    ('substructure = "foundation[1,0]"\nbody = "block"', r"give body or substructure, not both"),
    ('substructure = "foundation[1,0]"', None),
])
def test_the_named_part_must_hold_the_point(extra: str, message: str | None) -> None:
    if message is not None:
        with pytest.raises(ml.ModelError, match=message):
            _spec(extra=extra)
    else:
        _spec(extra=extra)
    with pytest.raises(ml.ModelError, match=r"\.substructure: the point \[12\.0, 15\.0\] does not "
                       r"lie in 'foundation\[1,0\]' \(it lies in 'block'\)"):
        _spec(point="[12.0, 15.0]", extra='substructure = "foundation[1,0]"')


def _lug_with_point(tmp_path, point: str) -> ml.ModelSpec:
    models = resources.files("multilatin") / "models"
    for name in ("lug.toml", "lug_plate.msh", "lug_pin.msh"):
        (tmp_path / name).write_bytes((models / name).read_bytes())
    path = tmp_path / "lug.toml"
    path.write_text(path.read_text() + f'''
[[qoi]]
name = "u_pin"
type = "displacement"
point = {point}
component = "x"
''')
    return ml.ModelSpec.from_toml(path)


def test_a_point_of_a_mesh_file_is_read_in_the_cells_that_hold_it(tmp_path) -> None:
    """A point of the pin lies in the lug's extent too, in its bore: it is the pin's (before:
    a ValueError from the lug's mesh); a point in the pin's hub hole is in no part."""
    model = ml.Model(_lug_with_point(tmp_path, "[44.0, 0.0]"))
    assembly = model.assemble()
    pin = next(sub for sub in assembly.substructures if sub.name == "pin")
    lug = next(sub for sub in assembly.substructures if sub.name == "lug")
    assert lug.mesh.contains((44.0, 0.0)) and not lug.mesh.holds((44.0, 0.0))
    assert pin.mesh.holds((44.0, 0.0))
    reference = model.reference()
    result = model.solve(options=LatinOptions(tol=1e-8))
    assert result.qoi["u_pin"] == pytest.approx(reference.qoi["u_pin"], rel=1e-5)
    # the pin's nodes near the point bracket the value
    near = np.linalg.norm(pin.mesh.nodes - [44.0, 0.0], axis=1) < 1.0
    u = reference.displacements["pin"][-1, near, 0]
    assert u.min() - 1e-12 <= reference.qoi["u_pin"] <= u.max() + 1e-12
    with pytest.raises(ml.ModelError, match=r"point: \[40\.0, 0\.0\] lies in no substructure "
                       r"\(it lies in the extent of 'lug', 'pin' but in none of its cells"):
        _lug_with_point(tmp_path, "[40.0, 0.0]")


def _b1_with_segment(segment: str, between: str = '["bottom", "centre"]') -> ml.Model:
    """B1 with its p_B over ``segment`` of the contact ``between`` two bodies."""
    text = (resources.files("multilatin") / "models" / "b1.toml").read_text()
    head, qoi = text.split('type = "contact_pressure"')
    assert qoi.count('segment = ["50 - 50 / 6", 50.0]') == 1
    qoi = qoi.replace('segment = ["50 - 50 / 6", 50.0]', f"segment = {segment}").replace(
        'between = ["bottom", "centre"]', f"between = {between}")
    return ml.Model(ml.ModelSpec.from_string(head + 'type = "contact_pressure"' + qoi,
                                             name="b1"))


@pytest.mark.parametrize(("segment", "between", "message"), [
    ("[150.0, 160.0]", '["bottom", "centre"]',
     r"qoi 'p_B': segment \[150\.0, 160\.0\] is not covered by the contact between 'bottom' "
     r"and 'centre': it covers \[0, 50\]"),
    ("[40.0, 60.0]", '["bottom", "centre"]', r"segment \[40\.0, 60\.0\] is not covered"),
    ("[10.0, 20.0]", '["bottom", "top"]', r"there is no contact interface between them"),
])
def test_a_contact_pressure_over_no_contact_is_refused(segment: str, between: str,
                                                       message: str) -> None:
    """A mean contact pressure over a segment the contact does not cover (in part or at
    all) is refused before the solve, its QoI named; it was a ValueError traceback, or,
    in part, a mean over the covered part only (session 44)."""
    model = _b1_with_segment(segment, between)
    with pytest.raises(ml.ModelError, match=message):
        model.solve(options=LatinOptions(max_iter=5))
    if segment == "[40.0, 60.0]":  # the reference, once: after its solve
        with pytest.raises(ml.ModelError, match=message):
            model.reference()
    assert _b1_with_segment("[0.0, 50.0]").solve(
        options=LatinOptions(max_iter=5), check=False).iterations == 5


def test_a_segment_holding_the_whole_contact_means_all_of_it() -> None:
    whole = _b1_with_segment("[-10.0, 100.0]").reference({"mu1": 0.3, "mu2": 0.0})
    exact = _b1_with_segment("[0.0, 50.0]").reference({"mu1": 0.3, "mu2": 0.0})
    assert whole.qoi["p_B"] == pytest.approx(exact.qoi["p_B"], rel=1e-12)


def _lug_with_hole(tmp_path, centre: str) -> ml.ModelSpec:
    _lug_with_point(tmp_path, "[47.0, 0.0]")
    path = tmp_path / "lug.toml"
    path.write_text(path.read_text() + f'''
[[holes]]
name = "h"
shape = "circle"
centre = {centre}
radius = 1.0
''')
    return ml.ModelSpec.from_toml(path)


def test_a_hole_is_placed_in_the_cells_that_hold_its_centre(tmp_path) -> None:
    """A hole centred in the pin, with no body named, was placed in the lug, whose extent
    holds the centre in its bore: it cut nothing, and the lug was solved without it (F =
    1 515.9 N against 1 493.4 N with the hole in the pin). A centre in the pin's hub hole is
    in no part's cells: refused."""
    assembly = ml.Model(_lug_with_hole(tmp_path, "[44.5, 0.0]")).assemble()
    holed = {sub.name for sub in assembly.substructures if sub.hole is not None}
    assert holed == {"pin"}
    with pytest.raises(ml.ModelError, match=r"holes\[0\] \('h'\): the hole at \[40\.0, 0\.0\] "
                       r"lies outside the assembly \(it lies in the extent of 'lug' but in "
                       r"none of its cells"):
        _lug_with_hole(tmp_path, "[40.0, 0.0]")


@pytest.mark.parametrize(("name", "other", "message"), [
    ("R", "R", r"qoi\[1\] \('R'\)\.name: 'R' names qoi\[0\] too"),
    ("mu", "S", r"qoi\[0\] \('mu'\)\.name: 'mu' is a parameter's name"),
    ("converged", "S", r"'converged' is a name the study's outputs use"),
    ("R", "R_err", r"qoi\[1\] \('R_err'\)\.name: 'R_err' is the name of 'R''s error "
     r"estimate"),
    ("R", "R_determined", r"qoi\[1\] \('R_determined'\)\.name: 'R_determined' is the name "
     r"of 'R''s determined flag"),
])
def test_qoi_names_that_would_mix_up_the_outputs_are_refused(name: str, other: str,
                                                              message: str) -> None:
    """Before session 44: two QoIs of one name gave one value (the second's); a QoI named
    ``converged`` or ``iterations`` was written in study.nc in place of that variable; one
    named ``R_err`` beside ``R`` took R's error estimate there; one named as a parameter
    crashed the study after its last case."""
    text = TWO_BODIES.format(kind="contact", point="[20.0, 15.0]", extra="").replace(
        '''[[qoi]]
name = "u"''', f'''[parameters.mu]
default = 0.3
[[qoi]]
name = "{name}"
type = "reaction"
boundary = "clamp"
component = "y"
[[qoi]]
name = "{other}"''').replace("friction = 0.3", 'friction = "mu"')
    with pytest.raises(ml.ModelError, match=message):
        ml.ModelSpec.from_string(text, name="two")


@pytest.mark.parametrize("name", ["mode", "step", "converged", "iterations", "log"])
def test_parameter_names_the_study_outputs_use_are_refused(name: str) -> None:
    """A study over a parameter named ``converged`` (or ``mode``, ``iterations``, ``log``)
    crashed after its last case, writing study.nc; ``step`` became study.nc's step axis."""
    text = TWO_BODIES.format(kind="contact", point="[20.0, 15.0]", extra="")
    with pytest.raises(ml.ModelError, match=rf"parameters\.{name}: '{name}' is a name the "
                       r"study's outputs use"):
        ml.ModelSpec.from_string(f"[parameters.{name}]\ndefault = 1.0\n" + text, name="two")


def test_a_qoi_name_that_is_no_file_name_gets_its_figure(tmp_path) -> None:
    """A study of a QoI named "R/push" crashed after its last case, writing
    response_R/push.png (session 44): its figure is response_R_push.png."""
    text = (resources.files("multilatin") / "models" / "slide.toml").read_text()
    model = tmp_path / "slide.toml"
    model.write_text(text.replace('name = "R_push"', 'name = "R/push"'))
    out = tmp_path / "study"
    assert main(["study", str(model), "--grid", "mu=0.2,0.3", "--out", str(out),
                 "--no-progress"]) == 0
    assert (out / "response_R_push.png").is_file()


def test_show_says_which_part_a_point_is_read_in(capsys) -> None:
    assert main(["show", "slide"]) == 0
    shown = capsys.readouterr().out
    assert "u_right [mm]: x displacement at (20, 10) of block, per load step" in shown
    assert "R_push [N]: x resultant of boundary 'push' on the structure" in shown
    assert main(["show", "b1"]) == 0
    assert ("p_B [MPa]: mean contact pressure between bottom and centre over [41.6667, 50]"
            in capsys.readouterr().out)
