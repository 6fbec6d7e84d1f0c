"""Warm starts and operator reuse: the answer must not depend on where LATIN starts from."""

from __future__ import annotations

import pytest

import multilatin as ml
from multilatin.errors import ModelError
from multilatin.latin import LatinOperators, LatinOptions, solve_latin

TIGHT = LatinOptions(tol=1e-9, max_iter=5000)


@pytest.fixture(scope="module")
def b1() -> ml.Model:
    return ml.load_model("b1")


def test_operators_reused_across_friction_take_the_new_friction(b1: ml.Model) -> None:
    """Operators built at (0.3, 0) serve (0.1, 0.3): friction lives in the local stage."""
    ops = LatinOperators(b1.assemble({"mu1": 0.3, "mu2": 0.0}), TIGHT)
    target = b1.assemble({"mu1": 0.1, "mu2": 0.3})
    reused = solve_latin(target, TIGHT, operators=ops)
    fresh = solve_latin(target, TIGHT)
    assert reused.qoi["R_stop"] == pytest.approx(fresh.qoi["R_stop"], rel=1e-9)
    assert reused.qoi["R_stop"] == pytest.approx(530.9, abs=0.5)


def test_operators_of_another_geometry_are_refused(b1: ml.Model) -> None:
    ops = LatinOperators(b1.assemble(), LatinOptions())
    with pytest.raises(ModelError, match="operators"):
        solve_latin(ml.load_model("b1-4").assemble(), operators=ops)
    with pytest.raises(ModelError, match="operators"):
        solve_latin(b1.assemble(), LatinOptions(kappa=1.0), operators=ops)


def test_initial_fields_of_the_wrong_shape_are_refused(b1: ml.Model) -> None:
    import numpy as np
    with pytest.raises(ModelError, match="initial"):
        solve_latin(b1.assemble(), initial=(np.zeros((3, 4, 2)), np.zeros((3, 4, 2))))


def test_warm_start_from_a_neighbour_reaches_the_cold_answer_and_the_reference(
        b1: ml.Model) -> None:
    """At (0.3, 0.15) the stop closes while the upper interface slides: before the held-corner
    rule, cold and warm LATIN and the Newton reference converged (η = 1e-9) to three
    different stop forces (391.7, 383.2, 380.9 N), all equilibrated — the friction at the
    node pair held by both the stop and the wall was indeterminate. Now one answer. The
    warm start saves iterations at the default tolerance, the one studies use (to η < 1e-9
    the slow modes it does not shorten take as long as from zero)."""
    ops = LatinOperators(b1.assemble({"mu1": 0.3, "mu2": 0.1}), TIGHT)
    target = b1.assemble({"mu1": 0.3, "mu2": 0.15})
    by_tolerance = {}
    for options in (LatinOptions(), TIGHT):
        neighbour = solve_latin(b1.assemble({"mu1": 0.3, "mu2": 0.1}), options, operators=ops)
        assert neighbour.interface is not None
        cold = solve_latin(target, options, operators=ops)
        warm = solve_latin(target, options, operators=ops,
                           initial=(neighbour.interface.displacement_hat,
                                    neighbour.interface.force_hat))
        by_tolerance[options.tol] = cold, warm
    cold, warm = by_tolerance[LatinOptions().tol]
    assert warm.iterations < cold.iterations
    cold, warm = by_tolerance[TIGHT.tol]
    reference = b1.reference({"mu1": 0.3, "mu2": 0.15})
    assert warm.qoi["R_stop"] == pytest.approx(cold.qoi["R_stop"], rel=1e-6)
    assert cold.qoi["R_stop"] == pytest.approx(reference.qoi["R_stop"], rel=1e-6)


def test_starting_from_the_converged_solution_stops_at_once(b1: ml.Model) -> None:
    result = b1.solve({"mu1": 0.1, "mu2": 0.3})
    assert result.interface is not None
    again = solve_latin(result.assembly, initial=(result.interface.displacement_hat,
                                                   result.interface.force_hat))
    assert again.iterations <= 2
    assert again.qoi["R_stop"] == pytest.approx(result.qoi["R_stop"], rel=1e-5)
