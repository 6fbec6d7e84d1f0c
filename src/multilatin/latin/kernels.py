"""The LATIN iteration's point-wise work compiled with Numba (optional extra ``fast``): the
same formulas as the NumPy code of ``LocalStage`` and ``latin``, written point by point, so
that a batch's fields are read once per pass. Without Numba the NumPy versions run; the two
agree to rounding (tests).

- ``perfect_and_boundary``: perfect interfaces (eq. [8]) and prescribed displacement / force
  components, every step at once;
- ``contact_and_stops``: contact with gap and Coulomb friction, and rigid stops (paper §3,
  eq. [16]–[17]), for every case step after step (Coulomb's law acts on increments), the
  stops first, then the contact pairs with the held-corner rule;
- ``coupled_contact``: the contact part of the two-scale direction's coupled local stage
  (``two_scale.coupled_local_stage``: its inner Chebyshev passes, the projections on the
  sides' macro functions with them), case by case;
- ``two_scale_correction``: out += (H − D) x row by row (``two_scale.TwoScaleDirection``);
- ``direction_update``: out = base + H (a − b) in one pass (the linear stage's forces,
  ``LatinOperators.direction_update``);
- ``relax``: s ← ω s_new + (1 − ω) s in place; ``relax_rows`` the same on chosen rows;
- ``indicator_squares``: ‖s − ŝ‖², ‖s‖², ‖ŝ‖², ‖F‖², ‖F̂‖² per case (paper §4.3), ‖s − ŝ‖²
  and ‖F − F̂‖² per step.

The Python of ``indicator_squares`` is in ``indicator_kernel``, that of the two-scale
products (``two_scale_correction``, ``direction_update`` and their helpers) in
``two_scale_kernels``, the cross points' groups in ``cross_points``.
"""

from __future__ import annotations

import importlib
import logging
import math
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from ..fem.elasticity import FloatArray, IntArray
from . import two_scale_kernels as _two_scale
from .cross_points import merge_members as _merge_members
from .cross_points import split_members as _split_members
from .held_stops import attached, beyond_stop
from .indicator_kernel import indicator_squares as _indicator_squares
from .two_scale_kernels import coupling_shift as _coupling_shift
from .two_scale_kernels import project_columns as _project_columns

log = logging.getLogger(__name__)

#: compiled inline with the contact kernel (``_compile``); the CUDA kernels take its
#: ``py_func``
_attached = attached
_beyond_stop = beyond_stop


def _in_cone(source_x: float, source_y: float, normal_force: float, nx: float, ny: float,
             friction: float) -> tuple[float, float]:
    """N n plus the tangential part of the source, limited to μ |N|."""
    along = source_x * nx + source_y * ny
    tx, ty = source_x - along * nx, source_y - along * ny
    size = math.sqrt(tx * tx + ty * ty)  # math: also compiled for CUDA (``cuda_local``)
    limit = friction * abs(normal_force)
    scale = limit / max(size, 1e-300) if size > limit else 1.0
    return normal_force * nx + scale * tx, normal_force * ny + scale * ty


def _series_trial(force_a: float, force_b: float, k_a: float, k_b: float,
                  jump: float) -> tuple[float, float]:
    """One component of a contact pair: the series stiffness k* = k_a k_b / (k_a + k_b)
    (k / 2 when both sides are equal) and the trial force F* = k* (F_a / k_a − F_b / k_b +
    [ΔW])."""
    if k_a == k_b:
        half = 0.5 * k_a
        return half, 0.5 * (force_a - force_b) + half * jump
    half = k_a * k_b / (k_a + k_b)
    return half, half * (force_a / k_a - force_b / k_b + jump)


def _contact_and_stops(displacement: FloatArray, force: FloatArray, w_hat: FloatArray,
                       f_hat: FloatArray, a: IntArray, b: IntArray, k_contact: FloatArray,
                       k_contact_b: FloatArray, n_contact: FloatArray, mu_contact: FloatArray,
                       gap_contact: FloatArray,
                       stops: IntArray, k_stop: FloatArray, n_stop: FloatArray,
                       mu_stop: FloatArray, gap_stop: FloatArray, corner_of_pair: IntArray,
                       corner_stops: IntArray, held_side: IntArray, held_boundary: IntArray,
                       held_stop: IntArray, stop_held_boundary: IntArray,
                       stop_held_stop: IntArray, prescribed: FloatArray,
                       corner_moving: npt.NDArray[np.bool_], group_pairs: IntArray,
                       group_share: FloatArray, stop_groups: IntArray, stop_share: FloatArray,
                       first: IntArray) -> None:  # pragma: no cover - compiled
    """Steps ``first[c]`` on of case c (the earlier ones settled, ``engine``): the
    history they start from is the last settled step's Ŵ (each point's, which its update
    carries) and F̂ (a held corner's force). A row of ``group_pairs`` runs as one pair,
    one of ``stop_groups`` as one stop (``cross_points``: W and F set to its means in
    place, put back after)."""
    n_cases, n_steps = displacement.shape[0], displacement.shape[1]
    n_pairs, n_stops = a.size, stops.size
    n_corners = corner_stops.shape[0]
    # kept W and F of the grouped points: (group, member, step, W / F, component)
    kept_a = np.empty((group_pairs.shape[0], group_pairs.shape[1], n_steps, 2, 2))
    kept_b = np.empty_like(kept_a)
    kept_stops = np.empty((stop_groups.shape[0], stop_groups.shape[1], n_steps, 2, 2))
    for c in range(n_cases):
        prev_a = np.zeros((n_pairs, 2))
        prev_b = np.zeros((n_pairs, 2))
        prev_stop = np.zeros((n_stops, 2))
        stop_closed = np.zeros(n_stops, dtype=np.bool_)
        stop_holds = np.zeros(n_stops, dtype=np.bool_)
        carried = np.zeros(n_stops, dtype=np.bool_)  # closed at the step before
        corner_force = np.zeros((n_corners, 2))
        t0 = first[c]
        if t0 > 0:
            for i in range(n_stops):
                for d in range(2):
                    prev_stop[i, d] = w_hat[c, t0 - 1, stops[i], d]
                carried[i] = (n_stop[i, 0] * f_hat[c, t0 - 1, stops[i], 0]
                              + n_stop[i, 1] * f_hat[c, t0 - 1, stops[i], 1]) < 0.0
            for j in range(n_pairs):
                for d in range(2):
                    prev_a[j, d] = w_hat[c, t0 - 1, a[j], d]
                    prev_b[j, d] = w_hat[c, t0 - 1, b[j], d]
                if corner_of_pair[j] >= 0:  # the corner's last pair in order wrote it
                    for d in range(2):
                        corner_force[corner_of_pair[j], d] = f_hat[c, t0 - 1, a[j], d]
        if group_pairs.shape[0]:  # each side of the contact groups
            _merge_members(displacement, force, prev_a, a, group_pairs, group_share, kept_a,
                           c, t0)
            _merge_members(displacement, force, prev_b, b, group_pairs, group_share, kept_b,
                           c, t0)
        if stop_groups.shape[0]:
            _merge_members(displacement, force, prev_stop, stops, stop_groups, stop_share,
                           kept_stops, c, t0)
        for t in range(t0, n_steps):
            for i in range(n_stops):
                p = stops[i]
                nx, ny = n_stop[i, 0], n_stop[i, 1]
                kx, ky = k_stop[i, 0], k_stop[i, 1]
                dwx = displacement[c, t, p, 0] - prev_stop[i, 0]
                dwy = displacement[c, t, p, 1] - prev_stop[i, 1]
                trial_x = force[c, t, p, 0] - kx * dwx
                trial_y = force[c, t, p, 1] - ky * dwy
                closing = gap_stop[c, i] - (nx * prev_stop[i, 0] + ny * prev_stop[i, 1])
                normal_force = (nx * trial_x + ny * trial_y
                                + (nx * nx * kx + ny * ny * ky) * closing)
                fx, fy = 0.0, 0.0
                if normal_force <= 0.0:
                    fx, fy = _in_cone(trial_x, trial_y, normal_force, nx, ny, mu_stop[c, i])
                stop_closed[i] = normal_force < 0.0
                # a corner's stop holds where its node was on it already
                stop_holds[i] = stop_closed[i] and _attached(
                    closing, gap_stop[c, i],
                    nx * displacement[c, t, p, 0] + ny * displacement[c, t, p, 1],
                    nx * force[c, t, p, 0] + ny * force[c, t, p, 1], nx * nx * kx + ny * ny * ky)
                prev_stop[i, 0] += dwx + (fx - force[c, t, p, 0]) / kx
                prev_stop[i, 1] += dwy + (fy - force[c, t, p, 1]) / ky
                f_hat[c, t, p, 0], f_hat[c, t, p, 1] = fx, fy
                w_hat[c, t, p, 0], w_hat[c, t, p, 1] = prev_stop[i, 0], prev_stop[i, 1]
            for i in range(n_stops):  # held stops (``held_nodes.held_stops``)
                if stop_held_boundary[i] < 0 and (stop_held_stop[i] < 0
                                                  or not stop_holds[stop_held_stop[i]]):
                    continue
                p = stops[i]
                d = 1 - (0 if abs(n_stop[i, 0]) >= abs(n_stop[i, 1]) else 1)
                if stop_held_boundary[i] >= 0:
                    target = prescribed[c, t, stop_held_boundary[i], d]
                    before = prescribed[c, t - 1, stop_held_boundary[i], d] if t > 0 else 0.0
                    if target != before:  # the holder moves: the stop slides, at the cone
                        continue
                else:
                    target = prev_stop[stop_held_stop[i], d]
                bound = 0.0
                if stop_closed[i]:
                    bound = -mu_stop[c, i] * (n_stop[i, 0] * f_hat[c, t, p, 0]
                                              + n_stop[i, 1] * f_hat[c, t, p, 1])
                previous = f_hat[c, t - 1, p, d] if t > 0 else 0.0
                f_hat[c, t, p, d] = min(max(previous, -bound), bound)
                prev_stop[i, d] = target
                w_hat[c, t, p, d] = target
            for j in range(n_pairs):
                pa, pb = a[j], b[j]
                nx, ny = n_contact[j, 0], n_contact[j, 1]
                kx, ky = k_contact[j, 0], k_contact[j, 1]  # side a
                kbx, kby = k_contact_b[j, 0], k_contact_b[j, 1]
                dax = displacement[c, t, pa, 0] - prev_a[j, 0]
                day = displacement[c, t, pa, 1] - prev_a[j, 1]
                dbx = displacement[c, t, pb, 0] - prev_b[j, 0]
                dby = displacement[c, t, pb, 1] - prev_b[j, 1]
                hx, trial_x = _series_trial(force[c, t, pa, 0], force[c, t, pb, 0], kx, kbx,
                                            dbx - dax)
                hy, trial_y = _series_trial(force[c, t, pa, 1], force[c, t, pb, 1], ky, kby,
                                            dby - day)
                closing = gap_contact[c, j] + (nx * (prev_b[j, 0] - prev_a[j, 0])
                                               + ny * (prev_b[j, 1] - prev_a[j, 1]))
                normal_force = (nx * trial_x + ny * trial_y
                                + (nx * nx * hx + ny * ny * hy) * closing)
                # held on one side (``held_nodes.held_corners``): the tangential trial
                # force from the free side alone, against the held node's motion
                hs = held_side[j]
                target = 0.0
                holding = False
                d = 0 if abs(ny) > abs(nx) else 1  # the tangential component
                if hs >= 0:
                    if held_boundary[j] >= 0:
                        target = prescribed[c, t, held_boundary[j], d]
                        holding = True
                    elif stop_closed[held_stop[j]]:
                        target = prev_stop[held_stop[j], d]
                        holding = True
                if holding:
                    wa_d = displacement[c, t, pa, d]
                    wb_d = displacement[c, t, pb, d]
                    if hs == 1:
                        ka_d = kx if d == 0 else ky
                        tangential = force[c, t, pa, d] + ka_d * (
                            prev_a[j, d] + target - prev_b[j, d] - wa_d)
                    else:
                        kb_d = kbx if d == 0 else kby
                        tangential = -(force[c, t, pb, d] + kb_d * (
                            prev_b[j, d] + target - prev_a[j, d] - wb_d))
                    if d == 0:
                        trial_x = tangential
                    else:
                        trial_y = tangential
                fx, fy = 0.0, 0.0
                if normal_force <= 0.0:
                    fx, fy = _in_cone(trial_x, trial_y, normal_force, nx, ny,
                                      mu_contact[c, j])
                q = corner_of_pair[j]
                held = False
                if q >= 0:
                    held = not corner_moving[c, t, q]
                    for h in range(2):
                        holder = corner_stops[q, h]
                        if holder >= 0 and not (stop_holds[holder] and carried[holder]):
                            held = False
                    if held:
                        fx, fy = _in_cone(corner_force[q, 0], corner_force[q, 1],
                                          fx * nx + fy * ny, nx, ny, mu_contact[c, j])
                    corner_force[q, 0], corner_force[q, 1] = fx, fy
                prev_a[j, 0] += dax + (fx - force[c, t, pa, 0]) / kx
                prev_a[j, 1] += day + (fy - force[c, t, pa, 1]) / ky
                prev_b[j, 0] += dbx + (-fx - force[c, t, pb, 0]) / kbx
                prev_b[j, 1] += dby + (-fy - force[c, t, pb, 1]) / kby
                if holding:  # the held side follows its holder
                    if hs == 1:
                        prev_b[j, d] = target
                    else:
                        prev_a[j, d] = target
                f_hat[c, t, pa, 0], f_hat[c, t, pa, 1] = fx, fy
                f_hat[c, t, pb, 0], f_hat[c, t, pb, 1] = -fx, -fy
                w_hat[c, t, pa, 0], w_hat[c, t, pa, 1] = prev_a[j, 0], prev_a[j, 1]
                w_hat[c, t, pb, 0], w_hat[c, t, pb, 1] = prev_b[j, 0], prev_b[j, 1]
                if q >= 0 and not held and _sticks(trial_x, trial_y, normal_force, nx, ny,
                                                   mu_contact[c, j]):
                    for h in range(2):  # friction first (``held_stops.open_arrivals``)
                        i = corner_stops[q, h]
                        if i < 0 or not stop_closed[i]:
                            continue
                        side, point = (prev_a[j], pa) if h == 0 else (prev_b[j], pb)
                        k_side = k_contact[j] if h == 0 else k_contact_b[j]
                        if _stop_opens(displacement, force, n_stop, gap_stop, side[0],
                                       side[1], point, k_side[0], k_side[1], c, t, i):
                            p = stops[i]
                            for d in range(2):
                                prev_stop[i, d] = (displacement[c, t, p, d]
                                                   - force[c, t, p, d] / k_stop[i, d])
                                f_hat[c, t, p, d] = 0.0
                                w_hat[c, t, p, d] = prev_stop[i, d]
                            stop_closed[i] = False
            for i in range(n_stops):
                carried[i] = stop_closed[i]
        if group_pairs.shape[0]:
            _split_members(displacement, force, w_hat, a, k_contact, group_pairs,
                           group_share, kept_a, c, t0)
            _split_members(displacement, force, w_hat, b, k_contact_b, group_pairs,
                           group_share, kept_b, c, t0)
        if stop_groups.shape[0]:
            _split_members(displacement, force, w_hat, stops, k_stop, stop_groups, stop_share,
                           kept_stops, c, t0)


def _sticks(trial_x: float, trial_y: float, normal_force: float, nx: float, ny: float,
            mu: float) -> bool:  # pragma: no cover - compiled
    """Whether a contact pair's trial force is pressed and in its cone (``_in_cone``)."""
    if normal_force > 0.0:
        return False
    tx = trial_x - (trial_x * nx + trial_y * ny) * nx
    ty = trial_y - (trial_x * nx + trial_y * ny) * ny
    return bool(math.sqrt(tx * tx + ty * ty) <= -mu * normal_force)


def _stop_opens(displacement: FloatArray, force: FloatArray, n_stop: FloatArray,
                gap_stop: FloatArray, side_x: float, side_y: float, point: int,
                k_x: float, k_y: float, c: int, t: int,
                i: int) -> bool:  # pragma: no cover - compiled
    """Whether stop i of a sticking corner opens: the pair's Ŵ on its side (``side_x``,
    ``side_y``, at ``point``, search direction ``k_x``, ``k_y``) is not beyond it
    (``held_stops.open_arrivals``)."""
    gap = gap_stop[c, i]
    beyond = n_stop[i, 0] * side_x + n_stop[i, 1] * side_y - gap
    size = (abs(displacement[c, t, point, 0]) + abs(displacement[c, t, point, 1])
            + abs(force[c, t, point, 0]) / k_x + abs(force[c, t, point, 1]) / k_y)
    return not _beyond_stop(beyond, gap, size)


def _perfect_and_boundary(displacement: FloatArray, force: FloatArray, w_hat: FloatArray,
                          f_hat: FloatArray, a: IntArray, b: IntArray, k_pair: FloatArray,
                          k_pair_b: FloatArray, boundary: IntArray, k_boundary: FloatArray,
                          is_displacement: npt.NDArray[np.bool_], prescribed: FloatArray,
                          pair_held_side: IntArray, pair_held_boundary: IntArray,
                          first: IntArray) -> None:  # pragma: no cover - compiled
    n_cases, n_steps = displacement.shape[0], displacement.shape[1]
    for c in range(n_cases):
        for t in range(first[c], n_steps):
            for j in range(a.size):
                pa, pb = a[j], b[j]
                for d in range(2):
                    k, kb = k_pair[j, d], k_pair_b[j, d]
                    wa, wb = displacement[c, t, pa, d], displacement[c, t, pb, d]
                    fa, fb = force[c, t, pa, d], force[c, t, pb, d]
                    held = pair_held_side[j, d]
                    if held == 1:  # b's node prescribed: a's E+ against it
                        w = prescribed[c, t, pair_held_boundary[j, d], d]
                        f = fa + k * (w - wa)
                    elif held == 0:  # a's node prescribed: b's E+ against it
                        w = prescribed[c, t, pair_held_boundary[j, d], d]
                        f = -(fb + kb * (w - wb))
                    elif k == kb:
                        w = 0.5 * (wa + wb) - (fa + fb) / (2.0 * k)
                        f = 0.5 * (fa - fb) - 0.5 * k * (wa - wb)
                    else:  # Ŵ = (k_a W_a + k_b W_b − F_a − F_b) / (k_a + k_b)
                        w = (k * wa + kb * wb - fa - fb) / (k + kb)
                        f = fa + k * (w - wa)
                    w_hat[c, t, pa, d], w_hat[c, t, pb, d] = w, w
                    f_hat[c, t, pa, d], f_hat[c, t, pb, d] = f, -f
            for i in range(boundary.size):
                p = boundary[i]
                for d in range(2):
                    k = k_boundary[i, d]
                    data = prescribed[c, t, i, d]
                    w, f = displacement[c, t, p, d], force[c, t, p, d]
                    if is_displacement[i, d]:
                        w_hat[c, t, p, d], f_hat[c, t, p, d] = data, f + k * (data - w)
                    else:
                        w_hat[c, t, p, d], f_hat[c, t, p, d] = w + (data - f) / k, data


def _coupled_contact(displacement: FloatArray, force: FloatArray, w_hat: FloatArray,
                     f_hat: FloatArray, start: FloatArray, macro: FloatArray,
                     starts: IntArray, flat: IntArray, basis: FloatArray,
                     weighted: FloatArray, coupling_starts: IntArray,
                     coupling_columns: IntArray, coupling_values: FloatArray,
                     alphas: FloatArray, betas: FloatArray,
                     a: IntArray, b: IntArray, k_contact: FloatArray,
                     k_contact_b: FloatArray, n_contact: FloatArray, mu_contact: FloatArray,
                     gap_contact: FloatArray, stops: IntArray, k_stop: FloatArray,
                     n_stop: FloatArray, mu_stop: FloatArray, gap_stop: FloatArray,
                     corner_of_pair: IntArray, corner_stops: IntArray, held_side: IntArray,
                     held_boundary: IntArray, held_stop: IntArray,
                     stop_held_boundary: IntArray, stop_held_stop: IntArray,
                     prescribed: FloatArray, corner_moving: npt.NDArray[np.bool_],
                     group_pairs: IntArray, group_share: FloatArray, stop_groups: IntArray,
                     stop_share: FloatArray, first: IntArray) -> None:  # pragma: no cover
    """Steps ``first[c]`` on of case c; ``macro`` keeps the earlier steps' rows."""
    n_cases, n_steps, n_points = displacement.shape[0], displacement.shape[1], \
        displacement.shape[2]
    r = coupling_starts.size - 1
    # the functions' support as compact columns (support[u]; entry e at slot[e]), so that
    # the projections and the shift run along contiguous steps; every sum in the order of
    # the row-by-row form (over e within a function, functions in order)
    slot = np.empty(flat.size, dtype=np.int64)
    position = np.full(2 * n_points, -1, dtype=np.int64)
    n_support = 0
    for e in range(flat.size):
        if position[flat[e]] < 0:
            position[flat[e]] = n_support
            n_support += 1
        slot[e] = position[flat[e]]
    support = np.empty(n_support, dtype=np.int64)
    for e in range(flat.size):
        support[slot[e]] = flat[e]
    columns = np.empty((n_support, n_steps))
    sums = np.empty((r, n_steps))
    shift_t = np.empty((r, n_steps))
    shifted = np.empty((1, n_steps, n_points, 2))
    shifted_rows = shifted.reshape(n_steps, 2 * n_points)
    for c in range(n_cases):
        t0 = first[c]
        live = n_steps - t0
        shifted[0, t0:] = force[c, t0:]  # the settled steps' rows are not read
        force_rows = force[c].reshape(n_steps, 2 * n_points)[t0:]
        projected = np.zeros((live, r))  # Eᵀ M0 W
        _project_columns(displacement[c].reshape(n_steps, 2 * n_points)[t0:], support, slot,
                         starts, weighted, columns, sums, projected)
        x = start[c, t0:] - projected  # Eᵀ M0 (Ŵ − W)
        step = np.zeros((live, r))
        for inner in range(alphas.size):
            shift = np.empty((live, r))  # G x
            for t in range(live):
                _coupling_shift(x[t], coupling_starts, coupling_columns, coupling_values,
                                shift[t])
            for j in range(r):
                for t in range(live):
                    shift_t[j, t] = shift[t, j]
            for u in range(n_support):  # F + E G x on the support
                for t in range(live):
                    columns[u, t] = force_rows[t, support[u]]
            for j in range(r):
                for e in range(starts[j], starts[j + 1]):
                    u, value = slot[e], basis[e]
                    for t in range(live):
                        columns[u, t] += value * shift_t[j, t]
            for u in range(n_support):
                for t in range(live):
                    shifted_rows[t0 + t, support[u]] = columns[u, t]
            _contact_and_stops(displacement[c:c + 1], shifted, w_hat[c:c + 1], f_hat[c:c + 1],
                               a, b, k_contact, k_contact_b, n_contact, mu_contact[c:c + 1],
                               gap_contact[c:c + 1], stops, k_stop, n_stop, mu_stop[c:c + 1],
                               gap_stop[c:c + 1], corner_of_pair, corner_stops, held_side,
                               held_boundary, held_stop, stop_held_boundary, stop_held_stop,
                               prescribed[c:c + 1], corner_moving[c:c + 1], group_pairs,
                               group_share, stop_groups, stop_share, first[c:c + 1])
            residual = -projected - x
            _project_columns(w_hat[c].reshape(n_steps, 2 * n_points)[t0:], support, slot,
                             starts, weighted, columns, sums, residual)
            # Chebyshev's steps (``two_scale.chebyshev_steps``)
            step[:] = residual + betas[inner] * step
            x += alphas[inner] * step
        macro[c, t0:] = x + projected


def _relax(current: FloatArray, new: FloatArray, omega: float
           ) -> None:  # pragma: no cover - compiled
    flat, flat_new = current.reshape(-1), new.reshape(-1)
    for i in range(flat.size):
        flat[i] = omega * flat_new[i] + (1.0 - omega) * flat[i]


def _relax_rows(current: FloatArray, new: FloatArray, rows: IntArray, omega: FloatArray
                ) -> None:  # pragma: no cover - compiled
    """current[rows[i]] ← ω_i new[i] + (1 − ω_i) current[rows[i]], rows of 2-D arrays."""
    for i in range(rows.size):
        target, w = rows[i], omega[i]
        for j in range(new.shape[1]):
            current[target, j] = w * new[i, j] + (1.0 - w) * current[target, j]


#: the compiled kernels, or None without Numba; compiled (or loaded from Numba's cache) on
#: first use, so that importing the solver does not import Numba (0.4 s)
contact_and_stops: Callable[..., Any] | None
relax: Callable[..., Any] | None
relax_rows: Callable[..., Any] | None
indicator_squares: Callable[..., Any] | None
perfect_and_boundary: Callable[..., Any] | None
coupled_contact: Callable[..., Any] | None
two_scale_correction: Callable[..., Any] | None
direction_update: Callable[..., Any] | None
_KERNELS = ("contact_and_stops", "relax", "relax_rows", "indicator_squares", "perfect_and_boundary",
            "coupled_contact", "two_scale_correction", "direction_update")


def _compile() -> None:
    global _in_cone, _series_trial, _attached, _beyond_stop, _sticks, _stop_opens
    global _contact_and_stops, _project_columns, _coupling_shift, _merge_members
    global _split_members
    compiled: dict[str, Callable[..., Any] | None] = dict.fromkeys(_KERNELS)
    try:  # pragma: no cover - depends on the installed extras
        numba = importlib.import_module("numba")
    except ImportError:  # pragma: no cover
        log.debug("numba is not installed: the NumPy local stage runs")
    else:
        jit_inline = numba.njit(cache=True, inline="always")
        _in_cone, _series_trial = jit_inline(_in_cone), jit_inline(_series_trial)
        _attached = jit_inline(_attached)
        _beyond_stop, _sticks = jit_inline(_beyond_stop), jit_inline(_sticks)
        _stop_opens = jit_inline(_stop_opens)
        jit = numba.njit(cache=True)
        # called from ``_coupled_contact`` and the corrections: compiled before them
        _merge_members, _split_members = jit(_merge_members), jit(_split_members)
        _contact_and_stops, _project_columns = jit(_contact_and_stops), jit(_project_columns)
        _coupling_shift = jit_inline(_coupling_shift)
        # the two-scale module's callers find its compiled helpers in its own namespace
        _two_scale.coupling_shift = _coupling_shift
        _two_scale.correction_row = jit_inline(_two_scale.correction_row)
        compiled = {"contact_and_stops": _contact_and_stops,
                    "perfect_and_boundary": jit(_perfect_and_boundary),
                    "relax": jit(_relax), "relax_rows": jit(_relax_rows),
                    "indicator_squares": jit(_indicator_squares),
                    "coupled_contact": jit(_coupled_contact),
                    "two_scale_correction": jit(_two_scale.two_scale_correction),
                    "direction_update": jit(_two_scale.direction_update)}
    globals().update(compiled)


def __getattr__(name: str) -> Any:
    if name in _KERNELS:
        _compile()
        return globals()[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
