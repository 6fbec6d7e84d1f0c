"""Restarted reduced-rank extrapolation (RRE) of the LATIN iterates (issue 15, item 3:
acceleration that pays for itself).

The tail of a LATIN solve is a few slow linear modes (forces at single nodes where an
interface ends, README "Why the tail is slow"): x_n ≈ x* + Σ c_j λ_j^n v_j with λ_j close
to 1. Every ``cycle`` iterations, with the last cycle + 1 iterates x_0 … x_K of a case
(s = (W, F) after relaxation) and their differences u_i = x_{i+1} − x_i, RRE takes

    γ = argmin ‖Σ γ_i u_i‖  subject to Σ γ_i = 1   (the indicator's norm),
    x ← Σ γ_i x_{i+1},

which removes up to K such modes at once, and restarts from there. For a linear map this is
restarted GMRES on the fixed point; here the map is only piecewise affine (contact
statuses), so a step is taken only where it promises a residual below ``SAFEGUARD`` times
the last difference (a crawl or a status change makes the least-squares problem useless:
then the history just restarts). The step is an affine combination of admissible fields (s
stays admissible) followed by a local stage; the fixed point does not move.

The least-squares problem is solved on a sketch: every iterate is also stored as a random
sign sketch (its scaled components, each with a fixed random sign, summed over ``SKETCH``
consecutive blocks: one pass), and the Gram matrix of the differences is formed from the
sketches — unbiased for every norm, so γ is that of the full norm to a small factor.
Its cost per iteration is a copy and a sketch of s, plus, per cycle, one combination of K
iterates: about three passes over the fields, against ~45 for Anderson mixing of depth 15
(whose step costs 2–3 relaxed iterations, docs/convergence.md); the full Gram matrix cost
about three iterations per cycle on b1-9.
"""

from __future__ import annotations

import numpy as np

from ..fem.elasticity import FloatArray, IntArray
from .field_engine import FieldEngine

__all__ = ["SAFEGUARD", "SKETCH", "ReducedRankExtrapolation"]

#: a step is taken when the extrapolated residual ‖Σ γ_i u_i‖ is below this fraction of the
#: last difference ‖u_{K−1}‖
SAFEGUARD = 0.5
#: blocks of the sign sketch of an iterate (≫ K²)
SKETCH = 1024


class ReducedRankExtrapolation:
    """Cycles of RRE over the active cases of a batch (module docstring); ``steps[c]``:
    extrapolations taken for case c."""

    def __init__(self, cycle: int, displacement_weight: FloatArray,
                 force_weight: FloatArray, n_cases: int) -> None:
        self.cycle = cycle
        self.w_scale = np.sqrt(displacement_weight)  # per flattened (point, component)
        self.f_scale = np.sqrt(force_weight)
        self.scale: FloatArray | None = None  # the indicator's norm on a flat (W, F)
        self.blocks: IntArray | None = None  # the sketch: where each block starts
        self.signed_scale: FloatArray | None = None  # ± the scale
        #: per case, its last iterates as rows of flat (W, F) and their sketches, and how
        #: many rows are filled
        self.history: dict[int, FloatArray] = {}
        self.sketches: dict[int, FloatArray] = {}
        self.filled: dict[int, int] = {}
        self.steps = np.zeros(n_cases, dtype=np.int64)

    def __call__(self, active: IntArray, engine: FieldEngine) -> list[int]:
        """Record s of every active case; extrapolate those whose cycle is complete.
        Returns the cases (batch indices) that took a step."""
        if not active.size:
            return []
        w, f = engine.fields()[:2]
        shape = w.shape[1:]
        if self.scale is None:
            repeats = int(np.prod(shape)) // self.w_scale.size
            self.scale = np.concatenate([np.tile(self.w_scale, repeats),
                                         np.tile(self.f_scale, repeats)])
            rng = np.random.default_rng(0)  # fixed: runs repeat to the iteration
            size = min(SKETCH, self.scale.size)
            self.blocks = np.linspace(0, self.scale.size, size, endpoint=False).astype(np.int64)
            self.signed_scale = self.scale * rng.choice([-1.0, 1.0], size=self.scale.size)
        assert self.blocks is not None and self.signed_scale is not None
        half = self.scale.size // 2
        positions: list[int] = []
        shifts: list[FloatArray] = []
        moved: list[int] = []
        for i, case in enumerate(active.tolist()):
            rows = self.history.get(case)
            if rows is None:
                rows = self.history[case] = np.empty((self.cycle + 1, self.scale.size))
                self.sketches[case] = np.empty((self.cycle + 1, self.blocks.size))
                self.filled[case] = 0
            sketches = self.sketches[case]
            n = self.filled[case]
            rows[n, :half] = w[i].ravel()
            rows[n, half:] = f[i].ravel()
            sketches[n] = np.add.reduceat(self.signed_scale * rows[n], self.blocks)
            n += 1
            self.filled[case] = n
            if n <= self.cycle:
                continue
            gamma = self._weights(sketches)
            if gamma is None:
                rows[0], sketches[0] = rows[-1], sketches[-1]
                self.filled[case] = 1
                continue
            new = gamma @ rows[1:]
            positions.append(i)
            shifts.append(new - rows[-1])
            rows[0], sketches[0] = new, gamma @ sketches[1:]
            self.filled[case] = 1
            self.steps[case] += 1
            moved.append(case)
        if positions:
            shift = np.stack(shifts)
            engine.shift(np.array(positions), list(shift[:, :half].reshape(-1, *shape)),
                         list(shift[:, half:].reshape(-1, *shape)))
            engine.local_stage()
        return moved

    def forget(self, case: int) -> None:
        """Restart the case's history (its fields were moved by another rule)."""
        self.filled[case] = 0

    @staticmethod
    def _weights(sketches: FloatArray) -> FloatArray | None:
        """γ of the RRE step from the iterates' sketches, or None (no promised gain)."""
        u = np.diff(sketches, axis=0)  # (K, SKETCH): the differences, sketched
        k = u.shape[0]
        gram = u @ u.T
        trace = float(np.trace(gram))
        if not np.isfinite(trace) or trace <= 0.0:
            return None
        try:
            y = np.linalg.solve(gram + 1e-14 * trace * np.eye(k), np.ones(k))
        except np.linalg.LinAlgError:
            return None
        if not np.isfinite(y).all() or y.sum() == 0.0:
            return None
        gamma: FloatArray = y / y.sum()
        # ‖U γ‖² = γᵀ G γ, against the last difference's ‖u_K‖² = G_KK
        if not float(gamma @ gram @ gamma) < SAFEGUARD**2 * float(gram[-1, -1]):
            return None
        return gamma
