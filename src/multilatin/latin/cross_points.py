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

The compiled kernel merges inside (``kernels.contact_and_stops``: ``group_pairs``,
``group_share``); the NumPy and PyTorch stages wrap their contact stage with ``merged`` and
``corrected``, written with operations both array libraries have.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Callable
from typing import Any

import numpy as np

from ..decomposition.interfaces import InterfacePoints
from ..fem.elasticity import FloatArray, IntArray

#: run the contact pairs of a cross point as one (False: each pair on its own, as before
#: session 35; ``benchmarks/merged_cross_points.py`` compares)
MERGE = True


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
    groups = []
    for members in _candidates(points, k) if MERGE and a.size > 1 else []:
        first = members[0]
        members = [j for j in members
                   if all(np.array_equal(law[:, j], law[:, first]) for law in laws)]
        if len(members) > 1:
            groups.append(members)
    if not groups:
        return np.zeros((0, 0), dtype=np.int64), np.zeros((0, 0))
    width = max(len(g) for g in groups)
    pairs = np.array([g + [g[0]] * (width - len(g)) for g in groups], dtype=np.int64)
    weights = points.weights[a[pairs]]
    share = np.where(np.arange(width)[None, :] < np.array([len(g) for g in groups])[:, None],
                     weights, 0.0)
    return pairs, share / share.sum(axis=1, keepdims=True)


#: the groups of the geometries seen last (``_candidates``): a study builds a local stage
#: for every batch of cases that joins, on the same few geometries
_KEPT: OrderedDict[tuple[int, ...], tuple[tuple[Any, ...], list[list[int]]]] = OrderedDict()
_KEPT_SIZE = 8


def _candidates(points: InterfacePoints, k: FloatArray | None) -> list[list[int]]:
    """``cross_point_groups`` before the contact laws: what the geometry and the search
    direction decide, worked out once per geometry (the cases of a geometry share their
    points' arrays, ``interfaces.with_contact_data``)."""
    arrays = (points.pairs[0], points.contact_pairs[0], points.coords, points.normals, k)
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
    _KEPT[key] = (arrays, groups)
    while len(_KEPT) > _KEPT_SIZE:
        _KEPT.popitem(last=False)
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


def merged(displacement: Any, force: Any, sides: tuple[Any, Any], share: Any
           ) -> tuple[Any, Any]:
    """Copies of the fields (n_cases, n_steps, n_points, 2) with every group's points on
    each side (``sides``: the points of side a and of side b, each (G, M)) at the group's
    weighted means (``share`` (G, M, 1))."""
    w = displacement.clone() if hasattr(displacement, "clone") else displacement.copy()
    f = force.clone() if hasattr(force, "clone") else force.copy()
    for points in sides:
        w[:, :, points] = (displacement[:, :, points] * share).sum(3)[:, :, :, None]
        f[:, :, points] = (force[:, :, points] * share).sum(3)[:, :, :, None]
    return w, f


def corrected(w_hat: Any, displacement: Any, force: Any, merged_fields: tuple[Any, Any],
              sides: tuple[Any, Any], k_sides: tuple[Any, Any]) -> None:
    """Each grouped point's Ŵ on its own search direction, in place: Ŵ_i = Ŵ (the group's)
    + (W_i − W̄) − (F_i − F̄) / k_i (``k_sides``: each side's k at its points, (G, M, 2))."""
    w, f = merged_fields
    for points, k in zip(sides, k_sides, strict=True):
        w_hat[:, :, points] += ((displacement[:, :, points] - w[:, :, points])
                                - (force[:, :, points] - f[:, :, points]) / k)


# compiled by ``kernels`` (called from its contact kernel, case by case)
def merge_groups(displacement: FloatArray, force: FloatArray, prev_a: FloatArray,
                 prev_b: FloatArray, a: IntArray, b: IntArray, group_pairs: IntArray,
                 group_share: FloatArray, kept: FloatArray, c: int, t0: int
                 ) -> None:  # pragma: no cover - compiled
    """Case c's W and F at each group's points (both sides, steps t0 on) kept, then set to
    the group's weighted means; the history Ŵ its pairs start from, likewise."""
    n_steps, width = displacement.shape[1], group_pairs.shape[1]
    for g in range(group_pairs.shape[0]):
        for m in range(width):
            j = group_pairs[g, m]
            for t in range(t0, n_steps):
                for d in range(2):
                    kept[g, m, t, 0, 0, d] = displacement[c, t, a[j], d]
                    kept[g, m, t, 0, 1, d] = force[c, t, a[j], d]
                    kept[g, m, t, 1, 0, d] = displacement[c, t, b[j], d]
                    kept[g, m, t, 1, 1, d] = force[c, t, b[j], d]
        for t in range(t0, n_steps):
            for side in range(2):
                for field in range(2):
                    for d in range(2):
                        mean = 0.0
                        for m in range(width):
                            mean += group_share[g, m] * kept[g, m, t, side, field, d]
                        for m in range(width):
                            p = a[group_pairs[g, m]] if side == 0 else b[group_pairs[g, m]]
                            if field == 0:
                                displacement[c, t, p, d] = mean
                            else:
                                force[c, t, p, d] = mean
        for d in range(2):
            mean_a = mean_b = 0.0
            for m in range(width):
                mean_a += group_share[g, m] * prev_a[group_pairs[g, m], d]
                mean_b += group_share[g, m] * prev_b[group_pairs[g, m], d]
            for m in range(width):
                prev_a[group_pairs[g, m], d] = mean_a
                prev_b[group_pairs[g, m], d] = mean_b


def split_groups(displacement: FloatArray, force: FloatArray, w_hat: FloatArray,
                 a: IntArray, b: IntArray, k_contact: FloatArray, k_contact_b: FloatArray,
                 group_pairs: IntArray, group_share: FloatArray, kept: FloatArray, c: int,
                 t0: int) -> None:  # pragma: no cover - compiled
    """After the case's steps: each grouped point's Ŵ on its own search direction, Ŵ_i =
    Ŵ + (W_i − W̄) − (F_i − F̄) / k_i, and its W and F put back (a padding entry repeats
    its group's first pair and is skipped)."""
    n_steps, width = displacement.shape[1], group_pairs.shape[1]
    for g in range(group_pairs.shape[0]):
        for m in range(width):
            if m > 0 and group_share[g, m] == 0.0:
                continue
            j = group_pairs[g, m]
            for t in range(t0, n_steps):
                for side in range(2):
                    p = a[j] if side == 0 else b[j]
                    for d in range(2):
                        k = k_contact[j, d] if side == 0 else k_contact_b[j, d]
                        w, f = kept[g, m, t, side, 0, d], kept[g, m, t, side, 1, d]
                        w_hat[c, t, p, d] += ((w - displacement[c, t, p, d])
                                              - (f - force[c, t, p, d]) / k)
        for m in range(width):
            j = group_pairs[g, m]
            for t in range(t0, n_steps):
                for d in range(2):
                    displacement[c, t, a[j], d] = kept[g, m, t, 0, 0, d]
                    force[c, t, a[j], d] = kept[g, m, t, 0, 1, d]
                    displacement[c, t, b[j], d] = kept[g, m, t, 1, 0, d]
                    force[c, t, b[j], d] = kept[g, m, t, 1, 1, d]
