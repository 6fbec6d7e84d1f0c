"""The field work of one LATIN iteration, apart from its control (``solver._iterate``):
the linear stage with the macro problem, relaxation or Anderson mixing, the local stage, the
tracked quantities of interest and the indicator's norms, on the interface fields of the
active cases of a batch.

``NumpyFields`` (a ``field_engine.FieldEngine``) is the reference (NumPy, with the Numba
kernels when installed); ``torch_engine.TorchFields`` does the same work with PyTorch on a
CPU or a GPU (``LatinOptions.backend``). Both hold s = (W, F) and ŝ = (Ŵ, F̂) of shape
``(n_active, n_steps, n_points, 2)``, hand to the solver only what its control needs (η's
norms and the QoIs per case, host arrays of a few numbers per case) and give the fields
back when cases leave the batch.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from ..fem.elasticity import FloatArray, IntArray
from . import kernels
from .acceleration import Anderson
from .guards import FORCE_FLOOR, FORCE_MARGIN
from .indicator_kernel import weighted_squares
from .local_stage import LocalStage
from .operators import Geometries, LatinOperators
from .options import LatinOptions
from .threads import one_blas_thread
from .tracking import QoiFunctionals
from .two_scale import compiled_local_stage, coupled_local_stage, keep_settled

__all__ = ["SETTLE_ITERATIONS", "NumpyFields", "as_run", "indicator_weights",
           "norms", "one_blas_thread"]

#: iterations a leading step's ‖s − ŝ‖ stays under its bound before it settles
#: (``NumpyFields.settle``)
SETTLE_ITERATIONS = 3


class NumpyFields:
    """The reference backend: NumPy, with the Numba kernels where installed."""

    def __init__(self, ops: LatinOperators, local: LocalStage, options: LatinOptions,
                 w_hat: FloatArray, f_hat: FloatArray, macro_data: FloatArray | None,
                 functionals: list[QoiFunctionals] | None,
                 geometries: tuple[list[LatinOperators], IntArray] | None = None) -> None:
        """geometries: the operators of the batch's geometries (sharing ``ops``'s
        interfaces, ``batching.same_interfaces``) and each case's index into them; None:
        ``ops`` for every case."""
        pts = ops.points
        #: per case, its geometry's operators (None: one geometry)
        self.geometry_of: list[LatinOperators] | None = (
            [geometries[0][g] for g in geometries[1]]
            if geometries is not None and len(geometries[0]) > 1 else None)
        k = ops.indicator_k  # the norm's k (the search direction without corner stiffening)
        self.ops, self.local, self.options = ops, local, options
        self.w_hat, self.f_hat = w_hat, f_hat
        self.w: FloatArray | None = None
        self.f: FloatArray | None = None
        self._linear_output: tuple[FloatArray, FloatArray] | None = None
        self.macro_data = macro_data
        self.functionals = functionals
        self.shared = functionals is not None and all(f is functionals[0] for f in functionals)
        self.active = np.arange(w_hat.shape[0])
        self.n_total = w_hat.shape[0]  # the cases ever in the batch (joined ones too)
        self.mixer = (Anderson(options.anderson_depth, options.relaxation,
                               np.sqrt(pts.weights[:, None] * k),
                               np.sqrt(pts.weights[:, None] / k))
                      if options.acceleration == "anderson" else None)
        self.displacement_weight, self.force_weight = indicator_weights(pts.weights, k)
        self.t_linear = self.t_macro = self.t_local = 0.0
        #: Eᵀ M0 Ŵ per case and step, where the coupled local stage starts (``two_scale``)
        self.side_macro = (ops.two_scale.project(w_hat.reshape(-1, 2 * pts.n_points))
                           .reshape(*w_hat.shape[:2], -1) if ops.two_scale is not None else None)
        #: the active cases' columns per geometry, for the linear stage (``_geometries``)
        self.geometries = self._geometries()
        #: settled leading steps (``settle``): per active case its first step still
        #: iterated, and per step the iterations its ‖s − ŝ‖ has stayed under the bound
        self.settling = (options.settled_steps > 0 and self.mixer is None
                         and options.acceleration == "relaxation" and local.fused
                         and kernels.indicator_squares is not None)
        self.first: IntArray = np.zeros(w_hat.shape[0], dtype=np.int64)
        self.calm: IntArray = np.zeros(w_hat.shape[:2], dtype=np.int64)
        self.step_gaps: FloatArray = np.zeros(w_hat.shape[:2])
        #: per case and step its force part ‖F − F̂‖², and per case ½(‖F‖ + ‖F̂‖)
        self.step_force_gaps: FloatArray = np.zeros(w_hat.shape[:2])
        self.force_size: FloatArray = np.zeros(w_hat.shape[0])
        #: the fields before ``moved_forces``, for ``take_back``
        self._before_move: tuple[Any, ...] = ()

    def linear_stage(self, relaxation: FloatArray) -> None:
        if self.first.any():
            self._live_linear_stage(relaxation)
            return
        ta = time.perf_counter()
        options = self.options
        shape = self.w_hat.shape
        w_new, f_new = self._admissible(slice(None), self.geometries)
        w_new, f_new = w_new.reshape(shape), f_new.reshape(shape)
        # held until the next linear stage replaces them, as the loop did before the
        # engine split: freed here, glibc gave the heap's top back to the system every
        # iteration and the next arrays page-faulted again (b3, 16 cases: 2.5 M page faults
        # against 1.0 M, 4.2 s against 3.2 s)
        self._linear_output = (w_new, f_new)
        w, f = self.w, self.f
        if w is None or f is None or options.relaxation == 1.0 and self.mixer is None:
            w, f = w_new, f_new
        elif self.mixer is not None:
            w, f = self.mixer(w, f, w_new, f_new)
        elif kernels.relax is not None and self.local.compiled and np.all(
                relaxation == relaxation[0]):
            kernels.relax(w, w_new, float(relaxation[0]))
            kernels.relax(f, f_new, float(relaxation[0]))
        else:
            omega = relaxation[:, None, None, None]
            w = omega * w_new + (1.0 - omega) * w
            f = omega * f_new + (1.0 - omega) * f
        self.w, self.f = w, f
        self.t_linear += time.perf_counter() - ta

    def _live_linear_stage(self, relaxation: FloatArray) -> None:
        """``linear_stage`` on the rows (case, step) not settled alone (``settle``): the
        linear stage is step by step, so the settled rows' s stays as it is."""
        assert self.w is not None and self.f is not None
        ta = time.perf_counter()
        rows = np.flatnonzero(self._live_steps())  # case × n_steps + step
        case_of_row = rows // self.w_hat.shape[1]
        w_new, f_new = self._admissible(rows, self._geometries(case_of_row))
        omega = np.ascontiguousarray(relaxation[case_of_row], dtype=np.float64)
        width = 2 * self.ops.points.n_points
        for current, new in ((self.w, w_new), (self.f, f_new)):
            assert kernels.relax_rows is not None and current.flags.c_contiguous
            kernels.relax_rows(current.reshape(-1, width), new.reshape(-1, width), rows, omega)
        self.t_linear += time.perf_counter() - ta

    def _admissible(self, rows: slice | IntArray, geometries: Geometries | None
                    ) -> tuple[FloatArray, FloatArray]:
        """The linear stage's s on the rows (case × n_steps + step) ``rows`` of ŝ: the
        substructure problems, then the macro correction; fields (n_rows, n_points, 2)."""
        flat = (-1, self.ops.points.n_points, 2)
        w_hat, f_hat = self.w_hat.reshape(flat), self.f_hat.reshape(flat)
        if not isinstance(rows, slice):
            w_hat, f_hat = np.take(w_hat, rows, 0), np.take(f_hat, rows, 0)
        body = self.local.body
        if body is not None:  # body forces' T S⁻¹ f per row (``body_forces``)
            body = body.reshape(flat) if isinstance(rows, slice) else np.take(
                body.reshape(flat), rows, 0)
        w_new, f_new = self.ops.micro_stage(w_hat, f_hat, geometries, body)
        tm = time.perf_counter()
        if self.macro_data is not None:
            self.ops.macro_correction(
                w_new, f_new, self.macro_data.reshape(-1, self.macro_data.shape[2])[rows],
                geometries)
        self.t_macro += time.perf_counter() - tm
        return w_new, f_new

    def _live_steps(self, cases: IntArray | slice = slice(None)) -> npt.NDArray[np.bool_]:
        """Per case at positions ``cases`` and step: still iterated (``settle``)."""
        return np.arange(self.w_hat.shape[1])[None, :] >= self.first[cases][:, None]

    def settle(self, size: FloatArray, bound: float) -> None:
        """Leading steps whose ‖s − ŝ‖ has stayed below ``bound`` × the case's ½(‖s‖ +
        ‖ŝ‖) for ``SETTLE_ITERATIONS`` iterations, with every step before them, are no
        longer iterated (their s and ŝ stay; the last step always is). A load step's
        fields depend on the earlier steps' alone (the linear stage and the macro problem
        are step by step, Coulomb's law acts on increments), so the later steps converge
        as they would: the settled ones leave ‖s − ŝ‖ at most ``bound`` × √n_steps of the
        size where η stops at ``tol``."""
        if not self.settling:
            return
        # and its forces' own share below ``FORCE_MARGIN`` × the bound × ½(‖F‖ + ‖F̂‖):
        # a large displacement of the assembly fills ‖s‖ and would settle steps whose
        # forces are unbalanced (``guards.FORCE_MARGIN``); forces under ``FORCE_FLOOR`` × the
        # size are zero to the solver's precision
        force_size = np.maximum(self.force_size, FORCE_FLOOR * size)
        calm = ((self.step_gaps < (bound * size)[:, None] ** 2)
                & (self.step_force_gaps < (FORCE_MARGIN * bound * force_size)[:, None] ** 2))
        self.calm = np.where(calm, self.calm + 1, 0)
        n_steps = int(self.step_gaps.shape[1])
        leading = np.cumprod(self.calm >= SETTLE_ITERATIONS, axis=1).sum(axis=1)
        self.first = np.maximum(self.first, np.minimum(leading, n_steps - 1))

    def _geometries(self, case_of_row: IntArray | None = None
                    ) -> list[tuple[LatinOperators, slice | IntArray]] | None:
        """Per geometry of the active cases, its operators and the columns (case × step)
        of its cases; None when they share one (``geometries``, set at the start and when
        cases leave). case_of_row: the active case (position) of each column where they are
        not every case's every step (``_live_linear_stage``)."""
        if self.geometry_of is None:
            return None
        if case_of_row is not None:
            by_row: dict[int, tuple[LatinOperators, list[IntArray]]] = {}
            for position, case in enumerate(self.active):
                ops = self.geometry_of[case]
                by_row.setdefault(id(ops), (ops, []))[1].append(
                    np.flatnonzero(case_of_row == position))
            if len(by_row) == 1 and next(iter(by_row.values()))[0] is self.ops:
                return None
            return [(ops, np.concatenate(parts)) for ops, parts in by_row.values()]
        n_steps = self.w_hat.shape[1]
        by: dict[int, tuple[LatinOperators, list[int]]] = {}
        for position, case in enumerate(self.active):
            ops = self.geometry_of[case]
            by.setdefault(id(ops), (ops, []))[1].append(position)
        if len(by) == 1:
            return None if next(iter(by.values()))[0] is self.ops else [
                (ops, slice(None)) for ops, _ in by.values()]
        out: list[tuple[LatinOperators, slice | IntArray]] = []
        for ops, positions in by.values():
            cases = np.array(positions)
            if cases[-1] - cases[0] + 1 == cases.size:  # contiguous: a view
                out.append((ops, slice(int(cases[0]) * n_steps, (int(cases[-1]) + 1) * n_steps)))
            else:
                out.append((ops, (cases[:, None] * n_steps + np.arange(n_steps)).ravel()))
        return out

    def local_stage(self) -> None:
        assert self.w is not None and self.f is not None
        tb = time.perf_counter()
        if self.side_macro is not None:  # set exactly when there is a two-scale H
            assert self.ops.two_scale is not None
            if self.local.fused:
                self.w_hat, self.f_hat, self.side_macro = compiled_local_stage(
                    self.local, self.ops.two_scale, self.w, self.f, self.side_macro,
                    (self.first, self.w_hat, self.f_hat) if self.first.any() else None)
            else:
                self.w_hat, self.f_hat, self.side_macro = coupled_local_stage(
                    self.local, self.local.contact_stage, self.ops.two_scale, self.w, self.f,
                    self.side_macro)
        elif self.first.any():
            w_hat, f_hat = self.local.without_contact(self.w, self.f, self.first)
            keep_settled(self.first, (w_hat, f_hat), (self.w_hat, self.f_hat))
            self.local.contact_stage(self.w, self.f, w_hat, f_hat, self.first)
            self.w_hat, self.f_hat = w_hat, f_hat
        else:
            self.w_hat, self.f_hat = self.local(self.w, self.f)
        self.t_local += time.perf_counter() - tb

    def qoi_values(self) -> FloatArray:
        return self._per_case("values")

    def qoi_magnitudes(self) -> FloatArray:
        return self._per_case("magnitudes")

    def _per_case(self, reading: str) -> FloatArray:
        """``QoiFunctionals.values`` or ``.magnitudes`` of every active case's fields."""
        assert self.functionals is not None and self.w is not None and self.f is not None
        w, f, f_hat = self.w, self.f, self.f_hat
        if self.shared:
            return np.asarray(getattr(self.functionals[0], reading)(w, f, f_hat))
        return np.stack([getattr(self.functionals[c], reading)(w[i:i + 1], f[i:i + 1],
                                                                f_hat[i:i + 1])[0]
                         for i, c in enumerate(self.active)])

    def indicator(self) -> tuple[FloatArray, FloatArray]:
        assert self.w is not None and self.f is not None
        if kernels.indicator_squares is not None and self.local.compiled:
            # Anderson gives views
            self.w, self.f = np.ascontiguousarray(self.w), np.ascontiguousarray(self.f)
            if self.step_gaps.shape != self.w.shape[:2]:
                self.step_gaps = np.zeros(self.w.shape[:2])
                self.step_force_gaps = np.zeros(self.w.shape[:2])
            squares = np.sqrt(kernels.indicator_squares(
                self.w, self.f, self.w_hat, self.f_hat, self.displacement_weight,
                self.force_weight, self.step_gaps, self.step_force_gaps))
            self.force_size = 0.5 * (squares[:, 3] + squares[:, 4])
            return squares[:, 0], 0.5 * (squares[:, 1] + squares[:, 2])
        dw, fw = self.displacement_weight, self.force_weight
        gap = norms(dw, fw, self.w - self.w_hat, self.f - self.f_hat)
        size = 0.5 * (norms(dw, fw, self.w, self.f) + norms(dw, fw, self.w_hat, self.f_hat))
        return gap, size

    def fields(self, cases: IntArray | None = None
               ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        assert self.w is not None and self.f is not None
        chosen = slice(None) if cases is None else cases
        return self.w[chosen], self.f[chosen], self.w_hat[chosen], self.f_hat[chosen]

    def shift(self, cases: IntArray, dw: Sequence[Any], df: Sequence[Any]) -> None:
        assert self.w is not None and self.f is not None
        self.w = np.array(self.w)  # its own array (not the linear stage's output)
        self.f = np.array(self.f)
        live = self._live_steps(cases)[..., None, None]
        self.w[cases] += np.where(live, np.stack(dw), 0.0)
        self.f[cases] += np.where(live, np.stack(df), 0.0)

    def local_stage_of(self, cases: IntArray) -> None:
        others = np.setdiff1d(np.arange(self.w_hat.shape[0]), cases)
        kept = [None if x is None else x[others] for x in (self.w_hat, self.f_hat,
                                                             self.side_macro)]
        self.local_stage()
        for name, rows in zip(("w_hat", "f_hat", "side_macro"), kept, strict=True):
            if rows is not None:
                getattr(self, name)[others] = rows

    def state(self, cases: IntArray) -> tuple[FloatArray, FloatArray]:
        assert self.w is not None and self.f is not None
        return self.w[cases], self.f[cases]  # indexed by an array: copies

    def take(self, rows: FloatArray, index: IntArray) -> FloatArray:
        run = as_run(index)
        return rows[index] if run is None else rows[run]

    def state_norms(self, dw: FloatArray, df: FloatArray) -> FloatArray:
        return norms(self.displacement_weight, self.force_weight, dw, df)

    def host(self, rows: FloatArray) -> FloatArray:
        return np.asarray(rows)

    def trial_forces(self, dw: FloatArray, cases: IntArray) -> FloatArray:
        """F̂ of the local stage of (W + dw, F) for the active cases at positions ``cases``
        (``dw``: theirs, (n, n_steps, n_points, 2)), the engine's own fields left as they
        are: the rigid balance's trials (``rigid_balance``)."""
        forces: FloatArray = self._local_of(cases, dw)[1]
        return forces

    def live_steps(self) -> npt.NDArray[np.bool_]:
        """Per active case and step: still iterated (``settle``)."""
        return self._live_steps()

    def moved_forces(self, dw: FloatArray, cases: IntArray) -> FloatArray:
        """W ← W + ``dw`` for the active cases at positions ``cases``, then their local
        stage; returns their F̂. ``take_back`` restores the cases it names."""
        assert self.w is not None
        self._before_move = (cases, self.w[cases], self.w_hat[cases], self.f_hat[cases],
                             None if self.side_macro is None else self.side_macro[cases])
        w_hat, f_hat, side_macro = self._local_of(cases, dw)
        self.shift(cases, list(dw), list(np.zeros_like(dw)))
        self.w_hat[cases], self.f_hat[cases] = w_hat, f_hat
        if self.side_macro is not None:
            self.side_macro[cases] = side_macro
        forces: FloatArray = f_hat
        return forces

    def saved(self, cases: IntArray) -> tuple[Any, ...]:
        assert self.w is not None and self.f is not None
        return tuple(None if x is None else x[cases] for x in  # indexed by an array: copies
                     (self.w, self.f, self.w_hat, self.f_hat, self.side_macro))

    def restore(self, cases: IntArray, saved: tuple[Any, ...]) -> None:
        self.w, self.f = np.array(self.w), np.array(self.f)  # not the linear stage's output
        live = self._live_steps(cases)  # settled steps stay as they settled
        for name, old in zip(("w", "f", "w_hat", "f_hat", "side_macro"), saved, strict=True):
            if old is not None:
                rows = getattr(self, name)
                rows[cases] = np.where(live.reshape(live.shape + (1,) * (old.ndim - 2)),
                                       old, rows[cases])

    def take_back(self, cases: IntArray) -> None:
        """The active cases at positions ``cases`` (of the last ``moved_forces``) as they
        were before it."""
        moved, *before = self._before_move
        where = np.flatnonzero(np.isin(moved, cases))
        for name, old in zip(("w", "w_hat", "f_hat", "side_macro"), before, strict=True):
            if old is not None:
                getattr(self, name)[moved[where]] = old[where]

    def _local_of(self, cases: IntArray, dw: FloatArray) -> tuple[Any, Any, Any]:
        """(Ŵ, F̂, Eᵀ M0 Ŵ) of the local stage of (W + dw, F) for the active cases at
        positions ``cases`` alone (``dw``: theirs), the engine's fields left as they are."""
        assert self.w is not None and self.f is not None
        kept = (self.local, self.w, self.f, self.w_hat, self.f_hat, self.side_macro,
                self.first)
        self.local = self.local.subset(cases)
        self.w = self.w[cases] + np.where(self._live_steps(cases)[..., None, None], dw, 0.0)
        self.f, self.w_hat, self.f_hat = self.f[cases], self.w_hat[cases], self.f_hat[cases]
        self.side_macro = None if self.side_macro is None else self.side_macro[cases]
        self.first = self.first[cases]
        try:
            self.local_stage()
            return self.w_hat, self.f_hat, self.side_macro
        finally:
            (self.local, self.w, self.f, self.w_hat, self.f_hat, self.side_macro,
             self.first) = kept

    def join(self, local: LocalStage, w_hat: FloatArray, f_hat: FloatArray,
             macro_data: FloatArray | None, functionals: list[QoiFunctionals] | None,
             ops: LatinOperators) -> None:
        """Cases join the active ones (``iteration.BatchIterations.join``): their local
        stage, start ŝ, F_dᴹ, QoI functionals and operators (sharing these interfaces). Their
        s is zero until their first linear stage, which is not relaxed."""
        n_new = w_hat.shape[0]
        numbers = np.arange(self.n_total, self.n_total + n_new)
        if self.geometry_of is None and ops is not self.ops:
            self.geometry_of = [self.ops] * self.n_total
        if self.geometry_of is not None:
            self.geometry_of.extend([ops] * n_new)
        self.n_total += n_new
        self.active = np.concatenate([self.active, numbers])
        if self.w is not None and self.f is not None:
            self.w = np.concatenate([self.w, np.zeros_like(w_hat)])
            self.f = np.concatenate([self.f, np.zeros_like(f_hat)])
        self.w_hat = np.concatenate([self.w_hat, w_hat])
        self.f_hat = np.concatenate([self.f_hat, f_hat])
        self.first = np.concatenate([self.first, np.zeros(n_new, dtype=np.int64)])
        self.calm = np.concatenate([self.calm, np.zeros(w_hat.shape[:2], dtype=np.int64)])
        if self.macro_data is not None and macro_data is not None:
            self.macro_data = np.concatenate([self.macro_data, macro_data])
        self.local = self.local.joined(local)
        if self.functionals is not None and functionals is not None:
            self.functionals = self.functionals + functionals
            self.shared = all(f is self.functionals[0] for f in self.functionals)
        if self.side_macro is not None:
            assert self.ops.two_scale is not None
            side = self.ops.two_scale.project(w_hat.reshape(-1, 2 * self.ops.points.n_points))
            self.side_macro = np.concatenate([self.side_macro,
                                              side.reshape(*w_hat.shape[:2], -1)])
        self.geometries = self._geometries()

    def renumber(self) -> None:
        """The active cases become cases 0 … n − 1, in their order: what the batch held for
        the cases that left is let go (a long rolling batch stays as small as its width)."""
        if self.geometry_of is not None:
            self.geometry_of = [self.geometry_of[c] for c in self.active]
        if self.functionals is not None:
            self.functionals = [self.functionals[c] for c in self.active]
            self.shared = all(f is self.functionals[0] for f in self.functionals)
        self.n_total = int(self.active.size)
        self.active = np.arange(self.n_total)
        self.geometries = self._geometries()

    def keep(self, cases: IntArray) -> None:
        assert self.w is not None and self.f is not None
        self.active = self.active[cases]
        self.w, self.f = self.w[cases], self.f[cases]
        self.w_hat, self.f_hat = self.w_hat[cases], self.f_hat[cases]
        self.first, self.calm = self.first[cases], self.calm[cases]
        if self.macro_data is not None:
            self.macro_data = self.macro_data[cases]
        self.local = self.local.subset(cases)
        self.geometries = self._geometries()
        if self.side_macro is not None:
            self.side_macro = self.side_macro[cases]
        if self.mixer is not None:
            self.mixer.subset(cases)


def as_run(index: IntArray) -> slice | None:
    """``index`` as a slice where it is a run of consecutive rows (a view, no copy)."""
    if index.size and np.all(np.diff(index) == 1):
        return slice(int(index[0]), int(index[-1]) + 1)
    return None


def indicator_weights(weights: FloatArray, k: FloatArray) -> tuple[FloatArray, FloatArray]:
    """∫ k and ∫ k⁻¹ per flattened (point, component): the weights of ``norms`` from the
    points' weights and the search direction k (n_points, 2)."""
    return (weights[:, None] * k).ravel(), (weights[:, None] / k).ravel()


def norms(displacement_weight: FloatArray, force_weight: FloatArray,
          displacement: FloatArray, force: FloatArray) -> FloatArray:
    """‖s‖ per case: ‖s‖² = Σ_t Σ_points ∫ (k⁻¹ F·F + k W·W) dΓ (paper §4.3); the weights
    are ∫ k and ∫ k⁻¹ per flattened (point, component)."""
    squares = weighted_squares(displacement_weight, displacement)
    squares += weighted_squares(force_weight, force)
    out: FloatArray = np.sqrt(squares)
    return out
