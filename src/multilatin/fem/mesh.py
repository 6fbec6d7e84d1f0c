"""Q4 meshes of rectangles: structured (``RectMesh``) or unstructured (``UnstructuredMesh``,
e.g. a conforming mesh of a holed rectangle from gmsh).

Cells are counter-clockwise quadrangles. The four sides are listed by name; each side's
nodes are ordered by increasing coordinate along the side, so that two matching sides pair
node by node.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from ..kept import Kept
from .elasticity import shape_functions

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

SIDES = ("bottom", "right", "top", "left")
"""Side names of a rectangle, in counter-clockwise order."""


def normal_axis(side: str) -> int:
    """The axis (0: x, 1: y) normal to a rectangle's side; the other one is tangential."""
    if side not in SIDES:
        raise ValueError(f"unknown side {side!r}; expected one of {SIDES}")
    return 0 if side in ("left", "right") else 1


def boundary_edges(cells: IntArray) -> IntArray:
    """(n, 2) node pairs of the edges that belong to one of the counter-clockwise ``cells``
    only, each in its cell's order (so the material lies to its left)."""
    edges = np.stack([cells, np.roll(cells, -1, axis=1)], axis=2).reshape(-1, 2)
    _, index, counts = np.unique(np.sort(edges, axis=1), axis=0, return_index=True,
                                 return_counts=True)
    return np.asarray(edges[index[counts == 1]], dtype=np.int64)


class RectangleSides:
    """Sides of the rectangle ``[x0, x1] × [y0, y1]`` that a mesh covers."""

    x0: float
    x1: float
    y0: float
    y1: float

    def side_line(self, side: str) -> tuple[int, float, float, float]:
        """``(axis, level, start, end)``: the side lies on coordinate ``axis`` = ``level``
        and spans ``[start, end]`` along the other axis."""
        if side == "bottom":
            return 1, self.y0, self.x0, self.x1
        if side == "top":
            return 1, self.y1, self.x0, self.x1
        if side == "left":
            return 0, self.x0, self.y0, self.y1
        if side == "right":
            return 0, self.x1, self.y0, self.y1
        raise ValueError(f"unknown side {side!r}; expected one of {SIDES}")

    def outward_normal(self, side: str) -> FloatArray:
        return {
            "bottom": np.array([0.0, -1.0]),
            "right": np.array([1.0, 0.0]),
            "top": np.array([0.0, 1.0]),
            "left": np.array([-1.0, 0.0]),
        }[side]

    def contains(self, point: npt.ArrayLike, tol: float = 1e-9) -> bool:
        """Whether ``point`` lies in the rectangle (for a mesh file, its extent)."""
        x, y = np.asarray(point, dtype=float)
        scale = tol * max(self.x1 - self.x0, self.y1 - self.y0)
        return bool(
            self.x0 - scale <= x <= self.x1 + scale and self.y0 - scale <= y <= self.y1 + scale
        )

    def locate(self, point: npt.ArrayLike) -> tuple[int, FloatArray]:
        """The cell containing ``point`` and the point's reference coordinates in it."""
        raise NotImplementedError

    def holds(self, point: npt.ArrayLike) -> bool:
        """Whether ``point`` lies in a cell: in the rectangle for a structured mesh; in a
        cell of a mesh file, whose extent may hold a hole or another part."""
        if not self.contains(point):
            return False
        try:
            self.locate(point)
        except ValueError:
            return False
        return True


#: nodes and cells of structured meshes, by box and divisions (read-only, shared): a
#: study's cases rebuild their substructures' meshes (B3: 27 per case, 5 ms)
_RECT_ARRAYS: Kept[tuple[float, float, float, float, int, int],
                   tuple[FloatArray, IntArray]] = Kept(256)
#: meshes of more nodes are built each time
_RECT_ARRAYS_MAX_NODES = 20_000


@dataclass(frozen=True)
class RectMesh(RectangleSides):
    """A structured ``nx`` × ``ny`` Q4 mesh of ``[x0, x1] × [y0, y1]``."""

    x0: float
    x1: float
    y0: float
    y1: float
    nx: int
    ny: int
    nodes: FloatArray = field(init=False, repr=False)
    cells: IntArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        key = (self.x0, self.x1, self.y0, self.y1, self.nx, self.ny)
        if (self.nx + 1) * (self.ny + 1) > _RECT_ARRAYS_MAX_NODES:
            nodes, cells = self._arrays()
        else:
            nodes, cells = _RECT_ARRAYS.get(key, self._arrays)
        object.__setattr__(self, "nodes", nodes)
        object.__setattr__(self, "cells", cells)

    def _arrays(self) -> tuple[FloatArray, IntArray]:
        xs = np.linspace(self.x0, self.x1, self.nx + 1)
        ys = np.linspace(self.y0, self.y1, self.ny + 1)
        gx, gy = np.meshgrid(xs, ys)  # shape (ny+1, nx+1)
        nodes = np.column_stack([gx.ravel(), gy.ravel()])
        i, j = np.meshgrid(np.arange(self.nx), np.arange(self.ny))
        n0 = (j * (self.nx + 1) + i).ravel()
        cells = np.column_stack([n0, n0 + 1, n0 + self.nx + 2, n0 + self.nx + 1]).astype(np.int64)
        for array in (nodes, cells):
            array.setflags(write=False)  # shared by every mesh of this box
        return nodes, cells

    @property
    def n_nodes(self) -> int:
        return (self.nx + 1) * (self.ny + 1)

    @property
    def n_cells(self) -> int:
        return self.nx * self.ny

    @property
    def hx(self) -> float:
        return (self.x1 - self.x0) / self.nx

    @property
    def hy(self) -> float:
        return (self.y1 - self.y0) / self.ny

    def side_nodes(self, side: str, reach: float = 0.0) -> IntArray:
        """Node indices of ``side``, ordered by increasing coordinate along it (``reach``:
        see ``UnstructuredMesh.side_nodes``; a rectangle's sides are straight)."""
        row = self.nx + 1
        if side == "bottom":
            return np.arange(row, dtype=np.int64)
        if side == "top":
            return np.arange(self.ny * row, (self.ny + 1) * row, dtype=np.int64)
        if side == "left":
            return np.arange(0, self.n_nodes, row, dtype=np.int64)
        if side == "right":
            return np.arange(self.nx, self.n_nodes, row, dtype=np.int64)
        raise ValueError(f"unknown side {side!r}; expected one of {SIDES}")

    def locate(self, point: npt.ArrayLike) -> tuple[int, FloatArray]:
        """The cell containing ``point`` and the point's reference coordinates in it."""
        x, y = np.asarray(point, dtype=float)
        i = min(max(int(np.floor((x - self.x0) / self.hx)), 0), self.nx - 1)
        j = min(max(int(np.floor((y - self.y0) / self.hy)), 0), self.ny - 1)
        xi = 2.0 * (x - (self.x0 + i * self.hx)) / self.hx - 1.0
        eta = 2.0 * (y - (self.y0 + j * self.hy)) / self.hy - 1.0
        return j * self.nx + i, np.array([xi, eta])


@dataclass(frozen=True, eq=False, repr=False)
class UnstructuredMesh(RectangleSides):
    """A Q4 or T3 mesh (``cells`` of 4 or 3 nodes, counter-clockwise) of (part of) the
    rectangle ``[x0, x1] × [y0, y1]``, e.g. with holes; its side nodes are the nodes on the
    rectangle's sides. ``groups``: named chains of boundary edges (a mesh file's physical
    groups of lines), faces of their own for boundary conditions."""

    x0: float
    x1: float
    y0: float
    y1: float
    nodes: FloatArray
    cells: IntArray
    groups: dict[str, IntArray] = field(default_factory=dict)  # name -> (n, 2) edges

    def __repr__(self) -> str:
        digest = hashlib.sha1(self.nodes.tobytes() + self.cells.tobytes()).hexdigest()[:12]
        return (f"UnstructuredMesh([{self.x0:g}, {self.x1:g}] x [{self.y0:g}, {self.y1:g}], "
                f"{self.n_nodes} nodes, {self.n_cells} cells, {digest})")

    @property
    def n_nodes(self) -> int:
        return int(self.nodes.shape[0])

    @property
    def n_cells(self) -> int:
        return int(self.cells.shape[0])

    def side_nodes(self, side: str, reach: float = 0.0) -> IntArray:
        """Node indices on ``side``, ordered by increasing coordinate along it.

        reach: > 0 for a curved face near the side (a cylinder touching a plane): the
            boundary nodes within ``reach`` of the side's line that lie on boundary edges
            running along it (not across: the other sides' edges are left out), which must
            form one chain, each node further along the side than the last.
        """
        if side in self.groups:
            return self._chain(side)
        axis, level, _, _ = self.side_line(side)
        scale = 1e-9 * max(self.x1 - self.x0, self.y1 - self.y0)
        if reach <= 0.0:
            on_side = np.flatnonzero(np.abs(self.nodes[:, axis] - level) <= scale)
            return on_side[np.argsort(self.nodes[on_side, 1 - axis])].astype(np.int64)
        edges = self.boundary_edges
        near = np.abs(self.nodes[:, axis] - level) <= reach + scale
        along = self.nodes[:, 1 - axis]
        chosen = edges[near[edges].all(axis=1)
                       & (np.abs(along[edges[:, 0]] - along[edges[:, 1]]) > scale)]
        nodes = np.unique(chosen)
        nodes = nodes[np.argsort(along[nodes])]
        degree = np.bincount(chosen.ravel(), minlength=self.n_nodes)[nodes]
        if nodes.size < 2 or np.any(degree > 2) or np.count_nonzero(degree == 1) != 2 \
                or np.any(np.diff(along[nodes]) <= scale):
            raise ValueError(f"the boundary within {reach:g} of the {side} side of {self!r} "
                             "is not one chain of edges running along the side")
        return nodes.astype(np.int64)

    def _chain(self, group: str) -> IntArray:
        """The nodes of a named group of edges, in order along it from the end with the
        smaller (x, y)."""
        edges = self.groups[group]
        nodes, degree = np.unique(edges, return_counts=True)
        ends = nodes[degree == 1]
        if edges.shape[0] == 0 or ends.size != 2 or np.any(degree > 2):
            raise ValueError(f"group {group!r} of {self!r} is not one open chain of edges "
                             f"({edges.shape[0]} edges, {ends.size} ends; split a closed "
                             "curve into two groups)")
        start = min(ends.tolist(), key=lambda n: (self.nodes[n, 0], self.nodes[n, 1]))
        neighbours: dict[int, list[int]] = {}
        for a, b in edges.tolist():
            neighbours.setdefault(a, []).append(b)
            neighbours.setdefault(b, []).append(a)
        order, previous = [start], -1
        while len(order) < nodes.size:
            following = [n for n in neighbours[order[-1]] if n != previous]
            previous = order[-1]
            order.append(following[0])
        return np.array(order, dtype=np.int64)

    def face_normals(self, side: str) -> FloatArray:
        """Outward unit normals at the nodes of the named group ``side`` (``side_nodes``
        order): the mean of its edges' at each node (a rectangle's side has one,
        ``outward_normal``)."""
        order = self._chain(side)
        boundary = {tuple(edge): True for edge in self.boundary_edges.tolist()}
        normals = np.zeros((order.size, 2))
        for k in range(order.size - 1):
            a, b = int(order[k]), int(order[k + 1])
            if (a, b) not in boundary:  # the cell's counter-clockwise edge runs b -> a
                a, b = b, a
            direction = self.nodes[b] - self.nodes[a]
            outward = np.array([direction[1], -direction[0]]) / np.linalg.norm(direction)
            normals[k] += outward
            normals[k + 1] += outward
        return np.asarray(normals / np.linalg.norm(normals, axis=1, keepdims=True),
                          dtype=np.float64)

    @property
    def boundary_edges(self) -> IntArray:
        """(n, 2) node pairs of the edges that belong to one cell only."""
        return boundary_edges(self.cells)

    def locate(self, point: npt.ArrayLike) -> tuple[int, FloatArray]:
        """The cell containing ``point`` and the point's reference coordinates in it
        (inverse bilinear map by Newton's method)."""
        x = np.asarray(point, dtype=float)
        corners = self.nodes[self.cells]
        scale = 1e-9 * max(self.x1 - self.x0, self.y1 - self.y0)
        inside = np.flatnonzero(np.all((corners.min(axis=1) - scale <= x)
                                       & (x <= corners.max(axis=1) + scale), axis=1))
        if self.cells.shape[1] == 3:  # T3: barycentric coordinates
            for cell in inside:
                a, b, c = corners[cell]
                ref = np.linalg.solve(np.column_stack([b - a, c - a]), x - a)
                if ref.min() >= -1e-9 and ref.sum() <= 1.0 + 1e-9:
                    return int(cell), ref
            raise ValueError(f"point {x.tolist()} lies in no cell of {self!r}")
        sx = np.array([-1.0, 1.0, 1.0, -1.0])
        sy = np.array([-1.0, -1.0, 1.0, 1.0])
        for cell in inside:
            xy = corners[cell]
            ref = np.zeros(2)
            for _ in range(20):
                shape = 0.25 * (1 + ref[0] * sx) * (1 + ref[1] * sy)
                jacobian = np.stack([0.25 * sx * (1 + ref[1] * sy), 0.25 * sy * (1 + ref[0] * sx)],
                                    axis=1).T @ xy  # (d xi, d x)
                step = np.linalg.solve(jacobian.T, x - shape @ xy)
                ref = ref + step
                if np.abs(step).max() < 1e-13:
                    break
            if np.all(np.abs(ref) <= 1.0 + 1e-9):
                return int(cell), ref
        raise ValueError(f"point {x.tolist()} lies in no cell of {self!r}")


def shape_at(mesh: RectMesh | UnstructuredMesh, point: npt.ArrayLike
             ) -> tuple[npt.NDArray[np.int64], npt.NDArray[np.float64]]:
    """The nodes of the cell that holds ``point`` (``locate``) and their shape functions
    there: what interpolates a nodal field at the point, or spreads a force at it onto the
    nodes."""
    cell, ref = mesh.locate(point)
    shape, _ = shape_functions(np.asarray(ref, dtype=np.float64)[None], mesh.cells.shape[1])
    return np.asarray(mesh.cells[cell], dtype=np.int64), np.ravel(shape)
