"""Interfaces between non-matching meshes: the mortar coupling (dual Lagrange multipliers).

Where the nodes of the two sides of a perfect or contact interface do not match, one side,
the *slave*, carries the interface points (its trace nodes, as on a matching interface)
and the other, the *master*, is seen there through the mortar projection P of its trace:

    P = D⁻¹ M,   M_ij = ∫_Γ μ_i ψ_j ds,   D_ii = ∫_Γ φ_i ds,

where φ_i are the slave's piecewise-linear trace functions, μ_i their biorthogonal (dual)
functions (on a slave edge with ends a, b: μ_a = 2 φ_a − φ_b, so that ∫ μ_i φ_k = δ_ik
D_ii) and ψ_j the master's trace functions; M is integrated exactly, segment to segment
(Gauss on every piece between the nodes of both sides). P reproduces every linear field
exactly and interpolates the master's trace where the slave's nodes refine the master's.

A converged interface then holds W_slave = P W_master at the slave's nodes and g_master
= −Pᵀ g_slave for the nodal forces g = M0 F: the dual mortar method, variationally
consistent (it passes the patch test on any non-matching mesh). LATIN's local stage is
unchanged: it acts point by point on pairs of points at the same places
(``interfaces.build_points``); the monolithic reference imposes the same constraint
(``reference.monolithic``).

The slave is a side whose nodes begin and end where the interface does, the finer of the
two when both do (the usual choice, which never over-constrains the finer side). A contact
piece that begins on a node of one side and ends on a node of the other (two bodies split at
different places) gives its slave a point of its own at each end where it has no node: its
value there is the slave edge's linear interpolation (``MortarCoupling.slave_trace``), so
that the slave's points still carry its trace on the piece exactly; the slave is then the
side whose such points do not face the other body's corner, else the finer
(``_cut_coupling``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import ModelError
from ..fem.elasticity import FloatArray, IntArray
from ..fem.mesh import SIDES, RectMesh, UnstructuredMesh
from .assembly import Assembly, Interface, Substructure

#: the two-point Gauss rule on [0, 1]: exact for the products of two linear functions
_GAUSS = np.array([0.5 - 0.5 / np.sqrt(3.0), 0.5 + 0.5 / np.sqrt(3.0)])


@dataclass(frozen=True)
class MortarCoupling:
    """How the sides of one non-matching interface are joined."""

    slave: int  # index of the slave side in ``Interface.sides``
    slave_nodes: IntArray  # the slave side's nodes along the interface, in order
    master_nodes: IntArray  # the master side's nodes that P uses, in order
    projection: sp.csr_matrix  # P: (n_slave, n_master), master trace values at slave nodes
    # the slave's points on the coordinate along the interface that P was computed on (a
    # straight side's coordinate; the master's arc length for named curved faces)
    slave_along: FloatArray
    # the slave's values at its points from its ``slave_nodes`` (n_points, n_slave_nodes);
    # None: the identity (every point a node). A contact piece that ends between the nodes
    # of both sides has a point there, on the slave's edge (``mortar_coupling``)
    slave_trace: sp.csr_matrix | None = None

    @property
    def master(self) -> int:
        return 1 - self.slave


def mortar_coupling(assembly: Assembly | Sequence[Substructure], itf: Interface
                    ) -> MortarCoupling | None:
    """The mortar coupling of a perfect or contact interface, None where its two sides have
    matching nodes (the interface is then node to node)."""
    if len(itf.sides) != 2 or itf.kind not in ("perfect", "contact"):
        return None
    subs = assembly.substructures if isinstance(assembly, Assembly) else assembly
    meshes = [subs[ref.substructure].mesh for ref in itf.sides]
    nodes = [ref.nodes(mesh) for ref, mesh in zip(itf.sides, meshes, strict=True)]
    scale = 1e-9 * max(max(m.x1 - m.x0, m.y1 - m.y0) for m in meshes)
    if nodes[0].size == nodes[1].size and np.allclose(
            meshes[0].nodes[nodes[0]], meshes[1].nodes[nodes[1]], atol=scale):
        return None
    if any(ref.side not in SIDES for ref in itf.sides):
        return _curved_coupling(itf, meshes, nodes)
    axis = meshes[0].side_line(itf.sides[0].side)[0]
    spans = [ref.segment if ref.segment is not None else
             (float(mesh.nodes[side_nodes[0], 1 - axis]), float(mesh.nodes[side_nodes[-1], 1 - axis]))
             for ref, mesh, side_nodes in zip(itf.sides, meshes, nodes, strict=True)]
    start, end = max(s[0] for s in spans), min(s[1] for s in spans)
    covering = []
    for index, (side_nodes, mesh) in enumerate(zip(nodes, meshes, strict=True)):
        along = mesh.nodes[side_nodes, 1 - axis]
        if side_nodes.size >= 2 and abs(along[0] - start) <= scale and abs(along[-1] - end) <= scale:
            covering.append(index)
    if not covering:
        if itf.kind != "contact":
            raise ModelError(
                f"interface {itf.name!r}: neither side has nodes where the shared part "
                f"[{start:g}, {end:g}] along {'yx'[axis]} begins and ends; place nodes of "
                "one of the two meshes there")
        return _cut_coupling(subs, itf, nodes, axis, (start, end), scale)
    slave = max(covering, key=lambda index: (nodes[index].size, -index))
    master = 1 - slave
    master_all = itf.sides[master].all_nodes(meshes[master])
    slave_at = meshes[slave].nodes[nodes[slave], 1 - axis]
    master_at = meshes[master].nodes[master_all, 1 - axis]
    return _coupling(slave, nodes[slave], master_all, slave_at, master_at)


def _cut_coupling(subs: Sequence[Substructure], itf: Interface, nodes: list[IntArray],
                  axis: int, span: tuple[float, float], scale: float) -> MortarCoupling:
    """A contact piece whose ends are not both nodes of either side (two bodies split at
    different places): the slave gets a point at each end where it has no node, on its edge
    there (its value interpolated from the edge's two nodes, one of them beyond the piece).
    On the piece the slave's trace is then exactly linear between its points, and the dual
    mortar projection is as on a covered piece. The slave is the side whose such points lie
    where the other body's face goes on (a split of it, not its corner: a point on an edge
    under a corner carried a force mode at 0.988 per iteration), then the side with more
    nodes on the piece."""
    meshes = [subs[ref.substructure].mesh for ref in itf.sides]

    def under_corners(slave: int) -> int:
        """How many of the slave's points on its edges face the other body's corner."""
        other = itf.sides[1 - slave]
        along = meshes[slave].nodes[nodes[slave], 1 - axis]
        return sum(not _face_goes_on(subs, other.substructure, other.side, end, scale)
                   for end in span if not np.any(np.abs(along - end) <= scale))

    slave = min((0, 1), key=lambda index: (under_corners(index), -nodes[index].size, index))
    side_nodes = itf.sides[slave].all_nodes(meshes[slave])
    along = meshes[slave].nodes[side_nodes, 1 - axis]
    order = np.argsort(along)
    side_nodes, along = side_nodes[order], along[order]
    start, end = span
    inside = np.flatnonzero((along >= start - scale) & (along <= end + scale))
    for position, first in ((start, 0), (end, -1)):
        if inside.size > 1 and np.abs(along - position).min() > scale:
            # a node nearer a point on its edge than half the edge is no point of its own:
            # two points that close share one trace, and the force between them moved at
            # 0.9999 per iteration (a block on a base split 0.04 mm from its node); the
            # slave's points keep its linear trace exactly there but for that node's kink
            nearest = int(inside[first])
            edge = along[nearest + (-1 if first == 0 else 1)] - along[nearest]
            if abs(along[nearest] - position) < 0.5 * abs(edge):
                inside = np.delete(inside, first)
    rows: list[int] = []
    cols: list[int] = []
    vals: list[float] = []
    at: list[float] = []

    def point(position: float, weights: dict[int, float]) -> None:
        for node, weight in weights.items():
            rows.append(len(at))
            cols.append(node)
            vals.append(weight)
        at.append(position)

    for position, edge_end in ((start, 0), (end, 1)):
        if edge_end == 1:
            for k in inside:
                point(float(along[k]), {int(k): 1.0})
        if np.abs(along - position).min() > scale:  # an end on the slave's edge
            right = int(np.searchsorted(along, position))
            share = (position - along[right - 1]) / (along[right] - along[right - 1])
            point(position, {right - 1: 1.0 - share, right: share})
    used = np.unique(cols)
    trace = sp.csr_matrix((vals, (rows, np.searchsorted(used, cols))),
                          shape=(len(at), used.size))
    master = 1 - slave
    master_all = itf.sides[master].all_nodes(meshes[master])
    master_at = meshes[master].nodes[master_all, 1 - axis]
    coupling = _coupling(slave, side_nodes[used], master_all, np.array(at), master_at)
    return dataclasses.replace(coupling, slave_trace=trace)


def _face_goes_on(subs: Sequence[Substructure], index: int, side: str, at: float,
                  scale: float) -> bool:
    """Whether another substructure of the body of ``subs[index]`` has its ``side`` on the
    same line, meeting this one's at ``at``: the body's face goes on there (a split)."""
    axis, level, _, _ = subs[index].mesh.side_line(side)
    for k, sub in enumerate(subs):
        if k == index or sub.body != subs[index].body:
            continue
        other_axis, other_level, lo, hi = sub.mesh.side_line(side)
        if (other_axis == axis and abs(other_level - level) <= scale
                and min(abs(lo - at), abs(hi - at)) <= scale):
            return True
    return False


def _coupling(slave: int, slave_nodes: IntArray, master_nodes: IntArray, slave_at: FloatArray,
              master_at: FloatArray) -> MortarCoupling:
    """P on the common coordinate (the slave's positions may run either way)."""
    flip = slave_at[-1] < slave_at[0]
    projection = dual_mortar_projection(slave_at[::-1] if flip else slave_at, master_at)
    if flip:
        projection = projection[::-1]
    used = np.flatnonzero(np.asarray(abs(projection).sum(axis=0)).ravel() > 0.0)
    return MortarCoupling(slave, slave_nodes, master_nodes[used].astype(np.int64),
                          projection[:, used].tocsr(), np.asarray(slave_at, dtype=np.float64))


def _curved_coupling(itf: Interface, meshes: list[RectMesh | UnstructuredMesh],
                     nodes: list[IntArray]) -> MortarCoupling:
    """Named curved faces: each side's nodes projected on the other side's polyline (the
    closest point); a side whose projections all fall on the other is covered by it. The
    slave is the finer covered side; the common coordinate is the master's arc length."""
    covered = []
    for index in (0, 1):
        master_xy = meshes[1 - index].nodes[nodes[1 - index]]
        at, inside = _on_polyline(meshes[index].nodes[nodes[index]], master_xy)
        monotone = np.all(np.diff(at) > 0) or np.all(np.diff(at) < 0)
        if inside and monotone:
            covered.append((index, at))
    if not covered:
        raise ModelError(f"interface {itf.name!r}: neither face lies along the other (each "
                         "face's nodes must project, in order, onto the other face)")
    slave, slave_at = max(covered, key=lambda item: (nodes[item[0]].size, -item[0]))
    master_xy = meshes[1 - slave].nodes[nodes[1 - slave]]
    master_at = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(master_xy, axis=0), axis=1))]
    return _coupling(slave, nodes[slave], nodes[1 - slave], slave_at, master_at)


def _on_polyline(points: FloatArray, polyline: FloatArray) -> tuple[FloatArray, bool]:
    """Arc length along ``polyline`` of each point's closest point on it, and whether every
    point projects inside it (not beyond its ends, up to 1e-9 of its length)."""
    start, direction = polyline[:-1], np.diff(polyline, axis=0)
    length = np.linalg.norm(direction, axis=1)
    t = np.einsum("psd,sd->ps", points[:, None, :] - start[None], direction) / length**2
    clipped = np.clip(t, 0.0, 1.0)
    nearest = start[None] + clipped[..., None] * direction[None]
    distance = np.linalg.norm(points[:, None, :] - nearest, axis=2)
    segment = np.argmin(distance, axis=1)
    rows = np.arange(points.shape[0])
    cumulative = np.r_[0.0, np.cumsum(length)]
    at = cumulative[segment] + clipped[rows, segment] * length[segment]
    total = cumulative[-1]
    beyond = (t[rows, segment] < -1e-9 * total / length[segment]) | (
        t[rows, segment] > 1.0 + 1e-9 * total / length[segment])
    return at, not bool(beyond.any())


def touching_by_declaration(itf: Interface) -> bool:
    """Named faces declared in an interface touch: the distance between their polylines
    (chords of different meshes of one curve sag differently) is no gap."""
    return any(ref.side not in SIDES for ref in itf.sides)


def facing_positions(subs: Sequence[Substructure], itf: Interface,
                     coupling: MortarCoupling | None) -> tuple[FloatArray, FloatArray]:
    """Where each side of an interface is at its points (nodal): the two sides' nodes, or
    (mortar) the slave's nodes and the master's projected trace, in side order."""
    meshes = [subs[ref.substructure].mesh for ref in itf.sides]
    if coupling is None:
        return tuple(mesh.nodes[ref.nodes(mesh)]  # type: ignore[return-value]
                     for ref, mesh in zip(itf.sides, meshes, strict=True))
    slave = meshes[coupling.slave].nodes[coupling.slave_nodes]
    if coupling.slave_trace is not None:
        slave = coupling.slave_trace @ slave
    master = coupling.projection @ meshes[coupling.master].nodes[coupling.master_nodes]
    return (slave, master) if coupling.slave == 0 else (master, slave)


def face_distances(subs: Sequence[Substructure], itf: Interface) -> tuple[FloatArray, FloatArray]:
    """Between the two faces of an interface, at each of its points: the distance from the
    one face to the other (``facing_positions``), and the longest edge next to the point."""
    here, there = facing_positions(subs, itf, mortar_coupling(subs, itf))
    edges = np.linalg.norm(np.diff(here, axis=0), axis=1)
    longest = np.maximum(np.r_[edges, 0.0], np.r_[0.0, edges])
    return np.linalg.norm(there - here, axis=1), longest


def dual_mortar_projection(slave_at: FloatArray, master_at: FloatArray) -> sp.csr_matrix:
    """P = D⁻¹ M for piecewise-linear traces on a straight interface: the slave's nodes at
    (increasing) positions ``slave_at``, the master's at ``master_at``; the interface is the
    slave's span [slave_at[0], slave_at[-1]], which the master's must cover."""
    lo, hi = float(slave_at[0]), float(slave_at[-1])
    tolerance = 1e-12 * (hi - lo)
    if master_at[0] > lo + tolerance or master_at[-1] < hi - tolerance:
        raise ModelError("mortar interface: the master side does not cover the slave side "
                         f"[{lo:g}, {hi:g}]")
    breaks = np.unique(np.concatenate([slave_at, np.clip(master_at, lo, hi)]))
    length = np.diff(breaks)
    keep = length > tolerance
    a, length = breaks[:-1][keep], length[keep]
    x = (a[:, None] + length[:, None] * _GAUSS[None, :]).ravel()  # Gauss points
    w = np.repeat(0.5 * length, 2)
    e = np.clip(np.searchsorted(slave_at, x) - 1, 0, slave_at.size - 2)  # slave edge
    xi = (x - slave_at[e]) / (slave_at[e + 1] - slave_at[e])
    m = np.clip(np.searchsorted(master_at, x) - 1, 0, master_at.size - 2)  # master edge
    eta = (x - master_at[m]) / (master_at[m + 1] - master_at[m])
    dual = (2.0 - 3.0 * xi, 3.0 * xi - 1.0)  # μ of the edge's first and second node
    shape = (1.0 - eta, eta)
    rows, cols, vals = [], [], []
    for i_local, mu in enumerate(dual):
        for j_local, psi in enumerate(shape):
            rows.append(e + i_local)
            cols.append(m + j_local)
            vals.append(w * mu * psi)
    mixed = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                          shape=(slave_at.size, master_at.size))
    edge = np.diff(slave_at)
    dual_cell = np.zeros(slave_at.size)
    dual_cell[:-1] += 0.5 * edge
    dual_cell[1:] += 0.5 * edge
    projection = sp.diags(1.0 / dual_cell) @ mixed
    projection.data[np.abs(projection.data) < 1e-14] = 0.0
    projection.eliminate_zeros()
    return projection.tocsr()
