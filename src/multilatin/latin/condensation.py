"""A substructure's condensed interface operator C_E = T_E S_E⁻¹ T_Eᵀ M0 (paper eq. [13])
from one sparse factorisation of S_E = K_E + T_Eᵀ M0 H T_E whose last unknowns are those
the trace reads (``condense``).

Eliminating the interior unknowns first leaves, in the factors' last block, the Schur
complement Σ = S_bb − S_bi S_ii⁻¹ S_ib on the trace's unknowns b, and (S⁻¹)_bb = Σ⁻¹: so
C_E = T_b U_bb⁻¹ L_bb⁻¹ T_bᵀ M0, two dense triangular solves of the size of the interface.
Before (session 21) C_E came from S⁻¹ Tᵀ M0 in full, one sparse solve per interface
unknown (100–200 per B1/B3 substructure): half of building a cold B1 case's operators,
and a cost growing as the interface times the factors (3-4 times the new one on a
substructure of 18 818 unknowns).
The interior ordering is SuperLU's minimum degree on S_ii; the factorisation takes its
diagonal pivots (S_E is positive definite), checked, else the solves of before are used.
The dense S⁻¹ Tᵀ M0 that recovers interior displacements as one product is built when it
pays (``SubstructureOperators.interior``).
"""

from __future__ import annotations

import functools
import hashlib
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..fem.elasticity import FloatArray, IntArray
from ..kept import Kept
from .threads import one_blas_thread

#: the largest S⁻¹ Tᵀ M0 kept per substructure for the recovery (entries: 16 MiB)
RECOVERY_ENTRIES = 2**21

#: substructures of fewer unknowns take the solves: the second factorisation and the
#: blocks cost more than they save there (``python benchmarks/condensation.py --refine 1 2
#: 4``, one BLAS thread, ms by solves against the Schur complement: 162 unknowns 1.1 /
#: 1.8-1.9; 578: 5.9-6.2 / 4.7-5.7; 1 250: 17.5-28.3 / 15.0-19.9; 4 802: 149-302 /
#: 71-107; 18 818: 1 700-3 695 / 580-1 079)
SCHUR_MIN_DOFS = 500


class Factorisation(Protocol):
    """S_E⁻¹ applied to right-hand sides (n_dofs,) or (n_dofs, n_columns)."""

    def solve(self, rhs: FloatArray) -> FloatArray: ...


class ReorderedFactor:
    """S⁻¹ from the factorisation of S[order][:, order] (``order``: new position → dof)."""

    def __init__(self, lu: spla.SuperLU, order: IntArray) -> None:
        self.lu = lu
        self.order = order

    def solve(self, rhs: FloatArray) -> FloatArray:
        out = np.empty_like(rhs, dtype=np.float64)
        # Fortran-ordered: SuperLU solves column by column (C order costs it 10-50 % more)
        out[self.order] = self.lu.solve(np.asfortranarray(rhs[self.order], dtype=np.float64))
        return out


def condense(operator: sp.spmatrix, trace: sp.csr_matrix, m0: FloatArray,
             schur: bool | None = None, pattern: sp.spmatrix | None = None
             ) -> tuple[Factorisation, FloatArray, FloatArray | None]:
    """The factorised S_E, C_E = T S_E⁻¹ Tᵀ M0 (dense, n_t × n_t) and, where it came as a
    by-product of the solves and holds at most ``RECOVERY_ENTRIES``, S_E⁻¹ Tᵀ M0 (else
    None). ``schur``: the Schur complement's
    way (True), the solves (False), or by size (None: from ``SCHUR_MIN_DOFS`` unknowns).
    ``pattern``: a matrix whose nonzeros include the operator's on the interior unknowns (a
    holed substructure's uncut stiffness), on which the interior's ordering is computed:
    every hole position of a mesh then shares one ordering (``interior_ordering``).
    BLAS on one thread (``threads.one_blas_thread``): small dense blocks."""
    with one_blas_thread():
        return _condense(operator, trace, m0, schur, pattern)


#: fill-reducing orderings of interiors, by a digest of the interior's nonzero pattern
_ORDERINGS: Kept[str, IntArray] = Kept(64)


def interior_ordering(inner: sp.csc_matrix) -> IntArray:
    """SuperLU's minimum-degree ordering of ``inner`` (position → unknown), computed once per
    nonzero pattern: the substructures of one mesh pattern (a study's hole positions, a
    regular decomposition's equal substructures) share it. It takes a factorisation of its
    own (SuperLU gives no ordering alone): 6 ms of a B3 substructure's 24."""
    key = hashlib.sha1(np.int64(inner.shape[0]).tobytes() + inner.indptr.tobytes()
                       + inner.indices.tobytes()).hexdigest()

    def order() -> IntArray:
        # SuperLU orders the columns on the pattern alone; values that keep the
        # factorisation regular whatever the pattern's matrix (-1 off the diagonal, a
        # dominant diagonal) leave that ordering as the matrix's own
        structure = sp.csc_matrix((np.full(inner.nnz, -1.0), inner.indices, inner.indptr),
                                  shape=inner.shape)
        structure = structure + sp.diags(np.diff(inner.indptr) + 1.0)
        out = np.argsort(spla.splu(structure.tocsc(), permc_spec="MMD_AT_PLUS_A").perm_c)
        out.setflags(write=False)
        return out

    return _ORDERINGS.get(key, order)


def _condense(operator: sp.spmatrix, trace: sp.csr_matrix, m0: FloatArray,
              schur: bool | None, pattern: sp.spmatrix | None
              ) -> tuple[Factorisation, FloatArray, FloatArray | None]:
    operator = sp.csc_matrix(operator)
    n = operator.shape[0]
    trace = sp.csr_matrix(trace)
    support = np.unique(trace.indices)
    interior = np.setdiff1d(np.arange(n), support)
    wanted = n >= SCHUR_MIN_DOFS if schur is None else schur
    if wanted and support.size and interior.size:
        source = operator if pattern is None else sp.csc_matrix(pattern)
        inner = source[interior][:, interior].tocsc()
        inner.sort_indices()
        ordering = interior_ordering(inner)
        order = np.concatenate([interior[ordering], support])
        lu = spla.splu(operator[order][:, order].tocsc(), permc_spec="NATURAL",
                       diag_pivot_thresh=0.0, options={"SymmetricMode": True})
        last = np.arange(n - support.size, n)
        # the trace's unknowns still last, in order, on both sides: no pivot moved them
        if np.array_equal(lu.perm_r[last], last) and np.array_equal(lu.perm_c[last], last):
            tail = slice(n - support.size, n)
            lower = sp.csc_matrix(lu.L)[tail, tail].toarray()
            upper = sp.csc_matrix(lu.U)[tail, tail].toarray()
            on_support = trace[:, support].toarray()  # T_b (n_t × n_b)
            inverse_rhs = sla.solve_triangular(lower, on_support.T * m0, lower=True,
                                               unit_diagonal=True, check_finite=False)
            inverse_rhs = sla.solve_triangular(upper, inverse_rhs, check_finite=False)
            return ReorderedFactor(lu, order), on_support @ inverse_rhs, None
    # small, no interior, or pivots the factorisation had to move: one solve per interface
    # unknown (Fortran-ordered right-hand sides: SuperLU solves column by column)
    factor = spla.splu(operator)
    interior_response = factor.solve((trace.T @ sp.diags(m0)).toarray(order="F"))
    kept = interior_response if interior_response.size <= RECOVERY_ENTRIES else None
    return factor, np.asarray(trace @ interior_response), kept  # S⁻¹ Tᵀ M0


@dataclass(frozen=True)
class SubstructureOperators:
    """What one substructure contributes to the linear stage: the factorised
    S_E = K_E + T_Eᵀ M0 k T_E (eq. [13]), the condensed C_E = T_E S_E⁻¹ T_Eᵀ M0, and its
    share of the macro problem: the response Q_E = C_E k Ẽ_E to unit macro unknowns and the
    homogenised operator L_E = Ẽ_Eᵀ M0 k Ẽ_E − (M0 k Ẽ_E)ᵀ Q_E (eq. [14]); k stands for
    the search direction H, diagonal or two-scale (``two_scale``)."""

    key: str
    factor: Factorisation
    condensed: FloatArray
    macro_columns: npt.NDArray[np.int64]  # the macro unknowns of E's interfaces
    macro_response: FloatArray  # Q_E on those columns (2 P_E × n_E)
    homogenised: FloatArray  # L_E on those columns (n_E × n_E)
    #: S_E⁻¹ T_Eᵀ M0, dense (n_dofs × 2 P_E), where it holds at most ``RECOVERY_ENTRIES``:
    #: the interior displacements of many columns as one product (``interior``)
    recovery: FloatArray | None = None
    #: T_Eᵀ M0 (n_dofs × 2 P_E, sparse): the right-hand sides of the interior solves
    trace_rhs: sp.csc_matrix | None = None
    #: H (Ẽ_E − Q_E) on ``macro_columns`` (2 P_E × n_E): the forces' share of the macro
    #: correction, F += H (Ẽ − Q) W̃ᴹ (eq. [13]–[15]); None without a macro problem
    force_response: FloatArray | None = None
    #: columns asked of ``interior`` so far, and ``recovery`` once built there
    _built: dict[str, Any] = field(default_factory=dict, init=False, repr=False,
                                   compare=False)

    def dense_recovery(self) -> FloatArray | None:
        """S_E⁻¹ T_Eᵀ M0, dense (built by solves on the first call where not kept from the
        build); None where it would hold more than ``RECOVERY_ENTRIES``."""
        if self.recovery is not None:
            return self.recovery
        if "recovery" not in self._built:
            rhs = self.trace_rhs
            fits = rhs is not None and rhs.shape[0] * rhs.shape[1] <= RECOVERY_ENTRIES
            self._built["recovery"] = (self.factor.solve(rhs.toarray(order="F"))
                                       if rhs is not None and fits else None)
        return self._built["recovery"]  # type: ignore[no-any-return]

    def interior(self, columns: FloatArray) -> FloatArray:
        """Interior displacements S_E⁻¹ T_Eᵀ M0 x for rows x of ``columns`` (n_columns,
        2 P_E), as (n_columns, n_dofs): by solves until as many columns have been asked as
        building the dense S_E⁻¹ T_Eᵀ M0 takes, then by one product with it (a single
        solve's few steps never pay for it, a study's cases do)."""
        recovery = self.recovery if self.recovery is not None else self._built.get("recovery")
        if recovery is None and self.trace_rhs is not None:
            asked = self._built.get("asked", 0) + columns.shape[0]
            self._built["asked"] = asked
            if asked >= self.trace_rhs.shape[1]:
                recovery = self.dense_recovery()
        if recovery is not None:
            return np.asarray(columns @ recovery.T)
        assert self.trace_rhs is not None
        rhs = np.asfortranarray(self.trace_rhs @ columns.T)
        return np.asarray(self.factor.solve(rhs).T)

    @functools.cached_property
    def condensed_transposed(self) -> FloatArray:
        """C_Eᵀ, contiguous: the linear stage multiplies rows of right-hand sides by it."""
        return np.ascontiguousarray(self.condensed.T)

    @functools.cached_property
    def macro_response_transposed(self) -> FloatArray:
        return np.ascontiguousarray(self.macro_response.T)

    @functools.cached_property
    def force_response_transposed(self) -> FloatArray:
        """(H (Ẽ_E − Q_E))ᵀ, contiguous (zeros where there is none)."""
        force = (self.force_response if self.force_response is not None
                 else np.zeros_like(self.macro_response))
        return np.ascontiguousarray(force.T)
