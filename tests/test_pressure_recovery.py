"""Mean contact pressures recovered consistently (the boundary mass matrix, as independent
FE codes do), exact for a pressure linear along the interface, and the same on both solvers."""

from __future__ import annotations

import numpy as np
import pytest

import multilatin as ml
from multilatin.decomposition.qoi import ContactPressures

PAIR = frozenset(("a", "b"))


def _interface(nodes: np.ndarray, pressure) -> tuple[np.ndarray, np.ndarray]:
    """Dual cells and lumped values (nodal force over dual length) of the consistent nodal
    forces f_i = ∫ p φ_i of ``pressure`` on 1-D linear elements between ``nodes``."""
    forces = np.zeros(nodes.size)
    for e in range(nodes.size - 1):
        h = nodes[e + 1] - nodes[e]
        # Simpson's rule: exact for p φ quadratic, i.e. p linear on the element
        for i, phi in ((e, lambda t: 1 - t), (e + 1, lambda t: t)):
            mid = pressure(0.5 * (nodes[e] + nodes[e + 1]))
            forces[i] += h / 6 * (pressure(nodes[e]) * phi(0) + 4 * mid * phi(0.5)
                                  + pressure(nodes[e + 1]) * phi(1))
    mids = 0.5 * (nodes[1:] + nodes[:-1])
    extents = np.column_stack([np.r_[nodes[0], mids], np.r_[mids, nodes[-1]]])
    return extents, forces / (extents[:, 1] - extents[:, 0])


def _two_interfaces(pressure) -> ContactPressures:
    """A non-uniform line [0, 4] split into two interfaces that share the node at 1.5 (each
    with its own end node and half dual cell there, as LATIN has them), listed shuffled."""
    parts = [_interface(np.array([0.0, 0.7, 1.5]), pressure),
             _interface(np.array([1.5, 2.0, 3.1, 4.0]), pressure)]
    extents = np.vstack([p[0] for p in parts])
    values = np.concatenate([p[1] for p in parts])
    order = np.random.default_rng(0).permutation(values.size)
    return ContactPressures([PAIR] * values.size, extents[order], values[order][None])


@pytest.mark.parametrize("segment", [(0.0, 4.0), (0.3, 3.3), (1.0, 1.5), (1.2, 2.6)])
def test_consistent_recovery_is_exact_for_a_linear_pressure(segment) -> None:
    pressures = _two_interfaces(lambda s: 2.0 + 3.0 * s)
    exact = 2.0 + 3.0 * 0.5 * (segment[0] + segment[1])
    assert pressures.mean(PAIR, segment)[0] == pytest.approx(exact, rel=1e-12)


def test_lumped_recovery_is_not_and_differs_where_the_pressure_varies() -> None:
    pressures = _two_interfaces(lambda s: 2.0 + 3.0 * s)
    lumped = pressures.mean(PAIR, (0.3, 3.3), recovery="lumped")[0]
    assert abs(lumped - (2.0 + 3.0 * 1.8)) > 1e-3
    with pytest.raises(ValueError, match="recovery"):
        pressures.mean(PAIR, (0.0, 1.0), recovery="nodal")


def test_consistent_recovery_converges_at_second_order_for_a_curved_pressure() -> None:
    pressure = lambda s: np.cos(s)  # noqa: E731
    exact = (np.sin(2.5) - np.sin(0.5)) / 2.0
    errors = []
    for n in (8, 16, 32):
        nodes = np.linspace(0.0, 3.0, n + 1) + 0.3 * np.sin(np.linspace(0, np.pi, n + 1)) / n
        extents, values = _interface(nodes, pressure)
        mean = ContactPressures([PAIR] * values.size, extents, values[None]).mean(PAIR, (0.5, 2.5))
        errors.append(abs(mean[0] - exact))
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(rates > 1.8), (errors, rates)


def test_b1_p_b_is_the_same_from_latin_and_the_reference() -> None:
    model = ml.load_model("b1")
    mu = {"mu1": 0.1, "mu2": 0.3}
    latin = model.solve(mu, options=ml.LatinOptions(tol=1e-9, max_iter=5000))
    reference = model.reference(mu)
    np.testing.assert_allclose(latin.qoi["p_B"], reference.qoi["p_B"], rtol=1e-6)
