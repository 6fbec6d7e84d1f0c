"""The local stage of LATIN: interface behaviours in closed form, point by point (paper §3,
§4.2; method.md §4). The search direction E+ is (F̂ − F) − k (Ŵ − W) = 0.
"""

from __future__ import annotations

import copy
import functools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla

from ..decomposition.assembly import Assembly
from ..decomposition.interfaces import InterfacePoints, boundary_data, interface_functions
from ..errors import ModelError
from ..fem.elasticity import FloatArray, IntArray
from . import kernels
from .branch_tape import BranchTape
from .cross_points import corrected, local_groups, merged
from .held_stops import attached, hold_stops, moving_corners, open_arrivals

__all__ = ["BranchTape", "LocalStage", "MacroOnlyMap", "macro_only_map"]


#: the local stage's arrays that hold one entry per case
_PER_CASE = ("mu_contact", "gap_contact", "mu_stop", "gap_stop", "prescribed", "corner_moving")


class LocalStage:
    """Closed-form interface behaviours, vectorised over every point of every case of a batch
    (paper §3, §4.2). Fields have shape ``(n_cases, n_steps, n_points, 2)``.

    The cases share the geometry and the search direction; each has its own friction
    coefficients, gaps and prescribed data. Perfect and prescribed interfaces act on all
    steps at once; contact and stops go through the steps in order, since Coulomb's law acts
    on increments (method.md §4).
    """

    def __init__(self, assemblies: Sequence[Assembly], points: Sequence[InterfacePoints],
                 k: FloatArray, compiled: bool | None = None,
                 macro_only: MacroOnlyMap | None = None, body: FloatArray | None = None
                 ) -> None:
        """compiled: the Numba kernels (``kernels``); None: when Numba is installed.
        macro_only: ``macro_only_map(points[0], k)`` when already built. body: per case,
        what body forces add to the linear stage's W (``body_forces.stacked_offsets``),
        carried here with the other per-case data; None: no body forces."""
        first = points[0]
        for other in points[1:]:
            if other.n_points != first.n_points or not np.array_equal(other.pairs, first.pairs):
                raise ModelError("a batch of cases must share the interface discretisation")
        self.pairs = first.pairs
        self.macro_map = macro_only if macro_only is not None else macro_only_map(first, k)
        self.macro_points = self.macro_map.points
        self.macro_columns = self.macro_map.columns
        self.k_macro = k[self.macro_points]
        self.k_pair = k[first.pairs[0]]
        self.k_pair_b = k[first.pairs[1]]
        self.boundary = first.boundary
        self.k_boundary = k[first.boundary]
        self.is_displacement = first.boundary_is_displacement
        self.contact_pairs = first.contact_pairs
        a = first.contact_pairs[0]
        self.k_contact = k[a]  # diagonal in the interface's (axis-aligned) frame
        self.k_contact_b = k[first.contact_pairs[1]]
        self.n_contact = first.normals[a]
        self.stops = first.stops
        self.k_stop = k[first.stops]
        self.n_stop = first.normals[first.stops]
        self.corner = first.corner
        self.corner_stops = first.corner_stops
        self.corner_of_pair = np.full(a.size, -1, dtype=np.int64)
        self.corner_of_pair[first.corner] = np.arange(first.corner.size)
        self.pair_held_side = first.pair_held_side
        self.pair_held_boundary = first.pair_held_boundary
        self.held_side = first.held_side
        self.held_boundary = first.held_boundary
        self.held_stop = first.held_stop
        self.stop_held_boundary = first.stop_held_boundary
        self.stop_held_stop = first.stop_held_stop
        self.held_stops = np.flatnonzero((first.stop_held_boundary >= 0)
                                         | (first.stop_held_stop >= 0))
        if compiled and kernels.contact_and_stops is None:
            raise ModelError("compiled local stage: Numba is not installed "
                             "(pip install 'multilatin[fast]')")
        self.compiled = (kernels.contact_and_stops is not None if compiled is None
                         else compiled)
        self.tape: BranchTape | None = None  # record / replay the branches (NumPy path)
        # per case: (n_cases, n) friction and gaps, (n_cases, n_steps, P_b, 2) W_d / F_d
        self.mu_contact = np.stack([p.contact_friction for p in points])
        self.gap_contact = np.stack([p.contact_gap for p in points])
        self.mu_stop = np.stack([p.stop_friction for p in points])
        self.gap_stop = np.stack([p.stop_gap for p in points])
        self.prescribed = np.stack([boundary_data(assembly, p)
                                    for assembly, p in zip(assemblies, points, strict=True)])
        self.corner_moving = moving_corners(self.prescribed, first.corner_boundaries,
                                            self.n_contact[first.corner])
        # the contact pairs and the stop points of a cross point, run as one
        # (``cross_points``)
        self.groups = local_groups(first, k, (self.mu_contact, self.gap_contact),
                                   (self.mu_stop, self.gap_stop))
        self.body = body

    @property
    def n_cases(self) -> int:
        return int(self.prescribed.shape[0])

    def subset(self, cases: IntArray) -> LocalStage:
        """The same local stage restricted to ``cases`` (cases leave a batch)."""
        out = copy.copy(self)
        for name in _PER_CASE:
            setattr(out, name, getattr(self, name)[cases])
        out.body = self.body[cases] if self.body is not None else None
        return out

    def joined(self, other: LocalStage) -> LocalStage:
        """This local stage's cases followed by ``other``'s (cases joining a running batch;
        the same interface discretisation)."""
        if not np.array_equal(other.pairs, self.pairs):
            raise ModelError("a batch of cases must share the interface discretisation")
        out = copy.copy(self)
        for name in _PER_CASE:
            setattr(out, name, np.concatenate([getattr(self, name), getattr(other, name)]))
        bodies = [(x.body, x.n_cases) for x in (self, other)]
        shape = next((b.shape[1:] for b, _ in bodies if b is not None), None)
        if shape is not None:  # zeros for the cases without body forces
            out.body = np.concatenate([b if b is not None else np.zeros((n, *shape))
                                       for b, n in bodies])
        out.groups = self.groups.common(other.groups)  # the groups of both
        return out

    def prescribed_force_field(self, n_points: int) -> FloatArray:
        """F_d at every interface point (zero where no force is prescribed), per case."""
        field = np.zeros((*self.prescribed.shape[:2], n_points, 2))
        field[:, :, self.boundary] = self.prescribed_forces()
        return field

    def prescribed_forces(self) -> FloatArray:
        """F_d at the boundary points (``boundary``; zero where a displacement is
        prescribed), per case: (n_cases, n_steps, n_boundary, 2)."""
        out: FloatArray = np.where(self.is_displacement, 0.0, self.prescribed)
        return out

    def __call__(self, displacement: FloatArray, force: FloatArray) -> tuple[FloatArray,
                                                                               FloatArray]:
        w_hat, f_hat = self.without_contact(displacement, force)
        self.contact_stage(displacement, force, w_hat, f_hat)
        return w_hat, f_hat

    def without_contact(self, displacement: FloatArray, force: FloatArray,
                        first: IntArray | None = None) -> tuple[FloatArray, FloatArray]:
        """ŝ on perfect, prescribed and macro-only interfaces (the rest of the arrays
        uninitialised: ``contact_stage`` fills them); first: as ``contact_stage``'s."""
        w_hat = np.empty(displacement.shape)  # C order: the flat views below are views
        f_hat = np.empty(force.shape)
        if self.tape is not None:
            self.tape.position = 0
        if self.fused:
            displacement = np.ascontiguousarray(displacement)
            force = np.ascontiguousarray(force)
            assert kernels.perfect_and_boundary is not None
            kernels.perfect_and_boundary(
                displacement, force, w_hat, f_hat, self.pairs[0], self.pairs[1], self.k_pair,
                self.k_pair_b, self.boundary, self.k_boundary, self.is_displacement,
                self.prescribed, self.pair_held_side, self.pair_held_boundary,
                np.zeros(len(w_hat), np.int64) if first is None else first)
        else:
            self._perfect_and_boundary(displacement, force, w_hat, f_hat)
        if self.macro_points.size:  # macro-only interface (eq. [20]), see ``macro_only_map``
            # on (case × step, point × component) rows: gathers of whole columns
            rows = int(np.prod(displacement.shape[:2]))
            columns, k = self.macro_columns, self.k_macro.ravel()
            w_m = np.take(displacement.reshape(rows, -1), columns, axis=1)
            f_m = np.take(force.reshape(rows, -1), columns, axis=1)
            x = w_m - f_m / k
            w_new = x + self.macro_map.apply(x)
            w_hat.reshape(rows, -1)[:, columns] = w_new
            f_hat.reshape(rows, -1)[:, columns] = f_m + k * (w_new - w_m)
        return w_hat, f_hat

    @property
    def fused(self) -> bool:
        """The compiled kernels run (``compiled``, no branch tape)."""
        return self.compiled and self.tape is None

    def contact_data(self) -> tuple[Any, ...]:
        """The contact and stop arguments of the compiled kernels, after the fields."""
        return (self.contact_pairs[0], self.contact_pairs[1], self.k_contact, self.k_contact_b,
                self.n_contact, self.mu_contact, self.gap_contact, self.stops, self.k_stop,
                self.n_stop, self.mu_stop, self.gap_stop, self.corner_of_pair,
                self.corner_stops, self.held_side, self.held_boundary, self.held_stop,
                self.stop_held_boundary, self.stop_held_stop, self.prescribed,
                self.corner_moving, self.groups.pairs, self.groups.pair_share, self.groups.stops,
                self.groups.stop_share)

    def contact_stage(self, displacement: FloatArray, force: FloatArray, w_hat: FloatArray,
                      f_hat: FloatArray, first: IntArray | None = None) -> None:
        """The contact interfaces' and stops' part of the local stage, in place (after the
        rest: held nodes read the boundary's Ŵ, F̂); the two-scale direction's inner
        iteration repeats it alone (``two_scale.coupled_local_stage``). first: per case
        its first step computed (compiled; the earlier ones' ŝ in place, ``engine``)."""
        if not (self.contact_pairs[0].size or self.stops.size):
            return
        if self.fused:
            assert kernels.contact_and_stops is not None
            kernels.contact_and_stops(
                np.ascontiguousarray(displacement), np.ascontiguousarray(force), w_hat, f_hat,
                *self.contact_data(), np.zeros(len(w_hat), np.int64) if first is None else first)
        elif self.groups.sides:  # merged around the stage here (the kernel merges inside)
            fields = merged(displacement, force, self.groups.sides)
            self._contact_and_stops(*fields, w_hat, f_hat)
            corrected(w_hat, displacement, force, fields, self.groups.sides)
        else:
            self._contact_and_stops(displacement, force, w_hat, f_hat)

    def _perfect_and_boundary(self, displacement: FloatArray, force: FloatArray,
                              w_hat: FloatArray, f_hat: FloatArray) -> None:
        a, b = self.pairs
        k, kb = self.k_pair, self.k_pair_b
        wa, wb = displacement[:, :, a], displacement[:, :, b]
        fa, fb = force[:, :, a], force[:, :, b]
        # perfect interface: Ŵ_E = Ŵ_E', F̂_E + F̂_E' = 0 on the search directions E+ of
        # both sides (eq. [8]): Ŵ = (k_a W_a + k_b W_b − F_a − F_b) / (k_a + k_b)
        equal = k == kb
        w_hat[:, :, a] = w_hat[:, :, b] = np.where(
            equal, 0.5 * (wa + wb) - (fa + fb) / (2.0 * k),
            (k * wa + kb * wb - fa - fb) / (k + kb))
        f_hat[:, :, a] = np.where(equal, 0.5 * (fa - fb) - 0.5 * k * (wa - wb),
                                  fa + k * (w_hat[:, :, a] - wa))
        f_hat[:, :, b] = -f_hat[:, :, a]
        # a node held on one side by a prescribed displacement: Ŵ = W_d, and the pair's
        # force from the free side's E+ (``held_nodes.held_perfect_pairs``)
        j, d = np.nonzero(self.pair_held_side >= 0)
        if j.size:
            data = self.prescribed[:, :, self.pair_held_boundary[j, d], d]
            on_b = self.pair_held_side[j, d] == 1
            w_hat[:, :, a[j], d] = w_hat[:, :, b[j], d] = data
            f_hat[:, :, a[j], d] = np.where(
                on_b, fa[:, :, j, d] + k[j, d] * (data - wa[:, :, j, d]),
                -(fb[:, :, j, d] + kb[j, d] * (data - wb[:, :, j, d])))
            f_hat[:, :, b[j], d] = -f_hat[:, :, a[j], d]
        # prescribed displacement / force, component-wise
        bd, k = self.boundary, self.k_boundary
        w, f, data = displacement[:, :, bd], force[:, :, bd], self.prescribed
        w_hat[:, :, bd] = np.where(self.is_displacement, data, w + (data - f) / k)
        f_hat[:, :, bd] = np.where(self.is_displacement, f + k * (data - w), data)

    def openings(self, case: int, displacement: FloatArray) -> FloatArray:
        """The normal openings (> 0: open) of every stop point and contact pair at every
        step of case ``case``, flat, from its displacements ``(n_steps, n_points, 2)``: the
        closings the contact local stage starts each step from."""
        parts = [np.zeros(0)]
        if self.stops.size:
            parts.append((self.gap_stop[case] - np.sum(
                self.n_stop * displacement[:, self.stops], axis=-1)).ravel())
        a, b = self.contact_pairs
        if a.size:
            parts.append((self.gap_contact[case] + np.sum(
                self.n_contact * (displacement[:, b] - displacement[:, a]), axis=-1)).ravel())
        return np.concatenate(parts)

    @functools.cached_property
    def held_pairs(self) -> IntArray:
        """Contact pairs held tangentially on one side (``held_nodes.held_corners``)."""
        return np.flatnonzero(self.held_side >= 0)

    @functools.cached_property
    def held_component(self) -> IntArray:
        """Their tangential component (0: x, 1: y)."""
        normal = self.n_contact[self.held_pairs]
        return np.where(np.abs(normal[:, 1]) > np.abs(normal[:, 0]), 0, 1)

    def _held_targets(self, t: int, stop_displacement: FloatArray,
                      stop_closed: npt.NDArray[np.bool_]
                      ) -> tuple[npt.NDArray[np.bool_], FloatArray]:
        """Per case and held pair, in step ``t``: whether its holder holds (a prescribed
        displacement always, a stop when closed) and the held node's tangential Ŵ."""
        h, d = self.held_pairs, self.held_component
        n_cases = self.prescribed.shape[0]
        if not h.size:
            return np.zeros((n_cases, 0), dtype=bool), np.zeros((n_cases, 0))
        by_boundary = self.held_boundary[h] >= 0
        stop = np.maximum(self.held_stop[h], 0)
        boundary = np.maximum(self.held_boundary[h], 0)
        target = np.where(by_boundary, self.prescribed[:, t, boundary, d],
                          stop_displacement[:, stop, d] if stop_displacement.shape[1]
                          else 0.0)
        holding = by_boundary | (stop_closed[:, stop] if stop_closed.shape[1] else False)
        return np.broadcast_to(holding, target.shape), target

    def _coulomb(self, trial: FloatArray, normal_force: FloatArray, normal: FloatArray,
                 friction: FloatArray) -> FloatArray:
        """F̂ on side E from the trial force: contact where N ≤ 0, then stick or slip."""
        contact_force = self._in_cone(trial, normal_force, normal, friction)
        contact = self._branch(normal_force <= 0.0)
        return np.where(contact[..., None], contact_force, 0.0)

    def _in_cone(self, tangential_source: FloatArray, normal_force: FloatArray,
                 normal: FloatArray, friction: FloatArray) -> FloatArray:
        """N n plus the tangential part of ``tangential_source``, limited to μ |N|."""
        tangential = (tangential_source
                      - np.sum(tangential_source * normal, axis=-1)[..., None] * normal)
        size = np.sqrt(np.sum(tangential**2, axis=-1))
        negative = self._branch(normal_force < 0.0)
        limit = friction * np.where(negative, -normal_force, normal_force)  # μ |N|
        slip = self._branch(size > limit)
        direction = self._branch(tangential / np.maximum(size, 1e-300)[..., None])
        limited = np.where(slip[..., None], limit[..., None] * direction, tangential)
        force: FloatArray = normal_force[..., None] * normal + limited
        return force

    def _branch(self, value: npt.NDArray[Any]) -> npt.NDArray[Any]:
        """A branch of the piecewise-affine local stage: recorded on ``tape`` while it
        records, read back from it while it replays (``BranchTape``), else ``value``."""
        tape = self.tape
        if tape is None:
            return value
        return tape.decide(value)

    def _contact_and_stops(self, displacement: FloatArray, force: FloatArray,
                           w_hat: FloatArray, f_hat: FloatArray) -> None:
        """Unilateral contact with gap and Coulomb friction between two substructures
        (paper §3, eq. [16]–[17]; n outward from E, [x] = x_E' − x_E) and against rigid
        stops, step after step: Coulomb's law acts on increments of the local history Ŵ.

        At a *held corner* (a contact pair whose tangential motion is fixed on both sides,
        by a prescribed displacement or a stop closed at the previous step already, its
        node on it, ``held_stops.ATTACHED``) the friction force is statically
        indeterminate; it keeps its previous value, limited to the cone — the limit of any
        tangential compliance, and what incremental penalty codes compute —, except where
        its prescribed holders moved since the last step, against each other or one against
        a closed stop (``corner_moving``): the pair slides, by Coulomb's law. Where it is
        not held, its stop opens while the pair sticks short of it (``open_arrivals``).
        """
        n_cases = displacement.shape[0]
        a, b = self.contact_pairs
        k, kb, n = self.k_contact, self.k_contact_b, self.n_contact
        # series stiffness k* = k_a k_b / (k_a + k_b), k / 2 when both sides are equal; its
        # normal part n·k*·n (exact for any normal when k is isotropic, the default)
        equal = k == kb
        half = np.where(equal, 0.5 * k, k * kb / (k + kb))
        half_normal = np.sum(n * n * half, axis=1)
        prev_a = np.zeros((n_cases, a.size, 2))
        prev_b = np.zeros((n_cases, a.size, 2))
        p = self.stops
        k_stop, n_stop = self.k_stop, self.n_stop
        k_stop_normal = np.sum(n_stop * n_stop * k_stop, axis=1)
        prev_stop = np.zeros((n_cases, p.size, 2))
        corner, corner_stops = self.corner, self.corner_stops
        previous_corner_force = np.zeros((n_cases, corner.size, 2))
        stop_closed = np.zeros((n_cases, p.size), dtype=bool)
        stop_holds = stop_closed
        carried = stop_closed  # closed at the step before, after ``open_arrivals``
        for t in range(displacement.shape[1]):
            if p.size:
                dw = displacement[:, t, p] - prev_stop
                trial = force[:, t, p] - k_stop * dw
                closing = self.gap_stop - np.sum(n_stop * prev_stop, axis=-1)
                normal_force = np.sum(n_stop * trial, axis=-1) + k_stop_normal * closing
                fp = self._coulomb(trial, normal_force, n_stop, self.mu_stop)
                stop_closed = self._branch(normal_force < 0.0)
                # a corner's stop holds where its node was on it already
                stop_holds = self._branch(stop_closed & attached(
                    closing, self.gap_stop, np.sum(n_stop * displacement[:, t, p], axis=-1),
                    np.sum(n_stop * force[:, t, p], axis=-1), k_stop_normal))
                prev_stop = prev_stop + dw + (fp - force[:, t, p]) / k_stop
                f_hat[:, t, p] = fp
                w_hat[:, t, p] = prev_stop
                if self.held_stops.size:
                    hold_stops(self, t, prev_stop, stop_closed, f_hat, w_hat, stop_holds)
            if not a.size:
                continue
            dwa = displacement[:, t, a] - prev_a  # increments from the local-stage history
            dwb = displacement[:, t, b] - prev_b
            # trial force F* = k* (F_a / k_a − F_b / k_b + [ΔW])
            trial = np.where(equal, 0.5 * (force[:, t, a] - force[:, t, b]) + half * (dwb - dwa),
                             half * (force[:, t, a] / k - force[:, t, b] / kb + dwb - dwa))
            closing = self.gap_contact + np.sum(n * (prev_b - prev_a), axis=-1)
            normal_force = np.sum(n * trial, axis=-1) + half_normal * closing
            holding, target = self._held_targets(t, prev_stop, stop_closed)
            if holding.any():  # held on one side: tangential trial from the free side
                h, d = self.held_pairs, self.held_component
                on_b = self.held_side[h] == 1
                pa_h, pb_h = a[h], b[h]
                free_b = force[:, t, pa_h, d] + k[h, d] * (
                    prev_a[:, h, d] + target - prev_b[:, h, d] - displacement[:, t, pa_h, d])
                free_a = -(force[:, t, pb_h, d] + kb[h, d] * (
                    prev_b[:, h, d] + target - prev_a[:, h, d] - displacement[:, t, pb_h, d]))
                trial[:, h, d] = np.where(holding, np.where(on_b, free_b, free_a),
                                          trial[:, h, d])
            fa = self._coulomb(trial, normal_force, n, self.mu_contact)
            if corner.size:
                holds = (stop_holds & carried)[:, np.maximum(corner_stops, 0)]
                held = np.all((corner_stops < 0) | holds, axis=-1)
                held &= ~self.corner_moving[:, t]
                current = fa[:, corner]
                frozen = self._in_cone(previous_corner_force,
                                       np.sum(current * n[corner], axis=-1), n[corner],
                                       self.mu_contact[:, corner])
                fa[:, corner] = np.where(held[..., None], frozen, current)
                previous_corner_force = fa[:, corner]
            prev_a = prev_a + dwa + (fa - force[:, t, a]) / k
            prev_b = prev_b + dwb + (-fa - force[:, t, b]) / kb
            if holding.any():  # the held side follows its holder
                h, d = self.held_pairs, self.held_component
                on_b = self.held_side[h] == 1
                prev_b[:, h, d] = np.where(holding & on_b, target, prev_b[:, h, d])
                prev_a[:, h, d] = np.where(holding & ~on_b, target, prev_a[:, h, d])
            f_hat[:, t, a], f_hat[:, t, b] = fa, -fa
            w_hat[:, t, a], w_hat[:, t, b] = prev_a, prev_b
            if corner.size and p.size:
                stop_closed = open_arrivals(self, t, trial, normal_force, held,
                                            (prev_a, prev_b), stop_closed, prev_stop,
                                            displacement, force, w_hat, f_hat)
            carried = stop_closed


@dataclass(frozen=True)
class MacroOnlyMap:
    """The local stage of the macro-only interfaces as Ŵ = X + Q X on the flattened
    (point, component) values of ``points`` (``macro_only_map``), Q = ``left`` @ ``right``
    of rank 2 × (macro functions) per interface side and component: applied as two thin
    products instead of one with Q."""

    points: IntArray  # (m,)
    left: FloatArray  # (2m, r)
    right: FloatArray  # (r, 2m)

    @property
    def columns(self) -> IntArray:
        """The flat (point, component) columns of the points, point-major."""
        return np.asarray((2 * self.points[:, None] + np.arange(2)).ravel(), dtype=np.int64)

    def apply(self, x: FloatArray) -> FloatArray:
        """Q X for rows X of shape (…, 2m)."""
        return np.asarray((x @ self.right.T) @ self.left.T)


def macro_only_map(points: InterfacePoints, k: FloatArray) -> MacroOnlyMap:
    """The local stage of macro-only perfect interfaces (paper eq. [20]) as a linear map.

    On each side s (points P_s, weights M_s, search direction k_s), with the interface's macro
    functions g_s (the same continuous functions on both sides, ``interface_functions``),
    find ŝ on E+ with zero micro forces, balanced macro forces Σ_s g_sᵀ M_s F̂_s = 0 and
    continuous macro displacements (Ŵ_s's M_s-projection on g_s is g_s a, the same a on both
    sides). With X_s = W_s − F_s / k_s and G_s = g_sᵀ M_s g_s, in closed form:

        a = (Σ_s k_s G_s)⁻¹ Σ_s k_s g_sᵀ M_s X_s,
        Ŵ_s = X_s + g_s (a − G_s⁻¹ g_sᵀ M_s X_s),   F̂_s = F_s + k_s (Ŵ_s − W_s),

    so that F̂_s = k_s g_s (a − G_s⁻¹ g_sᵀ M_s X_s) is macro only. Returns the points of
    every macro-only interface and Q with Ŵ = X + Q X on their flattened (point, component)
    values, factored: g_s on the left, (a − G_s⁻¹ g_sᵀ M_s X_s)'s map on the right.
    """
    left: list[tuple[IntArray, FloatArray]] = []  # (rows, g_s) per side and component
    right: list[tuple[IntArray, FloatArray]] = []  # (columns, map) of the same
    chosen: list[IntArray] = []
    offset = 0
    for i in points.macro_only:
        functions = interface_functions(points, i, 2)
        sides = [points.side_points[(i, s)] for s in range(2)]
        local = [offset + np.arange(sides[0].size),
                 offset + sides[0].size + np.arange(sides[1].size)]
        offset += sum(p.size for p in sides)
        chosen.extend(sides)
        columns = np.concatenate(local)
        for comp in range(2):
            weighted = [g.T * points.weights[p] for g, p in zip(functions, sides, strict=True)]
            gram = [wg @ g for wg, g in zip(weighted, functions, strict=True)]
            k_side = [float(k[p[0], comp]) for p in sides]
            total = sla.inv(sum(ks * gm for ks, gm in zip(k_side, gram, strict=True)))
            to_a = total @ np.hstack([ks * wg for ks, wg in zip(k_side, weighted, strict=True)])
            for side, start in enumerate((0, sides[0].size)):
                coefficients = to_a.copy()
                own = slice(start, start + sides[side].size)
                coefficients[:, own] -= sla.solve(gram[side], weighted[side])
                left.append((2 * local[side] + comp, functions[side]))
                right.append((2 * columns + comp, coefficients))
    rank = sum(g.shape[1] for _, g in left)
    out = MacroOnlyMap(np.concatenate(chosen).astype(np.int64) if chosen
                       else np.zeros(0, dtype=np.int64),
                       np.zeros((2 * offset, rank)), np.zeros((rank, 2 * offset)))
    at = 0
    for (rows, g), (columns, coefficients) in zip(left, right, strict=True):
        out.left[rows, at:at + g.shape[1]] = g
        out.right[at:at + g.shape[1], columns] = coefficients
        at += g.shape[1]
    return out
