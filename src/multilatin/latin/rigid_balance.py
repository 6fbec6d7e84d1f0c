"""A nonlinear balance of every body's free rigid motions after the local stage (issue 15,
session 36).

The tail of B1's cold solves, and what a warm start keeps of its neighbour's error, is a
body's *rigid slide* (docs/convergence.md, session 27): where the local stage fixes the
forces on a body's sides (a slipping contact's tangent, an open stop), only the search
direction's k holds it, so the linear stage moves it by a fraction of what remains each
iteration (0.87 per iteration on B1), or by the same amount each iteration toward a stop
(a crawl). Here, after every local stage, the rigid motions that a *cluster* (substructures
tied by perfect or macro-only interfaces: a body) is free to make — those its prescribed
displacements leave free: none on a clamped body, u_y alone on B1's top block, pressed
against a smooth wall — are solved for so that ŝ is in equilibrium on them, load step by
load step:

    r_j(τ) = Σ_p w_p F̂_p(W + Σ_i τ_i φ_i, F) · φ_j(p) = 0

(φ: the cluster's rigid modes on its interface points, w: M0's weights, F̂ from the local
stage of the moved state). One Newton step on a Jacobian measured by finite differences
(one local stage per mode, of the cases that need it: joining, every ``REFRESH``
iterations, after a step that lowered nothing), then, along a mode nothing resists (its
Jacobian's diagonal near zero: a free slide, r constant in τ), steps doubling until r
changes sign or halves and one secant step inside that bracket; the step halved up to
twice. A case whose residual falls moves: W ← W + Σ τ_i φ_i with F kept (a rigid motion of
a free cluster changes no stress and no macro balance, so s stays admissible), then its
local stage again — the affine step and local stage of the sliding jumps
(``latin.sliding``). η is read before the move, on the linear stage's own s, so a case
that stops is converged as before; at the fixed point
r(0) = Σ_p w_p F_p · φ_j = 0 (F is admissible), so the converged answer is unchanged.

Measured (docs/convergence.md, session 36): under the studies' QoI rule cold b1 57 / 74 /
52 / 62 → 35 / 49 / 38 / 54 iterations, the B1 13 × 13 study 4 395 → 3 295, the B1 μ2 line
521 → 351; but a move is a local stage, which costs on B1 what a linear stage does, so an
iteration costs 1.4–2.4 times as much and the studies take longer: off by default
(``LatinOptions.rigid_balance``). The remaining tail (0.87–0.91 per iteration) is not a
rigid slide.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..decomposition.rigid_clusters import clusters, rigid_rows
from ..errors import ModelError
from ..fem.elasticity import FloatArray, IntArray
from .engine import NumpyFields
from .operators import LatinOperators

__all__ = ["DAMPING", "FLAT", "FREE", "FREE_START", "MAX_DOUBLINGS", "PROBE",
           "REFRESH", "REST", "STEADY_CALLS", "STEADY_RATIO", "RigidBalance", "RigidClusters",
           "free_rigid_modes"]

#: the finite-difference step, as a fraction of the case's largest interface displacement
PROBE = 1e-4
#: the most doublings of a free slide's step
MAX_DOUBLINGS = 24
#: a mode's residual is flat (nothing resists the motion) where a step changes it by less
#: than this fraction of its size
FLAT = 0.05
#: a free slide's first step, as a fraction of the case's largest interface displacement
#: (from ``PROBE``: the B1 study 3 497 iterations; from 1e-2: 3 295, fewer doublings)
FREE_START = 1e-2
#: a mode is free (a slide: the local stage fixes every force along it) where its
#: Jacobian's diagonal is below this fraction of the case's largest
FREE = 1e-3
#: a case's Jacobian is measured again after this many iterations
REFRESH = 10
#: calls a case skips after a step on a freshly measured Jacobian lowered nothing
REST = 5
#: a case whose last ``STEADY_CALLS`` moves were all of like size (the smallest at least
#: ``STEADY_RATIO`` times the largest) is no longer balanced: where the solution is not
#: unique (a block held by a stop and friction at once, ``decomposition.uniqueness``) the
#: moves and the linear stage feed each other a steady drift along the solutions
STEADY_CALLS = 6
STEADY_RATIO = 0.8
#: the Newton step's fractions tried, each a local stage of the cases still pending
DAMPING = (1.0, 0.5, 0.25)


class RigidClusters:
    """Clusters of substructures tied by perfect or macro-only interfaces, and the rigid
    modes each is free to make, on its interface points (module docstring)."""

    def __init__(self, ops: LatinOperators) -> None:
        pts = ops.points
        held = np.zeros((pts.n_points, 2), dtype=bool)
        held[pts.boundary] = pts.boundary_is_displacement
        #: per cluster with a free rigid mode: (its points, its modes (m, n, 2))
        self.clusters: list[tuple[IntArray, FloatArray]] = []
        for group in clusters(ops.assembly):
            points = np.flatnonzero(np.isin(pts.substructure, group))
            if points.size == 0:
                continue
            modes = free_rigid_modes(pts.coords[points], held[points])
            if modes.shape[0]:
                self.clusters.append((points, modes))
        self.n_modes = sum(m.shape[0] for _, m in self.clusters)
        self.n_points = pts.n_points
        #: every mode on every interface point, (M, 2 n_points), and the same times M0's
        #: weights (the residual's rows)
        self.modes = np.zeros((self.n_modes, 2 * pts.n_points))
        j = 0
        for points, modes in self.clusters:
            m = modes.shape[0]
            full = np.zeros((m, pts.n_points, 2))
            full[:, points] = modes
            self.modes[j:j + m] = full.reshape(m, -1)
            j += m
        self.weighted = self.modes * np.repeat(pts.weights, 2)[None, :]

    def residual(self, f_hat: FloatArray) -> FloatArray:
        """r (n_cases, n_steps, n_modes): Σ_p w_p F̂_p · φ_j(p) per mode j."""
        out: FloatArray = f_hat.reshape(*f_hat.shape[:2], -1) @ self.weighted.T
        return out

    def motion(self, tau: FloatArray) -> FloatArray:
        """Σ_i τ_i φ_i on every interface point: (n_cases, n_steps, n_points, 2)."""
        return (tau @ self.modes).reshape(*tau.shape[:2], self.n_points, 2)


def free_rigid_modes(coords: FloatArray, held: np.ndarray) -> FloatArray:
    """The rigid motions (translations, the rotation about the points' centre, scaled by
    their extent) that vanish on every held component (``held``: (n, 2)); (m, n, 2), an
    orthonormal combination of the three."""
    centre = coords.mean(axis=0)
    size = max(float(np.ptp(coords, axis=0).max()), 1e-300)
    rigid = rigid_rows(coords, centre, size).transpose(2, 0, 1)  # (3, n, 2)
    constraints = rigid[:, held].T  # (n_held, 3): each mode's value where held
    if constraints.size == 0:
        return rigid
    _, singular, vt = np.linalg.svd(constraints, full_matrices=True)
    rank = int((singular > 1e-9 * max(float(singular.max()), 1.0)).sum())
    free: FloatArray = np.einsum("ij,jpk->ipk", vt[rank:], rigid)
    return free


class RigidBalance:
    """After the local stage, each active case's free clusters moved rigidly so that ŝ is
    in equilibrium on their rigid modes (module docstring). The Jacobian of a case's
    residual is measured by finite differences (one local stage per mode, of the cases
    that need it) when the case has none, every ``REFRESH`` iterations, and after a step
    that lowered nothing; a move then costs a local stage of the cases moved (twice more
    where the step is halved). ``moves``: case moves in all; ``trials``: local stages it
    ran."""

    def __init__(self, ops: LatinOperators) -> None:
        if any(sub.material.radial for sub in ops.assembly.substructures):
            raise ModelError("rigid_balance: its rigid modes are the plane's (two "
                             "translations, a rotation), not an axisymmetric part's")
        self.clusters = RigidClusters(ops)
        self.moves = 0
        self.trials = 0
        #: per case (its number in the batch): its Jacobian and the Jacobian's
        #: pseudo-inverse, each (n_steps, M, M), and their age
        self.jacobians: dict[int, tuple[FloatArray, FloatArray, int]] = {}
        #: per case: calls left without a free-slide search (after one that failed)
        self.quiet: dict[int, int] = {}
        #: per case: calls left without any balance (after a fresh Jacobian's step failed)
        self.rest: dict[int, int] = {}
        #: per case: the amplitudes of its last moves (``STEADY_CALLS``)
        self.sizes: dict[int, list[float]] = {}

    def renumber(self, kept: IntArray) -> None:
        """Cases ``kept`` become cases 0 … n − 1; the others are let go."""
        number = {int(c): i for i, c in enumerate(kept)}
        for name in ("jacobians", "quiet", "rest", "sizes"):
            table = getattr(self, name)
            setattr(self, name, {number[c]: v for c, v in table.items() if c in number})

    def forget(self, case: int) -> None:
        self.jacobians.pop(case, None)
        self.quiet.pop(case, None)
        self.rest.pop(case, None)
        self.sizes.pop(case, None)

    def __call__(self, engine: NumpyFields, cases: IntArray) -> IntArray:
        """Move the active cases (``cases``: their numbers, in the engine's order) whose
        residual falls; returns their positions. Trials run the local stage of the cases
        they concern alone."""
        clusters = self.clusters
        if clusters.n_modes == 0:
            return np.zeros(0, dtype=np.int64)
        for c in cases.tolist():
            self.rest[c] = max(self.rest.get(c, 0) - 1, 0)
        rows = np.flatnonzero([self.rest[int(c)] == 0 for c in cases])
        if rows.size == 0:
            return rows
        numbers = cases[rows]
        w, _, _, f_hat = engine.fields(rows)
        live = engine.live_steps()[rows][..., None]  # settled steps do not move
        r0 = np.where(live, clusters.residual(f_hat), 0.0)
        scale = PROBE * np.abs(w).reshape(w.shape[0], -1).max(axis=1) + 1e-300

        def evaluate(tau: FloatArray, which: IntArray) -> FloatArray:
            """r after moving the rows ``which`` (of ``rows``) by ``tau`` (theirs)."""
            self.trials += 1
            forces = engine.trial_forces(clusters.motion(tau), rows[which])
            return np.where(live[which], clusters.residual(forces), 0.0)

        stale = np.flatnonzero([int(c) not in self.jacobians
                                or self.jacobians[int(c)][2] >= REFRESH for c in numbers])
        if stale.size:
            measured = self._jacobian(evaluate, r0, scale, stale)
            inverse = np.linalg.pinv(measured, rcond=1e-8)
            for i, row in enumerate(stale.tolist()):
                self.jacobians[int(numbers[row])] = (measured[i], inverse[i], 0)
        jacobian = np.stack([self.jacobians[int(c)][0] for c in numbers])
        inverse = np.stack([self.jacobians[int(c)][1] for c in numbers])
        fresh = np.array([self.jacobians[int(c)][2] == 0 for c in numbers])
        for c in numbers.tolist():
            own, own_inverse, age = self.jacobians[c]
            self.jacobians[c] = (own, own_inverse, age + 1)
            self.quiet[c] = max(self.quiet.get(c, 0) - 1, 0)
        tau = -np.einsum("csij,csj->csi", inverse, r0)
        quiet = np.array([self.quiet[int(c)] > 0 for c in numbers])
        tau, searched = self._free_slides(evaluate, jacobian, tau, r0, scale, ~quiet)
        before = np.sqrt((r0 ** 2).sum(axis=(1, 2)))
        pending = before > 0.0
        kept = np.zeros_like(pending)
        size = np.zeros(rows.size)  # the largest amplitude each case moved by
        for attempt, damping in enumerate(DAMPING):
            which = np.flatnonzero(pending)
            if which.size == 0:
                break
            self.trials += 1
            trial = damping * tau[which]
            forces = engine.moved_forces(clusters.motion(trial), rows[which])
            after = np.sqrt((np.where(live[which], clusters.residual(forces), 0.0) ** 2
                             ).sum(axis=(1, 2)))
            now = after < before[which]
            if attempt == 0:
                for row in which[~now].tolist():
                    self.jacobians.pop(int(numbers[row]), None)  # measured again next time
            engine.take_back(rows[which[~now]])
            size[which[now]] = np.abs(trial[now]).max(axis=(1, 2), initial=0.0)
            kept[which[now]] = True
            pending[which[now]] = False
            if not pending.any():
                break
        for row in np.flatnonzero(searched & ~kept).tolist():
            self.quiet[int(numbers[row])] = REFRESH  # no slide search for a while
        for row in np.flatnonzero(fresh & ~kept).tolist():
            self.rest[int(numbers[row])] = REST  # a measured Jacobian did not help: rest
        for row, c in enumerate(numbers.tolist()):
            recent = self.sizes.setdefault(c, [])
            recent.append(float(size[row]))
            del recent[:-STEADY_CALLS]
            if (len(recent) == STEADY_CALLS and min(recent) > 0.0
                    and min(recent) >= STEADY_RATIO * max(recent)):
                self.rest[c] = np.iinfo(np.int64).max  # feeds a drift: off
        self.moves += int(kept.sum())
        moved: IntArray = rows[kept]
        return moved

    @staticmethod
    def _jacobian(evaluate: Any, r0: FloatArray, scale: FloatArray, which: IntArray
                  ) -> FloatArray:
        """∂r/∂τ of the rows ``which``, (n, n_steps, M, M), by forward differences."""
        n_modes = r0.shape[2]
        jacobian = np.empty((which.size,) + r0.shape[1:] + (n_modes,))
        for i in range(n_modes):
            probe = np.zeros((which.size,) + r0.shape[1:])
            probe[:, :, i] = scale[which, None]
            jacobian[..., i] = ((evaluate(probe, which) - r0[which])
                                / scale[which, None, None])
        return jacobian

    @staticmethod
    def _free_slides(evaluate: Any, jacobian: FloatArray, tau: FloatArray, r0: FloatArray,
                     scale: FloatArray, allowed: np.ndarray
                     ) -> tuple[FloatArray, np.ndarray]:
        """Per mode that nothing resists (its Jacobian's diagonal below ``FREE`` times the
        case's largest) and whose residual is not zero: steps along r doubling from
        ``FREE_START`` until r changes sign or halves (a stretch where r stays flat moves the
        start on only where r changed), then one secant step in that bracket; only for the
        rows ``allowed``. Returns τ with those modes' amplitudes set, and the rows
        searched."""
        diagonal = np.abs(np.einsum("csii->csi", jacobian))
        largest = diagonal.max(axis=(1, 2), initial=0.0)[:, None, None]
        free = ((diagonal <= FREE * largest) & (np.abs(r0) > 0.0)
                & allowed[:, None, None])
        for j in np.flatnonzero(free.any(axis=(0, 1))).tolist():
            which = np.flatnonzero(free[:, :, j].any(axis=1))
            open_ = free[which, :, j]
            start = r0[which, :, j]
            sign = np.sign(start)
            base = np.where(open_, 0.0, tau[which, :, j])
            tau[which, :, j] = base
            low, r_low = base.copy(), start.copy()
            high, r_high = low.copy(), r_low.copy()
            found = np.zeros_like(open_)
            step = FREE_START / PROBE * scale[which, None] * np.ones_like(start)
            for _ in range(MAX_DOUBLINGS):
                moving = open_ & ~found
                if not moving.any():
                    break
                trial = tau[which].copy()
                trial[:, :, j] = np.where(moving, low + sign * step, base)
                r = evaluate(trial, which)[:, :, j]
                crossed = moving & ((np.sign(r) != sign) | (np.abs(r) < 0.5 * np.abs(start)))
                high = np.where(crossed, trial[:, :, j], high)
                r_high = np.where(crossed, r, r_high)
                changed = moving & ~crossed & (np.abs(r - r_low) >= FLAT * np.abs(start))
                low = np.where(changed, trial[:, :, j], low)
                r_low = np.where(changed, r, r_low)
                found |= crossed
                step = step * 2.0
            span = np.where(found, r_high - r_low, 1.0)
            span = np.where(span == 0.0, 1.0, span)
            tau[which, :, j] = np.where(found, low - r_low * (high - low) / span, base)
        return tau, free.any(axis=(1, 2))
