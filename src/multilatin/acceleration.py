"""Acceleration of the LATIN fixed point s ↦ linear(local(s)) (method.md §7)."""

from __future__ import annotations

import numpy as np

from .fem.elasticity import FloatArray, IntArray


class Anderson:
    """Anderson mixing (type II) of the LATIN fixed point x ↦ G(x) = linear(local(x)),
    in the norm of the indicator, damped by ω; one independent history per case of a batch
    (fields of shape ``(n_cases, n_steps, n_points, 2)``). Affine combinations of admissible
    fields are admissible, so s stays in A_d."""

    def __init__(self, depth: int, damping: float, w_scale: FloatArray,
                 f_scale: FloatArray) -> None:
        self.depth = depth
        self.damping = damping
        self.w_scale = w_scale
        self.f_scale = f_scale
        self.scale: FloatArray | None = None  # the indicator's norm on flattened fields
        self.xs: list[FloatArray] = []  # (n_cases, n) iterates
        self.rs: list[FloatArray] = []  # (n_cases, n) residuals G(x) − x

    def subset(self, cases: IntArray) -> None:
        """Keep the histories of ``cases`` only (the others left the batch)."""
        self.xs = [x[cases] for x in self.xs]
        self.rs = [r[cases] for r in self.rs]

    def __call__(self, w: FloatArray, f: FloatArray, w_new: FloatArray,
                 f_new: FloatArray) -> tuple[FloatArray, FloatArray]:
        n_cases = w.shape[0]
        if self.scale is None:
            self.scale = np.concatenate([np.broadcast_to(self.w_scale, w.shape[1:]).ravel(),
                                         np.broadcast_to(self.f_scale, f.shape[1:]).ravel()])
        x = np.concatenate([w.reshape(n_cases, -1), f.reshape(n_cases, -1)], axis=1)
        g = np.concatenate([w_new.reshape(n_cases, -1), f_new.reshape(n_cases, -1)], axis=1)
        r = g - x
        self.xs.append(x)
        self.rs.append(r)
        if len(self.xs) > self.depth + 1:
            self.xs.pop(0)
            self.rs.pop(0)
        x_mix, r_mix = x, r
        if len(self.xs) > 1:
            d_r = np.stack([b - a for a, b in zip(self.rs[:-1], self.rs[1:], strict=True)],
                           axis=1)  # (n_cases, m, n)
            d_x = np.stack([b - a for a, b in zip(self.xs[:-1], self.xs[1:], strict=True)],
                           axis=1)
            scaled = d_r * self.scale
            gram = scaled @ scaled.transpose(0, 2, 1)
            # least squares min ‖r − ΔRᵀ γ‖ per case, by its (lightly regularised) normal
            # equations: the histories are short (depth ≤ 10)
            trace = np.trace(gram, axis1=1, axis2=2)[:, None, None]
            gram = gram + 1e-12 * trace * np.eye(gram.shape[1]) + 1e-300
            gamma = np.linalg.solve(gram, scaled @ (r * self.scale)[:, :, None])[:, :, 0]
            x_mix = x - np.einsum("cm,cmn->cn", gamma, d_x)
            r_mix = r - np.einsum("cm,cmn->cn", gamma, d_r)
        out = x_mix + self.damping * r_mix
        half = out.shape[1] // 2
        return out[:, :half].reshape(w.shape), out[:, half:].reshape(f.shape)
