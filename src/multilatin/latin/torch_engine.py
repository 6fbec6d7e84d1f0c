"""The iteration's field work on PyTorch (``LatinOptions(backend="torch", device=...)``),
on a CPU or a GPU, in fp64 (issue 19).

The operators are built with SciPy as for the NumPy backend (``LatinOperators``, once per
geometry) and moved to the device once: the condensed operators C_E as stacked dense
blocks, grouped by size so that one batched product serves every substructure of a size;
the macro problem per substructure on its own macro unknowns (its rows of Π = Ẽᵀ M0, of
Q = C k Ẽ and of Ẽ, stacked the same way; L⁻¹ dense). A linear stage for all steps of all
cases of a batch is then a few batched matrix products, the local stage
``torch_local.TorchLocalStage``. Only η's norms and the tracked QoIs (a few numbers per
case) come back to the host each iteration.
"""

from __future__ import annotations

import importlib
import time
from typing import Any

import numpy as np

from ..errors import ModelError
from ..fem.elasticity import FloatArray, IntArray
from ..limits import memory_limit
from .local_stage import LocalStage
from .operators import LatinOperators
from .options import LatinOptions
from .torch_local import Tensor, TorchLocalStage
from .tracking import QoiFunctionals

__all__ = ["DeviceOperators", "TorchFields", "cases_per_chunk", "load_torch"]

#: the extra that installs PyTorch
INSTALL_HINT = "pip install 'multilatin[gpu]'"


def load_torch(device: str) -> Any:
    """PyTorch, checked for ``device``; a ``ModelError`` naming the option otherwise."""
    try:
        torch = importlib.import_module("torch")
    except ImportError:
        raise ModelError(f"backend: 'torch' needs PyTorch, which is not installed "
                         f"({INSTALL_HINT})") from None
    if device.startswith("cuda"):
        if not torch.cuda.is_available():
            raise ModelError(f"device: {device!r} asked for, but PyTorch sees no CUDA GPU "
                             f"(torch {torch.__version__}; use device 'cpu')")
        index = int(device.split(":")[1]) if ":" in device else 0
        if index >= torch.cuda.device_count():
            raise ModelError(f"device: {device!r} asked for, but PyTorch sees "
                             f"{torch.cuda.device_count()} GPU(s)")
    return torch


#: field-sized arrays (n_steps × n_points × 2 doubles) alive at once per case of a batch:
#: s, ŝ, the new s, the linear stage's right-hand side and products, the macro correction,
#: the local stage's temporaries and the solver's host copies; measured 20.6 on the CPU
#: build (peak RSS growth, 400 b3 cases), taken with a margin
FIELDS_PER_CASE = 24
#: share of the free device memory a batch may take
MEMORY_SHARE = 0.7


def cases_per_chunk(n_steps: int, n_points: int, device: str) -> int:
    """How many cases of this shape a batch may hold on ``device``: the free memory (CUDA's
    own count on a GPU, the limit of ``multilatin.limits`` on the CPU) over the fields'
    footprint. A ``ModelError`` when not even one case fits."""
    torch = load_torch(device)
    if device.startswith("cuda"):
        free, _ = torch.cuda.mem_get_info(torch.device(device))
        source = f"{free / 2**30:.1f} GiB free on {device}"
    else:
        free, source = memory_limit()
    per_case = FIELDS_PER_CASE * n_steps * n_points * 2 * 8
    fits = int(MEMORY_SHARE * free // per_case)
    if fits < 1:
        raise ModelError(f"device: one case needs about {per_case / 2**20:.0f} MiB of "
                         f"fields, more than {MEMORY_SHARE:.0%} of what is left ({source})")
    return fits


class DeviceOperators:
    """``LatinOperators``' linear stage on a torch device (eq. [13]–[15])."""

    def __init__(self, ops: LatinOperators, torch: Any, device: Any) -> None:
        self.torch = torch

        def tensor(array: Any) -> Tensor:
            return torch.as_tensor(np.ascontiguousarray(array, dtype=np.float64),
                                   device=device)

        self.n_points = ops.points.n_points
        self.k = tensor(ops.search_direction)
        self.has_macro = ops.macro_basis is not None
        basis = ops.macro_basis.tocsr() if ops.macro_basis is not None else None
        self.n_macro = basis.shape[1] if basis is not None else 0
        # per block size: the substructures' flat indices (G, n), C_Eᵀ stacked (G, n, n),
        # and for the macro problem each one's own macro unknowns (G, m; padded with the
        # index n_macro of a zero column), Q_Eᵀ and Ẽ_Eᵀ (G, m, n) and M0 Ẽ_E (G, n, m)
        sizes: dict[int, list[int]] = {}
        for s, (lo, hi) in enumerate(ops.flat_ranges):
            sizes.setdefault(hi - lo, []).append(s)
        self.groups = []
        for n, members in sizes.items():
            blocks = [ops.substructure_operators[s] for s in members]
            indices = np.stack([np.arange(*ops.flat_ranges[s]) for s in members])
            group = {"indices": torch.as_tensor(indices, device=device),
                     "condensed_t": tensor(np.stack([b.condensed_transposed for b in blocks]))}
            if basis is not None:
                width = max(b.macro_columns.size for b in blocks)
                columns = np.full((len(members), width), self.n_macro, dtype=np.int64)
                response_t = np.zeros((len(members), width, n))
                basis_t = np.zeros((len(members), width, n))
                project = np.zeros((len(members), n, width))
                for i, (s, block) in enumerate(zip(members, blocks, strict=True)):
                    lo, hi = ops.flat_ranges[s]
                    used = block.macro_columns.size
                    columns[i, :used] = block.macro_columns
                    response_t[i, :used] = block.macro_response.T
                    own = basis[lo:hi][:, block.macro_columns].toarray()
                    basis_t[i, :used] = own.T
                    project[i, :, :used] = ops.m0[lo:hi, None] * own
                group.update(columns=torch.as_tensor(columns, device=device),
                             response_t=tensor(response_t), basis_t=tensor(basis_t),
                             project=tensor(project))
            self.groups.append(group)
        if basis is not None:
            self.homogenised_inverse = tensor(ops.homogenised_inverse)

    def micro_stage(self, w_hat: Tensor, f_hat: Tensor) -> tuple[Tensor, Tensor]:
        """W = C (F̂ + k Ŵ), F = F̂ + k (Ŵ − W) (eq. [13]) on fields (n, n_points, 2)."""
        shape = w_hat.shape
        rhs = (f_hat + self.k * w_hat).reshape(shape[0], -1)
        flat = self.torch.empty_like(rhs)
        for group in self.groups:
            indices = group["indices"]
            # (G, columns, n) @ (G, n, n): one batched product per block size
            part = self.torch.matmul(rhs[:, indices].transpose(0, 1), group["condensed_t"])
            flat[:, indices] = part.transpose(0, 1)
        displacement = flat.reshape(shape)
        return displacement, f_hat + self.k * (w_hat - displacement)

    def macro_correction(self, displacement: Tensor, force: Tensor, data: Tensor
                         ) -> tuple[Tensor, Tensor]:
        """W̃ᴹ = L⁻¹ (F_dᴹ − Π F), W += Q W̃ᴹ, F += k (Ẽ W̃ᴹ − Q W̃ᴹ) (eq. [14]–[15])."""
        torch = self.torch
        shape = displacement.shape
        n_columns = shape[0]
        flat_force = force.reshape(n_columns, -1)
        residual = torch.zeros((n_columns, self.n_macro + 1), dtype=force.dtype,
                               device=force.device)
        residual[:, :self.n_macro] = data
        for group in self.groups:  # − Π F, substructure by substructure
            part = torch.matmul(flat_force[:, group["indices"]].transpose(0, 1),
                                group["project"])
            residual.index_add_(1, group["columns"].reshape(-1),
                                part.transpose(0, 1).reshape(n_columns, -1), alpha=-1.0)
        macro = torch.zeros_like(residual)
        macro[:, :self.n_macro] = residual[:, :self.n_macro] @ self.homogenised_inverse
        correction = torch.empty_like(flat_force)
        extension = torch.empty_like(flat_force)
        for group in self.groups:  # Q_E W̃ᴹ and Ẽ_E W̃ᴹ on E's own macro unknowns
            indices = group["indices"]
            own = macro[:, group["columns"]].transpose(0, 1)  # (G, columns, m)
            correction[:, indices] = torch.matmul(own, group["response_t"]).transpose(0, 1)
            extension[:, indices] = torch.matmul(own, group["basis_t"]).transpose(0, 1)
        correction_field = correction.reshape(shape)
        return (displacement + correction_field,
                force + self.k * (extension.reshape(shape) - correction_field))


class TorchFields:
    """``engine.FieldEngine`` on PyTorch: the NumPy backend's formulas, fp64, on
    ``options.device``."""

    def __init__(self, ops: LatinOperators, local: LocalStage, options: LatinOptions,
                 w_hat: FloatArray, f_hat: FloatArray, macro_data: FloatArray | None,
                 functionals: list[QoiFunctionals] | None) -> None:
        if options.acceleration != "relaxation":
            raise ModelError(f"acceleration: {options.acceleration!r} runs on the numpy "
                             "backend only (the torch backend relaxes)")
        torch = self.torch = load_torch(options.device)
        self.device = torch.device(options.device)
        self.cuda = self.device.type == "cuda"
        self.options = options
        self.operators = _device_operators(ops, self.device.type, self.device.index, torch)
        self.local = TorchLocalStage(local, torch, self.device)
        self.w_hat, self.f_hat = self._tensor(w_hat), self._tensor(f_hat)
        self.w: Tensor | None = None
        self.f: Tensor | None = None
        self.macro_data = self._tensor(macro_data) if macro_data is not None else None
        self.active = np.arange(w_hat.shape[0])
        self.functionals = functionals
        self.shared = functionals is not None and all(f is functionals[0] for f in functionals)
        self.qoi_parts = ([self._qoi_parts(f) for f in functionals]
                          if functionals is not None else [])
        k = ops.search_direction
        self.displacement_weight = self._tensor((ops.points.weights[:, None] * k).ravel())
        self.force_weight = self._tensor((ops.points.weights[:, None] / k).ravel())
        self.t_linear = self.t_macro = self.t_local = 0.0

    def _tensor(self, array: Any) -> Tensor:
        return self.torch.as_tensor(np.ascontiguousarray(array, dtype=np.float64),
                                    device=self.device)

    def _qoi_parts(self, functionals: QoiFunctionals) -> list[tuple[Tensor, Tensor]]:
        return [(self.torch.as_tensor(used, device=self.device), self._tensor(coefficients))
                for used, coefficients in functionals.parts]

    def _clock(self) -> float:
        if self.cuda:
            self.torch.cuda.synchronize(self.device)
        return time.perf_counter()

    def linear_stage(self, relaxation: FloatArray) -> None:
        ta = self._clock()
        ops = self.operators
        flat = (-1, ops.n_points, 2)
        shape = self.w_hat.shape
        w_new, f_new = ops.micro_stage(self.w_hat.reshape(flat), self.f_hat.reshape(flat))
        tm = self._clock()
        if self.macro_data is not None:
            data = self.macro_data[self._index(self.active)]
            w_new, f_new = ops.macro_correction(w_new, f_new,
                                                data.reshape(-1, data.shape[2]))
        self.t_macro += self._clock() - tm
        w_new, f_new = w_new.reshape(shape), f_new.reshape(shape)
        if self.w is None or self.f is None or self.options.relaxation == 1.0:
            self.w, self.f = w_new, f_new
        else:
            omega = self._tensor(relaxation)[:, None, None, None]
            self.w = omega * w_new + (1.0 - omega) * self.w
            self.f = omega * f_new + (1.0 - omega) * self.f
        self.t_linear += self._clock() - ta

    def local_stage(self) -> None:
        tb = self._clock()
        self.w_hat, self.f_hat = self.local(self.w, self.f)
        self.t_local += self._clock() - tb

    def qoi_values(self) -> FloatArray:
        assert self.w is not None and self.f is not None
        fields = (self.w, self.f, self.f_hat)
        n_cases, n_steps = self.w.shape[:2]
        if self.shared:
            parts = self.qoi_parts[0]
            n_qoi = len(self.functionals[0].names) if self.functionals else 0
            total = self.torch.zeros((n_cases * n_steps, n_qoi), dtype=self.torch.float64,
                                     device=self.device)
            for (used, coefficients), values in zip(parts, fields, strict=True):
                if used.numel():
                    total = total + values.reshape(n_cases * n_steps, -1)[:, used] @ coefficients
            out = total.reshape(n_cases, n_steps, n_qoi).transpose(1, 2)
            return np.asarray(out.cpu().numpy(), dtype=np.float64)
        assert self.functionals is not None
        w, f, f_hat = (x.cpu().numpy() for x in fields)
        return np.stack([self.functionals[c].values(w[i:i + 1], f[i:i + 1],
                                                    f_hat[i:i + 1])[0]
                         for i, c in enumerate(self.active)])

    def indicator(self) -> tuple[FloatArray, FloatArray]:
        assert self.w is not None and self.f is not None

        def squares(w: Tensor, f: Tensor) -> Tensor:
            n_cases = w.shape[0]
            dw, fw = self.displacement_weight, self.force_weight
            return ((w * w).reshape(n_cases, -1, dw.numel()).sum(dim=1) @ dw
                    + (f * f).reshape(n_cases, -1, fw.numel()).sum(dim=1) @ fw)

        stacked = self.torch.stack([squares(self.w - self.w_hat, self.f - self.f_hat),
                                    squares(self.w, self.f),
                                    squares(self.w_hat, self.f_hat)])
        norms = np.sqrt(stacked.cpu().numpy())
        return norms[0], 0.5 * (norms[1] + norms[2])

    def fields(self, cases: IntArray | None = None
               ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        assert self.w is not None and self.f is not None
        out = []
        for x in (self.w, self.f, self.w_hat, self.f_hat):
            chosen = x if cases is None else x[self._index(cases)]
            out.append(np.asarray(chosen.cpu().numpy(), dtype=np.float64))
        return out[0], out[1], out[2], out[3]

    def keep(self, cases: IntArray) -> None:
        assert self.w is not None and self.f is not None
        chosen = self._index(cases)
        self.active = self.active[cases]
        self.w, self.f = self.w[chosen], self.f[chosen]
        self.w_hat, self.f_hat = self.w_hat[chosen], self.f_hat[chosen]
        self.local.subset(cases)

    def _index(self, cases: IntArray) -> Tensor:
        return self.torch.as_tensor(np.asarray(cases, dtype=np.int64), device=self.device)


_DEVICE_OPERATORS: dict[tuple[int, str], tuple[LatinOperators, DeviceOperators]] = {}


def _device_operators(ops: LatinOperators, device_type: str, device_index: int | None,
                      torch: Any) -> DeviceOperators:
    """The operators moved to the device once per ``LatinOperators`` and device (a study
    reuses one geometry's operators for every friction pair); the last few are kept."""
    key = (id(ops), f"{device_type}:{device_index}")
    held = _DEVICE_OPERATORS.get(key)
    if held is not None and held[0] is ops:
        return held[1]
    moved = DeviceOperators(ops, torch, torch.device(device_type, device_index)
                            if device_index is not None else torch.device(device_type))
    if len(_DEVICE_OPERATORS) >= 4:
        _DEVICE_OPERATORS.pop(next(iter(_DEVICE_OPERATORS)))
    _DEVICE_OPERATORS[key] = (ops, moved)
    return moved
