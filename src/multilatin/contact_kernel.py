"""The contact and stop part of the local stage compiled with Numba (optional extra ``fast``).

The same closed forms as ``LocalStage._contact_and_stops`` (paper §3, eq. [16]–[17]), written
point by point: for every case of a batch, step after step (Coulomb's law acts on
increments), the stops first, then the contact pairs with the held-corner rule. Without
Numba, ``LocalStage`` uses its NumPy version; the two agree to rounding (tests).
"""

from __future__ import annotations

import importlib
import logging
from collections.abc import Callable
from typing import Any

import numpy as np

from .fem.elasticity import FloatArray, IntArray

log = logging.getLogger(__name__)

numba: Any
try:  # pragma: no cover - depends on the installed extras
    numba = importlib.import_module("numba")
except ImportError:  # pragma: no cover
    numba = None


def _in_cone(source_x: float, source_y: float, normal_force: float, nx: float, ny: float,
             friction: float) -> tuple[float, float]:
    """N n plus the tangential part of the source, limited to μ |N|."""
    along = source_x * nx + source_y * ny
    tx, ty = source_x - along * nx, source_y - along * ny
    size = np.sqrt(tx * tx + ty * ty)
    limit = friction * abs(normal_force)
    scale = limit / max(size, 1e-300) if size > limit else 1.0
    return normal_force * nx + scale * tx, normal_force * ny + scale * ty


def _contact_and_stops(displacement: FloatArray, force: FloatArray, w_hat: FloatArray,
                       f_hat: FloatArray, a: IntArray, b: IntArray, k_contact: FloatArray,
                       n_contact: FloatArray, mu_contact: FloatArray, gap_contact: FloatArray,
                       stops: IntArray, k_stop: FloatArray, n_stop: FloatArray,
                       mu_stop: FloatArray, gap_stop: FloatArray, corner_of_pair: IntArray,
                       corner_stops: IntArray) -> None:  # pragma: no cover - compiled
    n_cases, n_steps = displacement.shape[0], displacement.shape[1]
    n_pairs, n_stops = a.size, stops.size
    n_corners = corner_stops.shape[0]
    for c in range(n_cases):
        prev_a = np.zeros((n_pairs, 2))
        prev_b = np.zeros((n_pairs, 2))
        prev_stop = np.zeros((n_stops, 2))
        stop_closed = np.zeros(n_stops, dtype=np.bool_)
        corner_force = np.zeros((n_corners, 2))
        for t in range(n_steps):
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
                                + (abs(nx) * kx + abs(ny) * ky) * closing)
                fx, fy = 0.0, 0.0
                if normal_force <= 0.0:
                    fx, fy = _in_cone(trial_x, trial_y, normal_force, nx, ny, mu_stop[c, i])
                stop_closed[i] = normal_force < 0.0
                prev_stop[i, 0] += dwx + (fx - force[c, t, p, 0]) / kx
                prev_stop[i, 1] += dwy + (fy - force[c, t, p, 1]) / ky
                f_hat[c, t, p, 0], f_hat[c, t, p, 1] = fx, fy
                w_hat[c, t, p, 0], w_hat[c, t, p, 1] = prev_stop[i, 0], prev_stop[i, 1]
            for j in range(n_pairs):
                pa, pb = a[j], b[j]
                nx, ny = n_contact[j, 0], n_contact[j, 1]
                kx, ky = k_contact[j, 0], k_contact[j, 1]
                dax = displacement[c, t, pa, 0] - prev_a[j, 0]
                day = displacement[c, t, pa, 1] - prev_a[j, 1]
                dbx = displacement[c, t, pb, 0] - prev_b[j, 0]
                dby = displacement[c, t, pb, 1] - prev_b[j, 1]
                trial_x = 0.5 * (force[c, t, pa, 0] - force[c, t, pb, 0]) + 0.5 * kx * (dbx - dax)
                trial_y = 0.5 * (force[c, t, pa, 1] - force[c, t, pb, 1]) + 0.5 * ky * (dby - day)
                closing = gap_contact[c, j] + (nx * (prev_b[j, 0] - prev_a[j, 0])
                                               + ny * (prev_b[j, 1] - prev_a[j, 1]))
                normal_force = (nx * trial_x + ny * trial_y
                                + 0.5 * (abs(nx) * kx + abs(ny) * ky) * closing)
                fx, fy = 0.0, 0.0
                if normal_force <= 0.0:
                    fx, fy = _in_cone(trial_x, trial_y, normal_force, nx, ny,
                                      mu_contact[c, j])
                q = corner_of_pair[j]
                if q >= 0:
                    held = True
                    for h in range(2):
                        holder = corner_stops[q, h]
                        if holder >= 0 and not stop_closed[holder]:
                            held = False
                    if held:
                        fx, fy = _in_cone(corner_force[q, 0], corner_force[q, 1],
                                          fx * nx + fy * ny, nx, ny, mu_contact[c, j])
                    corner_force[q, 0], corner_force[q, 1] = fx, fy
                prev_a[j, 0] += dax + (fx - force[c, t, pa, 0]) / kx
                prev_a[j, 1] += day + (fy - force[c, t, pa, 1]) / ky
                prev_b[j, 0] += dbx + (-fx - force[c, t, pb, 0]) / kx
                prev_b[j, 1] += dby + (-fy - force[c, t, pb, 1]) / ky
                f_hat[c, t, pa, 0], f_hat[c, t, pa, 1] = fx, fy
                f_hat[c, t, pb, 0], f_hat[c, t, pb, 1] = -fx, -fy
                w_hat[c, t, pa, 0], w_hat[c, t, pa, 1] = prev_a[j, 0], prev_a[j, 1]
                w_hat[c, t, pb, 0], w_hat[c, t, pb, 1] = prev_b[j, 0], prev_b[j, 1]


contact_and_stops: Callable[..., Any] | None = None
if numba is not None:  # pragma: no branch
    _in_cone = numba.njit(cache=True, inline="always")(_in_cone)
    contact_and_stops = numba.njit(cache=True)(_contact_and_stops)
