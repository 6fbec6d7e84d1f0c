"""Choice of the interface elements, by test (method.md §2)."""

import numpy as np
import pytest

import multilatin as ml


def checkerboard(result):
    """Largest second difference of the normal force along an interface side, relative to
    the force on that side: O(h²·F'') for a smooth field, O(F) for a zig-zag."""
    itf = result.interface
    worst = 0.0
    for i in np.unique(itf.interface):
        sel = np.flatnonzero(itf.interface == i)
        side = sel[itf.substructure[sel] == itf.substructure[sel].min()]
        f = itf.force_hat[0, side, 0]
        if f.size < 3 or not np.abs(f).max() > 0:
            continue
        worst = max(worst, np.abs(np.diff(f, 2)).max() / np.abs(f).max())
    return worst


@pytest.fixture(scope="module")
def results(b0):
    out = {}
    for kind in ("nodal", "edges", "edge-pairs"):
        out[kind] = b0.solve(options=ml.LatinOptions(tol=1e-8, interface_elements=kind,
                                                     max_iter=5000))
    return out


def test_nodal_elements_reproduce_the_conforming_solution(b0, results):
    reference = b0.reference().qoi["v_tip"]
    tight = b0.solve(options=ml.LatinOptions(tol=1e-10, max_iter=5000))
    assert tight.qoi["v_tip"] == pytest.approx(reference, rel=1e-6)
    assert checkerboard(results["nodal"]) < 0.2


def test_p0_on_every_edge_checkerboards_and_converges_slowly(b0, results):
    """The zig-zag is a mode the relaxed iteration hardly damps; the sliding
    extrapolation's geometric jump (``latin.sliding``) takes most of it out at once, so the
    iteration's own rate is compared with the jumps off."""
    assert checkerboard(results["edges"]) > 0.5
    plain = {kind: b0.solve(options=ml.LatinOptions(tol=1e-8, interface_elements=kind,
                                                    max_iter=5000, extrapolate_sliding=False))
             for kind in ("nodal", "edges")}
    assert plain["edges"].iterations > 5 * plain["nodal"].iterations
    assert results["edges"].iterations < plain["edges"].iterations


def test_p0_on_edge_pairs_is_continuous_in_the_mean_only(b0, results):
    reference = b0.reference().qoi["v_tip"]
    error = abs(results["edge-pairs"].qoi["v_tip"] / reference - 1)
    assert 1e-4 < error < 2e-2
    assert checkerboard(results["edge-pairs"]) < 0.5
