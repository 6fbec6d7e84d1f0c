"""The LATIN indicator's norms (paper §4.3): ``weighted_squares`` with NumPy (``engine.norms``,
``guards.force_indicator``), and ``indicator_squares`` point by point, for ``kernels`` to
compile with Numba: per case ‖s − ŝ‖², ‖s‖², ‖ŝ‖² and the forces' own ‖F‖², ‖F̂‖², and per
load step ‖s − ŝ‖² and its force part (``engine.NumpyFields.indicator``, ``settle``; the
forces' own indicator: ``guards.FORCE_MARGIN``)."""

from __future__ import annotations

import numpy as np

from ..fem.elasticity import FloatArray

__all__ = ["indicator_squares", "weighted_squares"]


def weighted_squares(weight: FloatArray, field: FloatArray) -> FloatArray:
    """Σ_t Σ_points ∫ weight x·x per case (first axis) of a field ``(n_cases, n_steps,
    n_points, 2)``; ``weight`` per flattened (point, component): ∫ k for W, ∫ k⁻¹ for F."""
    n_cases = field.shape[0]
    out: FloatArray = np.square(field).reshape(n_cases, -1, weight.size).sum(axis=1) @ weight
    return out


def indicator_squares(w: FloatArray, f: FloatArray, w_hat: FloatArray, f_hat: FloatArray,
                       displacement_weight: FloatArray, force_weight: FloatArray,
                       step_gaps: FloatArray, step_force_gaps: FloatArray
                       ) -> FloatArray:  # pragma: no cover - compiled
    """Per case ‖s − ŝ‖², ‖s‖², ‖ŝ‖² and the forces' own ‖F‖², ‖F̂‖²; ``step_gaps`` (n_cases,
    n_steps) gets ‖s − ŝ‖² per step (the same terms, summed in the same order) and
    ``step_force_gaps`` its force part ‖F − F̂‖²."""
    n_cases, n_steps = w.shape[0], w.shape[1]
    n = displacement_weight.size
    w2, f2 = w.reshape(n_cases, -1), f.reshape(n_cases, -1)
    wh2, fh2 = w_hat.reshape(n_cases, -1), f_hat.reshape(n_cases, -1)
    out = np.zeros((n_cases, 5))
    for c in range(n_cases):
        gap = size = size_hat = force_size = force_size_hat = 0.0
        for t in range(n_steps):
            step_gap = step_force_gap = 0.0
            for j in range(n):
                i = t * n + j
                kw, kf = displacement_weight[j], force_weight[j]
                dw, df = w2[c, i] - wh2[c, i], f2[c, i] - fh2[c, i]
                on_df = kf * df * df
                term = kw * dw * dw + on_df
                gap += term
                step_gap += term
                step_force_gap += on_df
                on_f, on_f_hat = kf * f2[c, i] * f2[c, i], kf * fh2[c, i] * fh2[c, i]
                size += kw * w2[c, i] * w2[c, i] + on_f
                size_hat += kw * wh2[c, i] * wh2[c, i] + on_f_hat
                force_size, force_size_hat = force_size + on_f, force_size_hat + on_f_hat
            step_gaps[c, t], step_force_gaps[c, t] = step_gap, step_force_gap
        out[c, 0], out[c, 1], out[c, 2], out[c, 3] = gap, size, size_hat, force_size
        out[c, 4] = force_size_hat
    return out
