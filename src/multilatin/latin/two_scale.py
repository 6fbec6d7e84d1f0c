"""A two-scale search direction (issue 15; ``LatinOptions.micro_stiffening``): stiff on the
micro part of the interface fields, κ E / L on their macro part, on contact interfaces and
stops.

A Robin-type iteration relaxes an interface mode of stiffness λ (the substructures'
Dirichlet-to-Neumann symbol) at about ((λ − k) / (λ + k))² per iteration. With k = κ E / L
the mesh-scale modes (λ up to ~E / h) relax slowly — the slow tail, located at corner
nodes — while a stiffer k slows the *crawls*: a body sliding over a contact moves by about
(unbalanced force) / k per iteration, a macro mode of the interface (constant tangential
slip). So on each side of a contact interface and on each stop

    H = D + E G Eᵀ M0,    G = Eᵀ M0 (k − D) E,

with D = k × ``micro_stiffening`` (diagonal, per point), k the search direction without
it, and E the side's M0-orthonormal constant and linear functions per component (the
macro functions of paper §2.2, per side): on those functions H acts as k, on the rest of
the fields as D. M0 H is symmetric, so the fixed point is that of any other direction
(tested: tight solves agree). Perfect and macro-only interfaces take D alone (k ×
``micro_stiffening`` on all their fields: the macro problem already carries their macro
modes).

The local stage must take the same direction as the linear stage (with another one the
iteration diverges: measured, ``benchmarks/two_scale_direction.py``), so the points of a
contact side are coupled through the rank-4 term. It is solved by an inner fixed point on
the side's macro coordinates a = Eᵀ M0 (Ŵ − W): the point-wise local stage with D and the
force shifted by E G a, a moved toward Eᵀ M0 (Ŵ(a) − W) (``coupled_local_stage``). That
map's slope on every branch (stick, slip, open) lies in [0, 1 − k / D], so Chebyshev's
semi-iteration over that interval takes three passes where plain relaxation took five,
started from the macro part of the previous iteration's Ŵ.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

from ..decomposition.assembly import Assembly
from ..decomposition.interfaces import InterfacePoints, interface_functions
from ..fem.elasticity import FloatArray, IntArray
from . import kernels

if TYPE_CHECKING:
    from .local_stage import LocalStage

#: inner passes of the coupled local stage per LATIN iteration (measured on b1, η < 3e-6:
#: 3 Chebyshev passes → 61–85 outer iterations, 2 → 82–103; 5 relaxed passes 59–82)
INNER_ITERATIONS = 3


@dataclass(frozen=True)
class TwoScaleDirection:
    """H − D = E G Eᵀ M0 on flat (point, component) vectors of length 2P, stored on the
    flat indices ``support`` of the contact sides and stops only; r macro functions in all
    (4 per side). NumPy arrays (applied through sparse copies: each function lives on one
    side), or torch tensors in the copy ``on`` makes."""

    support: Any  # flat indices, (n_s,)
    basis: Any  # E on the support, (n_s, r)
    weighted: Any  # M0 E on the support, (n_s, r)
    coupling: Any  # G, (r, r), symmetric
    ratio: float  # min k / D on the support: the inner map's slope lies in [0, 1 − ratio]
    #: NumPy: E and (M0 E)ᵀ as SciPy sparse matrices (None for tensors)
    sparse: tuple[Any, Any] | None = field(init=False, repr=False, default=None)
    #: NumPy: the support as runs of consecutive flat indices, (start, stop, offset in the
    #: support): slices gather and scatter twice as fast as an index array
    runs: tuple[tuple[int, int, int], ...] = field(init=False, repr=False, default=())
    #: NumPy: each function's entries, function after function: (starts (r + 1,), flat
    #: indices, E's and M0 E's values), for the compiled inner passes
    entries: tuple[Any, ...] = field(init=False, repr=False, default=())
    #: NumPy: G's nonzeros row by row (starts (r + 1,), columns, values): G is block
    #: diagonal (functions of different sides or components do not meet), 2 × 2 blocks
    coupling_entries: tuple[Any, ...] = field(init=False, repr=False, default=())

    def __post_init__(self) -> None:
        if isinstance(self.basis, np.ndarray):
            object.__setattr__(self, "sparse", (sp.csr_matrix(self.basis),
                                                sp.csr_matrix(self.weighted.T)))
            cuts = np.flatnonzero(np.diff(self.support) != 1) + 1
            starts = np.concatenate([[0], cuts])
            stops = np.concatenate([cuts, [self.support.size]])
            function, at = np.nonzero(self.basis.T)  # by function, then by index
            object.__setattr__(self, "entries", (
                np.searchsorted(function, np.arange(self.basis.shape[1] + 1)).astype(np.int64),
                self.support[at].astype(np.int64),
                np.ascontiguousarray(self.basis[at, function]),
                np.ascontiguousarray(self.weighted[at, function])))
            rows = sp.csr_matrix(self.coupling)  # its exact zeros left out
            object.__setattr__(self, "coupling_entries", (
                rows.indptr.astype(np.int64), rows.indices.astype(np.int64),
                np.ascontiguousarray(rows.data, dtype=np.float64)))
            object.__setattr__(self, "runs", tuple(
                (int(self.support[a]), int(self.support[b - 1]) + 1, int(a))
                for a, b in zip(starts, stops, strict=True)))

    def gather(self, flat: Any) -> Any:
        """The support's columns of ``flat`` (n, 2P): (n, n_s), a copy."""
        if self.runs:
            return np.concatenate([flat[:, lo:hi] for lo, hi, _ in self.runs], axis=1)
        return flat[:, self.support]

    def scatter(self, flat: Any, values: Any, add: bool = False) -> None:
        """flat[:, support] = values (or += with ``add``), in place."""
        if self.runs:
            for lo, hi, at in self.runs:
                if add:
                    flat[:, lo:hi] += values[:, at:at + hi - lo]
                else:
                    flat[:, lo:hi] = values[:, at:at + hi - lo]
        elif add:
            flat[:, self.support] += values
        else:
            flat[:, self.support] = values

    @property
    def n_functions(self) -> int:
        return int(self.basis.shape[1])

    def project(self, flat: Any) -> Any:
        """Eᵀ M0 x for rows x of ``flat`` (n, 2P): (n, r)."""
        if self.sparse is not None:
            return (self.sparse[1] @ self.gather(flat).T).T
        return flat[:, self.support] @ self.weighted

    def expand(self, coordinates: Any) -> Any:
        """E G a on the support for rows a of ``coordinates`` (n, r): (n, n_s)."""
        if self.sparse is not None:
            return (self.sparse[0] @ (coordinates @ self.coupling).T).T
        return (coordinates @ self.coupling) @ self.basis.T

    def add_correction(self, flat: Any, field: Any) -> None:
        """flat += (H − D) x for rows x of ``field``, both (n, 2P), in place (compiled
        where Numba is, for NumPy arrays: ``kernels.two_scale_correction``)."""
        if self.entries and kernels.two_scale_correction is not None and flat.flags.c_contiguous:
            kernels.two_scale_correction(flat, np.ascontiguousarray(field), *self.entries,
                                         *self.coupling_entries)
            return
        self.scatter(flat, self.expand(self.project(field)), add=True)

    def transposed_correction(self, flat: FloatArray) -> FloatArray:
        """(H − D)ᵀ v = M0 E G Eᵀ v for rows v of ``flat`` (NumPy)."""
        out = np.zeros_like(flat)
        out[:, self.support] = (flat[:, self.support] @ self.basis) @ self.coupling \
            @ self.weighted.T
        return out

    def block(self, lo: int, hi: int) -> FloatArray | None:
        """M0 (H − D) on the flat range [lo, hi) of one substructure (its sides' functions
        are supported there only): dense, symmetric; None where it has no contact side."""
        inside = (self.support >= lo) & (self.support < hi)
        if not inside.any():
            return None
        out = np.zeros((hi - lo, hi - lo))
        local = self.support[inside] - lo
        weighted = self.weighted[inside]
        out[np.ix_(local, local)] = weighted @ self.coupling @ weighted.T
        return out

    def on(self, torch: Any, device: Any) -> TwoScaleDirection:
        """The same direction as torch tensors on ``device`` (fp64; indices int64)."""
        def tensor(array: FloatArray) -> Any:
            return torch.as_tensor(np.ascontiguousarray(array, dtype=np.float64), device=device)

        return TwoScaleDirection(torch.as_tensor(self.support, device=device),
                                 tensor(self.basis), tensor(self.weighted),
                                 tensor(self.coupling), self.ratio)


def stiffened_points(assembly: Assembly, points: InterfacePoints) -> npt.NDArray[np.bool_]:
    """Per point: True on interfaces between substructures and on stops (where
    ``micro_stiffening`` acts), False on the outer boundary's prescribed data."""
    out = np.zeros(points.n_points, dtype=bool)
    for (i, _side), p in points.side_points.items():
        itf = assembly.interfaces[i]
        out[p] = itf.contact is not None or itf.kind != "boundary"
    return out


def two_scale_direction(assembly: Assembly, points: InterfacePoints, k: FloatArray,
                        stiff: FloatArray) -> TwoScaleDirection | None:
    """The correction for every side of a contact interface and every stop: k (n_points, 2)
    the direction of the macro part, ``stiff`` = D (n_points, 2). None without any."""
    columns: list[FloatArray] = []
    n_flat = 2 * points.n_points
    for (i, side), p in points.side_points.items():
        itf = assembly.interfaces[i]
        if itf.contact is None or p.size < 2:
            continue
        # the paper's macro functions (§2.2), orthonormal on this side's own points
        functions = interface_functions(points, i, len(itf.sides), reference=side)[side]
        for component in range(2):
            for values in functions.T:
                column = np.zeros(n_flat)
                column[2 * p + component] = values
                columns.append(column)
    if not columns:
        return None
    full = np.column_stack(columns)
    support = np.flatnonzero(np.any(full != 0.0, axis=1))
    basis = full[support]
    weighted = np.repeat(points.weights, 2)[support, None] * basis
    difference = (k - stiff).reshape(-1)[support]
    coupling = weighted.T @ (difference[:, None] * basis)
    ratio = float(np.min(k.reshape(-1)[support] / stiff.reshape(-1)[support]))
    return TwoScaleDirection(support, basis, weighted, 0.5 * (coupling + coupling.T), ratio)


def coupled_local_stage(local: Callable[[Any, Any], tuple[Any, Any]],
                        contact: Callable[[Any, Any, Any, Any], None] | None,
                        direction: TwoScaleDirection, displacement: Any, force: Any,
                        start: Any) -> tuple[Any, Any, Any]:
    """ŝ = (Ŵ, F̂) on Γ with F̂ − F = H (Ŵ − W) (E+ with the two-scale H), from the
    point-wise local stage ``local`` with D (and ``contact``, its contact part alone in
    place, for the inner iterations after the first; None: ``local`` every time): (Ŵ, F̂,
    Eᵀ M0 Ŵ) — the last per case and step, (n_cases, n_steps, r), the next call's
    ``start`` (the inner iteration begins from the last Ŵ's macro part: W moves between
    iterations, Ŵ's macro part hardly). NumPy arrays or torch tensors alike.

    The inner iteration solves a = T(a), T(a) = Eᵀ M0 (Ŵ(F + E G a) − W), whose Jacobian
    (on fixed branches) has its spectrum in [0, 1 − k / D]: Chebyshev's semi-iteration on
    I − T' ∈ [k / D, 1], ``INNER_ITERATIONS`` evaluations of T."""
    shape = displacement.shape
    rows = shape[0] * shape[1]
    projected_w = direction.project(displacement.reshape(rows, -1))
    a = start.reshape(rows, -1) - projected_w  # a = Eᵀ M0 (Ŵ − W)
    shifted = force.reshape(rows, -1) * 1.0  # a copy
    if isinstance(shifted, np.ndarray):
        shifted = np.ascontiguousarray(shifted)
    base = direction.gather(shifted)
    alphas, betas = chebyshev_steps(direction.ratio)
    step = None
    for inner, (alpha, beta) in enumerate(zip(alphas, betas, strict=True)):
        direction.scatter(shifted, base + direction.expand(a))
        if inner == 0 or contact is None:
            w_hat, f_hat = local(displacement, shifted.reshape(shape))
        else:
            contact(displacement, shifted.reshape(shape), w_hat, f_hat)
        residual = direction.project(w_hat.reshape(rows, -1)) - projected_w - a
        step = residual if step is None else residual + beta * step
        a = a + alpha * step
    return w_hat, f_hat, (a + projected_w).reshape(shape[0], shape[1], -1)


def chebyshev_steps(ratio: float) -> tuple[FloatArray, FloatArray]:
    """Chebyshev's semi-iteration for a map whose I − T' has its spectrum in [ratio, 1]:
    per pass (``INNER_ITERATIONS``), the step length α and the weight β of the previous
    direction (0 at the first pass), s ← r + β s, a ← a + α s."""
    passes = INNER_ITERATIONS
    centre, half = 0.5 * (1.0 + ratio), 0.5 * (1.0 - ratio)
    alphas, betas = np.zeros(passes), np.zeros(passes)
    alpha = 1.0 / centre
    alphas[0] = alpha
    for inner in range(1, passes):
        beta = 0.5 * (half * alpha) ** 2 if inner == 1 else (0.5 * half * alpha) ** 2
        alpha = 1.0 / (centre - beta / alpha)
        alphas[inner], betas[inner] = alpha, beta
    return alphas, betas


def compiled_local_stage(local: LocalStage, direction: TwoScaleDirection,
                         displacement: FloatArray, force: FloatArray, start: FloatArray,
                         settled: tuple[IntArray, FloatArray, FloatArray] | None = None
                         ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """``coupled_local_stage`` with the compiled kernels (``local.fused``): the local stage
    off the contact interfaces once, then the inner passes of the contact part with their
    projections in one compiled loop (``kernels.coupled_contact``); the same answers to
    rounding (tests). settled: per case its first step still iterated and the last ŝ
    (``engine``'s settled steps): the steps before keep that ŝ and their ``start`` rows."""
    assert kernels.coupled_contact is not None
    displacement = np.ascontiguousarray(displacement)
    force = np.ascontiguousarray(force)
    w_hat, f_hat = local.without_contact(displacement, force,
                                         None if settled is None else settled[0])
    if settled is None:
        first = np.zeros(displacement.shape[0], dtype=np.int64)
        macro = np.empty((*displacement.shape[:2], direction.n_functions))
    else:
        first = settled[0]
        keep_settled(first, (w_hat, f_hat), settled[1:])
        macro = np.array(start)
    kernels.coupled_contact(displacement, force, w_hat, f_hat,
                            np.ascontiguousarray(start), macro, *direction.entries,
                            *direction.coupling_entries,
                            *chebyshev_steps(direction.ratio), *local.contact_data(), first)
    return w_hat, f_hat, macro


def keep_settled(first: IntArray, into: tuple[FloatArray, ...],
                 source: tuple[FloatArray, ...]) -> None:
    """Rows (case, step) before each case's ``first`` step copied from ``source`` into
    ``into`` (arrays of shape (n_cases, n_steps, ...)): the settled steps keep their ŝ."""
    rows = np.arange(into[0].shape[1])[None, :] < first[:, None]
    for target, values in zip(into, source, strict=True):
        target[rows] = values[rows]
