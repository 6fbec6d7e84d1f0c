"""``[materials]``, ``[analysis]``, ``[[bodies]]`` and ``[[substructures]]`` of a model
file: the substructures with their meshes and materials (holes placed by ``decomposition.holes``)."""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ...decomposition.assembly import Material, Substructure
from ...decomposition.holes import place_holes
from ...errors import ModelError
from ...fem.elasticity import AXISYMMETRIC, HYPOTHESES, PLANE_STRESS
from ...fem.mesh import RectMesh, UnstructuredMesh
from ...limits import check_meshes
from ..meshfile import read_mesh
from .checks import ReadRecorder, SectionReader, check_keys, pair, positive_int, require

#: Young's moduli outside this window are a units error, and would over- or underflow the
#: solvers' norms (E² and 1/E appear in them)
YOUNG_RANGE = (1e-100, 1e100)
#: geometries (parameter values that the substructures read) a model keeps built
SUBSTRUCTURE_CACHE_SIZE = 8


class BodySections(SectionReader):
    """Materials, bodies and substructures."""

    def materials(self) -> dict[str, tuple[float, float, float]]:
        out = {}
        for mname, table in dict(self.data.get("materials", {})).items():
            where = f"materials.{mname}"
            if not isinstance(table, Mapping):
                raise ModelError(f"{where}: expected a table with E and nu")
            check_keys(table, {"E", "nu", "alpha"}, where)
            young = self.num(require(table, "E", where), f"{where}.E")
            poisson = self.num(require(table, "nu", where), f"{where}.nu")
            if not young > 0.0:
                raise ModelError(f"{where}.E: Young's modulus must be > 0, got {young:g}")
            if not YOUNG_RANGE[0] <= young <= YOUNG_RANGE[1]:
                raise ModelError(f"{where}.E: {young:g} is outside the range the solvers "
                                 f"represent [{YOUNG_RANGE[0]:g}, {YOUNG_RANGE[1]:g}]; check "
                                 "the units (e.g. MPa with mm and N)")
            if not -1.0 < poisson < 0.5:
                raise ModelError(f"{where}.nu: Poisson's ratio must lie in (-1, 0.5), got {poisson:g}")
            alpha = self.num(table.get("alpha", 0.0), f"{where}.alpha")
            if alpha < 0.0:
                raise ModelError(f"{where}.alpha: the thermal expansion coefficient must be "
                                 f">= 0, got {alpha:g}")
            out[mname] = (young, poisson, alpha)
        return out

    def material(self, table: Mapping[str, Any], where: str,
                 materials: dict[str, tuple[float, float, float]]) -> Material:
        mname = require(table, "material", where)
        if mname not in materials:
            known = ", ".join(sorted(materials)) or "none"
            raise ModelError(
                f"{where}.material: {mname!r} is not defined in [materials] (defined: {known})"
            )
        analysis = dict(self.data.get("analysis", {}))
        check_keys(analysis, {"hypothesis", "thickness"}, "analysis")
        # a field the body does not give is the [analysis] one: errors name where it is
        owner = {key: where if key in table else "analysis" for key in ("hypothesis",
                                                                         "thickness")}
        hypothesis = table.get("hypothesis", analysis.get("hypothesis", PLANE_STRESS))
        if hypothesis not in HYPOTHESES:
            raise ModelError(
                f"{owner['hypothesis']}.hypothesis: expected one of "
                f"{', '.join(map(repr, HYPOTHESES))}, got {hypothesis!r}")
        if hypothesis == AXISYMMETRIC and ("thickness" in table or "thickness" in analysis):
            raise ModelError(f"{owner['thickness']}.thickness: an axisymmetric part has none "
                             "(its forces are over the whole revolution, 2π r)")
        thickness = self.num(table.get("thickness", analysis.get("thickness", 1.0)),
                             f"{owner['thickness']}.thickness")
        if not thickness > 0.0:
            raise ModelError(f"{owner['thickness']}.thickness: must be > 0, got {thickness:g}")
        young, poisson, alpha = materials[mname]
        return Material(young, poisson, hypothesis, thickness, alpha)

    # -------------------------------------------------------------- substructures
    def rectangle(self, table: Mapping[str, Any], where: str) -> tuple[float, float, float, float]:
        x0, x1 = (self.num(v, f"{where}.x") for v in pair(require(table, "x", where), f"{where}.x"))
        y0, y1 = (self.num(v, f"{where}.y") for v in pair(require(table, "y", where), f"{where}.y"))
        if not x1 > x0:
            raise ModelError(f"{where}.x: expected [xmin, xmax] with xmax > xmin, got {[x0, x1]}")
        if not y1 > y0:
            raise ModelError(f"{where}.y: expected [ymin, ymax] with ymax > ymin, got {[y0, y1]}")
        return x0, x1, y0, y1

    def substructures(self) -> tuple[list[Substructure], dict[str, tuple[float, ...]]]:
        """The substructures (meshes, materials, holes) and the bodies' boxes. With a
        ``cache`` (the model's), those of an earlier build are returned again when every
        parameter they read has the same value: in a study over frictions, gaps or loads
        every case shares its geometry's meshes and cut cells (the same objects)."""
        if self.cache is None:
            return self._substructures()
        key = (self.refine, tuple(sorted(self.split.items())))
        with self.cache.lock:
            for n, (entry_key, read, subs, bodies) in enumerate(self.cache):
                if entry_key == key and all(self.mu.get(name) == value
                                            for name, value in read.items()):
                    self.cache.insert(0, self.cache.pop(n))  # most recently used first
                    return list(subs), dict(bodies)
        recorder = ReadRecorder(self.mu)
        self.lookup = recorder
        try:
            built, boxes = self._substructures()
        finally:
            self.lookup = self.mu
        with self.cache.lock:
            self.cache.insert(0, (key, dict(recorder.read), tuple(built), dict(boxes)))
            del self.cache[SUBSTRUCTURE_CACHE_SIZE:]
        return built, boxes

    def _substructures(self) -> tuple[list[Substructure], dict[str, tuple[float, ...]]]:
        materials = self.materials()
        subs: list[Substructure] = []
        planned: list[tuple[str, str, Material, tuple[float, float, float, float], int, int]] = []
        read: dict[str, UnstructuredMesh] = {}  # substructures meshed from a file
        bodies: dict[str, tuple[float, ...]] = {}
        common = {"name", "x", "y", "elements", "material", "hypothesis", "thickness"}
        for b, table in enumerate(self.data.get("bodies", [])):
            where = f"bodies[{b}]"
            check_keys(table, common | {"split", "mesh"}, where)
            name = _part_name(require(table, "name", where), where)
            where = f"bodies[{b}] ({name!r})"
            if name in bodies:
                raise ModelError(f"{where}.name: body {name!r} is defined twice")
            x0, x1, y0, y1 = self.rectangle(table, where)
            bodies[name] = (x0, x1, y0, y1)
            nx, ny = (positive_int(v, f"{where}.elements")
                      for v in pair(require(table, "elements", where), f"{where}.elements"))
            sx, sy = self.split.get(name) or tuple(
                positive_int(v, f"{where}.split") for v in pair(table.get("split", [1, 1]),
                                                                   f"{where}.split"))
            if nx % sx or ny % sy:
                raise ModelError(
                    f"{where}.split: {sx} x {sy} substructures do not divide the "
                    f"{nx} x {ny} elements evenly"
                )
            mat = self.material(table, where, materials)
            xs = np.linspace(x0, x1, sx + 1)
            ys = np.linspace(y0, y1, sy + 1)
            # a split chosen by the caller (a discretisation choice) replaces the file's
            # per-substructure meshes of that body
            own = ({} if name in self.split else
                   self.own_meshes(table.get("mesh", []), where, (sx, sy)))
            for j, i in itertools.product(range(sy), range(sx)):
                sub_name = name if sx * sy == 1 else f"{name}[{i},{j}]"
                ex, ey = own.get((i, j), (nx // sx, ny // sy))
                planned.append((sub_name, name, mat, (float(xs[i]), float(xs[i + 1]),
                                                      float(ys[j]), float(ys[j + 1])),
                                ex * self.refine, ey * self.refine))
        unknown = sorted(set(self.split) - set(bodies))
        if unknown:
            raise ModelError(f"--split {unknown[0]}: no body of that name in [[bodies]] "
                             f"(bodies: {', '.join(bodies) or 'none'})")
        for s, table in enumerate(self.data.get("substructures", [])):
            where = f"substructures[{s}]"
            check_keys(table, common | {"body", "mesh_file", "mesh_part"}, where)
            name = _part_name(require(table, "name", where), where)
            where = f"substructures[{s}] ({name!r})"
            if "mesh_part" in table and "mesh_file" not in table:
                raise ModelError(f"{where}.mesh_part: applies with mesh_file only")
            if "mesh_file" in table:
                mesh = self.file_mesh(table, where)
                read[name] = mesh
                x0, x1, y0, y1 = mesh.x0, mesh.x1, mesh.y0, mesh.y1
                # the size guard's equivalent square mesh: as many nodes (a strip of
                # n_cells x 1 would count every node on the boundary)
                nx = ny = max(int(math.ceil(math.sqrt(mesh.n_nodes))) - 1, 1)
            else:
                x0, x1, y0, y1 = self.rectangle(table, where)
                nx, ny = (positive_int(v, f"{where}.elements")
                          for v in pair(require(table, "elements", where), f"{where}.elements"))
            body = str(table.get("body", name))
            refine = 1 if name in read else self.refine
            planned.append((name, body, self.material(table, where, materials),
                            (x0, x1, y0, y1), nx * refine, ny * refine))
            lo = bodies.get(body, (x0, x1, y0, y1))
            bodies[body] = (min(lo[0], x0), max(lo[1], x1), min(lo[2], y0), max(lo[3], y1))
        # the size guard, before any mesh is built (a 3000 x 3000 mesh would take the
        # machine's memory)
        check_meshes([(name, ex, ey) for name, _, _, _, ex, ey in planned])
        for name, body, mat, (x0, x1, y0, y1), ex, ey in planned:
            subs.append(Substructure(name, body, read.get(name) or
                                     RectMesh(x0, x1, y0, y1, ex, ey), mat))
        if not subs:
            raise ModelError("model: no [[bodies]] or [[substructures]] defined")
        _check_axisymmetric(subs)
        names = [s.name for s in subs]
        for name in names:
            if names.count(name) > 1:
                raise ModelError(f"substructures: the name {name!r} is used twice")
        self._check_overlaps(subs)
        subs = place_holes(self.data.get("holes", []), subs, self.lookup, self.num, check_keys,
                           replaced=set(self.split))
        return subs, bodies

    def file_mesh(self, table: Mapping[str, Any], where: str) -> UnstructuredMesh:
        """``mesh_file``: a Q4 or T3 mesh read with meshio; its bounding box is the
        substructure's rectangle (``x`` and ``y``, when given, must be that box), whose sides
        carry the interfaces and boundary conditions, and so do its named groups of boundary
        edges (gmsh's physical groups)."""
        if "elements" in table:
            raise ModelError(f"{where}: give either elements or mesh_file, not both")
        if self.refine != 1:
            raise ModelError(f"{where}.mesh_file: a mesh read from a file cannot be refined "
                             f"(refine = {self.refine})")
        part = table.get("mesh_part")
        if part is not None and not isinstance(part, str):
            raise ModelError(f"{where}.mesh_part: expected the name of a group of surfaces, "
                             f"got {part!r}")
        nodes, cells, groups = read_mesh(str(table["mesh_file"]), f"{where}.mesh_file", part)
        (x0, y0), (x1, y1) = nodes.min(axis=0), nodes.max(axis=0)
        if "x" in table or "y" in table:
            given = self.rectangle(table, where)
            size = max(x1 - x0, y1 - y0)
            if np.abs(np.array(given) - [x0, x1, y0, y1]).max() > 1e-9 * size:
                raise ModelError(f"{where}: x {list(given[:2])} and y {list(given[2:])} are not "
                                 f"the mesh's extent x [{x0:g}, {x1:g}] y [{y0:g}, {y1:g}]")
        return UnstructuredMesh(float(x0), float(x1), float(y0), float(y1), nodes, cells,
                                groups)

    @staticmethod
    def own_meshes(tables: Any, where: str, split: tuple[int, int]
                   ) -> dict[tuple[int, int], tuple[int, int]]:
        """``[[bodies.mesh]]``: element counts of single substructures of a split body
        (``substructure = [i, j]``, ``elements = [nx, ny]``); their sides then meet their
        neighbours' with non-matching meshes (declare those interfaces ``type = "macro"``)."""
        out = {}
        if not isinstance(tables, list):
            raise ModelError(f"{where}.mesh: expected a list of tables, got {tables!r}")
        for m, table in enumerate(tables):
            here = f"{where}.mesh[{m}]"
            check_keys(table, {"substructure", "elements"}, here)
            i, j = pair(require(table, "substructure", here), f"{here}.substructure")
            if not (isinstance(i, int) and isinstance(j, int)
                    and 0 <= i < split[0] and 0 <= j < split[1]):
                raise ModelError(f"{here}.substructure: expected [i, j] with 0 <= i < {split[0]} "
                                 f"and 0 <= j < {split[1]}, got {[i, j]}")
            out[(i, j)] = tuple(positive_int(v, f"{here}.elements") for v in
                                pair(require(table, "elements", here), f"{here}.elements"))
        return out  # type: ignore[return-value]

    @staticmethod
    def _check_overlaps(subs: list[Substructure]) -> None:
        box = np.array([[s.mesh.x0, s.mesh.x1, s.mesh.y0, s.mesh.y1] for s in subs])
        scale = 1e-9 * float(np.max(box[:, [1, 3]] - box[:, [0, 2]]))
        ox = np.minimum(box[:, None, 1], box[None, :, 1]) - np.maximum(box[:, None, 0], box[None, :, 0])
        oy = np.minimum(box[:, None, 3], box[None, :, 3]) - np.maximum(box[:, None, 2], box[None, :, 2])
        overlap = (ox > scale) & (oy > scale)
        np.fill_diagonal(overlap, False)
        for i, j in np.argwhere(np.triu(overlap)):  # boxes of curved parts: the cells decide
            meshes = (subs[i].mesh, subs[j].mesh)
            if any(isinstance(m, UnstructuredMesh) for m in meshes) and not (
                    _cells_overlap(*meshes) or _cells_overlap(*meshes[::-1])):
                overlap[i, j] = overlap[j, i] = False
        if overlap.any():
            i, j = np.argwhere(overlap)[0]
            a, b = subs[i], subs[j]
            raise ModelError(
                f"substructures {a.name!r} and {b.name!r} overlap: "
                f"x {[a.mesh.x0, a.mesh.x1]} y {[a.mesh.y0, a.mesh.y1]} and "
                f"x {[b.mesh.x0, b.mesh.x1]} y {[b.mesh.y0, b.mesh.y1]}"
            )



def _cells_overlap(a: RectMesh | UnstructuredMesh, b: RectMesh | UnstructuredMesh) -> bool:
    """Whether a cell centre of ``a`` lies inside a cell of ``b`` (convex cells)."""
    from scipy.spatial import cKDTree

    centres = a.nodes[a.cells].mean(axis=1)
    corners = b.nodes[b.cells]
    own = corners.mean(axis=1)
    reach = float(np.linalg.norm(corners - own[:, None], axis=2).max())
    found = cKDTree(own).query_ball_point(centres, r=reach * (1.0 + 1e-9))
    pairs = [(p, c) for p, cells in enumerate(found) for c in cells]
    if not pairs:
        return False
    point, cell = (np.array(v, dtype=np.int64) for v in zip(*pairs, strict=True))
    xy = corners[cell]
    edge = np.roll(xy, -1, axis=1) - xy
    to_point = centres[point][:, None, :] - xy
    cross = edge[..., 0] * to_point[..., 1] - edge[..., 1] * to_point[..., 0]
    size = float(np.abs(edge).max())
    return bool(np.any(np.all(cross > 1e-9 * size * size, axis=1)))


def _part_name(value: object, where: str) -> str:
    """A body's or substructure's name: text, not empty, without "." (faces are named
    "body.side") nor "[" / "]" (a split body's substructures are named "body[i,j]")."""
    name = str(value)
    if not isinstance(value, str) or not name.strip() or any(c in name for c in ".[]"):
        raise ModelError(f"{where}.name: expected a name without '.', '[' or ']' (faces are "
                         f"'body.side', a split body's parts 'body[i,j]'), got {value!r}")
    return name


def _check_axisymmetric(subs: list[Substructure]) -> None:
    """Axisymmetric parts (x = r, y = z) go with axisymmetric parts only, and lie at r ≥ 0."""
    radial = [sub for sub in subs if sub.material.radial]
    if radial and len(radial) < len(subs):
        plane = next(sub for sub in subs if not sub.material.radial)
        raise ModelError(f"hypothesis: {radial[0].name!r} is axisymmetric and "
                         f"{plane.name!r} is {plane.material.hypothesis!r}; an assembly is "
                         "axisymmetric throughout or not at all")
    for sub in radial:
        if sub.mesh.nodes[:, 0].min() < -1e-12 * max(1.0, float(np.ptp(sub.mesh.nodes))):
            raise ModelError(f"{sub.name!r}: an axisymmetric part lies at x = r >= 0, but "
                             f"its nodes reach x = {sub.mesh.nodes[:, 0].min():g}")
