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
from ..fem.mesh import SIDES, boundary_edges

#: 2-D cell types meshio may return that the Q4 elements cannot use yet (issue 18)
_UNSUPPORTED = ("triangle6", "triangle7", "quad8", "quad9", "polygon")


def read_mesh(path: str | Path, where: str, part: str | None = None
              ) -> tuple[FloatArray, IntArray, dict[str, IntArray]]:
    """Nodes (n, 2), counter-clockwise cells of the mesh in ``path``, Q4 (c, 4) or T3 (c, 3),
    one kind per substructure (nodes no cell uses are dropped), and its named groups of line
    elements (gmsh's physical groups of curves) as (n, 2) edges, each edge on the mesh's
    boundary. ``part``: the cells of that named group of surfaces only (a file holding
    several parts), with the line groups' edges on it. Errors name ``where`` (the
    model-file field) and the file."""
    import meshio

    try:
        with contextlib.redirect_stdout(io.StringIO()):  # meshio prints blank lines (gmsh)
            mesh = meshio.read(path)
    except (OSError, meshio.ReadError, ValueError, KeyError) as exc:
        raise ModelError(f"{where}: cannot read mesh file {str(path)!r}: {exc}") from None
    by_type = _cells_by_type(mesh, path, where, part)
    found = set(by_type)
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
    if kind not in by_type:
        raise ModelError(f"{where}: mesh file {str(path)!r} holds no quadrilateral or "
                         f"triangle cells (cell types: {', '.join(sorted(found)) or 'none'})")
    cells = by_type[kind]
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
    _check_one_piece(nodes, cells, used, path, where)
    return nodes, cells, _line_groups(mesh, renumber, cells, path, where)


def _check_one_piece(nodes: FloatArray, cells: IntArray, used: IntArray, path: str | Path,
                     where: str) -> None:
    """A substructure's mesh is one piece with no cut inside: no two of its nodes at one
    point (surfaces meshed apart, or a crack, whose faces would pass through each other
    unseen, and a point QoI there would read either side), and every cell joined to every
    other through shared nodes (a piece that touches nothing floats: no equilibrium, or a
    position nothing determines)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    scale = float(np.ptp(nodes, axis=0).max())
    pairs = cKDTree(nodes).query_pairs(1e-9 * scale, output_type="ndarray")
    if pairs.size:
        first, second = (int(k) for k in pairs[0])
        x, y = nodes[first]
        raise ModelError(
            f"{where}: mesh file {str(path)!r}: nodes {int(used[first])} and "
            f"{int(used[second])} lie at the same point ({x:.6g}, {y:.6g}) ({len(pairs)} such "
            "pair(s)): the mesh is cut there (surfaces meshed "
            "apart, or a crack). Fuse the surfaces before meshing (gmsh: occ.fragment, or "
            "Geometry.AutoCoherence), or make each piece a part of its own, joined to the "
            "others by an interface")
    ring = np.roll(cells, -1, axis=1)
    graph = coo_matrix((np.ones(cells.size), (cells.ravel(), ring.ravel())),
                       shape=(nodes.shape[0],) * 2)
    n_pieces, piece = connected_components(graph, directed=False)
    if n_pieces > 1:
        sizes = np.bincount(piece[cells[:, 0]], minlength=n_pieces)
        raise ModelError(
            f"{where}: mesh file {str(path)!r}: its cells form {n_pieces} separate pieces "
            f"({', '.join(str(int(k)) for k in sizes)} cells) that share no node; a "
            "substructure is one piece: give each piece a named group of surfaces of its "
            "own (a part) and join the parts by interfaces")


def _cells_by_type(mesh: Any, path: str | Path, where: str, part: str | None
                   ) -> dict[str, IntArray]:
    """The 2-D cells of the file, or of its named group of surfaces ``part``, by type."""
    blocks: dict[str, list[IntArray]] = {}
    for block in mesh.cells:
        blocks.setdefault(block.type, []).append(np.asarray(block.data, dtype=np.int64))
    every = {kind: np.vstack(data) for kind, data in blocks.items() if kind != "vertex"}
    if part is None:
        return {kind: cells for kind, cells in every.items() if kind != "line"}
    sets = mesh.cell_sets_dict
    chosen = {kind: every[kind][np.asarray(index, dtype=np.int64)]
              for kind, index in sets.get(part, {}).items() if kind not in ("line", "vertex")}
    if not chosen:
        surfaces = sorted(name for name, by_kind in sets.items()
                          if set(by_kind) - {"line", "vertex"} and not name.startswith("gmsh:"))
        raise ModelError(f"{where}: mesh file {str(path)!r} has no named group of surfaces "
                         f"{part!r} (groups of surfaces: {', '.join(surfaces) or 'none'})")
    return chosen


def _line_groups(mesh: Any, renumber: IntArray, cells: IntArray, path: str | Path,
                 where: str) -> dict[str, IntArray]:
    """The named sets of line cells, renumbered; each edge must be a boundary edge."""
    lines = [block.data for block in mesh.cells if block.type == "line"]
    if not lines:
        return {}
    all_lines = np.vstack(lines).astype(np.int64)
    on_part = np.all(renumber[all_lines] >= 0, axis=1)  # edges of this part's nodes
    boundary = {tuple(edge) for edge in np.sort(boundary_edges(cells), axis=1).tolist()}
    groups: dict[str, IntArray] = {}
    for name, by_type in mesh.cell_sets_dict.items():
        if "line" not in by_type or name.startswith("gmsh:"):
            continue
        chosen = np.asarray(by_type["line"], dtype=np.int64)
        chosen = chosen[on_part[chosen]]
        if chosen.size == 0:
            continue  # a group of another part's edges
        if name in SIDES:  # "part.top" would silently read the extent's side instead
            raise ModelError(f"{where}: mesh file {str(path)!r}: group {name!r} has the name "
                             f"of a side of the part's extent ({', '.join(SIDES)}), which "
                             f"face = \"<part>.{name}\" reads; rename the group")
        edges = renumber[all_lines[chosen]]
        inside = [k for k, edge in enumerate(np.sort(edges, axis=1).tolist())
                  if min(edge) < 0 or tuple(edge) not in boundary]
        if inside:
            raise ModelError(f"{where}: mesh file {str(path)!r}: group {name!r} holds "
                             f"{len(inside)} edge(s) that are not on the mesh's boundary")
        groups[str(name)] = edges
    return groups
