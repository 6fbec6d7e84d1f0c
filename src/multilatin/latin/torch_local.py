"""The local stage (paper §3, §4.2) on PyTorch tensors: the formulas of ``LocalStage``
(NumPy, the reference) written with torch operations, vectorised over the cases of a batch
and the points, step after step for contact and stops (Coulomb's law acts on increments).

No host synchronisation inside: the rules that the NumPy code applies only where some point
needs them (held nodes, corners) are applied here as masked selections everywhere, which
gives the same values.
"""

from __future__ import annotations

import importlib
import logging
from typing import TYPE_CHECKING, Any

import numpy as np

from ..fem.elasticity import IntArray
from .cross_points import corrected, merged
from .held_stops import attached, beyond_stop
from .local_stage import LocalStage

if TYPE_CHECKING:
    import torch

Tensor = Any  # torch.Tensor, kept out of the annotations' imports (PyTorch is optional)

log = logging.getLogger(__name__)
#: the contact kernels' first answer is checked against the torch operations' to this
#: relative difference (``TorchLocalStage.use_kernels``)
KERNEL_CHECK_RTOL = 1e-9


def contact_kernels_available() -> bool:
    """Numba's CUDA target and a GPU it can use (``cuda_local``)."""
    try:
        cuda: Any = importlib.import_module("numba.cuda")
        return bool(cuda.is_available())
    except Exception:  # noqa: BLE001 - no Numba (an extra), or no driver it can use
        return False


class TorchLocalStage:
    """``LocalStage`` on a torch device; fields ``(n_cases, n_steps, n_points, 2)``."""

    def __init__(self, local: LocalStage, torch_module: Any, device: torch.device) -> None:
        self.torch = torch_module
        tensor = self._tensor = _converter(torch_module, device)
        index = self._index = _index_converter(torch_module, device)
        self.pairs = (index(local.pairs[0]), index(local.pairs[1]))
        self.k_pair, self.k_pair_b = tensor(local.k_pair), tensor(local.k_pair_b)
        self.pair_equal = self.k_pair == self.k_pair_b
        j, d = np.nonzero(local.pair_held_side >= 0)
        self.held_pair = (index(j), index(d), index(local.pairs[0][j]), index(local.pairs[1][j]),
                          index(local.pair_held_boundary[j, d]),
                          self.torch.as_tensor(local.pair_held_side[j, d] == 1, device=device))
        self.n_held_pairs = j.size
        self.boundary = index(local.boundary)
        self.k_boundary = tensor(local.k_boundary)
        self.is_displacement = self.torch.as_tensor(local.is_displacement, device=device)
        self.macro_points = index(local.macro_points)
        self.n_macro_points = local.macro_points.size
        self.k_macro = tensor(local.k_macro)
        self.macro_right_t = tensor(local.macro_map.right.T)  # Q = left @ right
        self.macro_left_t = tensor(local.macro_map.left.T)
        a, b = local.contact_pairs
        self.contact = (index(a), index(b))
        self.n_pairs = a.size
        k, kb, n = local.k_contact, local.k_contact_b, local.n_contact
        self.k_contact, self.k_contact_b, self.n_contact = tensor(k), tensor(kb), tensor(n)
        self.contact_equal = self.k_contact == self.k_contact_b
        self.all_contact_equal = bool(np.all(k == kb))  # then one branch of the where
        half = np.where(k == kb, 0.5 * k, k * kb / np.where(k + kb > 0, k + kb, 1.0))
        self.half = tensor(half)
        self.half_normal = tensor(np.sum(n * n * half, axis=1))
        self.stops = index(local.stops)
        self.n_stops = local.stops.size
        self.k_stop, self.n_stop = tensor(local.k_stop), tensor(local.n_stop)
        self.k_stop_normal = tensor(np.sum(local.n_stop**2 * local.k_stop, axis=1))
        self.corner = index(local.corner)
        self.n_corners = local.corner.size
        self.n_corner = tensor(n[local.corner])
        stops_of_corner = np.asarray(local.corner_stops, dtype=np.int64).reshape(-1, 2)
        self.corner_free = self.torch.as_tensor(stops_of_corner < 0, device=device)
        self.corner_stops = index(np.maximum(stops_of_corner, 0))
        #: (side, the corners with a stop on that side, those stops): ``open_arrivals``
        on_side = [stops_of_corner[:, side] >= 0 for side in (0, 1)]
        self.corner_sides = [(side, index(np.flatnonzero(has)),
                              index(stops_of_corner[has, side]))
                             for side, has in enumerate(on_side) if has.any()]
        h = local.held_pairs
        self.n_held = h.size
        self.held = (index(h), index(local.held_component),
                     self.torch.as_tensor(local.held_side[h] == 1, device=device))
        by_boundary = local.held_boundary[h] >= 0
        self.held_by_boundary = self.torch.as_tensor(by_boundary, device=device)
        self.held_stop = index(np.maximum(local.held_stop[h], 0))
        self.held_boundary = index(np.maximum(local.held_boundary[h], 0))
        self.k_held = (tensor(k[h, local.held_component]), tensor(kb[h, local.held_component]))
        self.mu_contact, self.gap_contact = tensor(local.mu_contact), tensor(local.gap_contact)
        self.mu_stop, self.gap_stop = tensor(local.mu_stop), tensor(local.gap_stop)
        self.prescribed = tensor(local.prescribed)
        self.mu_corner = self.mu_contact[:, self.corner]
        self.corner_moving = self.torch.as_tensor(local.corner_moving, device=device)
        self.any_corner_moving = bool(local.corner_moving.any())
        #: per case, step and held pair: its holder's prescribed tangential value
        self.held_prescribed = self.prescribed[:, :, self.held_boundary, self.held[1]]
        # stops held tangentially at their node (``held_stops``)
        q = local.held_stops
        self.n_held_stops = q.size
        held_axis = 1 - np.argmax(np.abs(local.n_stop[q]), axis=1)
        self.held_stops = (index(q), index(held_axis),
                           self.torch.as_tensor(local.stop_held_boundary[q] >= 0, device=device),
                           index(np.maximum(local.stop_held_boundary[q], 0)),
                           index(np.maximum(local.stop_held_stop[q], 0)))
        self.contact_kernels: Any = None
        self.kernels_checked = False
        # the contact pairs and stop points of a cross point, run as one (``cross_points``)
        self.group_sides = tuple((index(points), tensor(share), tensor(k))
                                 for points, share, k in local.groups.sides)

    def use_kernels(self, local: LocalStage) -> None:
        """Contact and stops by the CUDA kernels of ``cuda_local`` (two launches instead of
        thousands of operations); their first answer is checked against these operations'
        (a warning and the operations from then on where they differ)."""
        from .cuda_local import ContactKernels

        # a stop held by another reads it at the same step, which the kernel's thread per
        # stop does not; a corner between moving holders slides; the pair thread of a
        # corner runs its stops again (``held_stops.open_arrivals``), which no other
        # thread may read: these operations do all three
        if self.n_held_stops or self.any_corner_moving or _shared_corner_stops(local):
            return
        self.contact_kernels = ContactKernels(self, local)

    def subset(self, cases: IntArray) -> None:
        """Keep the cases at positions ``cases`` (in place)."""
        chosen = self._index(cases)
        for name in ("mu_contact", "gap_contact", "mu_stop", "gap_stop", "prescribed",
                     "mu_corner", "held_prescribed", "corner_moving"):
            setattr(self, name, getattr(self, name)[chosen])

    def __call__(self, displacement: Tensor, force: Tensor) -> tuple[Tensor, Tensor]:
        torch = self.torch
        w_hat = torch.empty_like(displacement)
        f_hat = torch.empty_like(force)
        self._perfect_and_boundary(displacement, force, w_hat, f_hat)
        if self.n_macro_points:  # macro-only interface (eq. [20]), see ``macro_only_map``
            m, k = self.macro_points, self.k_macro
            x = displacement[:, :, m] - force[:, :, m] / k
            w_m = x + (x.reshape(-1, 2 * self.n_macro_points) @ self.macro_right_t
                       @ self.macro_left_t).reshape(x.shape)
            w_hat[:, :, m] = w_m
            f_hat[:, :, m] = force[:, :, m] + k * (w_m - displacement[:, :, m])
        if self.group_sides:
            fields = merged(displacement, force, self.group_sides)
            self._contact_stage(*fields, w_hat, f_hat)
            corrected(w_hat, displacement, force, fields, self.group_sides)
        elif self.n_pairs or self.n_stops:
            self._contact_stage(displacement, force, w_hat, f_hat)
        return w_hat, f_hat

    def _contact_stage(self, displacement: Tensor, force: Tensor, w_hat: Tensor,
                       f_hat: Tensor) -> None:
        """The contact and stops' part, by the CUDA kernels where they run."""
        if self.contact_kernels is None:
            self._contact_and_stops(displacement, force, w_hat, f_hat)
        elif not self.kernels_checked:
            self._check_kernels(displacement, force, w_hat, f_hat)
        else:
            self.contact_kernels(self, displacement, force, w_hat, f_hat)

    def _check_kernels(self, displacement: Tensor, force: Tensor, w_hat: Tensor,
                       f_hat: Tensor) -> None:
        """The operations' answer in (``w_hat``, ``f_hat``), compared with the kernels'."""
        kernel_w, kernel_f = w_hat.clone(), f_hat.clone()
        self._contact_and_stops(displacement, force, w_hat, f_hat)
        self.kernels_checked = True
        try:  # a first compilation for this GPU, and its launch
            self.contact_kernels(self, displacement, force, kernel_w, kernel_f)
        except Exception as exc:  # noqa: BLE001 - any failure: the operations go on
            log.warning("the CUDA contact kernels failed (%s); the torch operations run "
                        "instead", exc)
            self.contact_kernels = None
            return
        worst = max(float((x - y).abs().max() / y.abs().max().clamp(min=1e-300))
                    for x, y in ((kernel_w, w_hat), (kernel_f, f_hat)))
        if not worst <= KERNEL_CHECK_RTOL:
            log.warning("the CUDA contact kernels differ from the torch operations by %.1e "
                        "(relative); the operations run instead", worst)
            self.contact_kernels = None

    def _perfect_and_boundary(self, displacement: Tensor, force: Tensor, w_hat: Tensor,
                              f_hat: Tensor) -> None:
        """Perfect interfaces (eq. [8]) with the held-node rule, and prescribed components
        (``LocalStage._perfect_and_boundary``)."""
        torch = self.torch
        a, b = self.pairs
        k, kb = self.k_pair, self.k_pair_b
        wa, wb = displacement[:, :, a], displacement[:, :, b]
        fa, fb = force[:, :, a], force[:, :, b]
        w_pair = torch.where(self.pair_equal, 0.5 * (wa + wb) - (fa + fb) / (2.0 * k),
                             (k * wa + kb * wb - fa - fb) / (k + kb))
        f_pair = torch.where(self.pair_equal, 0.5 * (fa - fb) - 0.5 * k * (wa - wb),
                             fa + k * (w_pair - wa))
        w_hat[:, :, a] = w_pair
        w_hat[:, :, b] = w_pair
        f_hat[:, :, a] = f_pair
        f_hat[:, :, b] = -f_pair
        if self.n_held_pairs:
            j, d, pa, pb, held_boundary, on_b = self.held_pair
            data = self.prescribed[:, :, held_boundary, d]
            held_force = torch.where(on_b, fa[:, :, j, d] + k[j, d] * (data - wa[:, :, j, d]),
                                     -(fb[:, :, j, d] + kb[j, d] * (data - wb[:, :, j, d])))
            w_hat[:, :, pa, d] = data
            w_hat[:, :, pb, d] = data
            f_hat[:, :, pa, d] = held_force
            f_hat[:, :, pb, d] = -held_force
        bd, kbd, data = self.boundary, self.k_boundary, self.prescribed
        w, f = displacement[:, :, bd], force[:, :, bd]
        w_hat[:, :, bd] = torch.where(self.is_displacement, data, w + (data - f) / kbd)
        f_hat[:, :, bd] = torch.where(self.is_displacement, f + kbd * (data - w), data)

    def _in_cone(self, source: Tensor, normal_force: Tensor, normal: Tensor,
                 friction: Tensor) -> Tensor:
        """N n plus the tangential part of ``source``, limited to μ |N|."""
        torch = self.torch
        tangential = source - torch.sum(source * normal, dim=-1, keepdim=True) * normal
        size = torch.sqrt(torch.sum(tangential * tangential, dim=-1))
        limit = friction * torch.abs(normal_force)
        scale = torch.where(size > limit, limit / torch.clamp(size, min=1e-300), 1.0)
        return normal_force[..., None] * normal + scale[..., None] * tangential

    def _coulomb(self, trial: Tensor, normal_force: Tensor, normal: Tensor,
                 friction: Tensor) -> Tensor:
        """F̂ on side E from the trial force: contact where N ≤ 0, then stick or slip."""
        force = self._in_cone(trial, normal_force, normal, friction)
        return self.torch.where((normal_force <= 0.0)[..., None], force, 0.0)

    def _contact_and_stops(self, displacement: Tensor, force: Tensor, w_hat: Tensor,
                           f_hat: Tensor) -> None:
        """Contact with gap and Coulomb friction, rigid stops, held nodes and held corners,
        step after step (``LocalStage._contact_and_stops``, paper §3, eq. [16]–[17]).

        Every step's inputs are gathered once for all steps and its outputs scattered once
        at the end (a step reads views): the operations per iteration, each a kernel
        launch on a GPU, are what bounds the time of a batch there."""
        torch = self.torch
        n_cases, n_steps = displacement.shape[:2]
        options = {"dtype": displacement.dtype, "device": displacement.device}
        a, b = self.contact
        k, kb, n = self.k_contact, self.k_contact_b, self.n_contact
        p = self.stops
        force_a, force_b = force[:, :, a], force[:, :, b]
        shift_a, shift_b = displacement[:, :, a], displacement[:, :, b]
        force_p, shift_p = force[:, :, p], displacement[:, :, p]
        h, d, on_b = self.held
        if self.n_held:  # the held components, all steps
            held_force_a, held_force_b = force_a[:, :, h, d], force_b[:, :, h, d]
            held_shift_a, held_shift_b = shift_a[:, :, h, d], shift_b[:, :, h, d]
            held_data = self.held_prescribed
            k_h, kb_h = self.k_held
        prev_a = torch.zeros((n_cases, self.n_pairs, 2), **options)
        prev_b = torch.zeros_like(prev_a)
        prev_stop = torch.zeros((n_cases, self.n_stops, 2), **options)
        stop_closed = torch.zeros((n_cases, self.n_stops), dtype=torch.bool,
                                  device=displacement.device)
        corner_force = torch.zeros((n_cases, self.n_corners, 2), **options)
        stop_holds = stop_closed
        carried = stop_closed  # closed at the step before, after ``_open_arrivals``
        stop_forces: list[Tensor] = []
        stop_shifts, pair_forces, shifts_a, shifts_b = [], [], [], []
        for t in range(n_steps):
            if self.n_stops:
                dw = shift_p[:, t] - prev_stop
                trial = force_p[:, t] - self.k_stop * dw
                closing = self.gap_stop - torch.sum(self.n_stop * prev_stop, dim=-1)
                normal_force = (torch.sum(self.n_stop * trial, dim=-1)
                                + self.k_stop_normal * closing)
                fp = self._coulomb(trial, normal_force, self.n_stop, self.mu_stop)
                stop_closed = normal_force < 0.0
                # a corner's stop holds where its node was on it already
                stop_holds = stop_closed & attached(
                    closing, self.gap_stop, torch.sum(self.n_stop * shift_p[:, t], dim=-1),
                    torch.sum(self.n_stop * force_p[:, t], dim=-1), self.k_stop_normal)
                prev_stop = prev_stop + dw + (fp - force_p[:, t]) / self.k_stop
                if self.n_held_stops:
                    fp, prev_stop = self._hold_stops(t, fp, prev_stop, stop_closed,
                                                     stop_forces[-1] if t else None,
                                                     stop_holds)
                stop_forces.append(fp)
                stop_shifts.append(prev_stop)
            if not self.n_pairs:
                continue
            dwa = shift_a[:, t] - prev_a  # increments from the local-stage history
            dwb = shift_b[:, t] - prev_b
            # trial force F* = k* (F_a / k_a − F_b / k_b + [ΔW])
            if self.all_contact_equal:
                trial = 0.5 * (force_a[:, t] - force_b[:, t]) + self.half * (dwb - dwa)
            else:
                trial = torch.where(
                    self.contact_equal,
                    0.5 * (force_a[:, t] - force_b[:, t]) + self.half * (dwb - dwa),
                    self.half * (force_a[:, t] / k - force_b[:, t] / kb + dwb - dwa))
            closing = self.gap_contact + torch.sum(n * (prev_b - prev_a), dim=-1)
            normal_force = torch.sum(n * trial, dim=-1) + self.half_normal * closing
            if self.n_held:  # held on one side: tangential trial from the free side
                holding, target = self._held_targets(held_data[:, t], prev_stop, stop_closed)
                before_a, before_b = prev_a[:, h, d], prev_b[:, h, d]
                free_b = held_force_a[:, t] + k_h * (before_a + target - before_b
                                                     - held_shift_a[:, t])
                free_a = -(held_force_b[:, t] + kb_h * (before_b + target - before_a
                                                        - held_shift_b[:, t]))
                trial[:, h, d] = torch.where(holding, torch.where(on_b, free_b, free_a),
                                             trial[:, h, d])
            fa = self._coulomb(trial, normal_force, n, self.mu_contact)
            if self.n_corners:
                corner = self.corner
                if self.n_stops:
                    held = torch.all(self.corner_free
                                     | (stop_holds & carried)[:, self.corner_stops], dim=-1)
                else:
                    held = torch.all(self.corner_free, dim=-1).expand(n_cases, -1)
                if self.any_corner_moving:  # an operation (a launch) only where needed
                    held = held & ~self.corner_moving[:, t]
                current = fa[:, corner]
                frozen = self._in_cone(corner_force,
                                       torch.sum(current * self.n_corner, dim=-1),
                                       self.n_corner, self.mu_corner)
                corner_force = torch.where(held[..., None], frozen, current)
                fa[:, corner] = corner_force
            prev_a = prev_a + dwa + (fa - force_a[:, t]) / k
            prev_b = prev_b + dwb + (-fa - force_b[:, t]) / kb
            if self.n_held:  # the held side follows its holder
                prev_b[:, h, d] = torch.where(holding & on_b, target, prev_b[:, h, d])
                prev_a[:, h, d] = torch.where(holding & ~on_b, target, prev_a[:, h, d])
            pair_forces.append(fa)
            shifts_a.append(prev_a)
            shifts_b.append(prev_b)
            if self.n_corners and self.corner_sides:
                stop_closed, stop_forces[-1], prev_stop = self._open_arrivals(
                    trial, normal_force, held, (prev_a, prev_b), stop_closed,
                    stop_forces[-1], prev_stop, shift_p[:, t], force_p[:, t],
                    (displacement[:, t], force[:, t]))
                stop_shifts[-1] = prev_stop
            carried = stop_closed
        if self.n_stops:
            f_hat[:, :, p] = torch.stack(stop_forces, dim=1)
            w_hat[:, :, p] = torch.stack(stop_shifts, dim=1)
        if self.n_pairs:
            pair_force = torch.stack(pair_forces, dim=1)
            f_hat[:, :, a] = pair_force
            f_hat[:, :, b] = -pair_force
            w_hat[:, :, a] = torch.stack(shifts_a, dim=1)
            w_hat[:, :, b] = torch.stack(shifts_b, dim=1)

    def _open_arrivals(self, trial: Tensor, normal_force: Tensor, held: Tensor,
                       sides: tuple[Tensor, Tensor], stop_closed: Tensor, stop_force: Tensor,
                       stop_shift: Tensor, shift: Tensor, force: Tensor,
                       fields: tuple[Tensor, Tensor]) -> tuple[Tensor, Tensor, Tensor]:
        """Friction first at corners that are not held (``held_stops.open_arrivals``): the
        stops' closed status, F̂ and Ŵ of the step after it (``shift``, ``force``: the
        stops' W and F in the step; ``fields``: every point's W and F in the step)."""
        torch = self.torch
        corner, n = self.corner, self.n_corner
        source = trial[:, corner]
        tangential = source - torch.sum(source * n, dim=-1)[..., None] * n
        friction = torch.sqrt(torch.sum(tangential**2, dim=-1))
        pushed = normal_force[:, corner]
        stick = (pushed <= 0.0) & (friction <= self.mu_corner * -pushed) & ~held
        closed, stop_force, stop_shift = stop_closed.clone(), stop_force.clone(), stop_shift.clone()
        for side, q, i in self.corner_sides:
            normal = self.n_stop[i]
            gap = self.gap_stop[:, i]
            pair = corner[q]
            point = self.contact[side][pair]
            k = (self.k_contact, self.k_contact_b)[side][pair]
            size = (torch.sum(torch.abs(fields[0][:, point]), dim=-1)
                    + torch.sum(torch.abs(fields[1][:, point]) / k, dim=-1))
            beyond = torch.sum(normal * sides[side][:, pair], dim=-1) - gap
            reached = beyond_stop(beyond, gap, size)
            opens = (stop_closed[:, i] & stick[:, q] & ~reached)[..., None]
            stop_force[:, i] = torch.where(opens, torch.zeros_like(force[:, i]), stop_force[:, i])
            stop_shift[:, i] = torch.where(opens, shift[:, i] - force[:, i] / self.k_stop[i],
                                           stop_shift[:, i])
            closed[:, i] &= ~opens[..., 0]
        return closed, stop_force, stop_shift

    def _hold_stops(self, t: int, fp: Tensor, prev_stop: Tensor, stop_closed: Tensor,
                    previous: Tensor | None, stop_holds: Tensor) -> tuple[Tensor, Tensor]:
        """The held stops' F̂ and Ŵ in step ``t`` (``held_stops.hold_stops``), as new
        tensors; ``previous``: every stop's F̂ of the step before."""
        torch = self.torch
        q, d, by_boundary, boundary, holder = self.held_stops
        now = self.prescribed[:, t, boundary, d]
        before = self.prescribed[:, t - 1, boundary, d] if t > 0 else torch.zeros_like(now)
        holding = torch.where(by_boundary, now == before, stop_holds[:, holder])
        target = torch.where(by_boundary, now, prev_stop[:, holder, d])
        bound = torch.where(stop_closed[:, q], -self.mu_stop[:, q] * torch.sum(
            self.n_stop[q] * fp[:, q], dim=-1), 0.0)
        kept = previous[:, q, d] if previous is not None else torch.zeros_like(bound)
        fp, prev_stop = fp.clone(), prev_stop.clone()
        fp[:, q, d] = torch.where(holding, torch.minimum(torch.maximum(kept, -bound), bound),
                                  fp[:, q, d])
        prev_stop[:, q, d] = torch.where(holding, target, prev_stop[:, q, d])
        return fp, prev_stop

    def _held_targets(self, data: Tensor, stop_displacement: Tensor, stop_closed: Tensor
                      ) -> tuple[Tensor, Tensor]:
        """Per case and held pair, in one step: whether its holder holds and the held
        node's tangential Ŵ (``LocalStage._held_targets``); ``data``: the step's prescribed
        values of the holders."""
        torch = self.torch
        d = self.held[1]
        by_boundary = self.held_by_boundary
        if self.n_stops:
            target = torch.where(by_boundary, data, stop_displacement[:, self.held_stop, d])
            holding = by_boundary | stop_closed[:, self.held_stop]
        else:
            target = torch.where(by_boundary, data, 0.0)
            holding = by_boundary.expand_as(target)
        return holding, target


def _converter(torch: Any, device: torch.device) -> Any:
    def tensor(array: Any) -> Tensor:
        return torch.as_tensor(np.ascontiguousarray(array, dtype=np.float64), device=device)
    return tensor


def _index_converter(torch: Any, device: torch.device) -> Any:
    def index(array: Any) -> Tensor:
        return torch.as_tensor(np.ascontiguousarray(array, dtype=np.int64), device=device)
    return index


def _shared_corner_stops(local: LocalStage) -> bool:
    """Whether a corner's stop is another corner's, or holds a pair or a stop (the CUDA
    pair kernel's thread of a corner writes its stops: ``cuda_local``)."""
    stops = local.corner_stops[local.corner_stops >= 0]
    holders = np.r_[local.held_stop[local.held_stop >= 0],
                    local.stop_held_stop[local.stop_held_stop >= 0]]
    return bool(np.unique(stops).size < stops.size or np.isin(stops, holders).any())
