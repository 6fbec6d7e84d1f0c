"""Substructures meshed from a file (meshio: gmsh .msh here): exact patch test on an
unstructured Q4 mesh, a file mesh beside a structured one equal to the monolithic solution,
and clear errors for meshes the elements cannot use."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import write_gmsh_mesh, write_gmsh_ring

import multilatin as ml

gmsh = pytest.importorskip("gmsh")
TIGHT = ml.LatinOptions(tol=1e-10, max_iter=10000)


def _gmsh_rectangle(path: Path, width: float, height: float, per_side: int | None,
                    recombine: bool = True, order: int = 1) -> Path:
    """An unstructured mesh of [0, width] × [0, height]; ``per_side``: uniform nodes on the
    right side (to match a neighbour)."""
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Verbosity", 0)
        gmsh.model.add("plate")
        gmsh.model.occ.addRectangle(0.0, 0.0, 0.0, width, height)
        gmsh.model.occ.synchronize()
        if per_side is not None:
            for _, tag in gmsh.model.getEntities(1):
                x0, _, _, x1, _, _ = gmsh.model.getBoundingBox(1, tag)
                if abs(x0 - width) < 1e-9 and abs(x1 - width) < 1e-9:
                    gmsh.model.mesh.setTransfiniteCurve(tag, per_side + 1)
        # a size that divides the height: the side matches the neighbour's nodes either way
        gmsh.option.setNumber("Mesh.MeshSizeMax", height / per_side if per_side else
                              0.15 * height)
        gmsh.option.setNumber("Mesh.RecombineAll", 1 if recombine else 0)
        gmsh.option.setNumber("Mesh.Algorithm", 8 if recombine else 6)
        gmsh.model.mesh.generate(2)
        if order > 1:
            gmsh.model.mesh.setOrder(order)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path


HEAD = """
[materials.m]
E = 1000.0
nu = 0.25
[[substructures]]
name = "plate"
mesh_file = "plate.msh"
material = "m"
"""

TENSION = HEAD + """
[[boundary]]
name = "roller_left"
face = "plate.left"
type = "mixed"
components = ["displacement", "force"]
value = [0.0, 0.0]
[[boundary]]
name = "roller_bottom"
face = "plate.bottom"
type = "mixed"
components = ["force", "displacement"]
value = [0.0, 0.0]
[[boundary]]
name = "pull"
face = "plate.right"
type = "force"
value = [5.0, 0.0]
[[qoi]]
name = "ux"
type = "displacement"
point = [20.0, 10.0]
component = "x"
[[qoi]]
name = "uy"
type = "displacement"
point = [20.0, 10.0]
component = "y"
"""


@pytest.mark.parametrize("recombine", [True, False], ids=["Q4", "T3"])
def test_patch_test_is_exact_on_an_unstructured_mesh_from_gmsh(tmp_path: Path,
                                                                recombine: bool) -> None:
    _gmsh_rectangle(tmp_path / "plate.msh", 20.0, 10.0, None, recombine=recombine)
    (tmp_path / "plate.toml").write_text(TENSION)
    model = ml.Model(ml.ModelSpec.from_toml(tmp_path / "plate.toml"))  # mesh beside the file
    mesh = model.assemble().substructures[0].mesh
    assert mesh.n_cells > 50 and mesh.cells.shape[1] == (4 if recombine else 3)
    result = model.solve(options=TIGHT)
    assert result.qoi["ux"] == pytest.approx(5.0 * 20.0 / 1000.0, rel=1e-8)
    assert result.qoi["uy"] == pytest.approx(-0.25 * 5.0 * 10.0 / 1000.0, rel=1e-8)


@pytest.mark.parametrize("recombine", [True, False], ids=["Q4", "T3"])
def test_a_file_mesh_beside_a_structured_one_equals_the_monolithic_solution(tmp_path,
                                                                            recombine) -> None:
    _gmsh_rectangle(tmp_path / "plate.msh", 20.0, 10.0, per_side=8, recombine=recombine)
    (tmp_path / "beam.toml").write_text(HEAD + """
[[substructures]]
name = "tip"
x = [20.0, 30.0]
y = [0.0, 10.0]
elements = [8, 8]
material = "m"
[[boundary]]
name = "clamp"
face = "plate.left"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "shear"
face = "tip.right"
type = "force"
value = [0.0, -1.0]
[[qoi]]
name = "v_tip"
type = "displacement"
point = [30.0, 5.0]
component = "y"
""")
    model = ml.Model(ml.ModelSpec.from_toml(tmp_path / "beam.toml"))
    kinds = [itf.kind for itf in model.assemble().interfaces if len(itf.sides) == 2]
    assert kinds == ["perfect"]
    latin, reference = model.solve(options=TIGHT), model.reference()
    assert latin.qoi["v_tip"] == pytest.approx(reference.qoi["v_tip"], rel=1e-7)
    assert np.isfinite(latin.qoi["v_tip"]) and latin.qoi["v_tip"] < 0


def test_meshes_the_elements_cannot_use_are_refused(tmp_path: Path) -> None:
    _gmsh_rectangle(tmp_path / "plate.msh", 20.0, 10.0, None, order=2)
    (tmp_path / "plate.toml").write_text(TENSION)
    with pytest.raises(ml.ModelError, match=r"substructures\[0\] \('plate'\)\.mesh_file: .*"
                                            "quad8|quad9"):
        ml.ModelSpec.from_toml(tmp_path / "plate.toml")
    (tmp_path / "missing.toml").write_text(TENSION.replace("plate.msh", "nowhere.msh"))
    with pytest.raises(ml.ModelError, match="cannot read mesh file"):
        ml.ModelSpec.from_toml(tmp_path / "missing.toml")
    (tmp_path / "both.toml").write_text(TENSION.replace('mesh_file = "plate.msh"',
                                                        'mesh_file = "plate.msh"\nelements = [2, 2]'))
    with pytest.raises(ml.ModelError, match="either elements or mesh_file"):
        ml.ModelSpec.from_toml(tmp_path / "both.toml")


def test_twisted_or_non_convex_quadrilaterals_are_refused_by_cell(tmp_path: Path) -> None:
    """A bow-tie (nodes out of order) and a dart-shaped quadrilateral: their signed area may
    be positive, but the Jacobian changes sign inside; the error names the cell."""
    import meshio

    square = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [2.0, 0.0], [2.0, 1.0]])
    for name, second in (("bowtie", [1, 4, 2, 5]), ("dart", [1, 4, 5, 2])):
        nodes = square.copy()
        # the bow-tie made unsymmetric (its signed area is then not zero); the dart's third
        # corner pushed inside: a re-entrant corner
        if name == "dart":
            nodes[5] = [1.2, 0.3]
        else:
            nodes[4] = [2.5, 0.0]
        meshio.write(tmp_path / "plate.msh", meshio.Mesh(
            np.column_stack([nodes * 10.0, np.zeros(len(nodes))]),
            [("quad", np.array([[0, 1, 2, 3], second]))]), file_format="gmsh22", binary=False)
        (tmp_path / "plate.toml").write_text(TENSION)
        with pytest.raises(ml.ModelError, match=r"mesh_file: .*cell 1 \(nodes .*\) is "
                                                "inverted, twisted or not convex"):
            ml.ModelSpec.from_toml(tmp_path / "plate.toml")


HOLE = """
[[holes]]
name = "hole"
body = "plate"
shape = "circle"
centre = [CX, 5.0]
radius = 2.0
"""


def _gmsh_holed(path: Path, size: float, recombine: bool) -> Path:
    """[0, 20] × [0, 10] minus the disc of radius 2 at (10, 5), elements of ``size``."""
    def geometry(gmsh: Any) -> None:
        occ = gmsh.model.occ
        occ.cut([(2, occ.addRectangle(0.0, 0.0, 0.0, 20.0, 10.0))],
                [(2, occ.addDisk(10.0, 5.0, 0.0, 2.0, 2.0))])

    return write_gmsh_mesh(path, geometry, size, recombine)


@pytest.mark.parametrize("recombine", [True, False], ids=["Q4", "T3"])
def test_level_set_hole_on_an_unstructured_mesh_converges_to_the_conforming_mesh(
        tmp_path: Path, recombine: bool) -> None:
    """X-FEM on gmsh meshes (Q4 and T3 cells cut by the circle): the material area
    converges at order 2, the stretch of a plate with a hole converges to that of a fine
    mesh with the hole cut out, and LATIN equals the monolithic solution on the same
    X-FEM mesh."""
    (tmp_path / "holed.toml").write_text(TENSION + HOLE.replace("CX", "10.0"))
    _gmsh_holed(tmp_path / "plate.msh", 0.25, recombine)
    (tmp_path / "plate.toml").write_text(TENSION)
    conforming = ml.Model(ml.ModelSpec.from_toml(tmp_path / "plate.toml")).reference()
    area_errors, stretch_errors = [], []
    for size in (2.0, 1.0, 0.5):
        _sized_rectangle(tmp_path / "plate.msh", size, recombine)
        model = ml.Model(ml.ModelSpec.from_toml(tmp_path / "holed.toml"))
        sub = model.assemble().substructures[0]
        assert sub.cut is not None and sub.cut.cut.size > 0
        cells = sub.mesh.nodes[sub.mesh.cells]
        x, y = cells[..., 0], cells[..., 1]
        cell_area = 0.5 * np.abs(np.sum(x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y,
                                        axis=1))
        area = float(cell_area @ sub.cut.material_fraction)
        area_errors.append(abs(area - (200.0 - np.pi * 4.0)))
        reference = model.reference(mesh="same")
        stretch_errors.append(abs(reference.qoi["ux"] / conforming.qoi["ux"] - 1.0))
    assert area_errors[2] < area_errors[0] / 8.0  # order 2: 16 for two halvings
    assert stretch_errors[0] > stretch_errors[2] and stretch_errors[2] < 5e-3
    latin = model.solve(options=TIGHT)
    assert latin.qoi["ux"] == pytest.approx(reference.qoi["ux"], rel=1e-7)


def _sized_rectangle(path: Path, size: float, recombine: bool) -> Path:
    return write_gmsh_mesh(path, lambda gmsh: gmsh.model.occ.addRectangle(0.0, 0.0, 0.0, 20.0,
                                                                         10.0), size, recombine)


def test_a_level_set_hole_meeting_the_file_mesh_boundary_is_refused(tmp_path: Path) -> None:
    _gmsh_holed(tmp_path / "plate.msh", 1.0, True)
    (tmp_path / "holed.toml").write_text(TENSION + HOLE.replace("CX", "12.5"))
    with pytest.raises(ml.ModelError, match=r"holes\[0\] \('hole'\): the hole meets the "
                                            "boundary of substructure 'plate'"):
        ml.ModelSpec.from_toml(tmp_path / "holed.toml")


def _gmsh_notched(path: Path, closed_hole: bool = False, notch: str = "notch") -> Path:
    """[0, 60] × [0, 20] with a semicircular notch of radius 4 at (30, 20) in its top, the
    notch's arc a physical group ``notch`` (and, with ``closed_hole``, a round hole at (10, 10)
    as one closed group "hole")."""
    def geometry(gmsh: Any) -> None:
        occ = gmsh.model.occ
        tools = [(2, occ.addDisk(30.0, 20.0, 0.0, 4.0, 4.0))]
        if closed_hole:
            tools.append((2, occ.addDisk(10.0, 10.0, 0.0, 2.0, 2.0)))
        occ.cut([(2, occ.addRectangle(0.0, 0.0, 0.0, 60.0, 20.0))], tools)
        occ.synchronize()
        boxes = {notch: (26.0, 34.0, 16.0, 20.0), "hole": (8.0, 12.0, 8.0, 12.0)}
        for name, (x0, x1, y0, y1) in boxes.items():
            arcs = []
            for _, tag in gmsh.model.getEntities(1):
                bx0, by0, _, bx1, by1, _ = gmsh.model.getBoundingBox(1, tag)
                if (bx0 > x0 - 1e-3 and bx1 < x1 + 1e-3 and by0 > y0 - 1e-3
                        and by1 < y1 + 1e-3 and by1 - by0 > 1.0):
                    arcs.append(tag)
            if arcs:
                gmsh.model.addPhysicalGroup(1, arcs, name=name)
        gmsh.model.addPhysicalGroup(2, [tag for _, tag in gmsh.model.getEntities(2)],
                                    name="plate")

    return write_gmsh_mesh(path, geometry, 1.0)


NOTCH = HEAD + """
[[boundary]]
name = "clamp"
face = "plate.left"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "bearing"
face = "plate.notch"             # the mesh file's physical group
type = "force"
value = [0.0, -3.0]
[[qoi]]
name = "v"
type = "displacement"
point = [60.0, 20.0]
component = "y"
"""


def test_a_named_group_of_edges_takes_a_boundary_condition(tmp_path: Path) -> None:
    """A traction on a gmsh physical group (a notch's arc): its resultant is the traction
    times the arc's (polyline) length, the clamp takes it, and LATIN equals the monolithic
    solution."""
    _gmsh_notched(tmp_path / "plate.msh")
    (tmp_path / "notch.toml").write_text(NOTCH)
    model = ml.Model(ml.ModelSpec.from_toml(tmp_path / "notch.toml"))
    mesh = model.assemble().substructures[0].mesh
    arc = mesh.nodes[mesh.side_nodes("notch")]
    assert np.allclose(np.hypot(arc[:, 0] - 30.0, arc[:, 1] - 20.0), 4.0)
    assert arc[0].tolist() == pytest.approx([26.0, 20.0]) and arc[-1].tolist() == \
        pytest.approx([34.0, 20.0])
    normals = mesh.face_normals("notch")  # out of the material: towards the notch's centre
    towards = np.array([30.0, 20.0]) - arc
    assert np.all(np.einsum("ij,ij->i", normals, towards) > 0.0)
    length = float(np.linalg.norm(np.diff(arc, axis=0), axis=1).sum())
    latin, reference = model.solve(options=TIGHT), model.reference()
    for result in (latin, reference):
        assert result.reactions["bearing"][0, 1] == pytest.approx(-3.0 * length, rel=1e-12)
        assert result.reactions["clamp"][0, 1] == pytest.approx(3.0 * length, rel=1e-7)
    assert latin.qoi["v"] == pytest.approx(reference.qoi["v"], rel=1e-7)


def test_a_named_group_takes_no_segment(tmp_path: Path) -> None:
    """``segment`` (a range along a straight side, session 45) has no meaning on a curved
    group: refused, naming the field."""
    _gmsh_notched(tmp_path / "plate.msh")
    text = NOTCH.replace('face = "plate.notch"', 'face = "plate.notch"\nsegment = [26, 30]')
    assert text != NOTCH
    (tmp_path / "notch.toml").write_text(text)
    with pytest.raises(ml.ModelError, match=r"\.segment: a segment applies to a side"):
        ml.ModelSpec.from_toml(tmp_path / "notch.toml")


def test_a_group_named_as_a_side_is_refused(tmp_path: Path) -> None:
    """A group named "top" (the notch's arc) was shadowed by the extent's top side: face =
    "plate.top" loaded the straight top edges beside the notch instead, silently (session
    44)."""
    _gmsh_notched(tmp_path / "plate.msh", notch="top")
    (tmp_path / "a.toml").write_text(NOTCH.replace("plate.notch", "plate.top"))
    with pytest.raises(ml.ModelError, match=r"group 'top' has the name of a side of the "
                       r"part's extent \(bottom, right, top, left\), which face = "
                       r"\"<part>\.top\" reads; rename the group"):
        ml.ModelSpec.from_toml(tmp_path / "a.toml")


def test_named_groups_errors_name_the_groups(tmp_path: Path) -> None:
    _gmsh_notched(tmp_path / "plate.msh", closed_hole=True)
    (tmp_path / "a.toml").write_text(NOTCH.replace("plate.notch", "plate.slot"))
    with pytest.raises(ml.ModelError, match=r"boundary\[1\] \('bearing'\).face: body 'plate' "
                       r"has no side or group named 'slot' \(sides: bottom, right, top, left; "
                       r"groups of its mesh files: hole, notch\)"):
        ml.ModelSpec.from_toml(tmp_path / "a.toml")
    (tmp_path / "b.toml").write_text(NOTCH.replace("plate.notch", "plate.hole"))
    with pytest.raises(ml.ModelError, match="group 'hole' .* is not one open chain of edges"):
        ml.ModelSpec.from_toml(tmp_path / "b.toml")
    (tmp_path / "c.toml").write_text(NOTCH.replace('type = "force"\nvalue = [0.0, -3.0]',
                                                   'type = "stop"'))
    with pytest.raises(ml.ModelError, match="a named group of edges takes displacement, force "
                       "or mixed conditions, not 'stop'"):
        ml.ModelSpec.from_toml(tmp_path / "c.toml")


RINGS = (Path(__file__).parent / "data" / "rings.toml").read_text()



def test_curved_faces_in_contact_converge_to_lame(tmp_path: Path) -> None:
    """Two rings pressed together by a pressure inside the inner one (quarter model): contact
    between two named curved faces meshed differently (mortar along the arc, normals from
    the geometry), a pressure on a curved face. Same material: the contact pressure and the
    outer radial displacement of Lamé's single cylinder 5 <= r <= 20, to which the
    monolithic solution converges at order 2 under refinement; LATIN equals it."""
    a, b, c, p, young, nu = 5.0, 10.0, 20.0, 100.0, 210_000.0, 0.3
    contact = p * a**2 * (c**2 / b**2 - 1.0) / (c**2 - a**2)
    u_outer = (1 + nu) / young * p * a**2 / (c**2 - a**2) * ((1 - 2 * nu) * c + c)
    (tmp_path / "rings.toml").write_text(RINGS)
    errors = []
    for size in (1.0, 0.5):
        write_gmsh_ring(tmp_path / "inner.msh", a, b, size, ("bore", "rim"))
        write_gmsh_ring(tmp_path / "outer.msh", b, c, 1.6 * size, ("seat", None))
        model = ml.Model(ml.ModelSpec.from_toml(tmp_path / "rings.toml"))
        reference = model.reference()
        errors.append((abs(reference.qoi["p_c"] / contact - 1.0),
                       abs(reference.qoi["u_out"] / u_outer - 1.0)))
        if size == 1.0:
            latin = model.solve(options=ml.LatinOptions(tol=1e-9, max_iter=20000))
            assert latin.converged
            assert latin.qoi["u_out"] == pytest.approx(reference.qoi["u_out"], rel=1e-8)
            # the mean pressure differs by 1.5e-4: at the arcs' ends, held on both sides by
            # the symmetry, only the sum of the contact and support forces is determined,
            # and the two solvers split it differently (the end normals lean by h / 2R)
            assert latin.qoi["p_c"] == pytest.approx(reference.qoi["p_c"], rel=1e-3)
    assert errors[0][0] < 0.01 and errors[1][0] < errors[0][0] / 3.0 and errors[1][0] < 2e-3
    assert errors[0][1] < 0.03 and errors[1][1] < errors[0][1] / 3.0 and errors[1][1] < 5e-3


def test_named_faces_apart_are_refused(tmp_path: Path) -> None:
    """Named faces are taken to touch: faces with a clearance between them are refused by
    name, never solved as if they touched."""
    write_gmsh_ring(tmp_path / "inner.msh", 5.0, 10.0, 1.0, ("bore", "rim"))
    write_gmsh_ring(tmp_path / "outer.msh", 10.5, 20.0, 1.6, ("seat", None))
    (tmp_path / "rings.toml").write_text(RINGS)
    with pytest.raises(ml.ModelError, match=r"interfaces\[0\].between: 'inner.rim' and "
                       r"'outer.seat' do not touch: \d+ node\(s\) 0.5 apart at most"):
        ml.ModelSpec.from_toml(tmp_path / "rings.toml")


def _two_parts(path: Path) -> Path:
    """One gmsh file of two parts meshed apart (their nodes do not match where they touch):
    a block [10, 30] × [10, 20] on a base [0, 40] × [0, 10], named groups of surfaces."""
    def geometry(gmsh: Any) -> None:
        occ = gmsh.model.occ
        base = occ.addRectangle(0.0, 0.0, 0.0, 40.0, 10.0)
        block = occ.addRectangle(10.0, 10.0, 0.0, 20.0, 10.0)
        occ.synchronize()
        gmsh.model.addPhysicalGroup(2, [base], name="base")
        gmsh.model.addPhysicalGroup(2, [block], name="block")
        gmsh.model.mesh.setSize(gmsh.model.getBoundary([(2, block)], recursive=True), 1.3)

    return write_gmsh_mesh(path, geometry, 2.0)


PARTS = """
[materials.m]
E = 1000.0
nu = 0.3
[[substructures]]
name = "base"
mesh_file = "parts.msh"
mesh_part = "base"
material = "m"
[[substructures]]
name = "block"
mesh_file = "parts.msh"
mesh_part = "block"
material = "m"
[[boundary]]
name = "clamp"
face = "base.bottom"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "load"
face = "block.top"
type = "force"
value = [0.5, -2.0]
[[qoi]]
name = "u"
type = "displacement"
point = [30.0, 20.0]
component = "x"
"""


def test_parts_of_one_mesh_file_are_substructures(tmp_path: Path) -> None:
    """``mesh_part``: each named group of surfaces of one file is a substructure; the two
    parts touch with other meshes there (mortar), and LATIN equals the monolithic solution;
    an unknown part is an error that lists the parts."""
    _two_parts(tmp_path / "parts.msh")
    (tmp_path / "parts.toml").write_text(PARTS)
    model = ml.Model(ml.ModelSpec.from_toml(tmp_path / "parts.toml"))
    base, block = model.assemble().substructures
    assert base.mesh.y1 == pytest.approx(10.0) and block.mesh.y0 == pytest.approx(10.0)
    latin, reference = model.solve(options=TIGHT), model.reference()
    assert reference.reactions["clamp"][0] == pytest.approx([-10.0, 40.0], rel=1e-9)
    assert latin.qoi["u"] == pytest.approx(reference.qoi["u"], rel=1e-7)
    (tmp_path / "bad.toml").write_text(PARTS.replace('mesh_part = "block"', 'mesh_part = "pin"'))
    with pytest.raises(ml.ModelError, match=r"substructures\[1\] \('block'\).mesh_file: mesh "
                       r"file .* has no named group of surfaces 'pin' \(groups of surfaces: "
                       r"base, block\)"):
        ml.ModelSpec.from_toml(tmp_path / "bad.toml")
