"""Contact pairs that meet at a cross point run as one pair in the local stage
(``multilatin.latin.cross_points``, issue 15 item 1): found where they are, the same in the
compiled and the NumPy local stage, each pair on its own search direction, the converged
answer unchanged, and the tail it removes."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import multilatin as ml
from multilatin.latin import LatinOperators, cross_points, solve_latin
from multilatin.latin.local_stage import LocalStage

TIGHT = ml.LatinOptions(tol=1e-10, max_iter=20000)


def _stage(name: str, compiled: bool, mu: dict[str, float] | None = None
           ) -> tuple[LatinOperators, LocalStage]:
    assembly = ml.load_model(name).assemble(mu or {"mu1": 0.1, "mu2": 0.3})
    operators = LatinOperators(assembly, ml.LatinOptions())
    return operators, LocalStage([assembly], [operators.points], operators.search_direction,
                                 compiled=compiled, macro_only=operators.macro_only)


def _fields(operators: LatinOperators, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    shape = (1, 15, operators.points.n_points, 2)
    return 1e-3 * rng.standard_normal(shape), 10.0 * rng.standard_normal(shape)


def test_the_groups_are_the_pieces_ends_at_cross_points() -> None:
    """b1-9: the contacts bottom|centre (y = 50) and centre|top (y = 100) are cut at x =
    16.7 and 33.3 by the substructures' perfect interfaces: four groups of two pairs, at
    the same two nodes, each pair half the group's weight; b1 (one substructure per body)
    has none."""
    operators, local = _stage("b1-9", compiled=True)
    points = operators.points
    assert local.groups.pairs.shape == (4, 2)
    np.testing.assert_allclose(local.groups.pair_share, 0.5)
    a, b = points.contact_pairs
    for group in local.groups.pairs:
        for side in (a, b):
            coords = points.coords[side[group]]
            np.testing.assert_allclose(coords, coords[:1].repeat(2, axis=0))
            assert points.substructure[side[group[0]]] != points.substructure[side[group[1]]]
    found = sorted((round(float(x), 1), round(float(y), 1))
                   for x, y in points.coords[a[local.groups.pairs[:, 0]]])
    assert found == [(16.7, 50.0), (16.7, 100.0), (33.3, 50.0), (33.3, 100.0)]
    assert _stage("b1", compiled=True)[1].groups.pairs.size == 0


@pytest.mark.parametrize("compiled", [True, False])
def test_a_group_takes_one_force_and_each_pair_its_own_direction(compiled: bool) -> None:
    """From fields that differ across a group, its pairs get the same F̂ (the merged pair's)
    and each its own Ŵ on its own search direction, F̂ − F_i = k_i (Ŵ_i − W_i), on both
    sides; the compiled kernel gives the NumPy stage's answer; W and F are left as given."""
    operators, local = _stage("b1-9", compiled=compiled)
    w, f = _fields(operators)
    w0, f0 = w.copy(), f.copy()
    w_hat, f_hat = local(w, f)
    np.testing.assert_array_equal(w, w0)
    np.testing.assert_array_equal(f, f0)
    k = operators.search_direction
    for sides, _, _ in local.groups.sides:
        for group in sides:
            np.testing.assert_allclose(f_hat[:, :, group[1]], f_hat[:, :, group[0]],
                                       rtol=1e-12, atol=1e-9)
            for p in group:
                np.testing.assert_allclose(f_hat[:, :, p] - f[:, :, p],
                                           k[p] * (w_hat[:, :, p] - w[:, :, p]),
                                           rtol=1e-9, atol=1e-9)
    assert not np.allclose(f[:, :, local.groups.sides[0][0][:, 0]],
                           f[:, :, local.groups.sides[0][0][:, 1]])  # the test's fields differ
    other = _stage("b1-9", compiled=not compiled)[1]
    w_other, f_other = other(w, f)
    np.testing.assert_allclose(w_other, w_hat, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(f_other, f_hat, rtol=1e-10, atol=1e-9)


def test_equal_pairs_are_run_as_they_were(monkeypatch) -> None:
    """Where a group's pairs see the same W and F (as at the fixed point), merging changes
    nothing: the local stage equals the one that runs each pair on its own."""
    operators, merging = _stage("b1-9", compiled=True)
    w, f = _fields(operators, seed=1)
    for sides, _, _ in merging.groups.sides:
        w[:, :, sides[:, 1]] = w[:, :, sides[:, 0]]
        f[:, :, sides[:, 1]] = f[:, :, sides[:, 0]]
    monkeypatch.setattr(cross_points, "MERGE", False)
    alone = _stage("b1-9", compiled=True)[1]
    assert alone.groups.pairs.size == 0
    for x, y in zip(merging(w, f), alone(w, f), strict=True):
        np.testing.assert_allclose(x, y, rtol=1e-12, atol=1e-12)


def test_merged_cross_points_converge_sooner_to_the_same_answer(monkeypatch) -> None:
    """b1-9 at (0.1, 0.3), whose slowest mode sat at these cross points: fewer iterations to
    the default tolerance with the pairs merged (95 against 111, measured), and the tight
    answers of both rules agree (the discrete problem sees only the pairs' sum)."""
    model = ml.load_model("b1-9")
    assembly = model.assemble({"mu1": 0.1, "mu2": 0.3})
    operators = LatinOperators(assembly, ml.LatinOptions())
    merged = solve_latin(assembly, operators=operators)
    merged_tight = solve_latin(assembly, TIGHT, operators=operators)
    monkeypatch.setattr(cross_points, "MERGE", False)
    alone = solve_latin(assembly, operators=operators)
    alone_tight = solve_latin(assembly, TIGHT, operators=operators)
    assert merged.iterations <= 0.9 * alone.iterations
    for name, value in alone_tight.qoi.items():
        np.testing.assert_allclose(np.asarray(merged_tight.qoi[name], dtype=float),
                                   np.asarray(value, dtype=float), rtol=1e-7, atol=1e-9)


def test_pairs_under_different_laws_are_not_merged() -> None:
    """A group's pairs share their friction coefficient and gap in every case of a batch;
    where one piece has another friction, its group is dropped — also when such a case
    joins a running batch (the groups both stages have)."""
    operators, local = _stage("b1-9", compiled=True)
    mu = local.mu_contact.copy()
    first_pair = local.groups.pairs[0, 0]
    mu[:, first_pair] += 0.1
    k = operators.search_direction
    pairs, share = cross_points.cross_point_groups(operators.points, k, (mu, local.gap_contact))
    assert pairs.shape == (3, 2) and first_pair not in pairs
    other = _stage("b1-9", compiled=True)[1]
    other.groups = dataclasses.replace(other.groups, pairs=pairs, pair_share=share)
    joined = local.joined(other)
    np.testing.assert_array_equal(joined.groups.pairs, pairs)
    np.testing.assert_array_equal(joined.groups.sides[0][0],
                                  operators.points.contact_pairs[0][pairs])
    np.testing.assert_array_equal(joined.groups.stops, local.groups.stops)
    assert joined.n_cases == 2


def test_pieces_not_tied_by_a_perfect_interface_are_not_merged() -> None:
    """The pairs' nodes must be one node of the discrete problem on each side: without the
    perfect pairs at (33.3, 100) (as if the substructures beside the node were two bodies
    that touch there, or tied by a macro-only interface), the two groups there are not
    formed; the other two stay."""
    operators, _ = _stage("b1-9", compiled=True)
    points = operators.points
    a, b = points.pairs
    at = np.all(np.isclose(points.coords[a], [100.0 / 3.0, 100.0]), axis=1)
    assert at.sum() == 2  # centre[1,2]|centre[2,2] and top[1,0]|top[2,0] end there
    untied = dataclasses.replace(points, pairs=(a[~at], b[~at]))
    pairs, _ = cross_points.cross_point_groups(untied)
    assert pairs.shape == (3, 2)
    positions = sorted({tuple(np.round(points.coords[points.contact_pairs[0][j]], 1))
                        for j in pairs[:, 0]})
    assert positions == [(16.7, 50.0), (16.7, 100.0), (33.3, 50.0)]


def test_the_stop_groups_are_the_pieces_ends_on_a_stop() -> None:
    """Where a perfect interface between the centre block's substructures ends on the stop
    (x = 50), the stop's two pieces end at one node: b1-9 and b3 at y = 66.7 and 83.3, b1-4
    at y = 75, each stop point half its group's weight and on another substructure; b1
    (one substructure per body) has none, nor has the stop's top corner, which holds the
    centre|top contact's corner (``held_nodes``)."""
    for name, heights in (("b1-9", [66.7, 83.3]), ("b3", [66.7, 83.3]), ("b1-4", [75.0])):
        operators, local = _stage(name, compiled=True, mu={"gap": 0.0})
        points = operators.points
        groups = local.groups
        assert groups.stops.shape == (len(heights), 2)
        np.testing.assert_allclose(groups.stop_share, 0.5)
        at = points.stops[groups.stops]
        for group in at:
            assert points.substructure[group[0]] != points.substructure[group[1]]
            np.testing.assert_allclose(points.coords[group[1]], points.coords[group[0]])
        found = sorted((round(float(x), 1), round(float(y), 1)) for x, y in points.coords[at[:, 0]])
        assert found == [(50.0, y) for y in heights]
        assert not set(groups.stops.ravel()) & set(points.corner_stops.ravel())
    assert _stage("b1", compiled=True, mu={"gap": 0.0})[1].groups.stops.size == 0


@pytest.mark.parametrize("compiled", [True, False])
def test_a_stop_group_takes_one_force_and_each_point_its_own_direction(compiled: bool) -> None:
    """b1-9 at gap 0, from fields that differ across a group and press the centre block on
    the stop: a group's stop points get one F̂ (the merged stop's), each its own Ŵ on its
    own search direction; the compiled, NumPy and PyTorch stages agree."""
    operators, local = _stage("b1-9", compiled=compiled, mu={"gap": 0.0, "mu2": 0.15})
    w, f = _fields(operators, seed=2)
    at = operators.points.stops[local.groups.stops]
    f[:, :, at, 0] = -500.0 + 100.0 * np.random.default_rng(3).standard_normal(f[:, :, at, 0].shape)
    w_hat, f_hat = local(w, f)
    k = operators.search_direction
    for group in at:
        assert np.all(f_hat[:, :, group[0], 0] < 0)  # closed: n·F̂ < 0 (n = +x)
        np.testing.assert_allclose(f_hat[:, :, group[1]], f_hat[:, :, group[0]],
                                   rtol=1e-12, atol=1e-9)
        for p in group:
            np.testing.assert_allclose(f_hat[:, :, p] - f[:, :, p],
                                       k[p] * (w_hat[:, :, p] - w[:, :, p]), rtol=1e-9, atol=1e-9)
    assert not np.allclose(f[:, :, at[:, 0]], f[:, :, at[:, 1]])
    other = _stage("b1-9", compiled=not compiled, mu={"gap": 0.0, "mu2": 0.15})[1]
    for x, y in zip(other(w, f), (w_hat, f_hat), strict=True):
        np.testing.assert_allclose(x, y, rtol=1e-10, atol=1e-9)
    torch = pytest.importorskip("torch")
    from multilatin.latin.torch_local import TorchLocalStage

    stage = TorchLocalStage(local, torch, torch.device("cpu"))
    for x, y in zip(stage(torch.as_tensor(w), torch.as_tensor(f)), (w_hat, f_hat), strict=True):
        np.testing.assert_allclose(x.numpy(), y, rtol=1e-10, atol=1e-9)


@pytest.mark.parametrize("name", ["b1-4", "b1-9"])
def test_merged_stop_points_converge_sooner_to_the_same_answer(name: str, monkeypatch) -> None:
    """At gap 0 the centre block presses on the stop from step 1 and the split of the force
    at the stop's cross points is free: merged, a cold solve under the studies' QoI rule
    takes fewer iterations (b1-4 104 → 83, b1-9 78 → 66, measured), and the tight answers
    of both rules agree."""
    assembly = ml.load_model(name).assemble({"gap": 0.0, "mu2": 0.15})
    options = ml.LatinOptions(qoi_rtol=1e-3)
    operators = LatinOperators(assembly, options)
    runs = {}
    for merge in (True, False):
        monkeypatch.setattr(cross_points, "MERGE_STOPS", merge)
        runs[merge] = (solve_latin(assembly, options, operators=operators),
                       solve_latin(assembly, ml.LatinOptions(tol=1e-9, max_iter=5000),
                                   operators=operators))
    assert runs[True][0].iterations <= 0.9 * runs[False][0].iterations
    for qoi, value in runs[False][1].qoi.items():
        np.testing.assert_allclose(np.asarray(runs[True][1].qoi[qoi], dtype=float),
                                   np.asarray(value, dtype=float), rtol=1e-7, atol=1e-9)
