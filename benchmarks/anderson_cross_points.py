"""Experiment (issue 15, docs/convergence.md): Anderson mixing on the cross-point components
only (points of one substructure shared by two interfaces, where the slow modes were found),
plain relaxation elsewhere, against relaxation and full Anderson — cold solves of b1, b1-9
and b3 at three friction pairs.

    python benchmarks/anderson_cross_points.py

Measured: worse than relaxation everywhere (the split update breaks the coupling); kept as
the record of a lead that failed.
"""

from __future__ import annotations

import numpy as np

import multilatin as ml
import multilatin.latin as L
from multilatin.latin import LatinOperators, LatinOptions, solve_latin
from multilatin.latin.acceleration import Anderson

MASK = np.zeros(0, dtype=bool)  # (points,) the cross points of the current model


class Partial(Anderson):
    """Anderson on the masked points' components, relaxation on the others."""

    def __call__(self, w: np.ndarray, f: np.ndarray, w_new: np.ndarray,
                 f_new: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        full_w = w + self.damping * (w_new - w)
        full_f = f + self.damping * (f_new - f)
        mask = MASK
        if not getattr(self, "_masked", False):
            self.w_scale, self.f_scale = self.w_scale[mask], self.f_scale[mask]
            self._masked = True

        def sub(a: np.ndarray) -> np.ndarray:
            return np.ascontiguousarray(a[:, :, mask])

        full_w[:, :, mask], full_f[:, :, mask] = Anderson.__call__(
            self, sub(w), sub(f), sub(w_new), sub(f_new))
        return full_w, full_f


def cross_points(pts: ml.latin.InterfacePoints) -> np.ndarray:
    groups: dict[tuple[int, float, float], list[int]] = {}
    for p in range(pts.n_points):
        key = (int(pts.substructure[p]), round(float(pts.coords[p, 0]), 9),
               round(float(pts.coords[p, 1]), 9))
        groups.setdefault(key, []).append(p)
    mask = np.zeros(pts.n_points, dtype=bool)
    for members in groups.values():
        if len(members) > 1:
            mask[members] = True
    return mask


ml.load_model("b1").solve({"mu1": 0.3, "mu2": 0.0})
for name in ("b1", "b1-9", "b3"):
    m = ml.load_model(name)
    for mu in ((0.3, 0.0), (0.1, 0.3), (0.35, 0.25)):
        a = m.assemble({"mu1": mu[0], "mu2": mu[1]})
        MASK = cross_points(LatinOperators(a, LatinOptions()).points)
        out = []
        anderson = LatinOptions(acceleration="anderson", anderson_depth=15)
        for label, opts, cls in (
                ("relaxation", LatinOptions(), Anderson),
                ("anderson 15", anderson, Anderson),
                ("cross-point anderson 15", anderson, Partial),
                ("cross-point anderson 30",
                 LatinOptions(acceleration="anderson", anderson_depth=30), Partial)):
            L.Anderson = cls  # type: ignore[misc]
            r = solve_latin(a, opts, operators=LatinOperators(a, opts), check=False)
            out.append(f"{label}: {r.iterations}{'' if r.converged else ' (not converged)'} "
                       f"it, {1e3 * r.timings['per_iteration']:.2f} ms/it, "
                       f"R_stop {r.qoi['R_stop']:.3f}")
        L.Anderson = Anderson  # type: ignore[misc]
        print(name, mu, f"cross points {MASK.sum()} of {MASK.size}:", " | ".join(out),
              flush=True)
