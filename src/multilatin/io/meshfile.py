"""Meshes a user brings: a mesh of 4-node quadrilaterals (Q4) or of 3-node triangles (T3),
read with meshio from any format it knows (gmsh ``.msh``, VTK, …) for one substructure,
checked before use."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ModelError
from ..fem.elasticity import FloatArray, IntArray

#: 2-D cell types meshio may return that the Q4 elements cannot use yet (issue 18)
_UNSUPPORTED = ("triangle6", "triangle7", "quad8", "quad9", "polygon")


def read_mesh(path: str | Path, where: str
              ) -> tuple[FloatArray, IntArray, dict[str, IntArray]]:
    """Nodes (n, 2), counter-clockwise cells of the mesh in ``path``, Q4 (c, 4) or T3 (c, 3),
    one kind per substructure (nodes no cell uses are dropped), and its named groups of line
    elements (gmsh's physical groups of curves) as (n, 2) edges, each edge on the mesh's
    boundary. Errors name ``where`` (the model-file field) and the file."""
    import meshio

    try:
        with contextlib.redirect_stdout(io.StringIO()):  # meshio prints blank lines (gmsh)
            mesh = meshio.read(path)
    except (OSError, meshio.ReadError, ValueError, KeyError) as exc:
        raise ModelError(f"{where}: cannot read mesh file {str(path)!r}: {exc}") from None
    found = {block.type for block in mesh.cells}
    unsupported = sorted(found & set(_UNSUPPORTED))
    if unsupported:
        raise ModelError(f"{where}: mesh file {str(path)!r} holds {', '.join(unsupported)} "
                         "cells; only linear elements are supported so far: 4-node "
                         "quadrilaterals (Q4) or 3-node triangles (T3)")
    if {"quad", "triangle"} <= found:
        raise ModelError(f"{where}: mesh file {str(path)!r} mixes quadrilaterals and "
                         "triangles; one kind per substructure (gmsh: Mesh.RecombineAll = 1 "
                         "for quadrilaterals only)")
    kind = "quad" if "quad" in found else "triangle"
    blocks = [block.data for block in mesh.cells if block.type == kind]
    if not blocks:
        raise ModelError(f"{where}: mesh file {str(path)!r} holds no quadrilateral or "
                         f"triangle cells (cell types: {', '.join(sorted(found)) or 'none'})")
    cells = np.vstack(blocks).astype(np.int64)
    points = np.asarray(mesh.points, dtype=np.float64)
    if points.shape[1] == 3 and np.ptp(points[:, 2]) > 1e-9 * max(np.ptp(points[:, :2]), 1e-300):
        raise ModelError(f"{where}: mesh file {str(path)!r} is not plane (z varies)")
    used = np.unique(cells)
    renumber = np.full(points.shape[0], -1, dtype=np.int64)
    renumber[used] = np.arange(used.size)
    nodes, cells = points[used, :2].copy(), renumber[cells]
    xy = nodes[cells]
    area = 0.5 * np.sum(xy[:, :, 0] * np.roll(xy[:, :, 1], -1, axis=1)
                        - np.roll(xy[:, :, 0], -1, axis=1) * xy[:, :, 1], axis=1)
    scale = np.ptp(nodes, axis=0).prod()
    if np.any(np.abs(area) <= 1e-12 * scale):
        bad = int(np.flatnonzero(np.abs(area) <= 1e-12 * scale)[0])
        raise ModelError(f"{where}: mesh file {str(path)!r}: cell {bad} has no area")
    cells[area < 0] = cells[area < 0][:, ::-1]  # counter-clockwise: positive Jacobian
    if cells.shape[1] == 4:  # a twisted or non-convex quadrilateral: the Jacobian changes sign
        xy = nodes[cells]
        after, before = np.roll(xy, -1, axis=1) - xy, np.roll(xy, 1, axis=1) - xy
        corner = after[:, :, 0] * before[:, :, 1] - after[:, :, 1] * before[:, :, 0]
        bad_cells = np.flatnonzero(np.any(corner <= 1e-12 * scale, axis=1))
        if bad_cells.size:
            bad = int(bad_cells[0])
            raise ModelError(
                f"{where}: mesh file {str(path)!r}: cell {bad} (nodes "
                f"{[int(i) for i in used[cells[bad]]]}) is inverted, twisted or not convex "
                f"(its Jacobian changes sign; {bad_cells.size} such cell(s))")
    return nodes, cells, _line_groups(mesh, renumber, cells, path, where)


def _line_groups(mesh: Any, renumber: IntArray, cells: IntArray, path: str | Path,
                 where: str) -> dict[str, IntArray]:
    """The named sets of line cells, renumbered; each edge must be a boundary edge."""
    lines = [block.data for block in mesh.cells if block.type == "line"]
    if not lines:
        return {}
    all_lines = np.vstack(lines).astype(np.int64)
    cell_edges = np.sort(np.stack([cells, np.roll(cells, -1, axis=1)], axis=2)
                         .reshape(-1, 2), axis=1)
    unique, counts = np.unique(cell_edges, axis=0, return_counts=True)
    boundary = {tuple(edge) for edge in unique[counts == 1].tolist()}
    groups: dict[str, IntArray] = {}
    for name, by_type in mesh.cell_sets_dict.items():
        if "line" not in by_type or name.startswith("gmsh:"):
            continue
        edges = renumber[all_lines[np.asarray(by_type["line"], dtype=np.int64)]]
        inside = [k for k, edge in enumerate(np.sort(edges, axis=1).tolist())
                  if min(edge) < 0 or tuple(edge) not in boundary]
        if inside:
            raise ModelError(f"{where}: mesh file {str(path)!r}: group {name!r} holds "
                             f"{len(inside)} edge(s) that are not on the mesh's boundary")
        groups[str(name)] = edges
    return groups
