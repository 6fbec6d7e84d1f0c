"""The contact pairs and rigid stops of the local stage as two CUDA kernels, for the torch
backend on a GPU (issue 19): the formulas of the Numba CPU kernel
``kernels._contact_and_stops`` (paper §3, eq. [16]–[17]), one thread per case and stop,
then one per case and contact pair, each carrying its own point's history through the
steps (Coulomb's law acts on increments). Two launches where the torch operations make
about 2 000 per pass: on an H200 those launches, not the arithmetic, set a GPU iteration's
time (docs/gpu.md).

The pairs read what the stops did at the same step (held nodes, held corners): whether each
stop is closed (a buffer the stop kernel writes) and its displacement (its Ŵ). Written with
Numba's CUDA target; its simulator (``NUMBA_ENABLE_CUDASIM=1``) runs them on the CPU, which
is how the tests check them against the NumPy local stage.
"""

from __future__ import annotations

import contextlib
import importlib
from typing import TYPE_CHECKING, Any

import numpy as np

from . import kernels

if TYPE_CHECKING:
    from .torch_local import TorchLocalStage

#: threads per block
THREADS = 128

if not hasattr(np, "row_stack"):
    # numba-cuda (0.30 and before) registers np.row_stack, which NumPy 2.5 removed, when
    # it first compiles: without the alias its CUDA target fails to start (seen on an H200
    # with NumPy 2.5.2, docs/gpu.md). The alias is what NumPy 2.0-2.4 had.
    numpy_module: Any = np
    numpy_module.row_stack = np.vstack

numba: Any = importlib.import_module("numba")
cuda: Any = importlib.import_module("numba.cuda")
for _config in ("numba.cuda.core.config", "numba.core.config"):
    # a small batch (one case) is a small grid: Numba's low-occupancy warning says nothing
    with contextlib.suppress(ImportError):
        config: Any = importlib.import_module(_config)
        config.CUDA_LOW_OCCUPANCY_WARNINGS = 0

_in_cone = cuda.jit(device=True)(getattr(kernels._in_cone, "py_func", kernels._in_cone))
_series_trial = cuda.jit(device=True)(getattr(kernels._series_trial, "py_func",
                                              kernels._series_trial))
_attached = cuda.jit(device=True)(getattr(kernels._attached, "py_func", kernels._attached))
_beyond_stop = cuda.jit(device=True)(getattr(kernels._beyond_stop, "py_func",
                                             kernels._beyond_stop))
_sticks = cuda.jit(device=True)(getattr(kernels._sticks, "py_func", kernels._sticks))
_stop_opens = cuda.jit(device=True)(getattr(kernels._stop_opens, "py_func",
                                            kernels._stop_opens))


def _stop_step(displacement: Any, force: Any, w_hat: Any, f_hat: Any, closed: Any,
               stops: Any, k_stop: Any, n_stop: Any, mu_stop: Any, gap_stop: Any,
               history: Any, h: int, c: int, t: int, i: int) -> None:  # pragma: no cover
    """Stop i of case c in step t, from its Ŵ after the previous step (``history[h]``,
    updated)."""
    p = stops[i]
    nx, ny = n_stop[i, 0], n_stop[i, 1]
    kx, ky = k_stop[i, 0], k_stop[i, 1]
    px, py = history[h, 0], history[h, 1]
    dwx = displacement[c, t, p, 0] - px
    dwy = displacement[c, t, p, 1] - py
    trial_x = force[c, t, p, 0] - kx * dwx
    trial_y = force[c, t, p, 1] - ky * dwy
    closing = gap_stop[c, i] - (nx * px + ny * py)
    normal_force = nx * trial_x + ny * trial_y + (nx * nx * kx + ny * ny * ky) * closing
    fx, fy = 0.0, 0.0
    if normal_force <= 0.0:
        fx, fy = _in_cone(trial_x, trial_y, normal_force, nx, ny, mu_stop[c, i])
    # 2: closed with its node on the stop at the previous step already, which holds
    # a corner (``held_stops.ATTACHED``); 1: closed; 0: open
    closed[c, t, i] = 0
    if normal_force < 0.0:
        closed[c, t, i] = 1
        if _attached(closing, gap_stop[c, i],
                     nx * displacement[c, t, p, 0] + ny * displacement[c, t, p, 1],
                     nx * force[c, t, p, 0] + ny * force[c, t, p, 1],
                     nx * nx * kx + ny * ny * ky):
            closed[c, t, i] = 2
    history[h, 0] = px + dwx + (fx - force[c, t, p, 0]) / kx
    history[h, 1] = py + dwy + (fy - force[c, t, p, 1]) / ky
    f_hat[c, t, p, 0] = fx
    f_hat[c, t, p, 1] = fy
    w_hat[c, t, p, 0] = history[h, 0]
    w_hat[c, t, p, 1] = history[h, 1]


def _stops(displacement: Any, force: Any, w_hat: Any, f_hat: Any, closed: Any, stops: Any,
           k_stop: Any, n_stop: Any, mu_stop: Any, gap_stop: Any) -> None:  # pragma: no cover
    thread = cuda.grid(1)
    n_stops = stops.shape[0]
    if thread >= displacement.shape[0] * n_stops:
        return
    c, i = thread // n_stops, thread % n_stops
    history = cuda.local.array((1, 2), numba.float64)  # Ŵ after the previous step
    history[0, 0], history[0, 1] = 0.0, 0.0
    for t in range(displacement.shape[1]):
        _stop_step(displacement, force, w_hat, f_hat, closed, stops, k_stop, n_stop, mu_stop,
                   gap_stop, history, 0, c, t, i)


def _pairs(displacement: Any, force: Any, w_hat: Any, f_hat: Any, closed: Any, a: Any, b: Any,
           k_contact: Any, k_contact_b: Any, n_contact: Any, mu_contact: Any,
           gap_contact: Any, stops: Any, corner_of_pair: Any, corner_stops: Any,
           held_side: Any, held_boundary: Any, held_stop: Any, prescribed: Any,
           k_stop: Any, n_stop: Any, mu_stop: Any, gap_stop: Any) -> None:  # pragma: no cover
    thread = cuda.grid(1)
    n_pairs = a.shape[0]
    if thread >= displacement.shape[0] * n_pairs:
        return
    c, j = thread // n_pairs, thread % n_pairs
    pa, pb = a[j], b[j]
    nx, ny = n_contact[j, 0], n_contact[j, 1]
    kx, ky = k_contact[j, 0], k_contact[j, 1]  # side a
    kbx, kby = k_contact_b[j, 0], k_contact_b[j, 1]
    q, hs = corner_of_pair[j], held_side[j]
    d = 0 if abs(ny) > abs(nx) else 1  # a held node's tangential component
    ax, ay, bx, by = 0.0, 0.0, 0.0, 0.0  # both sides' displacements after the previous step
    corner_x, corner_y = 0.0, 0.0
    # a corner's stops run again here, step by step with the pair, which opens them while
    # it sticks short of them (``held_stops.open_arrivals``): their Ŵ after the previous
    # step, and whether they were closed then
    history = cuda.local.array((2, 2), numba.float64)
    carried = cuda.local.array(2, numba.boolean)
    for h in range(2):
        history[h, 0], history[h, 1], carried[h] = 0.0, 0.0, False
    for t in range(displacement.shape[1]):
        if q >= 0:
            for h in range(2):
                if corner_stops[q, h] >= 0:
                    _stop_step(displacement, force, w_hat, f_hat, closed, stops, k_stop,
                               n_stop, mu_stop, gap_stop, history, h, c, t, corner_stops[q, h])
        dax = displacement[c, t, pa, 0] - ax
        day = displacement[c, t, pa, 1] - ay
        dbx = displacement[c, t, pb, 0] - bx
        dby = displacement[c, t, pb, 1] - by
        hx, trial_x = _series_trial(force[c, t, pa, 0], force[c, t, pb, 0], kx, kbx, dbx - dax)
        hy, trial_y = _series_trial(force[c, t, pa, 1], force[c, t, pb, 1], ky, kby, dby - day)
        closing = gap_contact[c, j] + (nx * (bx - ax) + ny * (by - ay))
        normal_force = nx * trial_x + ny * trial_y + (nx * nx * hx + ny * ny * hy) * closing
        target = 0.0
        holding = False
        if hs >= 0:
            if held_boundary[j] >= 0:
                target = prescribed[c, t, held_boundary[j], d]
                holding = True
            elif closed[c, t, held_stop[j]] != 0:
                target = w_hat[c, t, stops[held_stop[j]], d]
                holding = True
        if holding:
            a_d, b_d = (ax, bx) if d == 0 else (ay, by)
            if hs == 1:
                tangential = force[c, t, pa, d] + (kx if d == 0 else ky) * (
                    a_d + target - b_d - displacement[c, t, pa, d])
            else:
                tangential = -(force[c, t, pb, d] + (kbx if d == 0 else kby) * (
                    b_d + target - a_d - displacement[c, t, pb, d]))
            if d == 0:
                trial_x = tangential
            else:
                trial_y = tangential
        fx, fy = 0.0, 0.0
        if normal_force <= 0.0:
            fx, fy = _in_cone(trial_x, trial_y, normal_force, nx, ny, mu_contact[c, j])
        held = False
        if q >= 0:
            held = True
            for h in range(2):
                holder = corner_stops[q, h]
                if holder >= 0 and not (closed[c, t, holder] == 2 and carried[h]):
                    held = False
            if held:
                fx, fy = _in_cone(corner_x, corner_y, fx * nx + fy * ny, nx, ny,
                                  mu_contact[c, j])
            corner_x, corner_y = fx, fy
        ax += dax + (fx - force[c, t, pa, 0]) / kx
        ay += day + (fy - force[c, t, pa, 1]) / ky
        bx += dbx + (-fx - force[c, t, pb, 0]) / kbx
        by += dby + (-fy - force[c, t, pb, 1]) / kby
        if holding:  # the held side follows its holder
            if hs == 1 and d == 0:
                bx = target
            elif hs == 1:
                by = target
            elif d == 0:
                ax = target
            else:
                ay = target
        f_hat[c, t, pa, 0] = fx
        f_hat[c, t, pa, 1] = fy
        f_hat[c, t, pb, 0] = -fx
        f_hat[c, t, pb, 1] = -fy
        w_hat[c, t, pa, 0] = ax
        w_hat[c, t, pa, 1] = ay
        w_hat[c, t, pb, 0] = bx
        w_hat[c, t, pb, 1] = by
        if q >= 0:
            if not held and _sticks(trial_x, trial_y, normal_force, nx, ny, mu_contact[c, j]):
                _open_arrivals(displacement, force, w_hat, f_hat, closed, stops, k_stop,
                               n_stop, gap_stop, history, corner_stops, q, ax, ay, bx, by,
                               pa, pb, kx, ky, kbx, kby, c, t)
            for h in range(2):
                if corner_stops[q, h] >= 0:
                    carried[h] = closed[c, t, corner_stops[q, h]] != 0


def _open_arrivals(displacement: Any, force: Any, w_hat: Any, f_hat: Any, closed: Any,
                   stops: Any, k_stop: Any, n_stop: Any, gap_stop: Any, history: Any,
                   corner_stops: Any, q: int, ax: float, ay: float, bx: float, by: float,
                   pa: int, pb: int, kx: float, ky: float, kbx: float, kby: float, c: int,
                   t: int) -> None:  # pragma: no cover
    """``held_stops.open_arrivals`` at corner q, its pair sticking after step t."""
    for h in range(2):
        i = corner_stops[q, h]
        if i < 0 or closed[c, t, i] == 0:
            continue
        side_x, side_y, point = (ax, ay, pa) if h == 0 else (bx, by, pb)
        k_x, k_y = (kx, ky) if h == 0 else (kbx, kby)
        if not _stop_opens(displacement, force, n_stop, gap_stop, side_x, side_y, point,
                           k_x, k_y, c, t, i):
            continue
        p = stops[i]
        for d in range(2):
            history[h, d] = displacement[c, t, p, d] - force[c, t, p, d] / k_stop[i, d]
            f_hat[c, t, p, d] = 0.0
            w_hat[c, t, p, d] = history[h, d]
        closed[c, t, i] = 0


_stop_step = cuda.jit(device=True)(_stop_step)
_open_arrivals = cuda.jit(device=True)(_open_arrivals)
STOPS, PAIRS = cuda.jit(_stops), cuda.jit(_pairs)


class ContactKernels:
    """The two kernels with the local stage's fixed data on the device (the per-case data,
    which cases leaving a batch subset, is read from the ``TorchLocalStage`` at each call)."""

    def __init__(self, stage: TorchLocalStage, local: Any) -> None:
        """local: the ``LocalStage`` that ``stage`` was built from."""
        tensor, index = stage._tensor, stage._index
        self.fixed_pairs = (index(local.contact_pairs[0]), index(local.contact_pairs[1]),
                            tensor(local.k_contact), tensor(local.k_contact_b),
                            tensor(local.n_contact))
        self.stops = index(local.stops)
        self.fixed_stops = (self.stops, tensor(local.k_stop), tensor(local.n_stop))
        self.fixed_held = (self.stops, index(local.corner_of_pair),
                           index(local.corner_stops.reshape(-1, 2)), index(local.held_side),
                           index(local.held_boundary), index(local.held_stop))

    def __call__(self, stage: TorchLocalStage, displacement: Any, force: Any, w_hat: Any,
                 f_hat: Any) -> None:
        """F̂, Ŵ at the contact pairs' and stops' points, in place."""
        torch = stage.torch
        n_cases, n_steps = displacement.shape[:2]
        closed = torch.zeros((n_cases, n_steps, max(stage.n_stops, 1)), dtype=torch.int8,
                             device=displacement.device)
        fields = (displacement, force, w_hat, f_hat, closed)
        if stage.n_stops:
            _launch(STOPS, n_cases * stage.n_stops, torch,
                    *fields, *self.fixed_stops, stage.mu_stop, stage.gap_stop)
        if stage.n_pairs:
            _launch(PAIRS, n_cases * stage.n_pairs, torch, *fields, *self.fixed_pairs,
                    stage.mu_contact, stage.gap_contact, *self.fixed_held, stage.prescribed,
                    *self.fixed_stops[1:], stage.mu_stop, stage.gap_stop)


def _launch(kernel: Any, n_threads: int, torch: Any, *tensors: Any) -> None:
    """``kernel`` over ``n_threads`` threads on PyTorch's current stream (so that a CUDA
    graph captures it), on the tensors' memory without copies or synchronisation; in the
    simulator, on CPU tensors' memory."""
    blocks = (n_threads + THREADS - 1) // THREADS
    if numba.config.ENABLE_CUDASIM:
        kernel[blocks, THREADS](*(x.numpy() for x in tensors))
        return
    index = tensors[0].device.index or 0
    if index:  # Numba works on GPU 0 unless told
        with cuda.gpus[index]:
            _launch_on(kernel, blocks, torch.cuda.current_stream(index), tensors)
    else:
        _launch_on(kernel, blocks, torch.cuda.current_stream(), tensors)


def _launch_on(kernel: Any, blocks: int, stream: Any, tensors: tuple[Any, ...]) -> None:
    kernel[blocks, THREADS, cuda.external_stream(stream.cuda_stream)](
        *(cuda.as_cuda_array(x.detach(), sync=False) for x in tensors))
