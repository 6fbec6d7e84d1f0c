"""Acceleration of the LATIN fixed point s ↦ linear(local(s)) (method.md §7)."""

from __future__ import annotations

import numpy as np

from .fem.elasticity import FloatArray


class Anderson:
    """Anderson mixing (type II) of the LATIN fixed point x ↦ G(x) = linear(local(x)),
    in the norm of the indicator; damped by ω. Affine combinations of admissible fields are
    admissible, so s stays in A_d."""

    def __init__(self, depth: int, damping: float, w_scale: FloatArray,
                 f_scale: FloatArray) -> None:
        self.depth = depth
        self.damping = damping
        self.scale = np.concatenate([w_scale.ravel(), f_scale.ravel()])
        self.scale_all_steps: FloatArray | None = None
        self.xs: list[FloatArray] = []
        self.rs: list[FloatArray] = []

    def __call__(self, w: FloatArray, f: FloatArray, w_new: FloatArray,
                 f_new: FloatArray) -> tuple[FloatArray, FloatArray]:
        shape = w.shape
        x = np.concatenate([w.reshape(shape[0], -1), f.reshape(shape[0], -1)], axis=1)
        g = np.concatenate([w_new.reshape(shape[0], -1), f_new.reshape(shape[0], -1)], axis=1)
        r = g - x
        self.xs.append(x)
        self.rs.append(r)
        if len(self.xs) > self.depth + 1:
            self.xs.pop(0)
            self.rs.pop(0)
        x_mix, r_mix = x, r
        if len(self.xs) > 1:
            d_r = np.stack([(b - a).ravel() for a, b in zip(self.rs[:-1], self.rs[1:],
                                                          strict=True)], axis=1)
            d_x = np.stack([(b - a).ravel() for a, b in zip(self.xs[:-1], self.xs[1:],
                                                          strict=True)], axis=1)
            if self.scale_all_steps is None:
                self.scale_all_steps = np.tile(self.scale, shape[0])
            scale = self.scale_all_steps
            gamma, *_ = np.linalg.lstsq(d_r * scale[:, None], r.ravel() * scale, rcond=1e-10)
            x_mix = x - (d_x @ gamma).reshape(x.shape)
            r_mix = r - (d_r @ gamma).reshape(r.shape)
        out = x_mix + self.damping * r_mix
        half = w.reshape(shape[0], -1).shape[1]
        return out[:, :half].reshape(shape), out[:, half:].reshape(shape)
