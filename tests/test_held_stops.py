"""Stops held tangentially at their node (``held_nodes.held_stops``): a frictional flat
under a face whose sliding component is prescribed, a block in a rigid corner. The split
of such a node's force between the stop's friction and its holder is not determined by
equilibrium; both solvers give it the held-stop rule, so the converged answer is one,
whatever the search direction, and equals the monolithic reference's. Before the rule, the
corner's flat reaction moved by 1.9 % between κ = 0.5 and 2 and stood 15 % (of its largest
value) from the reference, which also merged the corner's two stops into one; the sheared
block's moved by 1.5 %."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import multilatin as ml
from multilatin.decomposition.interfaces import build_points
from multilatin.latin import LatinOperators, LatinOptions, kernels
from multilatin.latin.local_stage import LocalStage
from multilatin.reference.contact_newton import contact_set

DATA = Path(__file__).parent / "data"
MODELS = ["block_in_a_rigid_corner", "block_sheared_on_a_flat"]


def _model(name: str) -> ml.Model:
    return ml.Model(ml.ModelSpec.from_toml(DATA / f"{name}.toml"))


@pytest.fixture(scope="module", params=MODELS)
def case(request: pytest.FixtureRequest) -> tuple[ml.Model, ml.SolveResult]:
    model = _model(request.param)
    return model, model.reference()


def assert_qois_equal(result: ml.SolveResult, reference: ml.SolveResult,
                      tolerance: float = 1e-7) -> None:
    """Every QoI of ``result`` at every step within ``tolerance`` × its largest magnitude in
    ``reference`` (a tight LATIN solve against the monolithic one)."""
    for name in reference.qoi:
        expected = np.asarray(reference.qoi[name])
        np.testing.assert_allclose(result.qoi[name], expected, rtol=0,
                                   atol=tolerance * np.abs(expected).max())


@pytest.mark.parametrize("kappa", [0.5, 2.0])
def test_the_converged_answer_is_the_reference_whatever_kappa(case, kappa) -> None:
    model, reference = case
    result = model.solve(options=LatinOptions(kappa=kappa, tol=1e-10, max_iter=3000))
    assert result.converged
    assert_qois_equal(result, reference)


def test_the_torch_stage_gives_the_same_answer(case) -> None:
    pytest.importorskip("torch")
    model, reference = case
    result = model.solve(options=LatinOptions(backend="torch", tol=1e-10, max_iter=3000))
    assert_qois_equal(result, reference)


def test_the_flat_slides_at_the_cone_while_the_face_moves() -> None:
    """The sheared block: at step 3 the whole flat slides, R_flat_x = −μ N; the moving face
    makes its corner slide too (at steps 2, 3 its friction is at the cone)."""
    model = _model("block_sheared_on_a_flat")
    result = model.solve(options=LatinOptions(tol=1e-10, max_iter=3000))
    assert result.qoi["R_flat_y"][2] == pytest.approx(1000.0, rel=1e-9)
    assert result.qoi["R_flat_x"][2] == pytest.approx(-0.4 * 1000.0, rel=1e-7)
    assert result.interface is not None
    corner = np.flatnonzero((result.interface.coords[:, 1] == 0.0)
                            & (result.interface.coords[:, 0] == 0.0)
                            & (np.abs(result.interface.force_hat[0, :, 1]) > 0.0))
    force = result.interface.force_hat[:, corner[0]]
    np.testing.assert_allclose(force[1:3, 0], -0.4 * force[1:3, 1], rtol=1e-7)
    assert force[0, 0] == 0.0  # held, from rest: its previous (zero) force


def test_held_stops_are_found_and_the_corner_keeps_its_two_stops() -> None:
    corner = _model("block_in_a_rigid_corner").assemble()
    points = build_points(corner)
    held = np.flatnonzero(points.stop_held_stop >= 0)
    assert held.size == 2  # the corner node on each stop, each held by the other
    assert set(points.stop_held_stop[held]) == set(held)
    assert np.all(points.stop_held_boundary < 0)
    contacts = contact_set(corner, [np.arange(corner.substructures[0].mesh.nodes.shape[0])])
    assert contacts.size == points.stops.size  # the corner node is two pairs, not one
    sheared = build_points(_model("block_sheared_on_a_flat").assemble())
    assert np.count_nonzero(sheared.stop_held_boundary >= 0) == 1
    assert np.all(sheared.stop_held_stop < 0)


@pytest.mark.skipif(kernels.contact_and_stops is None, reason="Numba not installed")
@pytest.mark.parametrize("name", MODELS)
def test_compiled_and_torch_local_stages_equal_the_numpy_one(name) -> None:
    """Random fields in which the held stops open, close, stick and slip."""
    model = _model(name)
    assemblies = [model.assemble()] * 3
    ops = LatinOperators(assemblies[0], LatinOptions())
    points = [build_points(a) for a in assemblies]
    rng = np.random.default_rng(7)
    shape = (3, assemblies[0].n_steps, points[0].n_points, 2)
    w, f = 1e-3 * rng.normal(size=shape), 50.0 * rng.normal(size=shape)
    expected = LocalStage(assemblies, points, ops.search_direction, compiled=False)(w, f)
    got = LocalStage(assemblies, points, ops.search_direction, compiled=True)(w, f)
    for e, g in zip(expected, got, strict=True):
        np.testing.assert_allclose(g, e, rtol=1e-12, atol=1e-12 * np.abs(e).max())
    torch = pytest.importorskip("torch")
    from multilatin.latin.torch_local import TorchLocalStage

    stage = TorchLocalStage(LocalStage(assemblies, points, ops.search_direction,
                                       compiled=False), torch, torch.device("cpu"))
    for e, g in zip(expected, stage(torch.as_tensor(w), torch.as_tensor(f)), strict=True):
        np.testing.assert_allclose(g.numpy(), e, rtol=1e-12, atol=1e-12 * np.abs(e).max())
