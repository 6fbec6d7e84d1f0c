"""Discretisation of the interface fields W, F (paper §2.1–2.2).

Every interface side carries piecewise-constant fields on *interface elements*. All
interface points of the whole assembly are numbered globally, grouped by substructure, so
that each linear-stage operator is block-diagonal and the local stage works on flat arrays.

Choice of interface elements (``interface_elements``), decided by test
(``tests/test_interface_discretisation.py``):

``"nodal"`` (default)
    P0 on the dual cells of the trace nodes: each element is the half-edges around a node
    and its value is the trace at that node (T selects nodal values; the M0 weights are the
    dual-cell lengths). T has no kernel, so continuity of W is exactly the conforming
    finite-element continuity: a converged perfect interface reproduces the monolithic
    solution on the same mesh to round-off, there is no checkerboard in F, and contact acts
    node to node.
``"edges"``
    the paper's P0 on every mesh edge, W = mean of the trace on the edge. T has a zig-zag
    kernel: the converged forces checkerboard and continuity holds in the mean only.
``"edge-pairs"``
    P0 on groups of two mesh edges (method.md's prototype): no checkerboard, but continuity
    in the mean only, so the answer differs from the monolithic one at discretisation level.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from ..errors import ModelError
from ..fem.elasticity import FloatArray, IntArray
from ..fem.mesh import SIDES, RectMesh, UnstructuredMesh, normal_axis
from .assembly import DISPLACEMENT, FORCE, Assembly, Interface, consistent_densities
from .held_nodes import (
    held_corners,
    held_perfect_pairs,
    held_stops,
    nodal_points,
    node_key,
    prescribed_components,
)
from .mortar import MortarCoupling, mortar_coupling, touching_by_declaration

INTERFACE_ELEMENTS = ("nodal", "edges", "edge-pairs")


@dataclass(frozen=True)
class SideDiscretisation:
    """Interface elements on one substructure side: trace rows and weights."""

    nodes: IntArray  # side nodes of the substructure mesh, in order
    trace: sp.csr_matrix  # (n_points, n_side_nodes): value at point = trace @ nodal values
    weights: FloatArray  # element lengths × thickness (the diagonal of M0)
    coords: FloatArray  # (n_points, 2) element centres (nodes for "nodal")
    extents: FloatArray  # (n_points, 2) element start/end along the side's coordinate


def discretise_side(node_coords: FloatArray, nodes: IntArray, kind: str,
                    thickness: float, along: FloatArray | None = None) -> SideDiscretisation:
    """Interface elements of kind ``kind`` on a side whose ordered nodes are ``nodes``.

    along: the nodes' positions on the interface's own coordinate (a mortar interface's,
        ``MortarCoupling.slave_along``: a curved face meeting a side is measured along the
        side), for the lengths and the extents; by default lengths are along the edges.
    """
    xy = node_coords[nodes]
    if along is None:
        along = xy[:, int(np.argmax(np.abs(xy[-1] - xy[0])))]  # the coordinate that varies
        edge_len = np.linalg.norm(np.diff(xy, axis=0), axis=1)
    else:
        edge_len = np.abs(np.diff(along))
    n_edges = edge_len.size
    if kind == "nodal":
        dual = np.zeros(n_edges + 1)
        dual[:-1] += 0.5 * edge_len
        dual[1:] += 0.5 * edge_len
        mid = 0.5 * (along[1:] + along[:-1])
        extents = np.sort(np.column_stack([np.r_[along[0], mid], np.r_[mid, along[-1]]]),
                          axis=1)
        identity = sp.csr_matrix((np.ones(n_edges + 1), np.arange(n_edges + 1),
                                  np.arange(n_edges + 2)), shape=(n_edges + 1, n_edges + 1))
        return SideDiscretisation(nodes, identity,
                                  np.asarray(dual * thickness, dtype=np.float64), xy.copy(),
                                  extents)
    if kind == "edges":
        group = 1
    elif kind == "edge-pairs":
        group = 2
    else:
        raise ValueError(f"interface_elements must be one of {INTERFACE_ELEMENTS}, got {kind!r}")
    n_groups = max(n_edges // group, 1)
    owner = np.minimum(np.arange(n_edges) // group, n_groups - 1)  # remainder joins the last
    length = np.bincount(owner, weights=edge_len, minlength=n_groups)
    # mean over the group of the linear trace: each edge contributes len/2 to both its nodes
    share = 0.5 * edge_len / length[owner]
    rows = np.concatenate([owner, owner])
    cols = np.concatenate([np.arange(n_edges), np.arange(n_edges) + 1])
    trace = sp.csr_matrix((np.concatenate([share, share]), (rows, cols)),
                          shape=(n_groups, n_edges + 1))
    centres = trace @ xy
    first = np.r_[0, np.flatnonzero(np.diff(owner)) + 1]
    last = np.r_[first[1:], n_edges]
    extents = np.column_stack([along[first], along[last]])
    return SideDiscretisation(nodes, trace, np.asarray(length * thickness, dtype=np.float64),
                              np.asarray(centres, dtype=np.float64), extents)


def slave_side(node_coords: FloatArray, coupling: MortarCoupling) -> SideDiscretisation:
    """A mortar interface's points on its slave side: its nodes, or where a contact piece
    ends between nodes (``MortarCoupling.slave_trace``) a point on the edge there too, with
    the dual cells' lengths along the interface."""
    if coupling.slave_trace is None:
        return discretise_side(node_coords, coupling.slave_nodes, "nodal", 1.0,
                               along=coupling.slave_along)
    at = coupling.slave_trace @ node_coords[coupling.slave_nodes]
    disc = discretise_side(at, np.arange(at.shape[0]), "nodal", 1.0, along=coupling.slave_along)
    return dataclasses.replace(disc, nodes=coupling.slave_nodes, trace=coupling.slave_trace)


def point_normals(mesh: RectMesh | UnstructuredMesh, side: str, nodes: IntArray,
                  trace: sp.csr_matrix | None = None) -> FloatArray:
    """Outward unit normals of ``side`` at points whose values are ``trace`` (default: the
    identity) times the values at its ``nodes``: a rectangle side's one normal, or a named
    face's normals at its nodes, interpolated (a mortar master's at the slave's nodes)."""
    n = nodes.size if trace is None else trace.shape[0]
    if side in SIDES:
        return np.broadcast_to(mesh.outward_normal(side), (n, 2)).copy()
    assert isinstance(mesh, UnstructuredMesh)
    row = {int(node): k for k, node in enumerate(mesh.side_nodes(side))}
    at = mesh.face_normals(side)[[row[int(node)] for node in nodes]]
    if trace is not None:
        at = trace @ at
    return np.asarray(at / np.linalg.norm(at, axis=1, keepdims=True), dtype=np.float64)


def _discretise_interface(assembly: Assembly, itf: Interface, kind: str
                          ) -> list[SideDiscretisation]:
    """Interface elements on each side of ``itf``. Between non-matching meshes (mortar,
    ``decomposition.mortar``) both sides carry the slave side's points: the master's trace
    there is the mortar projection of its own, with the slave's weights, so the local stage
    acts on pairs of points at the same places as on a matching interface. The weights are
    lengths (thickness 1): LATIN's interface forces are per unit length, whatever the two
    sides' thicknesses (a traction density times its side's thickness), so that a perfect
    pair balances as F_a = −F_b between parts of other thicknesses."""
    subs = [assembly.substructures[ref.substructure] for ref in itf.sides]
    coupling = mortar_coupling(assembly, itf)
    if coupling is None:  # weights of thickness 1: LATIN's fields are per unit length
        return [discretise_side(sub.mesh.nodes, ref.nodes(sub.mesh), kind, 1.0)
                for ref, sub in zip(itf.sides, subs, strict=True)]
    if kind != "nodal":
        raise ModelError(f"interface {itf.name!r} joins non-matching meshes (mortar), which "
                         f"needs interface_elements = 'nodal', got {kind!r}")
    slave = slave_side(subs[coupling.slave].mesh.nodes, coupling)
    master = dataclasses.replace(slave, nodes=coupling.master_nodes, trace=coupling.projection)
    return [slave, master] if coupling.slave == 0 else [master, slave]


@dataclass(frozen=True)
class InterfacePoints:
    """All interface points of an assembly, numbered globally and grouped by substructure.

    Field arrays are shaped ``(n_steps, n_points, 2)`` (x, y components).
    """

    substructure: IntArray  # (P,) owning substructure
    interface: IntArray  # (P,) interface index in ``assembly.interfaces``
    coords: FloatArray  # (P, 2)
    weights: FloatArray  # (P,) diagonal of M0: lengths (fields are per unit length)
    normals: FloatArray  # (P, 2) outward normal of the point's substructure side
    extents: FloatArray  # (P, 2) element start/end along its side's coordinate
    offsets: IntArray  # (n_sub + 1,) points of substructure s: offsets[s]:offsets[s+1]
    traces: tuple[sp.csr_matrix, ...]  # per substructure: (2 P_s, 2 n_nodes) dof trace T_E
    pairs: tuple[IntArray, IntArray]  # perfect interfaces: point a of E faces point b of E'
    macro_only: tuple[int, ...]  # macro-only interfaces (eq. [20]), possibly non-matching
    contact_pairs: tuple[IntArray, IntArray]  # contact interfaces, a on side E (normal n_E)
    contact_friction: FloatArray  # per contact pair
    contact_gap: FloatArray  # the law's gap + ``contact_offset``
    # per contact pair: n_a · (X_b − X_a), the initial distance between the two sides'
    # traces of the node positions (0 on straight sides; a curved face's own gaps)
    contact_offset: FloatArray
    stops: IntArray  # points in contact with a rigid obstacle
    stop_friction: FloatArray
    stop_gap: FloatArray
    boundary: IntArray  # (P_b,) points with prescribed displacement / force components
    boundary_is_displacement: npt.NDArray[np.bool_]  # (P_b, 2) prescribed displacement (else force)
    side_points: dict[tuple[int, int], IntArray]  # (interface, side index) -> points
    corner: IntArray  # contact pairs whose two sides' tangential motion is rigidly held
    corner_stops: IntArray  # (n_corner, 2) index in ``stops`` holding side a / b, −1: fixed
    corner_boundaries: IntArray  # (n_corner, 2) index in ``boundary`` holding a / b, −1: a stop
    # contact pairs held tangentially on one side only (``held_nodes.held_corners``), per pair: the
    # held side (0: a, 1: b, −1: neither or both), and what holds it: an index in
    # ``boundary`` (a prescribed displacement) or in ``stops`` (when closed), else −1
    held_side: IntArray
    held_boundary: IntArray
    held_stop: IntArray
    # perfect pairs held on one side by a prescribed displacement, per pair and component:
    # the held side (0: a, 1: b, −1: neither or both) and its index in ``boundary``
    pair_held_side: IntArray  # (n_pairs, 2)
    pair_held_boundary: IntArray  # (n_pairs, 2)
    # stops held tangentially at their node (``held_nodes.held_stops``), per stop: the
    # holder's index in ``boundary`` (a prescribed displacement) or in ``stops``, else −1
    stop_held_boundary: IntArray
    stop_held_stop: IntArray

    @property
    def n_points(self) -> int:
        return int(self.weights.size)



def _dof_trace(rows: list[IntArray], nodes: list[IntArray], values: list[FloatArray],
               n_points: int, n_nodes: int) -> sp.csr_matrix:
    """T_E on degrees of freedom, (2 n_points, 2 n_nodes), from the node trace's entries
    (point row, node, value): the same entry for x and for y."""
    if not rows:
        return sp.csr_matrix((2 * n_points, 2 * n_nodes))
    row, node, value = np.concatenate(rows), np.concatenate(nodes), np.concatenate(values)
    return sp.csr_matrix((np.concatenate([value, value]),
                          (np.concatenate([2 * row, 2 * row + 1]),
                           np.concatenate([2 * node, 2 * node + 1]))),
                         shape=(2 * n_points, 2 * n_nodes))


def build_points(assembly: Assembly, kind: str = "nodal", *,
                 held_nodes: bool = True) -> InterfacePoints:
    """Discretise every interface side of ``assembly`` with interface elements ``kind``.

    held_nodes: find the contact and perfect pairs held on one side (``held_nodes.held_corners``,
        ``held_nodes.held_perfect_pairs``); False leaves them to the two-sided rule (before issue 15).
    """
    per_sub: list[list[tuple[int, int, SideDiscretisation]]] = [
        [] for _ in assembly.substructures
    ]
    for i, itf in enumerate(assembly.interfaces):
        for side_index, disc in enumerate(_discretise_interface(assembly, itf, kind)):
            per_sub[itf.sides[side_index].substructure].append((i, side_index, disc))

    substructure, interface, coords, weights, traces = [], [], [], [], []
    nodal = []  # per point: its trace is one node's value (``held_nodes.node_key``)
    positions = []  # the trace of the node positions at every point
    normals, extents = [], []
    side_points: dict[tuple[int, int], IntArray] = {}
    offsets = [0]
    count = 0
    for s, sides in enumerate(per_sub):
        n_nodes = assembly.substructures[s].mesh.n_nodes
        first = count
        trace_rows, trace_nodes, trace_values = [], [], []
        for i, side_index, disc in sides:
            n = disc.weights.size
            side_points[(i, side_index)] = np.arange(count, count + n)
            count += n
            substructure.append(np.full(n, s))
            interface.append(np.full(n, i))
            coords.append(disc.coords)
            positions.append(disc.trace @ assembly.substructures[s].mesh.nodes[disc.nodes])
            weights.append(disc.weights)
            extents.append(disc.extents)
            side = assembly.interfaces[i].sides[side_index].side
            normals.append(point_normals(assembly.substructures[s].mesh, side, disc.nodes,
                                         disc.trace))
            trace = disc.trace
            nodal.append(nodal_points(trace))
            trace_rows.append(np.repeat(np.arange(count - n - first, count - first),
                                        np.diff(trace.indptr)))
            trace_nodes.append(disc.nodes[trace.indices])
            trace_values.append(trace.data)
        traces.append(_dof_trace(trace_rows, trace_nodes, trace_values, count - first,
                                 n_nodes))
        offsets.append(count)

    all_coords = np.concatenate(coords) if coords else np.zeros((0, 2))
    pairs_a, pairs_b, bnd, bnd_disp = [], [], [], []
    contact_a, contact_b, stop = [], [], []
    macro_only: list[int] = []
    for i, itf in enumerate(assembly.interfaces):
        pa = side_points[(i, 0)]
        if itf.kind == "macro":
            macro_only.append(i)
        elif itf.kind in ("perfect", "contact"):
            pb = side_points[(i, 1)]
            if itf.kind == "perfect":
                pairs_a.append(pa)
                pairs_b.append(pb)
            else:
                assert itf.contact is not None
                contact_a.append(pa)
                contact_b.append(pb)
        elif itf.is_stop:
            stop.append(pa)
        else:
            assert itf.condition is not None
            bnd.append(pa)
            mask = np.array([k == DISPLACEMENT for k in itf.condition.kinds])
            bnd_disp.append(np.broadcast_to(mask, (pa.size, 2)))

    def cat(parts: list[np.ndarray], dtype: type = np.int64) -> np.ndarray:
        return np.concatenate(parts).astype(dtype) if parts else np.zeros(0, dtype=dtype)

    contact_pairs = (cat(contact_a), cat(contact_b))
    stops = cat(stop)
    boundary = cat(bnd)
    is_displacement = (np.concatenate(bnd_disp) if bnd_disp else np.zeros((0, 2), dtype=bool))
    all_normals = np.concatenate(normals) if normals else np.zeros((0, 2))
    at = np.concatenate(positions) if positions else np.zeros((0, 2))
    a, b = contact_pairs
    contact_offset = np.einsum("pi,pi->p", all_normals[a], at[b] - at[a])
    contact_offset[np.abs(contact_offset) <= 1e-12 * max(np.ptp(at), 1.0)] = 0.0
    touching = [i for i, itf in enumerate(assembly.interfaces) if touching_by_declaration(itf)]
    contact_offset[np.isin(cat(interface)[a], touching)] = 0.0
    key = node_key(cat(substructure), all_coords, cat(nodal, bool))
    fixed = prescribed_components(key, boundary, is_displacement)
    held = held_corners(key, fixed, contact_pairs, stops, all_normals)
    held.update(held_perfect_pairs(key, fixed, (cat(pairs_a), cat(pairs_b))))
    held.update(held_stops(key, fixed, stops, all_normals))
    if not held_nodes:
        for name in ("held_side", "held_boundary", "held_stop", "pair_held_side",
                     "pair_held_boundary", "stop_held_boundary", "stop_held_stop"):
            held[name] = np.full_like(held[name], -1)
    return InterfacePoints(
        substructure=cat(substructure),
        interface=cat(interface),
        coords=all_coords,
        weights=cat(weights, np.float64),
        normals=np.concatenate(normals) if normals else np.zeros((0, 2)),
        extents=np.concatenate(extents) if extents else np.zeros((0, 2)),
        offsets=np.array(offsets, dtype=np.int64),
        traces=tuple(traces),
        pairs=(cat(pairs_a), cat(pairs_b)),
        macro_only=tuple(macro_only),
        contact_pairs=contact_pairs,
        stops=stops,
        boundary=boundary,
        boundary_is_displacement=is_displacement,
        **_contact_data(assembly, side_points, contact_offset),
        contact_offset=contact_offset,
        side_points=side_points,
        corner=held["corner"],
        corner_stops=held["corner_stops"],
        corner_boundaries=held["corner_boundaries"],
        held_side=held["held_side"],
        held_boundary=held["held_boundary"],
        held_stop=held["held_stop"],
        pair_held_side=held["pair_held_side"],
        pair_held_boundary=held["pair_held_boundary"],
        stop_held_boundary=held["stop_held_boundary"],
        stop_held_stop=held["stop_held_stop"],
    )


def _contact_data(assembly: Assembly, side_points: dict[tuple[int, int], IntArray],
                  contact_offset: FloatArray) -> dict[str, Any]:
    """Friction coefficients and initial gaps per contact pair and per stop point, in the
    order of ``InterfacePoints.contact_pairs`` and ``stops``; the pairs' gaps include
    ``contact_offset``."""
    parts: dict[str, list[FloatArray]] = {"contact_friction": [], "contact_gap": [],
                                          "stop_friction": [], "stop_gap": []}
    for i, itf in enumerate(assembly.interfaces):
        if itf.kind != "contact" and not itf.is_stop:
            continue
        assert itf.contact is not None
        n = side_points[(i, 0)].size
        prefix = "stop" if itf.is_stop else "contact"
        parts[f"{prefix}_friction"].append(np.full(n, itf.contact.friction))
        parts[f"{prefix}_gap"].append(np.full(n, itf.contact.gap))
    data = {name: np.concatenate(values) if values else np.zeros(0)
            for name, values in parts.items()}
    data["contact_gap"] = data["contact_gap"] + contact_offset
    return data


def with_contact_data(points: InterfacePoints, assembly: Assembly) -> InterfacePoints:
    """``points`` (built for an assembly of the same geometry) with the friction
    coefficients and gaps of ``assembly``: what changes between the cases of a batch."""
    data = _contact_data(assembly, points.side_points, points.contact_offset)
    return dataclasses.replace(points, contact_friction=data["contact_friction"],
                               contact_gap=data["contact_gap"],
                               stop_friction=data["stop_friction"], stop_gap=data["stop_gap"])


def interface_functions(points: InterfacePoints, interface: int, n_sides: int,
                        reference: int = 0) -> list[FloatArray]:
    """The macro functions of one straight interface, per side: columns (constant, linear in
    s), s along the interface from the ``reference`` side's first point. They are
    orthonormal in that side's discrete M0 inner product and take the same (affine) values
    at the points of the other side, so that on a non-matching interface both sides carry
    the same continuous functions."""
    pts = points.side_points[(interface, reference)]
    xy = points.coords[pts]
    w = points.weights[pts]
    tangent = xy[-1] - xy[0]
    tangent = tangent / np.linalg.norm(tangent)
    s = (xy - xy[0]) @ tangent
    const = 1.0 / np.sqrt(w.sum())
    mean = (w @ s) / w.sum()
    norm = np.sqrt(w @ (s - mean) ** 2)
    linear = norm > 1e-12 * np.abs(s).max()
    out = []
    for side in range(n_sides):
        side_s = (points.coords[points.side_points[(interface, side)]] - xy[0]) @ tangent
        columns = [np.full_like(side_s, const)] + ([(side_s - mean) / norm] if linear else [])
        out.append(np.column_stack(columns))
    return out


def macro_basis(assembly: Assembly, points: InterfacePoints) -> sp.csr_matrix:
    """The macro basis Ẽ (2P × n_macro) of the *free* macro unknowns (paper §2.2, fig. 3).

    Per interface and per component (x, y): a constant and a linear-in-s function, i.e.
    resultant, extension and moment, n_M = 4 for a straight interface; orthonormal in the
    discrete M0 inner product, so Π(F) = Σ (F, e_i) e_i is an exact projector (eq. [5]–[6]).
    A column takes the same values on both sides of a perfect or contact interface (W̃ᴹ
    continuous, eq. [10]: action–reaction holds across contact too) and the same continuous
    function on both sides of a non-matching macro-only one (``interface_functions``); see
    ``free_macro_components`` for the outer boundary.
    """
    rows: list[np.ndarray] = []
    cols: list[np.ndarray] = []
    vals: list[np.ndarray] = []
    n_cols = 0
    for i, itf in enumerate(assembly.interfaces):
        functions = interface_functions(points, i, len(itf.sides))
        free = free_macro_components(itf)
        for comp in range(2):
            if not free[comp]:
                continue
            for f in range(functions[0].shape[1]):
                for side_index, values in enumerate(functions):
                    side_pts = points.side_points[(i, side_index)]
                    rows.append(2 * side_pts + comp)
                    cols.append(np.full(side_pts.size, n_cols))
                    vals.append(values[:, f])
                n_cols += 1
    if not rows:
        return sp.csr_matrix((2 * points.n_points, 0))
    return sp.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
        shape=(2 * points.n_points, n_cols),
    )


def free_macro_components(itf: Interface) -> tuple[bool, bool]:
    """Which components (x, y) of an interface carry free macro unknowns W̃ᴹ.

    Between two substructures: both. On the outer boundary W̃ᴹ = 0 where the force is
    unknown to the outside (prescribed displacement; the normal of a rigid stop; its tangent
    too when it has friction) and free where the force is prescribed (including the zero
    tangential force of a frictionless stop).
    """
    if len(itf.sides) == 2:
        return True, True
    assert itf.condition is not None
    if itf.is_stop:
        assert itf.contact is not None
        axis = normal_axis(itf.sides[0].side)
        frictionless = itf.contact.friction == 0.0
        return (frictionless and axis == 1, frictionless and axis == 0)
    kinds = itf.condition.kinds
    return kinds[0] == FORCE, kinds[1] == FORCE


def boundary_data(assembly: Assembly, points: InterfacePoints) -> FloatArray:
    """W_d on displacement components, F_d on force ones, at the boundary points, per step
    (F_d per unit length: the traction times the side's thickness, or 2π r)."""
    prescribed = np.zeros((assembly.n_steps, points.boundary.size, 2))
    offset = 0
    for i, itf in enumerate(assembly.interfaces):
        if itf.kind != "boundary" or itf.is_stop:
            continue
        assert itf.condition is not None
        n = points.side_points[(i, 0)].size
        factor = assembly.history.factor(itf.condition.factor)
        at = points.side_points[(i, 0)]
        material = assembly.substructures[itf.sides[0].substructure].material
        thickness = material.thickness_at(points.coords[at])[:, None]  # 2π r axisymmetric
        values = itf.condition.values_at(points.coords[at])  # (n, 2)
        if itf.condition.pressure:  # traction −p n at each point
            values = -values[:, :1] * points.normals[at]
        force = np.array([kind != DISPLACEMENT for kind in itf.condition.kinds])
        if itf.condition.varying is not None:  # the consistent load of a varying traction
            values[:, force] = consistent_densities(points.coords[at], values)[:, force]
        prescribed[:, offset:offset + n] = factor[:, None, None] * values[None]
        prescribed[:, offset:offset + n, force] *= thickness
        offset += n
    return prescribed
