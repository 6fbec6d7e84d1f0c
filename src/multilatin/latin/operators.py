"""The geometry-dependent part of the LATIN linear stage (paper §2.3, eq. [12]–[15];
method.md §4): per substructure the factorised stiffness with the search direction, the
condensed interface operator and its share of the homogenised macro operator, built once per
geometry and reused across friction coefficients, gaps, loads and unchanged substructures.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ..decomposition.assembly import DISPLACEMENT, Assembly, Substructure
from ..decomposition.interfaces import (
    InterfacePoints,
    build_points,
    macro_basis,
    with_contact_data,
)
from ..errors import ModelError
from ..fem.elasticity import FloatArray, IntArray
from ..fem.mesh import SIDES, normal_axis
from ..kept import Kept
from . import kernels
from .condensation import SubstructureOperators, condense
from .local_stage import MacroOnlyMap, macro_only_map
from .signatures import digest, interface_signature, with_substructures
from .threads import one_blas_thread
from .two_scale import TwoScaleDirection, stiffened_points, two_scale_direction

if TYPE_CHECKING:
    from .options import LatinOptions


#: a batch of several geometries: per geometry, its operators and the columns (case ×
#: step) of its cases
Geometries = Sequence[tuple["LatinOperators", "slice | IntArray"]]


class LatinOperators:
    """Everything of the linear stage that depends on the geometry only: factorised
    substructure operators, the condensed block-diagonal operator C, the macro basis and the
    factorised homogenised macro operator (eq. [15]).

    reuse: operators of another assembly; every substructure whose geometry, interface
        discretisation, search direction and macro basis are unchanged takes its operators
        from there (paper §6: when a hole changes, only its substructure is rebuilt).
        ``rebuilt`` names the substructures built here; where only holes differ (the same
        ``interface_signature``) the interface points, search direction and macro basis
        are taken over too (the contact data from ``assembly``).
    """

    points: InterfacePoints
    indicator_k: FloatArray
    search_direction: FloatArray
    two_scale: TwoScaleDirection | None
    m0: FloatArray
    macro_basis: sp.csr_matrix | None
    interface_keys: tuple[str, ...]
    project: sp.csr_matrix  # Π = Ẽᵀ M0 (with a macro basis)

    def __init__(self, assembly: Assembly, options: LatinOptions,
                 reuse: LatinOperators | None = None) -> None:
        # BLAS on one thread: the dense blocks here are small, and a threaded BLAS woken
        # after the iteration's one-thread sections (or beside PyTorch's OpenMP threads)
        # spent 20–200 ms on the macro problem's 204 × 204 Cholesky factor (b3)
        with one_blas_thread():
            self._build(assembly, options, reuse)

    def _build(self, assembly: Assembly, options: LatinOptions,
               reuse: LatinOperators | None) -> None:
        self.assembly = assembly
        self.options = options
        self.interface_signature = interface_signature(assembly, options)
        self.signature = with_substructures(self.interface_signature, assembly)
        if reuse is not None and reuse.interface_signature == self.interface_signature:
            # the same interfaces (paper §6: a hole moved inside a substructure): their
            # points, search direction and macro basis are the same, the contact data apart
            self.points = with_contact_data(reuse.points, assembly)
            self.indicator_k, self.search_direction = reuse.indicator_k, reuse.search_direction
            self.two_scale = reuse.two_scale
            self.m0, basis = reuse.m0, reuse.macro_basis
            self.interface_keys = reuse.interface_keys
            if "macro_only" in reuse.__dict__:  # built (``macro_only``): the same points and k
                self.__dict__["macro_only"] = reuse.macro_only
        else:
            basis = self._build_interfaces(assembly, options)
        pts = self.points
        k_flat = self.search_direction.reshape(-1)
        available = reuse.blocks if reuse is not None else {}

        self.blocks: dict[str, SubstructureOperators] = {}
        self.substructure_operators: list[SubstructureOperators] = []
        rebuilt = []
        for s, sub in enumerate(assembly.substructures):
            key = digest(sub.signature(), self.interface_keys[s])
            block = available.get(key) or self.blocks.get(key)
            if block is None:
                lo, hi = 2 * pts.offsets[s], 2 * pts.offsets[s + 1]
                rows = basis[lo:hi] if basis is not None else None
                coupling = self.two_scale.block(lo, hi) if self.two_scale is not None else None
                block = self._substructure(sub.stiffness(), pts.traces[s], self.m0[lo:hi],
                                           k_flat[lo:hi], rows, key, coupling,
                                           sub.stiffness_pattern(),
                                           interface_key=self.interface_keys[s])
                rebuilt.append(sub.name)
            self.blocks[key] = block
            self.substructure_operators.append(block)
        self.rebuilt = tuple(rebuilt)
        self.factors = [b.factor for b in self.substructure_operators]
        self.flat_ranges = [(2 * pts.offsets[s], 2 * pts.offsets[s + 1])
                            for s in range(len(assembly.substructures))]

        self.macro_basis = basis
        if basis is not None:
            n_macro = basis.shape[1]
            homogenised = np.zeros((n_macro, n_macro))
            for block in self.substructure_operators:
                columns = block.macro_columns
                # L = Σ_E L_E, the assembled homogenised operator (eq. [14]–[15])
                homogenised[np.ix_(columns, columns)] += block.homogenised
            homogenised = 0.5 * (homogenised + homogenised.T)
            factor = self._factorise_macro(homogenised)
            # L⁻¹, dense (n_macro² is small): W̃ᴹ = L⁻¹ (F_dᴹ − Π F) (eq. [15])
            self.homogenised_inverse = sla.cho_solve(factor, np.eye(homogenised.shape[0]))
            # Π = Ẽᵀ M0, taken over with the interfaces (a hole moved inside a substructure)
            self.project = (reuse.project if reuse is not None and basis is reuse.macro_basis
                            else (basis.T @ sp.diags(self.m0)).tocsr())

    def _build_interfaces(self, assembly: Assembly, options: LatinOptions
                          ) -> sp.csr_matrix | None:
        """The interface points, the search direction H (D and the two-scale part), M0 and
        per substructure a digest of its interface data (``interface_keys``); returns the
        macro basis (None without a macro problem)."""
        self.points = build_points(assembly, options.interface_elements,
                                   held_nodes=options.held_nodes)
        pts = self.points
        #: k of the indicator's norm (paper §4.3) and of the accelerations' inner products:
        #: the search direction without the corner stiffening, so that η — and the default
        #: tolerance chosen on it — mean what they meant before it (docs/convergence.md)
        self.indicator_k = self._search_direction()
        macro_k = self.indicator_k * self._corner_factors()[:, None]
        #: D, the diagonal of the search direction H (the local stage's point-wise k)
        self.search_direction = macro_k
        #: H − D on contact sides and stops (``LatinOptions.micro_stiffening``), or None
        self.two_scale = None
        if options.micro_stiffening != 1.0:
            stiffened = stiffened_points(assembly, pts)
            self.search_direction = macro_k * np.where(stiffened, options.micro_stiffening,
                                                       1.0)[:, None]
            self.two_scale = two_scale_direction(assembly, pts, macro_k,
                                                 self.search_direction)
        k_flat = self.search_direction.reshape(-1)
        self.m0 = np.repeat(pts.weights, 2)  # diagonal of M0 on flat (2P) vectors
        basis = macro_basis(assembly, pts) if options.macro else None
        if basis is not None and not basis.shape[1]:
            basis = None
        keys = []
        for s in range(len(assembly.substructures)):
            lo, hi = 2 * pts.offsets[s], 2 * pts.offsets[s + 1]
            keys.append(digest(pts.traces[s], k_flat[lo:hi], self.m0[lo:hi],
                                basis[lo:hi] if basis is not None else None,
                                self.two_scale.block(lo, hi) if self.two_scale else None))
        #: per substructure, a digest of what its operators take from the interfaces:
        #: substructures with equal stiffness and equal keys share their operators
        self.interface_keys = tuple(keys)
        return basis

    @staticmethod
    def _substructure(stiffness: sp.csr_matrix, trace: sp.csr_matrix, m0: FloatArray,
                      k: FloatArray, basis_rows: sp.csr_matrix | None, key: str,
                      coupling: FloatArray | None = None,
                      pattern: sp.csr_matrix | None = None, *,
                      interface_key: str) -> SubstructureOperators:
        """coupling: M0 (H − D) on the substructure's points (``TwoScaleDirection.block``),
        H's part beyond its diagonal D = k; pattern: ``Substructure.stiffness_pattern``;
        interface_key: a digest of trace, M0 and H there (``interface_keys``), under which
        Tᵀ M0 H T and Tᵀ M0 are kept: a hole moved inside the substructure changes neither."""
        def interface_terms() -> tuple[sp.csr_matrix, sp.csc_matrix]:
            m0_h = sp.diags(m0 * k) + (sp.csr_matrix(coupling) if coupling is not None else 0)
            return (sp.csr_matrix(trace.T @ m0_h @ trace),
                    sp.csc_matrix(trace.T @ sp.diags(m0)))

        term, trace_rhs = _INTERFACE_TERMS.get(interface_key, interface_terms)
        operator = (stiffness + term).tocsc()
        # C_E = T S⁻¹ Tᵀ M0, dense, from the factorisation's last block (``condensation``)
        factor, condensed, recovery = condense(operator, trace, m0, pattern=pattern)
        if basis_rows is None:
            empty = np.zeros((0, 0))
            return SubstructureOperators(key, factor, condensed, np.zeros(0, dtype=np.int64),
                                         np.zeros((condensed.shape[0], 0)), empty, recovery,
                                         trace_rhs)
        columns = np.unique(basis_rows.indices).astype(np.int64)  # E's own macro unknowns
        own_basis = basis_rows[:, columns]
        mk_basis = (sp.diags(m0 * k) @ own_basis).toarray()  # M0 H Ẽ_E
        if coupling is not None:
            mk_basis += coupling @ own_basis
        response = condensed @ (mk_basis / m0[:, None])  # Q_E = C_E H Ẽ_E
        homogenised = (own_basis.T @ mk_basis) - mk_basis.T @ response
        # H (Ẽ_E − Q_E) = M0⁻¹ (M0 H Ẽ_E) − D Q_E − M0⁻¹ M0 (H − D) Q_E
        force_response = mk_basis / m0[:, None] - k[:, None] * response
        if coupling is not None:
            force_response -= (coupling @ response) / m0[:, None]
        return SubstructureOperators(key, factor, condensed, columns, response,
                                     np.asarray(homogenised), recovery, trace_rhs,
                                     force_response)

    def _search_direction(self) -> FloatArray:
        """k per interface point and component: κ E t / L (per unit length, as the
        interface forces: t the thickness), with E, t and L per side as
        ``LatinOptions.search_modulus`` says; stiffer on prescribed displacements."""
        opts = self.options
        pts = self.points
        k = np.zeros((pts.n_points, 2))
        section = _sections(self.assembly.substructures)

        for i, itf in enumerate(self.assembly.interfaces):
            indices = [r.substructure for r in itf.sides]
            subs = [self.assembly.substructures[j] for j in indices]
            if opts.search_modulus == "mean" or len(subs) == 1:
                young = float(np.mean([s.material.young * section[j]
                                       for s, j in zip(subs, indices, strict=True)]))
                values = [opts.kappa * young / self._smaller_side(subs[0].body)] * len(subs)
            else:  # each side from the substructure on the other side, or its own
                order = indices[::-1] if opts.search_modulus == "neighbour" else indices
                values = [opts.kappa * self.assembly.substructures[j].material.young
                          * section[j] / self._smaller_side(self.assembly.substructures[j].body)
                          for j in order]
            for side_index, value in enumerate(values):
                k[pts.side_points[(i, side_index)]] = value
            if itf.contact is not None and opts.tangential_ratio != 1.0:
                if itf.sides[0].side not in SIDES:
                    raise ModelError(f"interface {itf.name!r}: tangential_ratio != 1 needs an "
                                     "axis-aligned contact normal (a rectangle's side), not "
                                     f"the named face {itf.sides[0].side!r}")
                tangential = 1 - normal_axis(itf.sides[0].side)
                for side_index in range(len(itf.sides)):
                    k[pts.side_points[(i, side_index)], tangential] *= opts.tangential_ratio
            elif itf.condition is not None:
                for comp, kind in enumerate(itf.condition.kinds):
                    if kind == DISPLACEMENT:
                        k[pts.side_points[(i, 0)], comp] *= opts.dirichlet_stiffening
        return k

    def _smaller_side(self, body: str) -> float:
        """L of k = κ E / L: the smaller side of the body's bounding box."""
        x0, x1, y0, y1 = self.assembly.body_box(body)
        return min(x1 - x0, y1 - y0)

    def _corner_factors(self) -> FloatArray:
        """``LatinOptions.corner_stiffening`` per interface point (1 where it does not act)."""
        opts, pts = self.options, self.points
        if opts.corner_stiffening == 1.0:
            return np.ones(pts.n_points)
        sides = np.array([self._smaller_side(sub.body) for sub in self.assembly.substructures])
        factors = corner_factors(pts, opts.corner_stiffening,
                                 opts.corner_reach * sides[pts.substructure])
        # a macro-only interface's local stage (eq. [20]) takes one k per side
        factors[np.isin(pts.interface, list(pts.macro_only))] = 1.0
        return factors

    @staticmethod
    def _factorise_macro(homogenised: FloatArray) -> tuple[FloatArray, bool]:
        try:
            factor = sla.cho_factor(homogenised)
        except np.linalg.LinAlgError:
            raise ModelError(
                "macro problem is singular: the assembly is not held against rigid-body motion"
            ) from None
        pivots = np.abs(np.diag(factor[0]))
        if pivots.min() < 1e-7 * pivots.max():
            raise ModelError(
                "macro problem is singular: the assembly is not held against rigid-body motion"
            )
        return factor  # type: ignore[no-any-return]

    @functools.cached_property
    def macro_only(self) -> MacroOnlyMap:
        """The local stage's map on macro-only interfaces (``local_stage.macro_only_map``):
        it depends on the interface discretisation and k only, so it is built once here."""
        return macro_only_map(self.points, self.search_direction)

    def _blocks(self, s: int, geometries: Geometries | None
                ) -> Sequence[tuple[SubstructureOperators, slice | IntArray | None]]:
        """Substructure ``s``'s operators and the columns they act on: all (None) when every
        geometry of the batch shares them, else each geometry's on its own columns."""
        own = self.substructure_operators[s]
        if geometries is None or all(ops.substructure_operators[s] is own
                                     for ops, _ in geometries):
            return ((own, None),)
        return [(ops.substructure_operators[s], columns) for ops, columns in geometries]

    def micro_stage(self, displacement_hat: FloatArray, force_hat: FloatArray,
                    geometries: Geometries | None = None, body: FloatArray | None = None
                    ) -> tuple[FloatArray, FloatArray]:
        """The linear stage (eq. [12]–[15]) is ``micro_stage`` then, with a macro basis,
        ``macro_correction``, for all columns (steps, and cases of a batch) at once; fields
        ``(n_columns, n_points, 2)``. Here, the substructure problems with zero macro
        correction: W = C (F̂ + k Ŵ) and F = F̂ + k (Ŵ − W) (eq. [13]). Dense products per
        substructure, rows being columns of the right-hand side, so nothing is transposed.

        geometries: a batch of several geometries sharing these interfaces
        (``same_interfaces``: a hole moved inside a substructure), each one's operators and
        the columns of its cases; the substructures they share act on every column at
        once, the others geometry by geometry. None: these operators on every column.
        body: T S⁻¹ f per column, added to W (body forces, ``body_forces``)."""
        shape = displacement_hat.shape
        rhs = self.direction_update(displacement_hat, base=force_hat).reshape(shape[0], -1)
        flat_displacement = np.empty_like(rhs)
        for s, (lo, hi) in enumerate(self.flat_ranges):
            for block, columns in self._blocks(s, geometries):
                if columns is None:
                    np.matmul(rhs[:, lo:hi], block.condensed_transposed,
                              out=flat_displacement[:, lo:hi])
                else:
                    flat_displacement[columns, lo:hi] = (rhs[columns, lo:hi]
                                                         @ block.condensed_transposed)
        displacement: FloatArray = flat_displacement.reshape(shape)
        if body is not None:
            displacement += body
        force = self.direction_update(displacement_hat, displacement, base=force_hat)
        return displacement, force

    def apply_direction(self, field: FloatArray) -> FloatArray:
        """H x: k x, plus the two-scale part where there is one; fields (n, n_points, 2)."""
        out: FloatArray = self.search_direction * field
        if self.two_scale is not None:
            self.two_scale.add_correction(out.reshape(field.shape[0], -1),
                                          field.reshape(field.shape[0], -1))
        return out

    @functools.cached_property
    def _direction_entries(self) -> tuple[FloatArray | IntArray, ...]:
        """k and the two-scale part's arrays for ``kernels.direction_update``."""
        k_flat = np.ascontiguousarray(self.search_direction.reshape(-1))
        if self.two_scale is None:
            none, zero = np.zeros(0, dtype=np.int64), np.zeros(1, dtype=np.int64)
            return (k_flat, zero, none, np.zeros(0), np.zeros(0), zero, none, np.zeros(0))
        return (k_flat, *self.two_scale.entries, *self.two_scale.coupling_entries)

    def direction_update(self, a: FloatArray, b: FloatArray | None = None,
                         base: FloatArray | None = None, out: FloatArray | None = None
                         ) -> FloatArray:
        """base + H (a − b) on fields (n, n_points, 2) (``b``, ``base`` optional; ``out``
        may be ``base``): one compiled pass where Numba is, the same numbers as
        ``apply_direction`` (the linear stage's force updates, eq. [13])."""
        arrays = [x for x in (a, b, base, out) if x is not None]
        if kernels.direction_update is None or not all(x.flags.c_contiguous for x in arrays):
            value = self.apply_direction(a if b is None else a - b)
            if base is None:
                return value
            if out is base:
                base += value
                return base
            return base + value
        rows = a.reshape(a.shape[0], -1)
        result = out if out is not None else np.empty_like(a)
        kernels.direction_update(result.reshape(rows.shape),
                                 rows if base is None else base.reshape(rows.shape), rows,
                                 rows if b is None else b.reshape(rows.shape), base is not None,
                                 b is not None, *self._direction_entries)
        return result

    def macro_correction(self, displacement: FloatArray, force: FloatArray,
                         macro_force_data: FloatArray, geometries: Geometries | None = None
                         ) -> None:
        """The macro problem, in place: W̃ᴹ = L⁻¹ (F_dᴹ − Π F) (eq. [14]–[15]), then
        substructure by substructure (on E's own macro unknowns) W += Q W̃ᴹ and
        F += H (Ẽ − Q) W̃ᴹ, by products with Qᵀ and (H (Ẽ − Q))ᵀ (an extension Ẽ W̃ᴹ
        over every point and a pass of H over the fields cost B3 twice as much).
        geometries: as in ``micro_stage`` (L⁻¹ per geometry). Fields C-contiguous
        (``micro_stage``'s)."""
        shape = displacement.shape
        flat_force = force.reshape(shape[0], -1)
        residual = macro_force_data - (self.project @ flat_force.T).T
        if geometries is None:
            macro = residual @ self.homogenised_inverse
        else:
            macro = np.empty_like(residual)
            for ops, rows in geometries:
                macro[rows] = residual[rows] @ ops.homogenised_inverse
        on_displacement = np.empty_like(flat_force)
        on_force = np.empty_like(flat_force)
        for s, (lo, hi) in enumerate(self.flat_ranges):
            for block, columns in self._blocks(s, geometries):
                if columns is None:
                    own = macro[:, block.macro_columns]
                    np.matmul(own, block.macro_response_transposed,
                              out=on_displacement[:, lo:hi])
                    np.matmul(own, block.force_response_transposed, out=on_force[:, lo:hi])
                else:
                    own = macro[columns][:, block.macro_columns]
                    on_displacement[columns, lo:hi] = own @ block.macro_response_transposed
                    on_force[columns, lo:hi] = own @ block.force_response_transposed
        displacement += on_displacement.reshape(shape)
        flat_force += on_force

    def recover(self, displacement: FloatArray, force: FloatArray) -> dict[str, FloatArray]:
        """Interior displacements u_E = S_E⁻¹ T_Eᵀ M0 (F + k W) of every substructure, for
        fields (n_columns, n_points, 2) (``SubstructureOperators.interior``)."""
        n_columns = displacement.shape[0]
        x = (force + self.apply_direction(displacement)).reshape(n_columns, -1)
        out = {}
        for s, sub in enumerate(self.assembly.substructures):
            lo, hi = self.flat_ranges[s]
            u_t = self.substructure_operators[s].interior(x[:, lo:hi])
            out[sub.name] = u_t.reshape(n_columns, -1, 2)
        return out


#: Tᵀ M0 H T and Tᵀ M0 per substructure's interface data (``LatinOperators._substructure``)
_INTERFACE_TERMS: Kept[str, tuple[sp.csr_matrix, sp.csc_matrix]] = Kept(64)


def _sections(substructures: Sequence[Substructure]) -> list[float]:
    """Per substructure, the thickness that scales k (κ E t / L): its own; axisymmetric, 2π
    times the mean radius of its body's nodes (as L is the body's), so that a body's pieces
    meeting at a cross point have one k and run as one pair there (``cross_points``; per
    substructure, 6 of 26 random axisymmetric straps stalled: docs/correctness.md, session
    61). Each body's nodes are read once."""
    radial: dict[str, float] = {}
    out = []
    for sub in substructures:
        material = sub.material
        if not material.radial:
            out.append(float(material.thickness))
            continue
        if sub.body not in radial:
            nodes = np.unique(np.round(np.vstack([s.mesh.nodes for s in substructures
                                                  if s.body == sub.body]), 9), axis=0
                              ).astype(np.float64)
            radial[sub.body] = float(material.thickness_at(nodes).mean())
        out.append(radial[sub.body])
    return out


def corner_factors(points: InterfacePoints, factor: float, reach: FloatArray) -> FloatArray:
    """Per interface point: ``factor`` at a corner node — a substructure node that carries
    points of two or more interfaces (an interface ending on another one, on a stop or on a
    loaded, clamped or held face) — falling linearly with the distance to the nearest
    corner to 1 at ``reach`` (per point). A node is a substructure and coordinates rounded
    to 1e-9, as ``held_nodes.node_key`` (here for all points at once)."""
    keys = np.column_stack([points.substructure, np.round(points.coords, 9)])
    _, node, count = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    corners = np.unique(np.round(points.coords[count[node.ravel()] >= 2], 9), axis=0)
    if not corners.size:
        return np.ones(points.n_points)
    distance = np.full(points.n_points, np.inf)
    for xy in corners:  # a few corners per model: one pass over the points each
        distance = np.minimum(distance, np.hypot(*(points.coords - xy).T))
    return np.asarray(1.0 + (factor - 1.0) * np.clip(1.0 - distance / reach, 0.0, 1.0))
