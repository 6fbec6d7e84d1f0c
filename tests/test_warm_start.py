"""Warm starts and operator reuse: the answer must not depend on where LATIN starts from."""

from __future__ import annotations

import copy

import pytest

import multilatin as ml
from multilatin.errors import ModelError
from multilatin.io.modelfile import ModelSpec
from multilatin.latin import LatinOperators, LatinOptions, solve_latin
from multilatin.latin.signatures import operator_signature
from multilatin.parameters import Grid

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


def test_a_stop_with_and_without_friction_has_other_operators(b1: ml.Model) -> None:
    """A stop's tangential macro component is free when it has no friction, held when it
    has (``free_macro_components``), so its friction coefficient, a parameter here, changes
    the macro basis: operators built at 0 must not serve 0.3 (they did, and the solve did
    not converge in 1 000 iterations), and a study across it gives the reference's answer."""
    data = copy.deepcopy(dict(b1.spec.data))
    for table in data["boundary"]:
        if table["name"] == "stop":
            table["friction"] = "mu3"
    data["parameters"]["mu3"] = {"default": 0.0, "min": 0.0, "unit": "1"}
    model = ml.Model(ModelSpec.from_dict(data, name="b1-stop-friction"))
    frictionless = model.assemble({"mu1": 0.3, "mu2": 0.2, "mu3": 0.0})
    rough = model.assemble({"mu1": 0.3, "mu2": 0.2, "mu3": 0.3})
    assert operator_signature(frictionless, LatinOptions()) != operator_signature(
        rough, LatinOptions())
    with pytest.raises(ModelError, match="operators"):
        solve_latin(rough, operators=LatinOperators(frictionless, LatinOptions()))
    study = ml.run_study(model, Grid.parse(["mu3=0:0.3:2", "mu1=0.3", "mu2=0.2"]),
                         progress=False)
    assert not study.failed
    found = {r["params"]["mu3"]: r["qoi"]["R_stop"] for r in study.records}
    for mu3, value in found.items():
        reference = ml.solve_monolithic(model.assemble({"mu1": 0.3, "mu2": 0.2, "mu3": mu3}))
        assert value == pytest.approx(reference.qoi["R_stop"], rel=1e-3)
    assert found[0.3] != pytest.approx(found[0.0], rel=1e-2)  # the friction matters


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
