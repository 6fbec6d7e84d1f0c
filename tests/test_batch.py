"""Batched parametric LATIN and the compiled local stage give the case-by-case answers."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from conftest import has_torch, warm_b1_4_batch

import multilatin as ml
from multilatin.errors import ModelError
from multilatin.latin import LatinOperators, LatinOptions, kernels, solve_latin, solve_latin_batch
from multilatin.latin.local_stage import LocalStage


@pytest.mark.skipif(kernels.contact_and_stops is None, reason="Numba not installed")
@pytest.mark.parametrize("name", ["b1", "b1-9", "b3"])
def test_compiled_local_stage_equals_the_numpy_one(
        name: str, random_local_stage_input: Callable[[str, int], tuple[Any, ...]]) -> None:
    """On fields that open, close, stick and slip (random, of the sizes of a solve), at the
    stops and the held corner too."""
    assemblies, points, ops, reference, w, f = random_local_stage_input(name, 3)
    expected = reference(w, f)
    stage = LocalStage(assemblies, points, ops.search_direction, compiled=True,
                       macro_only=ops.macro_only)
    got = stage(w, f)
    for e, g in zip(expected, got, strict=True):
        np.testing.assert_allclose(g, e, rtol=1e-12, atol=1e-12 * np.abs(e).max())
    slipping = np.abs(got[1][:, :, stage.contact_pairs[0]]).max()
    assert slipping > 0  # contact forces were produced, not only open gaps


@pytest.mark.parametrize("acceleration", ["relaxation", "anderson"])
def test_a_batch_gives_the_case_by_case_answers(acceleration: str) -> None:
    """Same iterations (each case leaves the batch when its own η < tol), same fields, for
    cold and warm starts mixed in one batch."""
    assemblies, ops, starts = warm_b1_4_batch(LatinOptions(acceleration=acceleration))
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
    """Hole sizes and positions (the same interfaces): the NumPy backend solves them in one
    batch — the shared substructures on every column at once, the holed one and the macro
    operator geometry by geometry, also once cases have left the batch — and returns the
    answers in the cases' order, each its own geometry's."""
    b3 = ml.load_model("b3")
    mus = [{"rc": 2.0, "mu1": 0.3}, {"rc": 4.0, "mu1": 0.35, "mu2": 0.25},
           {"rc": 2.0, "mu1": 0.1, "mu2": 0.3}, {"rc": 3.0, "xc": 24.0}]
    assemblies = [b3.assemble(mu) for mu in mus]
    together = solve_latin_batch(assemblies)
    alone = [solve_latin(assembly) for assembly in assemblies]
    for assembly, result, one in zip(assemblies, together, alone, strict=True):
        assert result.assembly is assembly
        assert result.iterations == one.iterations
        assert result.qoi["R_stop"] == pytest.approx(one.qoi["R_stop"], rel=1e-8)
        np.testing.assert_allclose(result.qoi["u_A"], one.qoi["u_A"], rtol=1e-7, atol=1e-12)
        assert result.timings["batch_size"] == 4
    assert len({r.iterations for r in together}) > 1  # cases left the batch one by one
    values = [r.qoi["R_stop"] for r in together]
    assert abs(values[3] / values[0] - 1) > 1e-3  # the geometries' answers differ


def test_cases_of_other_interfaces_are_solved_in_batches_of_their_own() -> None:
    b1, b1_4 = ml.load_model("b1").assemble(), ml.load_model("b1-4").assemble()
    for backend in ("numpy", "torch") if has_torch() else ("numpy",):
        results = solve_latin_batch([b1, b1_4, b1], LatinOptions(backend=backend))
        assert [r.assembly for r in results] == [b1, b1_4, b1]
        assert [r.timings["batch_size"] for r in results] == [2, 1, 2]
        assert results[0].qoi["R_stop"] == pytest.approx(results[2].qoi["R_stop"], rel=1e-12)


def test_a_batch_refuses_operators_of_another_geometry() -> None:
    b3 = ml.load_model("b3")
    ops = LatinOperators(b3.assemble({"rc": 2.0}), LatinOptions())
    with pytest.raises(ModelError, match="operators: they were built for another geometry"):
        solve_latin_batch([b3.assemble({"rc": 3.0})], operators=ops)
    with pytest.raises(ModelError, match="initial: expected 2 entries"):
        model = ml.load_model("b1")
        solve_latin_batch([model.assemble(), model.assemble()], initial=[None])


@pytest.mark.parametrize("name", ["b1", "b3", "slide"])
def test_without_recovery_the_qois_come_from_the_interface_fields(name: str) -> None:
    """``recover_displacements=False`` (what studies use): no interior displacements and
    no contact pressures, the same iterations, free motions and QoIs — the functionals
    (``tracking.qoi_functionals``) are the recovery's linear maps, equal to rounding;
    reactions, contact pressures and displacements all among the QoIs checked."""
    from dataclasses import replace

    model = ml.load_model(name)
    frictions = [{"mu1": 0.1, "mu2": 0.2}, {"mu1": 0.2, "mu2": 0.1}] if name != "slide" else [{}]
    assemblies = [model.assemble(mu) for mu in frictions]
    options = LatinOptions(qoi_rtol=1e-3)
    full = solve_latin_batch(assemblies, options)
    lean = solve_latin_batch(assemblies, replace(options, recover_displacements=False))
    kinds = {q.kind for q in assemblies[0].qois}
    assert "displacement" in kinds and len(kinds) >= 2
    for a, b in zip(full, lean, strict=True):
        assert a.displacements and not b.displacements and b.contact is None
        assert (a.iterations, a.free_motions) == (b.iterations, b.free_motions)
        assert a.qoi.keys() == b.qoi.keys()
        for key, value in a.qoi.items():
            expected = np.atleast_1d(value)
            assert np.max(np.abs(np.atleast_1d(b.qoi[key]) - expected)) <= (
                1e-12 * np.max(np.abs(expected))), key


@pytest.mark.parametrize("name", ["b1", "b3"])
def test_macro_force_data_from_the_boundary_points_equals_the_whole_field(name: str) -> None:
    """A batch's F_dᴹ = Π F_d is taken from Π's columns at the boundary points (where F_d
    is not zero): the same as Π applied to the whole field, case by case and step by step."""
    from multilatin.latin.iteration import BatchIterations

    model = ml.load_model(name)
    batch = [model.assemble({"mu1": mu, "mu2": 0.2}) for mu in (0.0, 0.3)]
    ops = LatinOperators(batch[0], LatinOptions())
    local = LocalStage(batch, [ops.points] * 2, ops.search_direction,
                       macro_only=ops.macro_only)
    iterations = BatchIterations.__new__(BatchIterations)
    iterations.ops = ops
    found = iterations._macro_data(local, 2)
    field = local.prescribed_force_field(ops.points.n_points)
    assert np.abs(field).max() > 0.0
    for c in range(2):
        for t in range(field.shape[1]):
            expected = ops.project @ field[c, t].ravel()
            np.testing.assert_allclose(found[c, t], expected, rtol=1e-13,
                                       atol=1e-13 * np.abs(expected).max())
