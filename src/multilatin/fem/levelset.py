"""Geometric details by level set on a fixed mesh (paper §5, fig. 8).

A detail (a hole) is the region where a level set φ < 0; the material is where φ ≥ 0. Any
callable ``φ(x) -> (...)`` on points ``x (..., 2)`` works, provided it is 1-Lipschitz
(|φ(x)| is at most the distance from x to the zero level set): signed distance functions
are, and so are the min of several (a union of holes). Cells are classified with that bound
(a cell whose centre is farther from the boundary than its half-diagonal is not cut), so a
hole smaller than a cell is still found.

Cut cells are integrated on their material part only, with no new unknowns: each reference
cell is split into ``subdivisions``² small triangles (a Q4's square into sub-squares, two
triangles each; a T3's triangle into triangles), φ is interpolated linearly on each from its
exact values at the (mapped) vertices, and the material part of the triangle (a triangle or
a quadrangle, cut into two triangles) carries a degree-2 triangle rule. On the
axis-aligned rectangles of ``RectMesh`` the Q4 stiffness integrand has total degree 2, and
on a T3 it is constant, so the stiffness of a cell cut by a straight line is integrated
exactly; a curved boundary is approximated by segments of length h / ``subdivisions``.
Unstructured Q4 and T3 meshes (mesh files) are cut the same way.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .elasticity import FloatArray, IntArray, Quadrature, shape_functions
from .mesh import RectMesh, UnstructuredMesh

LevelSet = Callable[[FloatArray], FloatArray]


@dataclass(frozen=True)
class Circle:
    """A circular hole: φ(x) = ‖x − centre‖ − radius (paper §7.2)."""

    centre: tuple[float, float]
    radius: float

    def __call__(self, x: FloatArray) -> FloatArray:
        return np.asarray(np.hypot(x[..., 0] - self.centre[0], x[..., 1] - self.centre[1])
                          - self.radius, dtype=np.float64)

    def bounding_box(self) -> tuple[float, float, float, float]:
        cx, cy = self.centre
        r = self.radius
        return cx - r, cx + r, cy - r, cy + r


@dataclass(frozen=True)
class Slot:
    """A slot (stadium): the points within ``radius`` of the segment [start, end]."""

    start: tuple[float, float]
    end: tuple[float, float]
    radius: float

    def __call__(self, x: FloatArray) -> FloatArray:
        a = np.asarray(self.start)
        d = np.asarray(self.end) - a
        t = np.clip(((x - a) @ d) / max(float(d @ d), 1e-300), 0.0, 1.0)
        nearest = a + t[..., None] * d
        return np.asarray(np.linalg.norm(x - nearest, axis=-1) - self.radius, dtype=np.float64)

    def bounding_box(self) -> tuple[float, float, float, float]:
        xs, ys = (self.start[0], self.end[0]), (self.start[1], self.end[1])
        r = self.radius
        return min(xs) - r, max(xs) + r, min(ys) - r, max(ys) + r


@dataclass(frozen=True)
class Union:
    """Several holes: φ = min φ_i (1-Lipschitz when every φ_i is)."""

    parts: tuple[LevelSet, ...]

    def __call__(self, x: FloatArray) -> FloatArray:
        return np.asarray(np.min(np.stack([part(x) for part in self.parts]), axis=0),
                          dtype=np.float64)


@dataclass(frozen=True)
class CutCells:
    """Classification of the cells of a mesh against a level set, and the quadrature of the
    cut ones (paper §5.1, fig. 8)."""

    material: IntArray  # cells entirely in the material
    cut: IntArray  # cells cut by the zero level set
    void: IntArray  # cells entirely in the hole
    cut_quadrature: Quadrature  # rule of each cut cell (reference coordinates), in ``cut`` order
    material_fraction: FloatArray  # (n_cells,) material area / cell area
    active_nodes: npt.NDArray[np.bool_]  # nodes whose support holds material

    @property
    def inactive_nodes(self) -> IntArray:
        """Nodes whose support is entirely void: their unknowns are removed."""
        return np.flatnonzero(~self.active_nodes).astype(np.int64)


# degree-2 rule on a triangle, barycentric coordinates (weights sum to 1)
_TRIANGLE_POINTS = np.array([[2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]])
_TRIANGLE_WEIGHTS = np.full(3, 1.0 / 3.0)


def _material_triangles(vertices: FloatArray, phi: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The material part (φ ≥ 0, φ linear) of triangles ``vertices (..., 3, 2)``: two
    triangles ``(..., 2, 3, 2)`` each, with their areas ``(..., 2)`` (zero when unused)."""
    order = np.argsort(-phi, axis=-1)  # most positive vertex first
    phi = np.take_along_axis(phi, order, axis=-1)
    vertices = np.take_along_axis(vertices, order[..., None], axis=-2)
    a, b, c = (vertices[..., i, :] for i in range(3))
    fa, fb, fc = (phi[..., i] for i in range(3))

    def crossing(p: FloatArray, q: FloatArray, fp: FloatArray, fq: FloatArray) -> FloatArray:
        denominator = fp - fq
        t = np.where(denominator > 0.0, fp / np.where(denominator > 0.0, denominator, 1.0), 0.0)
        return np.asarray(p + np.clip(t, 0.0, 1.0)[..., None] * (q - p))

    p_ab, p_ac, p_bc = crossing(a, b, fa, fb), crossing(a, c, fa, fc), crossing(b, c, fb, fc)
    n_material = np.sum(phi >= 0.0, axis=-1)[..., None, None]
    first = np.select([n_material == 3, n_material == 2],
                      [np.stack([a, b, c], -2), np.stack([a, b, p_bc], -2)],
                      np.stack([a, p_ab, p_ac], -2))
    second = np.stack([a, p_bc, p_ac], -2)
    pieces = np.stack([first, second], axis=-3)
    edge1 = pieces[..., 1, :] - pieces[..., 0, :]
    edge2 = pieces[..., 2, :] - pieces[..., 0, :]
    area = 0.5 * np.abs(edge1[..., 0] * edge2[..., 1] - edge1[..., 1] * edge2[..., 0])
    count = n_material[..., 0, 0]
    used = np.stack([count >= 1, count == 2], axis=-1)
    return pieces, np.where(used, area, 0.0)


def _reference_triangles(n_corners: int, m: int) -> tuple[FloatArray, float]:
    """The reference cell cut into small triangles: (n_tri, 3, 2) vertices, and the cell's
    reference area. Q4: the square [−1, 1]² in m² sub-squares, two triangles each; T3: the
    triangle (0, 0), (1, 0), (0, 1) in m² triangles."""
    if n_corners == 4:
        ticks = np.linspace(-1.0, 1.0, m + 1)
        i, j = (a.ravel() for a in np.meshgrid(np.arange(m), np.arange(m), indexing="ij"))
        lower = np.stack([np.stack([i, j], -1), np.stack([i + 1, j], -1),
                          np.stack([i + 1, j + 1], -1)], axis=1)
        upper = np.stack([np.stack([i, j], -1), np.stack([i + 1, j + 1], -1),
                          np.stack([i, j + 1], -1)], axis=1)
        return ticks[np.concatenate([lower, upper])], 4.0
    ticks = np.linspace(0.0, 1.0, m + 1)
    i, j = (a.ravel() for a in np.meshgrid(np.arange(m), np.arange(m), indexing="ij"))
    keep_lower, keep_upper = i + j <= m - 1, i + j <= m - 2
    lower = np.stack([np.stack([i, j], -1), np.stack([i + 1, j], -1),
                      np.stack([i, j + 1], -1)], axis=1)[keep_lower]
    upper = np.stack([np.stack([i + 1, j], -1), np.stack([i + 1, j + 1], -1),
                      np.stack([i, j + 1], -1)], axis=1)[keep_upper]
    return ticks[np.concatenate([lower, upper])], 0.5


def cut_cells(mesh: RectMesh | UnstructuredMesh, level_set: LevelSet, subdivisions: int = 4,
              min_fraction: float = 1e-6) -> CutCells:
    """Classify the cells of ``mesh`` (Q4, structured or not, or T3) against ``level_set``
    and integrate the cut ones on their material part (see the module docstring);
    vectorised over the cut cells.

    A cell is a candidate when |φ| at its centroid is at most the distance from the centroid
    to its farthest corner (1-Lipschitz φ). A cell with less than ``min_fraction`` of
    material (a hole through a node leaves slivers of 1e-30) counts as void: its stiffness
    would be of that order, and its nodes could be left with no stiffness at all.
    """
    if subdivisions < 1:
        raise ValueError(f"subdivisions must be >= 1, got {subdivisions}")
    corners = mesh.nodes[mesh.cells]  # (c, a, 2)
    n_corners = corners.shape[1]
    centre = corners.mean(axis=1)
    phi_centre = level_set(centre)
    reach = np.linalg.norm(corners - centre[:, None, :], axis=2).max(axis=1)
    fraction = np.where(phi_centre >= 0.0, 1.0, 0.0)
    candidates = np.flatnonzero(np.abs(phi_centre) <= reach * (1.0 + 1e-12))

    vertices, full_area = _reference_triangles(n_corners, subdivisions)  # (n_tri, 3, 2)
    shapes, _ = shape_functions(vertices, n_corners)  # (n_tri, 3, a)
    phys = np.einsum("tva,cad->ctvd", shapes, corners[candidates])
    phi_tri = level_set(phys)  # (n_cand, n_tri, 3)
    pieces, area = _material_triangles(
        np.broadcast_to(vertices, phi_tri.shape + (2,)), phi_tri)
    material_area = area.sum(axis=(1, 2))  # reference area: ``full_area`` for a full cell
    material_area = np.where(material_area < full_area * min_fraction, 0.0, material_area)
    full = material_area >= full_area * (1.0 - 1e-12)
    fraction[candidates] = np.where(full, 1.0, material_area / full_area)
    cut_mask = (material_area > 0.0) & ~full
    cut = candidates[cut_mask]
    points = np.einsum("qv,ctpvd->ctpqd", _TRIANGLE_POINTS, pieces[cut_mask])
    weights = area[cut_mask][..., None] * _TRIANGLE_WEIGHTS
    per_cell = vertices.shape[0] * 2 * _TRIANGLE_WEIGHTS.size  # triangles x pieces x points
    points = points.reshape(cut.size, per_cell, 2)
    weights = weights.reshape(cut.size, per_cell)
    # the points of void sub-triangles and unused pieces (zero weight) left out: each cell's
    # others first, in their order, as many columns as the fullest cell needs (B3: 192 → ~100)
    used = weights > 0.0
    keep = int(used.sum(axis=1).max()) if cut.size else 0
    first = np.argsort(~used, axis=1, kind="stable")[:, :keep]
    quadrature = Quadrature(np.take_along_axis(points, first[..., None], axis=1),
                            np.take_along_axis(weights, first, axis=1))

    material = np.flatnonzero(fraction == 1.0).astype(np.int64)
    void = np.flatnonzero(fraction == 0.0).astype(np.int64)
    active = np.zeros(mesh.n_nodes, dtype=bool)
    active[mesh.cells[fraction > 0.0].ravel()] = True
    return CutCells(material, cut.astype(np.int64), void, quadrature, fraction, active)
