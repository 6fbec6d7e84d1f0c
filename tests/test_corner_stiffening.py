"""k stiffened at corner nodes (``LatinOptions.corner_stiffening``, session 14 of issue 15):
where it acts, that it moves no answer, and that it shortens the tail where the slow modes
sit (docs/convergence.md)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

import multilatin as ml
from multilatin.errors import ModelError
from multilatin.latin import LatinOperators, LatinOptions, solve_latin
from multilatin.latin.operators import corner_factors

#: the diagonal direction of session 14 (before the two-scale one became the default, whose
#: stiffer micro part leaves the corners nothing to gain: docs/convergence.md)
OFF = LatinOptions(corner_stiffening=1.0, micro_stiffening=1.0)
ON = LatinOptions(corner_stiffening=1.5, micro_stiffening=1.0)


def test_the_factor_peaks_at_the_corners_and_falls_linearly() -> None:
    """B1: the corners are the centre block's four (its contact interfaces end on the stop
    and on the pushed face) and the top block's wall-pressure corner; the factor is the
    option's there, 1 beyond the reach, linear in between."""
    assembly = ml.load_model("b1").assemble()
    points = LatinOperators(assembly, OFF).points
    factor = corner_factors(points, 3.0, np.full(points.n_points, 10.0))
    at = {tuple(xy) for xy in np.round(points.coords[factor == 3.0], 6)}
    assert at == {(0.0, 50.0), (0.0, 100.0), (50.0, 50.0), (50.0, 100.0), (50.0, 150.0)}
    distance = np.min([np.hypot(*(points.coords - c).T) for c in at], axis=0)
    expected = 1.0 + 2.0 * np.clip(1.0 - distance / 10.0, 0.0, 1.0)
    np.testing.assert_allclose(factor, expected)
    stiffened = LatinOperators(assembly, ON)
    plain = LatinOperators(assembly, OFF).search_direction
    ratio = stiffened.search_direction / plain
    assert ratio.max() == pytest.approx(ON.corner_stiffening) and ratio.min() == 1.0
    # the indicator's norm keeps k alike: η (and the default tolerance) mean what they meant
    np.testing.assert_array_equal(stiffened.indicator_k, plain)


def test_macro_only_interfaces_keep_one_k_per_side() -> None:
    """Their local stage (paper eq. [20]) is written for one k per side: B3's four
    non-matching interfaces around the holed substructure keep it (with a k varying along
    them the tight solve stalled at η ≈ 1e-4)."""
    assembly = ml.load_model("b3").assemble()
    ops = LatinOperators(assembly, LatinOptions(corner_stiffening=3.0, micro_stiffening=1.0))
    points, k = ops.points, ops.search_direction
    assert points.macro_only
    for i in points.macro_only:
        for side in range(2):
            values = k[points.side_points[(i, side)]]
            assert np.ptp(values, axis=0).max() == 0.0
    assert np.ptp(k[np.isin(points.interface, list(points.macro_only), invert=True)]) > 0.0


@pytest.mark.parametrize("name, mu", [("b1", {"mu1": 0.3, "mu2": 0.15}),
                                      ("b3", {"mu1": 0.35, "mu2": 0.25})])
def test_the_answer_does_not_move_and_the_tail_is_shorter(name: str, mu: dict[str, float]
                                                          ) -> None:
    """Tight solves with and without the stiffening agree (the fixed point does not depend
    on k); to the default tolerance the stiffened one needs fewer iterations (b1 (0.3, 0.15)
    130 → 100, b3 (0.35, 0.25) 209 → 175 when written)."""
    assembly = ml.load_model(name).assemble(mu)
    tight = {c: solve_latin(assembly, LatinOptions(corner_stiffening=c, micro_stiffening=1.0,
                                                   tol=1e-10, max_iter=20000))
             for c in (1.0, 1.5)}
    for q in tight[1.0].qoi:
        np.testing.assert_allclose(tight[1.5].qoi[q], tight[1.0].qoi[q], rtol=1e-7, atol=1e-8)
    # the iteration's own tail, without the sliding extrapolation's jumps: since session
    # 34 its two-mode jump takes out on b1 what the stiffening saved (106 / 102 with jumps;
    # without: 127 / 167, b3 232 / 284)
    stiffened = solve_latin(assembly, replace(ON, extrapolate_sliding=False))
    plain = solve_latin(assembly, replace(OFF, extrapolate_sliding=False))
    assert stiffened.iterations < 0.9 * plain.iterations
    assert stiffened.qoi["R_stop"] == pytest.approx(tight[1.0].qoi["R_stop"], rel=1e-3)


def test_bad_values_are_named() -> None:
    with pytest.raises(ModelError, match="corner_stiffening"):
        LatinOptions(corner_stiffening=0.5)
    with pytest.raises(ModelError, match="corner_reach"):
        LatinOptions(corner_reach=0.0)
