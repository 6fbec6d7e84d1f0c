"""The iteration's field work on PyTorch (``LatinOptions(backend="torch", device=...)``),
on a CPU or a GPU, in fp64 (issue 19): ``TorchFields``, the ``field_engine.FieldEngine`` of the
torch backend, with the linear stage of ``torch_operators`` and the local stage of
``torch_local``. Only η's norms and the tracked QoIs (a few numbers per case) come back to
the host each iteration. A batch may hold cases of several geometries that share the
interface discretisation (B3's hole positions).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..fem.elasticity import FloatArray, IntArray
from .acceleration import Anderson, ArrayOps
from .engine import as_run
from .local_stage import LocalStage
from .operators import LatinOperators
from .options import LatinOptions
from .torch_graph import DeviceGraph, load_torch
from .torch_local import Tensor, TorchLocalStage, contact_kernels_available
from .torch_operators import DeviceOperators, Rows
from .tracking import QoiFunctionals
from .two_scale import coupled_local_stage

__all__ = ["DeviceOperators", "TorchFields", "load_torch"]

log = logging.getLogger(__name__)

#: the devices on which a batch keeps the rows of cases that left it until at most
#: ``COMPACT_BELOW`` of them remain (then compacts: a new width, new CUDA graphs, as a graph
#: holds its shapes, ``torch_graph.DeviceGraph``; a smaller fraction, fewer captures for
#: more idle rows: ``gpu.py --compact-below``). Tests add "cpu" (no graph there).
PADDED_DEVICES = ("cuda",)
COMPACT_BELOW = 0.5
#: the devices on which a padded batch's whole iteration — linear stage with the macro
#: problem, relaxation, local stage, η's norms and the tracked QoIs — is one graph per
#: width (``TorchFields._iteration``); its first replay is checked against the operations.
#: (Tests add "cpu", where the same function runs eagerly, to check the bookkeeping.)
FUSED_DEVICES = ("cuda",)
#: largest relative difference between the iteration graph's first replay and the same
#: operations one by one (CUDA's atomic sums round in any order; a defect, far more)
GRAPH_CHECK_RTOL = 1e-9


class TorchFields:
    """``field_engine.FieldEngine`` on PyTorch: the NumPy backend's formulas, fp64, on
    ``options.device``."""

    def __init__(self, operators: list[LatinOperators], geometry: IntArray,
                 local: LocalStage, options: LatinOptions, w_hat: FloatArray,
                 f_hat: FloatArray, macro_data: FloatArray | None,
                 functionals: list[QoiFunctionals] | None) -> None:
        """operators: one per geometry; geometry: each case's index into them."""
        torch = self.torch = load_torch(options.device)
        self.device = torch.device(options.device)
        self.cuda = self.device.type == "cuda"
        self.options = options
        self.operators = _device_operators(operators, self.device, torch)
        self.local = TorchLocalStage(local, torch, self.device)
        if self.cuda and not options.fuse and contact_kernels_available():
            self.local.use_kernels(local)
        self.local_call = _fused(torch) if options.fuse else TorchLocalStage.__call__
        self.w_hat, self.f_hat = self._tensor(w_hat), self._tensor(f_hat)
        self.w: Tensor | None = None
        self.f: Tensor | None = None
        self.macro_data = self._tensor(macro_data) if macro_data is not None else None
        self.body = self._tensor(local.body) if local.body is not None else None
        self.active = np.arange(w_hat.shape[0])
        self.geometry = np.asarray(geometry, dtype=np.int64)
        self.n_steps = w_hat.shape[1]
        self.rows = self._rows()
        self.n_qoi = len(functionals[0].names) if functionals else 0
        #: per field (W, F, F̂): the columns any case's QoIs read, and each active case's
        #: coefficients on them (n_active, n_columns, n_qoi)
        self.qoi_parts: list[tuple[Tensor, Tensor]] = []
        #: per row, body forces' share of the QoIs (``QoiFunctionals.constant``) or None
        self.qoi_constant = (np.stack([np.zeros((self.n_qoi, self.n_steps)) if f.constant is
                                       None else f.constant for f in functionals])
                             if functionals and any(f.constant is not None for f in functionals)
                             else None)
        if functionals:
            distinct = list({id(f): f for f in functionals}.values())
            which = {id(f): i for i, f in enumerate(distinct)}
            functional_of = self._index(np.array([which[id(f)] for f in functionals]))
            for part in range(3):  # the union of the columns read
                used = np.unique(np.concatenate([f.parts[part][0] for f in distinct]))
                coefficients = np.zeros((len(distinct), used.size, self.n_qoi))
                for i, f in enumerate(distinct):
                    own, values = f.parts[part]
                    coefficients[i, np.searchsorted(used, own)] = values
                self.qoi_parts.append((self._index(used),
                                       self._tensor(coefficients)[functional_of]))
        k = operators[0].indicator_k  # the norm's k (without corner stiffening)
        weights = operators[0].points.weights[:, None]
        self.displacement_weight = self._tensor((weights * k).ravel())
        self.force_weight = self._tensor((weights / k).ravel())
        self.mixer = (Anderson(options.anderson_depth, options.relaxation,
                               self._tensor(np.sqrt(weights * k)),
                               self._tensor(np.sqrt(weights / k)), self._array_ops())
                      if options.acceleration == "anderson" else None)
        self.t_linear = self.t_macro = self.t_local = 0.0
        #: the rows of the active cases in the fields; rows of cases that left stay (and
        #: are iterated along, each row on its own) until at most half are active
        self.slots = np.arange(w_hat.shape[0])
        self.padded = (self.device.type in PADDED_DEVICES and self.mixer is None
                       and not options.fuse)
        self.graph = (DeviceGraph(torch, self._local_fields)
                      if self.padded and self.cuda else None)
        #: the whole iteration as one graph (``FUSED_DEVICES``); ``_omega`` holds the
        #: relaxation of a linear stage deferred to it, ``_results`` its norms and QoIs
        self.iteration_graph = (DeviceGraph(torch, self._iteration, eager=not self.cuda)
                                if self.padded and self.device.type in FUSED_DEVICES
                                else None)
        self.graph_checked = False
        self._omega: Tensor | None = None
        self._results: dict[str, Tensor] = {}
        two_scale = self.operators.two_scale
        #: Eᵀ M0 Ŵ per case and step, where the coupled local stage starts (``two_scale``)
        self.side_macro = (two_scale.project(self.w_hat.reshape(-1, 2 * w_hat.shape[2]))
                           .reshape(*w_hat.shape[:2], -1) if two_scale is not None else None)

    def _tensor(self, array: Any) -> Tensor:
        return self.torch.as_tensor(np.ascontiguousarray(array, dtype=np.float64),
                                    device=self.device)

    def _array_ops(self) -> ArrayOps:
        torch, options = self.torch, {"dtype": self.torch.float64, "device": self.device}
        return ArrayOps(lambda arrays, axis: torch.cat(arrays, dim=axis),
                        lambda shape: torch.zeros(shape, **options),
                        lambda m: torch.eye(m, **options), torch.linalg.solve)

    def _rows(self) -> Rows:
        """Per geometry of the active cases, the columns (case × step) of its cases."""
        geometry = self.geometry[self.active]
        rows: Rows = []
        for g in np.unique(geometry):
            cases = np.flatnonzero(geometry == g)
            if cases[-1] - cases[0] + 1 == cases.size:  # contiguous: a view
                rows.append((int(g), slice(int(cases[0]) * self.n_steps,
                                           (int(cases[-1]) + 1) * self.n_steps)))
            else:
                columns = (cases[:, None] * self.n_steps + np.arange(self.n_steps)).ravel()
                rows.append((int(g), self._index(columns)))
        return rows

    def _clock(self) -> float:
        if self.cuda:
            self.torch.cuda.synchronize(self.device)
        return time.perf_counter()

    def linear_stage(self, relaxation: FloatArray) -> None:
        self._results = {}
        if self.iteration_graph is not None and self.w is not None:
            self._omega = self._per_row(relaxation)
            return  # with the local stage, as one graph (``local_stage``)
        ta = self._clock()
        w_new, f_new = self._linear(self.w_hat, self.f_hat, timed=True)
        if self.w is None or self.f is None or (self.options.relaxation == 1.0
                                                and self.mixer is None):
            self.w, self.f = w_new, f_new
        elif self.mixer is not None:
            self.w, self.f = self.mixer(self.w, self.f, w_new, f_new)
        else:  # one ω for the batch unless some case's was lowered (no host copy then)
            omega: Any = (float(relaxation[0]) if np.all(relaxation == relaxation[0])
                          else self._per_row(relaxation))
            self.w, self.f = _relaxed(omega, w_new, self.w), _relaxed(omega, f_new, self.f)
        self.t_linear += self._clock() - ta

    def _per_row(self, relaxation: FloatArray) -> Tensor:
        """ω per row of the fields, (rows, 1, 1, 1): the active cases' own, 1 for the rows
        of cases that left (iterated along, unrelaxed)."""
        assert self.w is not None
        per_row = np.ones(self.w.shape[0])
        per_row[self.slots] = relaxation
        return self._tensor(per_row)[:, None, None, None]

    def _linear(self, w_hat: Tensor, f_hat: Tensor, timed: bool = False
                ) -> tuple[Tensor, Tensor]:
        """W, F from Ŵ, F̂: the micro stage and the macro correction (eq. [13]–[15]);
        ``timed``: the macro problem's time counted apart (never inside a graph's capture,
        where the clock's synchronisation is not allowed)."""
        ops = self.operators
        flat = (-1, ops.n_points, 2)
        w_new, f_new = ops.micro_stage(w_hat.reshape(flat), f_hat.reshape(flat), self.rows,
                                       None if self.body is None else self.body.reshape(flat))
        tm = self._clock() if timed else 0.0
        if self.macro_data is not None:
            w_new, f_new = ops.macro_correction(
                w_new, f_new, self.macro_data.reshape(-1, self.macro_data.shape[2]),
                self.rows)
        if timed:
            self.t_macro += self._clock() - tm
        return w_new.reshape(w_hat.shape), f_new.reshape(f_hat.shape)

    def _iteration(self, w_hat: Tensor, f_hat: Tensor, w: Tensor, f: Tensor, omega: Tensor,
                   *side_macro: Tensor) -> tuple[Tensor, ...]:
        """One whole iteration as a function of its inputs (what ``iteration_graph``
        captures): the linear stage, relaxation by ``omega`` per row, the local stage,
        then η's squared norms and the tracked QoIs. Returns (W, F, Ŵ, F̂[, Eᵀ M0 Ŵ],
        norms, QoIs)."""
        w_new, f_new = self._relaxed_linear(w_hat, f_hat, w, f, omega)
        local = self._local_fields(w_new, f_new, *side_macro)
        return (w_new, f_new, *local, self._norm_squares(w_new, f_new, local[0], local[1]),
                self._qoi_total(w_new, f_new, local[1]))

    def _settle(self) -> None:
        """A linear stage deferred to the iteration graph, done now on its own (the fields
        are asked for before the local stage)."""
        if self._omega is None:
            return
        assert self.w is not None and self.f is not None
        omega, self._omega = self._omega, None
        self.w, self.f = self._relaxed_linear(self.w_hat, self.f_hat, self.w, self.f, omega)

    def _relaxed_linear(self, w_hat: Tensor, f_hat: Tensor, w: Tensor, f: Tensor,
                        omega: Tensor) -> tuple[Tensor, Tensor]:
        """The linear stage from ŝ, relaxed by ``omega`` per row against s = (W, F) (none
        where the options' relaxation is 1, as ``linear_stage``)."""
        w_new, f_new = self._linear(w_hat, f_hat)
        if self.options.relaxation == 1.0:
            return w_new, f_new
        return _relaxed(omega, w_new, w), _relaxed(omega, f_new, f)

    def _fused_step(self) -> None:
        """The deferred linear stage and the local stage as one replay of the iteration
        graph; its first replay is compared with the operations run one by one, and a
        difference (or a failed capture) is a warning and the operations from then on."""
        assert self.w is not None and self.f is not None and self._omega is not None
        assert self.iteration_graph is not None
        tb = self._clock()
        inputs = (self.w_hat, self.f_hat, self.w, self.f, self._omega) + (
            () if self.side_macro is None else (self.side_macro,))
        outputs = self.iteration_graph(inputs)
        if outputs is not None and not self.graph_checked:
            self.graph_checked = True
            expected = self._iteration(*inputs)
            worst = max((_difference(x, y) for x, y in zip(outputs, expected, strict=True)),
                        default=0.0)
            if not worst <= GRAPH_CHECK_RTOL:
                log.warning("the iteration graph's first replay differs from the operations "
                            "by %.1e (relative); the operations run instead", worst)
                self.iteration_graph, outputs = None, expected
        if outputs is None:  # the capture failed (said so): operation by operation
            self.iteration_graph = None
            outputs = self._iteration(*inputs)
        self._omega = None
        self.w, self.f, self.w_hat, self.f_hat = outputs[:4]
        if self.side_macro is not None:
            self.side_macro = outputs[4]
        self._results = {"norms": outputs[-2], "qoi": outputs[-1]}
        self.t_local += self._clock() - tb

    def local_stage(self) -> None:
        if self._omega is not None:
            self._fused_step()
            return
        tb = self._clock()
        assert self.w is not None and self.f is not None
        inputs = (self.w, self.f) + (() if self.side_macro is None else (self.side_macro,))
        if self.graph is not None:
            outputs = self.graph(inputs)
            if outputs is None:  # the capture failed: eager from now on
                self.graph = None
                outputs = self._local_fields(*inputs)
        else:
            outputs = self._local_fields(*inputs)
        self.w_hat, self.f_hat = outputs[0], outputs[1]
        if self.side_macro is not None:
            self.side_macro = outputs[2]
        self.t_local += self._clock() - tb

    def _local_fields(self, w: Tensor, f: Tensor, *side_macro: Tensor) -> tuple[Tensor, ...]:
        """ŝ = (Ŵ, F̂) from s = (W, F), with the two-scale coupling's Eᵀ M0 Ŵ where the
        direction has one (``side_macro``, set exactly when there is a two-scale H)."""
        if side_macro:
            assert self.operators.two_scale is not None
            return coupled_local_stage(lambda w, f: self.local_call(self.local, w, f), None,
                                       self.operators.two_scale, w, f, side_macro[0])
        return tuple(self.local_call(self.local, w, f))

    def _qoi_total(self, w: Tensor, f: Tensor, f_hat: Tensor) -> Tensor:
        """The tracked QoIs of every row, (rows, steps, QoIs), from W, F and F̂."""
        n_cases, n_steps = w.shape[:2]
        total = self.torch.zeros((n_cases, n_steps, self.n_qoi), dtype=self.torch.float64,
                                 device=self.device)
        for (used, coefficients), values in zip(self.qoi_parts, (w, f, f_hat), strict=True):
            if used.numel():  # (cases, steps, columns read) @ each case's coefficients
                total = total + self.torch.bmm(values.reshape(n_cases, n_steps, -1)[:, :, used],
                                               coefficients)
        return total

    def qoi_values(self) -> FloatArray:
        assert self.w is not None and self.f is not None
        total = self._results.get("qoi")
        if total is None:
            total = self._qoi_total(self.w, self.f, self.f_hat)
        values = np.asarray(total.transpose(1, 2).cpu().numpy(), dtype=np.float64)
        if self.qoi_constant is not None:
            values = values + self.qoi_constant
        return values if self.slots.size == self.w.shape[0] else values[self.slots]

    def qoi_magnitudes(self) -> FloatArray:
        assert self.w is not None and self.f is not None
        torch = self.torch
        n_cases, n_steps = self.w.shape[:2]
        total = torch.zeros((n_cases, n_steps, self.n_qoi), dtype=torch.float64,
                            device=self.device)
        for (used, coefficients), values in zip(self.qoi_parts, (self.w, self.f, self.f_hat),
                                                strict=True):
            if used.numel():
                total = total + torch.bmm(
                    values.reshape(n_cases, n_steps, -1)[:, :, used].abs(), coefficients.abs())
        out = np.asarray(total.transpose(1, 2).cpu().numpy(), dtype=np.float64)
        if self.qoi_constant is not None:
            out = out + np.abs(self.qoi_constant)
        return out if self.slots.size == self.w.shape[0] else out[self.slots]

    def _norm_squares(self, w: Tensor, f: Tensor, w_hat: Tensor, f_hat: Tensor) -> Tensor:
        """‖s − ŝ‖², ‖s‖², ‖ŝ‖² of every row (§4.3), stacked (3, rows)."""
        squares = self._squares
        return self.torch.stack([squares(w - w_hat, f - f_hat), squares(w, f),
                                 squares(w_hat, f_hat)])

    def _squares(self, w: Tensor, f: Tensor) -> Tensor:
        """‖(w, f)‖² per row in the indicator's norm (§4.3)."""
        n_cases = w.shape[0]
        dw, fw = self.displacement_weight, self.force_weight
        return ((w * w).reshape(n_cases, -1, dw.numel()).sum(dim=1) @ dw
                + (f * f).reshape(n_cases, -1, fw.numel()).sum(dim=1) @ fw)

    def indicator(self) -> tuple[FloatArray, FloatArray]:
        assert self.w is not None and self.f is not None
        stacked = self._results.pop("norms", None)
        if stacked is None:
            stacked = self._norm_squares(self.w, self.f, self.w_hat, self.f_hat)
        norms = np.sqrt(stacked.cpu().numpy())[:, self.slots]
        return norms[0], 0.5 * (norms[1] + norms[2])

    def fields(self, cases: IntArray | None = None
               ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        self._settle()
        assert self.w is not None and self.f is not None
        rows = self.slots if cases is None else self.slots[cases]
        whole = rows.size == self.w.shape[0]  # then the rows are 0 … n − 1
        out = []
        for x in (self.w, self.f, self.w_hat, self.f_hat):
            chosen = x if whole else x[self._index(rows)]
            out.append(np.asarray(chosen.cpu().numpy(), dtype=np.float64))
        return out[0], out[1], out[2], out[3]

    def shift(self, cases: IntArray, dw: Sequence[Tensor], df: Sequence[Tensor]) -> None:
        self._settle()
        self._results = {}
        assert self.w is not None and self.f is not None
        index = self._index(self.slots[cases])
        self.w = self.w.index_add(0, index, self._stacked(dw))
        self.f = self.f.index_add(0, index, self._stacked(df))

    def local_stage_of(self, cases: IntArray) -> None:
        """The whole batch's local stage (its graphs replay whole batches), the others'
        rows of ŝ put back (copies: a graph's outputs are its own buffers)."""
        index = self._index(self.slots[cases])
        names = ("w_hat", "f_hat") + (() if self.side_macro is None else ("side_macro",))
        kept = [getattr(self, name).clone() for name in names]
        self.local_stage()
        for name, old in zip(names, kept, strict=True):
            setattr(self, name, old.index_copy(0, index, getattr(self, name)[index]))

    def saved(self, cases: IntArray) -> tuple[Any, ...]:
        self._settle()
        assert self.w is not None and self.f is not None
        index = self._index(self.slots[cases])
        return tuple(None if x is None else x.index_select(0, index)
                     for x in (self.w, self.f, self.w_hat, self.f_hat, self.side_macro))

    def restore(self, cases: IntArray, saved: tuple[Any, ...]) -> None:
        self._settle()
        self._results = {}
        index = self._index(self.slots[cases])
        for name, old in zip(("w", "f", "w_hat", "f_hat", "side_macro"), saved, strict=True):
            if old is not None:
                setattr(self, name, getattr(self, name).index_copy(0, index, old))

    def _stacked(self, rows: Sequence[Any]) -> Tensor:
        """Rows (tensors, or host arrays: ``extrapolation``) as one tensor on the device."""
        return self.torch.stack([row if isinstance(row, self.torch.Tensor) else
                                 self._tensor(row) for row in rows])

    def state(self, cases: IntArray) -> tuple[Tensor, Tensor]:
        self._settle()
        assert self.w is not None and self.f is not None
        index = self._index(self.slots[cases])
        return self.w.index_select(0, index), self.f.index_select(0, index)

    def take(self, rows: Tensor, index: IntArray) -> Tensor:
        run = as_run(index)  # a run of rows: a view
        return rows.index_select(0, self._index(index)) if run is None else rows[run]

    def state_norms(self, dw: Tensor, df: Tensor) -> FloatArray:
        out: FloatArray = np.sqrt(self._squares(dw, df).cpu().numpy())
        return out

    def host(self, rows: Tensor) -> FloatArray:
        return np.asarray(rows.cpu().numpy(), dtype=np.float64)

    def keep(self, cases: IntArray) -> None:
        """The active cases at positions ``cases`` go on; padded (``PADDED_DEVICES``), the
        rows stay as they are while more than ``COMPACT_BELOW`` of them are active."""
        assert self.w is not None and self.f is not None
        rows = self.slots[cases]
        if self.padded and rows.size > COMPACT_BELOW * self.w.shape[0]:
            self.slots = rows
            return
        self.slots = np.arange(rows.size)
        for graph in (self.graph, self.iteration_graph):
            if graph is not None:
                graph.reset()
        chosen = self._index(rows)
        cases = rows
        self.active = self.active[cases]
        self.w, self.f = self.w[chosen], self.f[chosen]
        self.w_hat, self.f_hat = self.w_hat[chosen], self.f_hat[chosen]
        if self.macro_data is not None:
            self.macro_data = self.macro_data[chosen]
        if self.body is not None:
            self.body = self.body[chosen]
        if self.qoi_constant is not None:
            self.qoi_constant = self.qoi_constant[rows]
        self.qoi_parts = [(used, coefficients[chosen]) for used, coefficients in self.qoi_parts]
        if self.side_macro is not None:
            self.side_macro = self.side_macro[chosen]
        self.local.subset(cases)
        self.rows = self._rows()
        if self.mixer is not None:
            self.mixer.subset(chosen)

    def _index(self, cases: IntArray) -> Tensor:
        return self.torch.as_tensor(np.asarray(cases, dtype=np.int64), device=self.device)


def _relaxed(omega: Any, new: Tensor, old: Tensor) -> Tensor:
    """ω new + (1 − ω) old (ω a number or per row)."""
    return omega * new + (1.0 - omega) * old


def _difference(x: Tensor, y: Tensor) -> float:
    """Largest |x − y| over max |y|, where y is finite (a case that left on an overflow
    iterates along as NaN); inf where x and y are not finite at the same places."""
    finite = y.isfinite()
    if not bool((x.isfinite() == finite).all()):
        return float("inf")
    if not bool(finite.any()):
        return 0.0
    scale = float(y[finite].abs().max())
    return float((x[finite] - y[finite]).abs().max()) / max(scale, 1e-300)


_DEVICE_OPERATORS: dict[tuple[tuple[int, ...], str], tuple[list[LatinOperators],
                                                           DeviceOperators]] = {}


def _device_operators(operators: list[LatinOperators], device: Any, torch: Any
                      ) -> DeviceOperators:
    """The operators moved to the device once per set of ``LatinOperators`` and device (a
    study reuses one geometry's operators for every friction pair); the last few are kept."""
    key = (tuple(id(ops) for ops in operators), str(device))
    held = _DEVICE_OPERATORS.get(key)
    if held is not None and all(a is b for a, b in zip(held[0], operators, strict=True)):
        return held[1]
    moved = DeviceOperators(operators, torch, device)
    if len(_DEVICE_OPERATORS) >= 4:
        _DEVICE_OPERATORS.pop(next(iter(_DEVICE_OPERATORS)))
    _DEVICE_OPERATORS[key] = (list(operators), moved)
    return moved


_FUSED: list[Any] = []


def _fused(torch: Any) -> Any:
    """``TorchLocalStage.__call__`` compiled by ``torch.compile`` once per process (dynamic
    shapes: cases may leave a batch without a new compilation, but for a batch of one)."""
    if not _FUSED:
        _FUSED.append(torch.compile(TorchLocalStage.__call__, dynamic=True))
    return _FUSED[0]
