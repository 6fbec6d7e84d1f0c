"""Contact pairs that meet at a cross point, run by the local stage as one pair (issue 15,
item 1; session 35).

Where a contact interface is cut into pieces by the perfect interfaces between the
substructures of a body (b1-9, b3: the centre|top contact at x = 16.7 and 33.3), the pieces'
end points at a cross point are two contact pairs at the same two nodes. The discrete
problem sees only their sum — the monolithic reference merges them into one pair with the
weights added (``reference.contact_newton.contact_set``) — and nodal LATIN fields split it
freely: one piece's point at its friction cone while the other's sticks, a split the
iteration moves at ~0.96 per iteration (b1-9 (0.1, 0.3): docs/convergence.md, session 35).
The local stage therefore runs such a group on its weighted means of W and F on each side
(the merged pair); every pair of the group takes the group's F̂, and each its own Ŵ on its
own search direction, Ŵ_i = W_i + (F̂ − F_i) / k_i. At the fixed point (W and F equal across
the group, as the perfect interfaces tie the nodes) this is the reference's contact law on
the summed pair, the split in proportion to the weights; converged answers are unchanged
(tests). Measured: ``benchmarks/merged_cross_points.py``.

The stop points of a cross point run as one likewise (``stop_groups``, session 56): where a
perfect interface between a body's substructures ends on a rigid stop (b1-4 at (50, 75); b1-9
and b3 at (50, 66.7) and (50, 83.3), where the stop touches the centre block's side), the
stop's pieces' end points are two stop points at one node, and the split of their force
drifts (docs/convergence.md, session 55: b1-9 at gap 0 warm-started from gap 0.01, 120
iterations at η ≈ 1.4e-5 while 1.5e-3 N a step moved between them).

The compiled kernel merges inside (``kernels.contact_and_stops``: ``group_pairs``,
``group_share``, ``stop_groups``, ``stop_share``); the NumPy and PyTorch stages wrap their
contact stage with ``merged`` and ``corrected`` (``Groups.sides``), written with operations
both array libraries have. Inside the two-scale direction's coupled stage the merge acts on
each inner pass's shifted forces, with the pointwise direction D (merged around the whole
local stage, with k, b1-9 at gap 0 took 78 → 346 iterations; inside, 66).
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..decomposition.interfaces import InterfacePoints
from ..fem.elasticity import FloatArray, IntArray

#: run the contact pairs of a cross point as one (False: each pair on its own, as before
#: session 35; ``benchmarks/merged_cross_points.py`` compares)
MERGE = True
#: run the stop points of a cross point as one (False: each on its own, as before session
#: 56; ``benchmarks/merged_stops.py`` compares)
MERGE_STOPS = True


def cross_point_groups(points: InterfacePoints, k: FloatArray | None = None,
                       laws: tuple[FloatArray, ...] = ()) -> tuple[IntArray, FloatArray]:
    """The groups of two or more contact pairs whose two sides are the same two nodes of
    the discrete problem (the pieces' end points at a cross point: each side's points at one
    position, on substructures tied there by perfect interfaces — not by a macro-only one,
    nor two bodies that merely touch), as (``group_pairs`` (G, M): indices into the
    contact pairs, a shorter group padded with its first pair; ``group_share`` (G, M): each
    pair's weight over the group's, 0 on padding). Pairs held on one side or at a held
    corner keep their own rule (``held_nodes``) and join no group, nor do pairs whose normal,
    search direction ``k`` (per point; then a group's history, its pairs' mean Ŵ, is the
    merged pair's: settled steps restart from it) or contact law (``laws``: arrays (n_cases,
    n_pairs), the friction coefficients and gaps of a batch's cases) differs from the
    group's first; empty with ``MERGE`` off."""
    a = points.contact_pairs[0]
    candidates = _candidates(points, k)[0] if MERGE and a.size > 1 else []
    return _padded(_under_one_law(candidates, laws), points.weights[a])


def stop_groups(points: InterfacePoints, k: FloatArray | None = None,
                laws: tuple[FloatArray, ...] = ()) -> tuple[IntArray, FloatArray]:
    """The groups of two or more stop points at one node of the discrete problem (tied
    through perfect pairs, ``tied_nodes``) with the same normal, search direction ``k`` and
    law (``laws``: (n_cases, n_stops) friction coefficients and gaps), as
    ``cross_point_groups`` (indices into the stops). Stops held at their node, holding
    another stop or a contact pair, or holding a corner (``held_nodes``) keep their own rule
    and join no group; empty with ``MERGE_STOPS`` off."""
    candidates = _candidates(points, k)[1] if MERGE_STOPS else []
    return _padded(_under_one_law(candidates, laws), points.weights[points.stops])


def _under_one_law(candidates: list[list[int]], laws: tuple[FloatArray, ...]
                   ) -> list[list[int]]:
    """Each candidate group's members whose law (``laws``: arrays (n_cases, n), indexed
    by member) equals its first member's in every case; groups of two or more."""
    groups = []
    for members in candidates:
        first = members[0]
        members = [j for j in members
                   if all(np.array_equal(law[:, j], law[:, first]) for law in laws)]
        if len(members) > 1:
            groups.append(members)
    return groups


def _padded(groups: list[list[int]], weights: FloatArray) -> tuple[IntArray, FloatArray]:
    """Groups of indices as (G, M), a shorter one padded with its first member, and each
    member's weight over its group's (0 on padding)."""
    if not groups:
        return np.zeros((0, 0), dtype=np.int64), np.zeros((0, 0))
    width = max(len(g) for g in groups)
    rows = np.array([g + [g[0]] * (width - len(g)) for g in groups], dtype=np.int64)
    share = np.where(np.arange(width)[None, :] < np.array([len(g) for g in groups])[:, None],
                     weights[rows], 0.0)
    return rows, share / share.sum(axis=1, keepdims=True)


@dataclass(frozen=True)
class Groups:
    """What a local stage runs as one at its cross points: ``pairs`` (G, M) into the contact
    pairs with ``pair_share`` (``cross_point_groups``), ``stops`` (S, M) into the stops with
    ``stop_share`` (``stop_groups``); ``sides``, per merged side (the pairs' side a, their
    side b, the stops; only those with groups): its points, shares (·, M, 1) and search
    directions (·, M, 2), as ``merged`` and ``corrected`` take them."""

    pairs: IntArray
    pair_share: FloatArray
    stops: IntArray
    stop_share: FloatArray
    sides: tuple[tuple[Any, Any, Any], ...]

    def common(self, other: Groups) -> Groups:
        """The groups both have (cases joining a running batch: their laws may split one)."""
        rows = [np.array([i for i, row in enumerate(mine.tolist()) if row in theirs],
                         dtype=np.int64)
                for mine, theirs in ((self.pairs, other.pairs.tolist()),
                                     (self.stops, other.stops.tolist()))]
        kinds = [0] * (2 if self.pairs.size else 0) + [1] * (1 if self.stops.size else 0)
        sides = tuple(tuple(x[rows[kind]] for x in side)
                      for kind, side in zip(kinds, self.sides, strict=True))
        return Groups(self.pairs[rows[0]], self.pair_share[rows[0]], self.stops[rows[1]],
                      self.stop_share[rows[1]], sides)


def local_groups(points: InterfacePoints, k: FloatArray, contact_laws: tuple[FloatArray, ...],
                 stop_laws: tuple[FloatArray, ...]) -> Groups:
    """The ``Groups`` of a local stage on ``points`` with search direction ``k`` and its
    cases' contact and stop laws."""
    pairs, pair_share = cross_point_groups(points, k, contact_laws)
    stops, stop_share = stop_groups(points, k, stop_laws)
    sides: list[tuple[Any, Any, Any]] = []
    if pairs.size:
        sides += [(side[pairs], pair_share[:, :, None], k[side[pairs]])
                  for side in points.contact_pairs]
    if stops.size:
        at = points.stops[stops]
        sides.append((at, stop_share[:, :, None], k[at]))
    return Groups(pairs, pair_share, stops, stop_share, tuple(sides))


#: the groups of the geometries seen last (``_candidates``): a study builds a local stage
#: for every batch of cases that joins, on the same few geometries
_Found = tuple[list[list[int]], list[list[int]]]  # the pairs' candidates, the stops'
_KEPT: OrderedDict[tuple[int, ...], tuple[tuple[Any, ...], _Found]] = OrderedDict()
_KEPT_SIZE = 8


def _candidates(points: InterfacePoints, k: FloatArray | None) -> _Found:
    """``cross_point_groups`` and ``stop_groups`` before the laws: what the geometry and
    the search direction decide, worked out once per geometry (the cases of a geometry
    share their points' arrays, ``interfaces.with_contact_data``)."""
    arrays = (points.pairs[0], points.contact_pairs[0], points.stops, points.coords,
              points.normals, k)
    key = tuple(id(x) for x in arrays)
    kept = _KEPT.get(key)
    if kept is not None and all(x is y for x, y in zip(kept[0], arrays, strict=True)):
        _KEPT.move_to_end(key)
        return kept[1]
    a, b = points.contact_pairs
    held = np.zeros(a.size, dtype=bool)
    held[points.corner] = True
    if points.held_side.size:
        held |= points.held_side >= 0
    node = tied_nodes(points)
    keys: dict[tuple[Any, Any], list[int]] = {}
    for j in np.flatnonzero(~held).tolist():
        keys.setdefault((node(int(a[j])), node(int(b[j]))), []).append(j)
    normals, groups = points.normals, []
    for members in keys.values():
        first = members[0]
        members = [j for j in members
                   if np.allclose(normals[a[j]], normals[a[first]], rtol=0.0, atol=1e-9)
                   and (k is None or (np.array_equal(k[a[j]], k[a[first]])
                                      and np.array_equal(k[b[j]], k[b[first]])))]
        if len(members) > 1:
            groups.append(members)
    found = (groups, _stop_candidates(points, node, k))
    _KEPT[key] = (arrays, found)
    while len(_KEPT) > _KEPT_SIZE:
        _KEPT.popitem(last=False)
    return found


def _stop_candidates(points: InterfacePoints, node: Callable[[int], Any],
                     k: FloatArray | None) -> list[list[int]]:
    """The stops at one node (``node``: ``tied_nodes``) with one normal and ``k``, none
    held, holding or a corner's (``stop_groups``)."""
    stops = points.stops
    own_rule = (points.stop_held_boundary >= 0) | (points.stop_held_stop >= 0)
    for holders in (points.stop_held_stop, points.held_stop, points.corner_stops.ravel()):
        own_rule[holders[holders >= 0]] = True
    keys: dict[Any, list[int]] = {}
    for i in np.flatnonzero(~own_rule).tolist():
        keys.setdefault(node(int(stops[i])), []).append(i)
    normals, groups = points.normals, []
    for members in keys.values():
        first = stops[members[0]]
        members = [i for i in members
                   if np.allclose(normals[stops[i]], normals[first], rtol=0.0, atol=1e-9)
                   and (k is None or np.array_equal(k[stops[i]], k[first]))]
        if len(members) > 1:
            groups.append(members)
    return groups


def tied_nodes(points: InterfacePoints) -> Callable[[int], Any]:
    """A function of an interface point: its node of the discrete problem — its
    substructure's node at its position, joined through the perfect pairs there with the
    nodes of the other substructures (as the monolithic reference merges them)."""
    scale = max(float(np.ptp(points.coords)), 1.0)
    at = np.round(points.coords / scale * 1e9).astype(np.int64).tolist()
    parent: dict[Any, Any] = {}

    def own(p: int) -> tuple[int, tuple[int, ...]]:
        return int(points.substructure[p]), tuple(at[p])

    def root(x: Any) -> Any:
        while parent.setdefault(x, x) != x:
            x = parent[x]
        return x

    for p, q in zip(*points.pairs, strict=True):
        parent[root(own(int(p)))] = root(own(int(q)))
    return lambda p: root(own(p))


def merged(displacement: Any, force: Any, sides: Sequence[tuple[Any, Any, Any]]
           ) -> tuple[Any, Any]:
    """Copies of the fields (n_cases, n_steps, n_points, 2) with every group's points on
    each side (``Groups.sides``: its points (G, M), shares (G, M, 1), k) at the group's
    weighted means."""
    w = displacement.clone() if hasattr(displacement, "clone") else displacement.copy()
    f = force.clone() if hasattr(force, "clone") else force.copy()
    for points, share, _ in sides:
        w[:, :, points] = (displacement[:, :, points] * share).sum(3)[:, :, :, None]
        f[:, :, points] = (force[:, :, points] * share).sum(3)[:, :, :, None]
    return w, f


def corrected(w_hat: Any, displacement: Any, force: Any, merged_fields: tuple[Any, Any],
              sides: Sequence[tuple[Any, Any, Any]]) -> None:
    """Each grouped point's Ŵ on its own search direction, in place: Ŵ_i = Ŵ (the group's)
    + (W_i − W̄) − (F_i − F̄) / k_i (``sides`` as ``merged``'s, k at its points (G, M, 2))."""
    w, f = merged_fields
    for points, _, k in sides:
        w_hat[:, :, points] += ((displacement[:, :, points] - w[:, :, points])
                                - (force[:, :, points] - f[:, :, points]) / k)


# compiled by ``kernels`` (called from its contact kernel, case by case: once per side of
# the contact groups, once for the stop groups)
def merge_members(displacement: FloatArray, force: FloatArray, history: FloatArray,
                  point_of: IntArray, groups: IntArray, share: FloatArray, kept: FloatArray,
                  c: int, t0: int) -> None:  # pragma: no cover - compiled
    """Case c's W and F at each group's points (steps t0 on) kept (``kept``: (group,
    member, step, W / F, component)), then set to the group's weighted means; the history
    Ŵ its members start from likewise. A member is a row of ``history`` (a contact side's
    or the stops'), ``point_of`` its interface point (``a``, ``b`` or ``stops``)."""
    n_steps, width = displacement.shape[1], groups.shape[1]
    for g in range(groups.shape[0]):
        for m in range(width):
            p = point_of[groups[g, m]]
            for t in range(t0, n_steps):
                for d in range(2):
                    kept[g, m, t, 0, d] = displacement[c, t, p, d]
                    kept[g, m, t, 1, d] = force[c, t, p, d]
        for t in range(t0, n_steps):
            for d in range(2):
                mean_w = mean_f = 0.0
                for m in range(width):
                    mean_w += share[g, m] * kept[g, m, t, 0, d]
                    mean_f += share[g, m] * kept[g, m, t, 1, d]
                for m in range(width):
                    p = point_of[groups[g, m]]
                    displacement[c, t, p, d] = mean_w
                    force[c, t, p, d] = mean_f
        for d in range(2):
            mean = 0.0
            for m in range(width):
                mean += share[g, m] * history[groups[g, m], d]
            for m in range(width):
                history[groups[g, m], d] = mean


def split_members(displacement: FloatArray, force: FloatArray, w_hat: FloatArray,
                  point_of: IntArray, k: FloatArray, groups: IntArray, share: FloatArray,
                  kept: FloatArray, c: int, t0: int) -> None:  # pragma: no cover - compiled
    """After the case's steps: each grouped point's Ŵ on its own search direction (``k``,
    by member), Ŵ_i = Ŵ + (W_i − W̄) − (F_i − F̄) / k_i, then its W and F put back (a
    padding entry repeats its group's first member and is skipped)."""
    n_steps, width = displacement.shape[1], groups.shape[1]
    for g in range(groups.shape[0]):
        for m in range(width):
            if m > 0 and share[g, m] == 0.0:
                continue
            i = groups[g, m]
            p = point_of[i]
            for t in range(t0, n_steps):
                for d in range(2):
                    w_hat[c, t, p, d] += ((kept[g, m, t, 0, d] - displacement[c, t, p, d])
                                          - (kept[g, m, t, 1, d] - force[c, t, p, d])
                                          / k[i, d])
        for m in range(width):
            p = point_of[groups[g, m]]
            for t in range(t0, n_steps):
                for d in range(2):
                    displacement[c, t, p, d] = kept[g, m, t, 0, d]
                    force[c, t, p, d] = kept[g, m, t, 1, d]
