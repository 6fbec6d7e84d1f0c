"""The two-scale search direction (``LatinOptions.micro_stiffening``, issue 15): H is
symmetric in the M0 pairing, acts as k on each contact side's macro functions and as k ×
the factor on the rest; the coupled local stage takes that direction; the fixed point does
not depend on it; it shortens the iteration."""

from __future__ import annotations

import numpy as np
import pytest

import multilatin as ml
from multilatin.decomposition.interfaces import with_contact_data
from multilatin.errors import ModelError
from multilatin.latin import LatinOperators, LatinOptions, kernels, two_scale
from multilatin.latin.local_stage import LocalStage


def _operators(name: str = "b1", **options: float) -> tuple[ml.Assembly, LatinOperators]:
    assembly = ml.load_model(name).assemble({"mu1": 0.1, "mu2": 0.3})
    return assembly, LatinOperators(assembly, ml.LatinOptions(**options))  # type: ignore[arg-type]


def _matrix(ops: LatinOperators) -> np.ndarray:
    """H as a dense matrix on flat (point, component) vectors."""
    n = 2 * ops.points.n_points
    unit = np.eye(n).reshape(n, ops.points.n_points, 2)
    return ops.apply_direction(unit).reshape(n, n).T


def test_the_direction_is_symmetric_stiff_on_micro_and_k_on_macro_parts() -> None:
    _, ops = _operators(micro_stiffening=4.0)
    direction = ops.two_scale
    assert direction is not None and direction.n_functions == 4 * 5  # 2 contacts × 2 + stop
    h = _matrix(ops)
    m0h = ops.m0[:, None] * h
    np.testing.assert_allclose(m0h, m0h.T, rtol=0, atol=1e-12 * np.abs(m0h).max())
    k = ops.indicator_k.reshape(-1)  # κ E / L: the macro part's direction
    d = ops.search_direction.reshape(-1)
    support = direction.support
    assert np.allclose(d[support], 4.0 * k[support])
    for column in range(direction.n_functions):
        e = np.zeros(h.shape[0])
        e[support] = direction.basis[:, column]
        np.testing.assert_allclose(h @ e, k * e, rtol=0, atol=1e-9 * np.abs(k * e).max())
        # a micro field on the same side: M0-orthogonal to every macro function there
        side = support[direction.basis[:, column] != 0]
        rng = np.random.default_rng(column)
        v = np.zeros(h.shape[0])
        v[side] = rng.normal(size=side.size)
        v[support] -= direction.basis @ (direction.weighted.T @ v[support])
        np.testing.assert_allclose(h @ v, d * v, rtol=0, atol=1e-9 * np.abs(d * v).max())
    # off the contact sides and stops: the diagonal D alone
    off = np.setdiff1d(np.arange(h.shape[0]), support)
    np.testing.assert_array_equal(h[np.ix_(off, off)], np.diag(d[off]))


def test_the_diagonal_direction_is_the_factor_one() -> None:
    _, ops = _operators(micro_stiffening=1.0)
    assert ops.two_scale is None


def test_the_coupled_local_stage_takes_the_same_direction(monkeypatch) -> None:
    """With enough inner iterations the local stage's output satisfies its search
    direction F̂ − F = H (Ŵ − W) (E+), H the linear stage's, wherever the point-wise local
    stage satisfies its own (not at a held node: there the force comes from the free side,
    ``LatinOptions.held_nodes``)."""
    assembly, ops = _operators(micro_stiffening=4.0)
    assert ops.two_scale is not None
    local = LocalStage([assembly], [ops.points], ops.search_direction)
    rng = np.random.default_rng(0)
    shape = (1, assembly.n_steps, ops.points.n_points, 2)
    w = 1e-3 * rng.normal(size=shape)
    f = 10.0 * rng.normal(size=shape)
    start = ops.two_scale.project(w.reshape(assembly.n_steps, -1)).reshape(1, assembly.n_steps, -1)
    monkeypatch.setattr(two_scale, "INNER_ITERATIONS", 80)
    w_hat, f_hat, _ = two_scale.coupled_local_stage(local, local.contact_stage, ops.two_scale,
                                                    w, f, start)
    residual = f_hat - f - ops.apply_direction((w_hat - w).reshape(-1, *shape[2:])
                                                ).reshape(shape)
    point_w, point_f = local(w, f)
    own = np.abs(point_f - f - ops.search_direction * (point_w - w)).max(axis=(0, 1, 3))
    held = own > 1e-9 * np.abs(f).max()
    assert 0 < held.sum() <= 2  # b1: the node (50, 100)
    assert np.abs(residual[:, :, ~held]).max() <= 1e-8 * np.abs(f_hat - f).max()
    assert np.abs(f_hat - f).max() > 0.0


@pytest.mark.skipif(kernels.coupled_contact is None, reason="Numba not installed")
@pytest.mark.parametrize("name", ["b1", "b3"])
def test_the_compiled_inner_passes_equal_the_numpy_ones(name: str) -> None:
    """``compiled_local_stage`` (one compiled loop of the inner passes) gives
    ``coupled_local_stage``'s answer on fields that open, close, stick and slip, and
    ``kernels.two_scale_correction`` the NumPy product (H − D) x."""
    assembly = ml.load_model(name).assemble({"mu1": 0.2, "mu2": 0.1})
    ops = LatinOperators(assembly, LatinOptions())
    assert ops.two_scale is not None
    assemblies = [assembly, ml.load_model(name).assemble({"mu1": 0.4, "mu2": 0.0})]
    points = [ops.points, with_contact_data(ops.points, assemblies[1])]
    local = LocalStage(assemblies, points, ops.search_direction, macro_only=ops.macro_only)
    rng = np.random.default_rng(1)
    shape = (2, assembly.n_steps, ops.points.n_points, 2)
    scale_w = np.abs(ops.points.coords).max() * 1e-4
    w = scale_w * rng.normal(size=shape)
    f = 20.0 * rng.normal(size=shape)
    start = ops.two_scale.project((w + scale_w * rng.normal(size=shape)).reshape(
        -1, 2 * ops.points.n_points)).reshape(*shape[:2], -1)
    expected = two_scale.coupled_local_stage(local, local.contact_stage, ops.two_scale, w, f,
                                             start)
    got = two_scale.compiled_local_stage(local, ops.two_scale, w, f, start)
    for e, g in zip(expected, got, strict=True):
        np.testing.assert_allclose(g, e, rtol=1e-11, atol=1e-11 * np.abs(e).max())
    assert np.abs(got[1][:, :, local.contact_pairs[0]]).max() > 0
    rows = w.reshape(-1, 2 * ops.points.n_points)
    compiled = np.zeros_like(rows)
    ops.two_scale.add_correction(compiled, rows)
    numpy_product = np.zeros_like(rows)
    ops.two_scale.scatter(numpy_product, ops.two_scale.expand(ops.two_scale.project(rows)),
                          add=True)
    np.testing.assert_allclose(compiled, numpy_product, rtol=1e-12,
                               atol=1e-12 * np.abs(numpy_product).max())


@pytest.mark.skipif(kernels.direction_update is None, reason="Numba not installed")
@pytest.mark.parametrize("micro_stiffening", [4.0, 1.0])
def test_the_fused_force_update_is_the_numpy_one_bitwise(micro_stiffening: float) -> None:
    """``LatinOperators.direction_update`` (one compiled pass: base + H (a − b)) gives the
    very numbers of the NumPy composition, with and without the two-scale part, with b and
    base left out, and in place."""
    options = LatinOptions(micro_stiffening=micro_stiffening)
    ops = LatinOperators(ml.load_model("b3").assemble({}), options)
    assert (ops.two_scale is None) == (micro_stiffening == 1.0)
    rng = np.random.default_rng(3)
    a, b, base = (rng.normal(size=(7, ops.points.n_points, 2)) for _ in range(3))
    np.testing.assert_array_equal(ops.direction_update(a, b, base=base),
                                  base + ops.apply_direction(a - b))
    np.testing.assert_array_equal(ops.direction_update(a, base=base),
                                  base + ops.apply_direction(a))
    np.testing.assert_array_equal(ops.direction_update(a, b), ops.apply_direction(a - b))
    expected = base + ops.apply_direction(a - b)
    out = ops.direction_update(a, b, base=base, out=base)
    assert out is base
    np.testing.assert_array_equal(base, expected)
    # a non-contiguous field takes the NumPy path, with the same numbers
    np.testing.assert_array_equal(ops.direction_update(a[::2], b[::2]),
                                  ops.apply_direction(a[::2] - b[::2]))


@pytest.mark.parametrize("name, mu", [("b1", (0.1, 0.3)), ("b1", (0.3, 0.15)),
                                      ("b3", (0.35, 0.25))])
def test_the_fixed_point_does_not_depend_on_it(name: str, mu: tuple[float, float]) -> None:
    assembly = ml.load_model(name).assemble({"mu1": mu[0], "mu2": mu[1]})
    results = [ml.solve_latin(assembly, ml.LatinOptions(micro_stiffening=factor, tol=1e-10,
                                                        max_iter=20000))
               for factor in (1.0, 4.0)]
    for q in results[0].qoi:
        reference = np.asarray(results[0].qoi[q], dtype=float)
        scale = max(np.abs(reference).max(), 1e-12)
        np.testing.assert_allclose(np.asarray(results[1].qoi[q], dtype=float), reference,
                                   rtol=0, atol=1e-6 * scale, err_msg=q)


@pytest.mark.parametrize("name, pairs", [
    ("b1", [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]),
    ("b3", [(0.3, 0.0), (0.3, 0.15)])])
def test_it_shortens_the_iteration(name: str, pairs: list[tuple[float, float]]) -> None:
    """Against the diagonal direction (both without corner stiffening, the default tolerance):
    at most 0.81 of its iterations. docs/convergence.md: b1 −20 to −30 % and b3 −41 to −48 %
    at η < 1e-6 against session 14's default (corner stiffening, η < 3e-6); b1 (0.3, 0.15)
    81 against 101 iterations since session 53's corner rule (102 before)."""
    model = ml.load_model(name)
    for mu1, mu2 in pairs:
        assembly = model.assemble({"mu1": mu1, "mu2": mu2})
        diagonal = ml.solve_latin(assembly, ml.LatinOptions(micro_stiffening=1.0))
        two = ml.solve_latin(assembly, ml.LatinOptions(micro_stiffening=4.0))
        assert two.iterations <= 0.81 * diagonal.iterations, (mu1, mu2, two.iterations,
                                                              diagonal.iterations)


@pytest.mark.parametrize("value", [0.5, 0.0, 2e3])
def test_a_bad_factor_is_named(value: float) -> None:
    with pytest.raises(ModelError, match="micro_stiffening"):
        ml.LatinOptions(micro_stiffening=value)
