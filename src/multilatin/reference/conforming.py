"""A conforming-mesh reference for models with holes: each body that holds a hole is meshed
explicitly with gmsh (the hole cut out of the geometry, no level set) and the assembly is
solved monolithically (``multilatin.monolithic``), contact included.

This checks the X-FEM treatment of the hole (paper §5) and the macro-only interfaces around
it (eq. [20]) against a discretisation that has neither. The body's outer sides keep the
node distribution of the structured meshes (uniform, the same count), so contact with the
other bodies stays node to node. gmsh (``pip install gmsh``, extra ``multilatin[reference]``)
is needed for this reference only.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..decomposition.assembly import Assembly
from ..errors import ModelError
from ..fem.levelset import Circle, LevelSet, Slot, Union
from ..fem.mesh import RectMesh, UnstructuredMesh
from ..io.modelfile import ModelSpec

log = logging.getLogger(__name__)


def _shapes(hole: LevelSet) -> list[Circle | Slot]:
    parts = hole.parts if isinstance(hole, Union) else (hole,)
    shapes = [p for p in parts if isinstance(p, (Circle, Slot))]
    if len(shapes) != len(parts):
        raise ModelError("conforming reference: only circles and slots can be meshed "
                         f"explicitly, got {hole!r}")
    return shapes


def _add_hole(occ: Any, hole: Circle | Slot) -> list[tuple[int, int]]:
    """The hole as OpenCASCADE surfaces: a disk, or a slot's two disks and the rectangle
    between them (fused by the cut that takes them out)."""
    if isinstance(hole, Circle):
        return [(2, occ.addDisk(hole.centre[0], hole.centre[1], 0.0, hole.radius,
                                hole.radius))]
    (ax, ay), (bx, by), r = hole.start, hole.end, hole.radius
    parts = [(2, occ.addDisk(x, y, 0.0, r, r)) for x, y in ((ax, ay), (bx, by))]
    length = math.hypot(bx - ax, by - ay)
    if length > 1e-12 * r:
        band = (2, occ.addRectangle(ax, ay - r, 0.0, length, 2.0 * r))
        occ.rotate([band], ax, ay, 0.0, 0.0, 0.0, 1.0, math.atan2(by - ay, bx - ax))
        parts.append(band)
    return parts


def mesh_holed_rectangle(box: tuple[float, float, float, float],
                         holes: Sequence[Circle | Slot], divisions: tuple[int, int],
                         hole_size: float | None = None) -> UnstructuredMesh:
    """An all-quadrangle mesh of ``box`` minus the circles and slots ``holes``, with
    ``divisions`` uniform elements along x and y on the outer sides and elements of about
    ``hole_size`` along each hole (default: the outer size, at most 1/48 of the
    circumference of a circle of the hole's radius)."""
    try:
        import gmsh
    except ImportError:  # pragma: no cover - depends on the installation
        raise ModelError("the conforming reference needs gmsh: pip install gmsh "
                         "(or pip install 'multilatin[reference]')") from None
    x0, x1, y0, y1 = box
    nx, ny = divisions
    if nx % 2 or ny % 2:
        raise ModelError(f"conforming reference: the outer sides need an even number of "
                         f"elements (all-quad subdivision), got {nx} x {ny}")
    outer = min((x1 - x0) / nx, (y1 - y0) / ny)
    initialised_here = not gmsh.isInitialized()
    if initialised_here:
        gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Verbosity", 0)
        gmsh.model.add("multilatin-conforming")
        occ = gmsh.model.occ
        surface = [(2, occ.addRectangle(x0, y0, 0.0, x1 - x0, y1 - y0))]
        tools = [part for hole in holes for part in _add_hole(occ, hole)]
        if tools:
            surface, _ = occ.cut(surface, tools)
        occ.synchronize()
        size = max(x1 - x0, y1 - y0)
        boxes = [hole.bounding_box() for hole in holes]
        # subdivision (each quad into four) halves every size: mesh at twice the target
        for _, tag in gmsh.model.getBoundary(surface, oriented=False):
            bx0, by0, _, bx1, by1, _ = gmsh.model.getBoundingBox(1, tag)
            flat_y, flat_x = by1 - by0 < 1e-6 * size, bx1 - bx0 < 1e-6 * size
            if flat_y and min(abs(by0 - y0), abs(by0 - y1)) < 1e-6 * size:
                gmsh.model.mesh.setTransfiniteCurve(tag, nx // 2 + 1)
            elif flat_x and min(abs(bx0 - x0), abs(bx0 - x1)) < 1e-6 * size:
                gmsh.model.mesh.setTransfiniteCurve(tag, ny // 2 + 1)
            else:  # along a hole: the smallest hole whose box holds the curve sets its size
                slack = 1e-6 * size
                radius = min((hole.radius for hole, (hx0, hx1, hy0, hy1)
                              in zip(holes, boxes, strict=True)
                              if hx0 - slack <= bx0 and bx1 <= hx1 + slack
                              and hy0 - slack <= by0 and by1 <= hy1 + slack),
                             default=0.25 * ((bx1 - bx0) + (by1 - by0)))
                length = occ.getMass(1, tag)
                target = hole_size or min(outer, 2.0 * math.pi * radius / 48)
                least = math.ceil(8 * length / (2.0 * math.pi * radius) - 1e-9)
                count = max(least, 1, math.ceil(length / (2.0 * target)))
                gmsh.model.mesh.setTransfiniteCurve(tag, count + 1)
        gmsh.option.setNumber("Mesh.MeshSizeMax", 2.0 * outer)
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
        gmsh.option.setNumber("Mesh.Algorithm", 8)
        gmsh.option.setNumber("Mesh.RecombinationAlgorithm", 1)
        gmsh.option.setNumber("Mesh.SubdivisionAlgorithm", 1)
        gmsh.model.mesh.generate(2)
        types, _, connectivity = gmsh.model.mesh.getElements(2)
        tags, coords, _ = gmsh.model.mesh.getNodes()
    finally:
        gmsh.model.remove()
        if initialised_here:
            gmsh.finalize()
    if list(types) != [3]:
        raise ModelError(f"conforming reference: gmsh returned element types {list(types)}, "
                         "expected quadrangles only")
    index = np.full(int(tags.max()) + 1, -1, dtype=np.int64)
    index[tags.astype(np.int64)] = np.arange(tags.size)
    cells = index[np.asarray(connectivity[0], dtype=np.int64).reshape(-1, 4)]
    nodes = np.asarray(coords, dtype=np.float64).reshape(-1, 3)[:, :2]
    used = np.unique(cells)
    renumber = np.full(nodes.shape[0], -1, dtype=np.int64)
    renumber[used] = np.arange(used.size)
    nodes, cells = nodes[used], renumber[cells]
    # counter-clockwise cells (positive Jacobian)
    xy = nodes[cells]
    area = 0.5 * np.sum(xy[:, :, 0] * np.roll(xy[:, :, 1], -1, axis=1)
                        - np.roll(xy[:, :, 0], -1, axis=1) * xy[:, :, 1], axis=1)
    cells[area < 0] = cells[area < 0][:, ::-1]
    log.info("conforming mesh of [%g, %g] x [%g, %g] with %d hole(s): %d nodes, %d quads",
             x0, x1, y0, y1, len(holes), nodes.shape[0], cells.shape[0])
    return UnstructuredMesh(x0, x1, y0, y1, nodes, cells)


def conforming_assembly(spec: ModelSpec, assembly: Assembly, refine: int = 1,
                        hole_size: float | None = None) -> Assembly:
    """The conforming counterpart of ``assembly`` (built from ``spec`` with ``refine``): one
    substructure per body (the monolithic solver merges them anyway; macro-only interfaces
    disappear), every body holding a hole meshed by gmsh: its outer sides as the body's
    structured mesh (uniform, the same element counts), the hole cut out."""
    for sub in assembly.substructures:
        if sub.hole is not None and not isinstance(sub.mesh, RectMesh):
            raise ModelError(
                f"conforming reference: the hole of substructure {sub.name!r} lies in a mesh "
                "of its own (a mesh file); only a structured rectangle can be meshed again "
                "with the hole cut out. The reference on the same meshes solves the same "
                "discrete problem (mesh='same', `--reference-mesh same`), or cut the hole "
                "out of the mesh file")
    # one substructure per [[bodies]] entry; [[substructures]] stay as they are
    declared = {str(t.get("name")) for t in spec.data.get("bodies", []) if isinstance(t, dict)}
    bodies = {s.body for s in assembly.substructures} & declared
    whole = spec.build(assembly.mu, refine=refine, split={body: (1, 1) for body in bodies})
    subs = list(whole.substructures)
    for i, sub in enumerate(subs):
        if sub.hole is None:
            continue
        assert isinstance(sub.mesh, RectMesh)
        m = sub.mesh
        mesh = mesh_holed_rectangle((m.x0, m.x1, m.y0, m.y1), _shapes(sub.hole), (m.nx, m.ny),
                                    hole_size)
        subs[i] = dataclasses.replace(sub, mesh=mesh, hole=None)
    return dataclasses.replace(whole, substructures=tuple(subs))
