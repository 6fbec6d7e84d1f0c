"""Batched parametric LATIN and the compiled local stage give the case-by-case answers."""

from __future__ import annotations

import numpy as np
import pytest

import multilatin as ml
from multilatin.decomposition.interfaces import build_points
from multilatin.errors import ModelError
from multilatin.latin import LatinOperators, LatinOptions, kernels, solve_latin, solve_latin_batch
from multilatin.latin.local_stage import LocalStage

FRICTIONS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.0, 0.0)]


@pytest.mark.skipif(kernels.contact_and_stops is None, reason="Numba not installed")
@pytest.mark.parametrize("name", ["b1", "b1-9", "b3"])
def test_compiled_local_stage_equals_the_numpy_one(name: str) -> None:
    """On fields that open, close, stick and slip (random, of the sizes of a solve), at the
    stops and the held corner too."""
    model = ml.load_model(name)
    assemblies = [model.assemble({"mu1": a, "mu2": b}) for a, b in FRICTIONS]
    ops = LatinOperators(assemblies[0], LatinOptions())
    points = [build_points(a) for a in assemblies]
    rng = np.random.default_rng(3)
    shape = (len(assemblies), assemblies[0].n_steps, points[0].n_points, 2)
    w, f = 1e-2 * rng.normal(size=shape), 1e3 * rng.normal(size=shape)
    expected = LocalStage(assemblies, points, ops.search_direction, compiled=False)(w, f)
    stage = LocalStage(assemblies, points, ops.search_direction, compiled=True)
    got = stage(w, f)
    for e, g in zip(expected, got, strict=True):
        np.testing.assert_allclose(g, e, rtol=1e-12, atol=1e-12 * np.abs(e).max())
    slipping = np.abs(got[1][:, :, stage.contact_pairs[0]]).max()
    assert slipping > 0  # contact forces were produced, not only open gaps


@pytest.mark.parametrize("acceleration", ["relaxation", "anderson"])
def test_a_batch_gives_the_case_by_case_answers(acceleration: str) -> None:
    """Same iterations (each case leaves the batch when its own η < tol), same fields, for
    cold and warm starts mixed in one batch."""
    model = ml.load_model("b1-4")
    options = LatinOptions(acceleration=acceleration)
    assemblies = [model.assemble({"mu1": a, "mu2": b}) for a, b in FRICTIONS]
    ops = LatinOperators(assemblies[0], options)
    neighbour = solve_latin(model.assemble({"mu1": 0.3, "mu2": 0.05}), operators=ops)
    assert neighbour.interface is not None
    warm = (neighbour.interface.displacement_hat, neighbour.interface.force_hat)
    starts = [None, warm, None, warm]
    single = [solve_latin(a, operators=ops, initial=s) for a, s in
              zip(assemblies, starts, strict=True)]
    batch = solve_latin_batch(assemblies, operators=ops, initial=starts)
    assert len({r.iterations for r in batch}) > 1  # the cases left the batch at different times
    for one, together in zip(single, batch, strict=True):
        assert together.iterations == one.iterations
        assert together.qoi["R_stop"] == pytest.approx(one.qoi["R_stop"], rel=1e-9)
        np.testing.assert_allclose(together.qoi["u_A"], one.qoi["u_A"], rtol=1e-8, atol=1e-12)
        assert together.timings["batch_size"] == len(assemblies)


def test_a_batch_of_several_geometries_gives_each_geometrys_answers() -> None:
    """Hole positions (the same interfaces): the NumPy backend solves one batch per
    geometry and returns the answers in the cases' order."""
    b3 = ml.load_model("b3")
    mus = [{"rc": 2.0, "mu1": 0.3}, {"rc": 4.0, "mu1": 0.35, "mu2": 0.25},
           {"rc": 2.0, "mu1": 0.1, "mu2": 0.3}]
    assemblies = [b3.assemble(mu) for mu in mus]
    together = solve_latin_batch(assemblies)
    for assembly, result in zip(assemblies, together, strict=True):
        alone = solve_latin(assembly)
        assert result.assembly is assembly
        assert result.iterations == alone.iterations
        assert result.qoi["R_stop"] == pytest.approx(alone.qoi["R_stop"], rel=1e-9)
    assert together[0].timings["batch_size"] == 2  # rc = 2 twice, together


def test_a_batch_refuses_cases_of_other_interfaces() -> None:
    with pytest.raises(ModelError, match="share the interface discretisation"):
        solve_latin_batch([ml.load_model("b1").assemble(), ml.load_model("b1-4").assemble()])
    b3 = ml.load_model("b3")
    ops = LatinOperators(b3.assemble({"rc": 2.0}), LatinOptions())
    with pytest.raises(ModelError, match="operators: they were built for another geometry"):
        solve_latin_batch([b3.assemble({"rc": 3.0})], operators=ops)
    with pytest.raises(ModelError, match="initial: expected 2 entries"):
        model = ml.load_model("b1")
        solve_latin_batch([model.assemble(), model.assemble()], initial=[None])
