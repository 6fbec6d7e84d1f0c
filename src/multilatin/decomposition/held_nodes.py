"""Interface points held on one side or both (cross points), found once when the interface
points are built (``interfaces.build_points``); the local stage's held-node rule (issue 15)
uses them.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from ..fem.elasticity import FloatArray, IntArray

NodeKey = Callable[[int], tuple[int, float, float]]


def held_corners(key: NodeKey, fixed: dict[tuple[tuple[int, float, float], int], int],
                  contact_pairs: tuple[IntArray, IntArray], stops: IntArray,
                  normals: FloatArray) -> dict[str, IntArray]:
    """Contact pairs whose tangential displacement is held, at the same node of the same
    substructure, by a prescribed displacement or a stop: the ends of a contact interface on
    a clamped or pushed face or on a stop (cross points).

    Held on both sides (B1's corner between the stop and the wall-held top block): the
    friction force is statically indeterminate (any value in the cone balances); the local
    stage keeps it at its previous step's value, the limit of any tangential compliance
    (``corner``, ``corner_stops``). While the stop of such a corner is open, its prescribed
    displacement holds alone: the one-sided rule below applies.

    Held on both sides by prescribed displacements that move against each other along the
    contact, or by one that moves and a closed stop (``corner_boundaries``: the holders'
    indices in ``boundary``, −1 for a stop), the pair slides, and Coulomb's law gives its
    friction: at the cone (``latin.held_stops.moving_corners``).

    Held on one side only: the held node's tangential force is shared between the contact
    point and the holding condition, and only their sum is determined: with nodal
    interface fields that split is an (almost) neutral mode of the iteration, so slow
    against a stiff partner that η hardly sees it (measured: R_push 3.7 % off at η < 3e-6
    for a block on a 1 000 times stiffer foundation, ``benchmarks/slide.py``). The local
    stage therefore gives that pair's friction from the *free* side alone, as against an
    obstacle moving with the held node (``held_side``, ``held_boundary``, ``held_stop``).
    """
    stop_of = _stops_by_axis(key, stops, normals)
    n_pairs = contact_pairs[0].size
    corner, corner_stops, corner_boundaries = [], [], []
    held_side = np.full(n_pairs, -1, dtype=np.int64)
    held_boundary = np.full(n_pairs, -1, dtype=np.int64)
    held_stop = np.full(n_pairs, -1, dtype=np.int64)
    for j, (a, b) in enumerate(zip(*contact_pairs, strict=True)):
        tangential = 1 - int(np.argmax(np.abs(normals[a])))
        holders: list[tuple[int, int, int]] = []  # (side, boundary index, stop index)
        for side, p in enumerate((int(a), int(b))):
            if (key(p), tangential) in fixed:
                holders.append((side, fixed[(key(p), tangential)], -1))
            elif (key(p), tangential) in stop_of:
                holders.append((side, -1, stop_of[(key(p), tangential)]))
        if len(holders) == 2:
            corner.append(j)
            corner_stops.append([-1 if stop < 0 else stop for _, _, stop in holders])
            corner_boundaries.append([boundary for _, boundary, _ in holders])
            # while a stop holder is open, the other side's prescribed displacement holds
            # alone: the one-sided rule (B1's (50, 100) before the stop closes)
            by_displacement = [h for h in holders if h[1] >= 0]
            if len(by_displacement) == 1:
                held_side[j], held_boundary[j], held_stop[j] = by_displacement[0]
        elif len(holders) == 1:
            held_side[j], held_boundary[j], held_stop[j] = holders[0]
    return {"corner": np.array(corner, dtype=np.int64),
            "corner_stops": np.array(corner_stops, dtype=np.int64).reshape(-1, 2),
            "corner_boundaries": np.array(corner_boundaries, dtype=np.int64).reshape(-1, 2),
            "held_side": held_side, "held_boundary": held_boundary, "held_stop": held_stop}


def _stops_by_axis(key: NodeKey, stops: IntArray, normals: FloatArray
                   ) -> dict[tuple[tuple[int, float, float], int], int]:
    """(node, the axis of its stop's normal) -> the stop's index in ``stops``: what a stop
    holds at its node."""
    return {(key(int(p)), int(np.argmax(np.abs(normals[p])))): q for q, p in enumerate(stops)}


def node_key(substructure: IntArray, coords: FloatArray,
             nodal: npt.NDArray[np.bool_] | None = None) -> NodeKey:
    """A point's node: its substructure and coordinates (points of different sides of a
    substructure at the same node share it). nodal: per point, whether its trace is one
    node's value; a point that is not (a mortar master's, ``decomposition.mortar``: the
    projection of several nodes' values) is a node of its own, so that no rule holds it
    by a condition on the node it sits at. Held there, its Ŵ would be that node's value
    while the linear stage can only give it the projection: the iteration stalled with
    η constant (a strap on a base of another mesh, pressed into a stop)."""
    def key(p: int) -> tuple[int, float, float]:
        owner = int(substructure[p]) if nodal is None or nodal[p] else -1 - p
        return (owner, round(float(coords[p, 0]), 9), round(float(coords[p, 1]), 9))
    return key


def nodal_points(trace: sp.csr_matrix) -> npt.NDArray[np.bool_]:
    """Per row of a side's trace (points × the side's nodes): whether it is one node's
    value (a single entry 1)."""
    single = np.diff(trace.indptr) == 1
    value = np.zeros(trace.shape[0])
    value[single] = trace.data[trace.indptr[:-1][single]]
    out: npt.NDArray[np.bool_] = single & (np.abs(value - 1.0) <= 1e-12)
    return out


def prescribed_components(key: NodeKey, boundary: IntArray,
                           is_displacement: npt.NDArray[np.bool_]
                           ) -> dict[tuple[tuple[int, float, float], int], int]:
    """(node, component) -> index in ``boundary`` of the point prescribing its
    displacement."""
    return {(key(int(p)), c): i for i, (p, mask) in
            enumerate(zip(boundary, is_displacement, strict=True)) for c in range(2) if mask[c]}


def held_perfect_pairs(key: NodeKey, fixed: dict[tuple[tuple[int, float, float], int], int],
                        pairs: tuple[IntArray, IntArray]) -> dict[str, IntArray]:
    """Perfect pairs whose node is held on one side only by a prescribed displacement
    component (an interface ending on a clamped or pushed face next to a substructure that
    is not held there): as for contact (``held_corners``), only the sum of the pair's and
    the holder's forces at the held node is determined, so the local stage takes the pair's
    force from the free side's search direction against the prescribed displacement.
    Held on both sides, the split is exactly neutral (it enters neither η nor any answer)
    and is left alone."""
    n_pairs = pairs[0].size
    held_side = np.full((n_pairs, 2), -1, dtype=np.int64)
    held_boundary = np.full((n_pairs, 2), -1, dtype=np.int64)
    for j, (a, b) in enumerate(zip(*pairs, strict=True)):
        for c in range(2):
            holders = [(side, fixed[(key(int(p)), c)]) for side, p in enumerate((a, b))
                       if (key(int(p)), c) in fixed]
            if len(holders) == 1:
                held_side[j, c], held_boundary[j, c] = holders[0]
    return {"pair_held_side": held_side, "pair_held_boundary": held_boundary}


def held_stops(key: NodeKey, fixed: dict[tuple[tuple[int, float, float], int], int],
               stops: IntArray, normals: FloatArray) -> dict[str, IntArray]:
    """Stop points whose tangential displacement is held at the same node of the same
    substructure, by a prescribed displacement component (a frictional flat under a face
    pushed sideways) or by another stop (a block in a rigid corner): the node's tangential
    force is then shared between the stop's friction and its holder, and only their sum is
    determined. Both solvers give the friction there the held-corner rule (``held_corners``):
    while the holder holds (a prescribed displacement that did not move since the last
    step, a stop that is closed), it keeps its previous step's value, limited to the cone;
    a prescribed displacement that moves makes the stop slide, at the cone. Per stop
    (−1: not held; axis-aligned stops only): the index in ``boundary`` of its holder, or in
    ``stops``."""
    stop_of = _stops_by_axis(key, stops, normals)
    by_boundary = np.full(stops.size, -1, dtype=np.int64)
    by_stop = np.full(stops.size, -1, dtype=np.int64)
    for q, p in enumerate(stops):
        tangential = 1 - int(np.argmax(np.abs(normals[p])))
        if abs(normals[p, tangential]) > 1e-12:  # an oblique stop: no axis holds its tangent
            continue
        if (key(int(p)), tangential) in fixed:
            by_boundary[q] = fixed[(key(int(p)), tangential)]
        elif (key(int(p)), tangential) in stop_of:
            by_stop[q] = stop_of[(key(int(p)), tangential)]
    return {"stop_held_boundary": by_boundary, "stop_held_stop": by_stop}
