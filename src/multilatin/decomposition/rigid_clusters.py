"""The groups of substructures that may move rigidly, for ``uniqueness``: *clusters*
(substructures joined by perfect or macro-only interfaces, which move together), those
that some rigid mode is not held in by prescribed displacements (``free_clusters``, with
what a search needs of their geometry), and the unions of such clusters joined through
contact interfaces (``contact_unions``: bodies that may slide as one, session 51)."""

from __future__ import annotations

import logging
import threading
import weakref
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..fem.elasticity import FloatArray, IntArray
from .assembly import Assembly
from .interfaces import InterfacePoints

__all__ = ["MAX_UNIONS", "Cluster", "clusters", "contact_unions", "free_clusters", "rigid_rows"]

#: unions of clusters (joined through contact interfaces) searched for a motion together,
#: the smallest first; larger unions beyond this count are not searched (logged)
MAX_UNIONS = 64

log = logging.getLogger(__name__)


def clusters(assembly: Assembly) -> list[IntArray]:
    """Substructures joined by perfect or macro-only interfaces (they move together)."""
    parent = list(range(len(assembly.substructures)))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for itf in assembly.interfaces:
        if itf.kind in ("perfect", "macro") and len(itf.sides) == 2:
            a, b = (root(side.substructure) for side in itf.sides)
            parent[a] = b
    groups: dict[int, list[int]] = {}
    for s in range(len(parent)):
        groups.setdefault(root(s), []).append(s)
    return [np.array(g, dtype=np.int64) for g in groups.values()]


@dataclass(frozen=True)
class Cluster:
    """What ``free_motions`` needs of a cluster that depends on the geometry alone: its
    points, rigid modes and prescribed displacements (the same for every case of a
    geometry: friction, gaps and fields are the case's)."""

    bodies: tuple[str, ...]
    centre: FloatArray
    size: float
    held: FloatArray  # (3, 3): the prescribed displacements' Gram matrix on the modes
    p: IntArray  # the cluster's contact points (its side of contact pairs, then stops)
    partner: IntArray  # the other side's point, -1 for a stop
    rows: tuple[IntArray, IntArray]  # its contact pairs' rows (a's side, b's), its stops'
    partner_or_own: IntArray  # ``partner``, or the point itself on a stop
    at_stop: np.ndarray  # partner < 0
    normal: FloatArray
    modes: FloatArray  # (n, 2, 3)
    along_normal: FloatArray  # (n, 3)
    weights: FloatArray


#: per interface geometry (``InterfacePoints.coords``'s identity, kept alive by a weak
#: reference check) and topology, its clusters that some rigid mode is not held in
_GEOMETRIES: OrderedDict[tuple[Any, ...], tuple[weakref.ref[Any], list[Cluster]]] = (
    OrderedDict())
_GEOMETRY_CACHE_SIZE = 8
_GEOMETRIES_LOCK = threading.Lock()


def free_clusters(assembly: Assembly, points: InterfacePoints) -> list[Cluster]:
    """The free-to-move candidates of ``clusters(assembly)`` with their geometry, cached
    per interface geometry: the cases of a study share ``points.coords``."""
    key = (id(points.coords), tuple(itf.kind for itf in assembly.interfaces),
           tuple(sub.body for sub in assembly.substructures))
    with _GEOMETRIES_LOCK:
        found = _GEOMETRIES.get(key)
        if found is not None and found[0]() is points.coords:
            _GEOMETRIES.move_to_end(key)
            return found[1]
    free_groups, out = [], []
    for group in clusters(assembly):
        cluster = _cluster(assembly, points, group)
        if cluster is not None:  # else held in every rigid mode (a clamped body)
            free_groups.append(group)
            out.append(cluster)
    for union in contact_unions(assembly, free_groups):
        cluster = _cluster(assembly, points, union)
        if cluster is not None:
            out.append(cluster)
    with _GEOMETRIES_LOCK:
        _GEOMETRIES[key] = (weakref.ref(points.coords), out)
        while len(_GEOMETRIES) > _GEOMETRY_CACHE_SIZE:
            _GEOMETRIES.popitem(last=False)
    return out


def _cluster(assembly: Assembly, points: InterfacePoints, group: IntArray) -> Cluster | None:
    """``Cluster`` of the substructures ``group`` (None where its prescribed displacements
    hold it in every rigid mode): its contact points are its side of the pairs whose other
    side is outside it, and its stops' (pairs within it move with it)."""
    a, b = points.contact_pairs
    inside = np.isin(points.substructure, group)
    coords = points.coords[inside]
    centre = coords.mean(axis=0)
    size = float(np.ptp(coords, axis=0).max()) or 1.0
    fixed = points.boundary[inside[points.boundary]]
    rows = rigid_rows(points.coords[fixed], centre, size)[
        points.boundary_is_displacement[inside[points.boundary]]]
    held = rows.T @ rows  # prescribed displacements: the same at every step
    if assembly.substructures[int(group[0])].material.radial:  # only z translates
        held = held + np.diag([1.0, 0.0, 1.0]) * max(float(np.trace(held)), 1.0)
    if np.linalg.matrix_rank(held, tol=1e-10 * max(np.abs(held).max(), 1e-300)) == 3:
        return None
    own_a, own_b = inside[a] & ~inside[b], inside[b] & ~inside[a]
    own_stops = inside[points.stops]
    p = np.concatenate([a[own_a], b[own_b], points.stops[own_stops]])
    partner = np.concatenate([b[own_a], a[own_b], np.full(int(own_stops.sum()), -1)])
    normal = points.normals[p]
    modes = rigid_rows(points.coords[p], centre, size)  # (n, 2, 3)
    return Cluster(
        tuple(sorted({assembly.substructures[s].body for s in group})), centre, size,
        held, p, partner,
        (np.concatenate([np.flatnonzero(own_a), np.flatnonzero(own_b)]),
         np.flatnonzero(own_stops)),
        np.where(partner >= 0, partner, p), partner < 0, normal, modes,
        np.einsum("nc,nck->nk", normal, modes), points.weights[p])


def contact_unions(assembly: Assembly, groups: Sequence[IntArray]) -> list[IntArray]:
    """The unions of two or more ``groups`` (clusters, as substructure indices) connected
    through contact interfaces — bodies that may move as one while friction holds them to
    each other —, by size and then by their groups' order, at most ``MAX_UNIONS``."""
    owner = {int(s): g for g, group in enumerate(groups) for s in group}
    neighbours: list[set[int]] = [set() for _ in groups]
    for itf in assembly.interfaces:
        if itf.kind == "contact" and len(itf.sides) == 2:
            first, second = (owner.get(side.substructure) for side in itf.sides)
            if first is not None and second is not None and first != second:
                neighbours[first].add(second)
                neighbours[second].add(first)
    out: list[IntArray] = []
    level = [frozenset((g,)) for g in range(len(groups))]
    while level:
        grown = {members | {h} for members in level for g in members
                 for h in neighbours[g] - members}
        level = sorted(grown, key=sorted)
        if len(out) + len(level) > MAX_UNIONS:
            log.warning("%s: %d unions of bodies joined by contact searched for a common "
                        "free motion, larger ones not (MAX_UNIONS)", assembly.label,
                        MAX_UNIONS)
            level = level[:MAX_UNIONS - len(out)]
        out += [np.concatenate([groups[g] for g in sorted(members)]) for members in level]
        if len(out) >= MAX_UNIONS:
            break
    return out


def rigid_rows(x: FloatArray, centre: FloatArray, size: float) -> FloatArray:
    """Velocity components of the three rigid modes at points ``x``: shape (n, 2, 3), the
    rotation scaled by ``size`` so that the three modes weigh alike."""
    rows = np.zeros((x.shape[0], 2, 3))
    rows[:, 0, 0] = 1.0
    rows[:, 1, 1] = 1.0
    rows[:, 0, 2] = -(x[:, 1] - centre[1]) / size
    rows[:, 1, 2] = (x[:, 0] - centre[0]) / size
    return rows
