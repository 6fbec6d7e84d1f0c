"""The LATIN micro-macro solver (paper §2.3, §4; method.md §4).

Every load step is one column of the same right-hand side: the linear stage solves all
steps at once. The linear stage works on interface quantities only, through the condensed
operator ``C_E = T_E (K_E + T_Eᵀ M0 k T_E)⁻¹ T_Eᵀ M0`` of each substructure (computed once
per geometry from its factorisation), so that W = C (F̂ + k Ŵ + k W̃ᴹ) (eq. [13]).
Interior displacements are recovered once, at the end.
"""

from __future__ import annotations

import hashlib
import logging
import time
from dataclasses import asdict, dataclass

import numpy as np
import numpy.typing as npt
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from threadpoolctl import threadpool_limits

from .acceleration import Anderson
from .assembly import DISPLACEMENT, Assembly
from .errors import ModelError, NotConvergedError
from .fem.elasticity import FloatArray
from .fem.mesh import normal_axis
from .interfaces import INTERFACE_ELEMENTS, InterfacePoints, build_points, macro_basis
from .local_stage import LocalStage
from .qoi import ContactPressures, evaluate_qois
from .result import InterfaceFields, SolveResult

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class LatinOptions:
    """Discretisation and solver choices (arguments, not model parameters).

    kappa: search direction k = κ E / L per interface (E: mean Young's modulus of the two
        sides, L: the smaller side of the body the interface bounds, so that splitting a
        body into more substructures keeps the same k, measured best in
        ``benchmarks/b1_search_direction.py``); the converged answer does not depend on it.
    tol: stop when the indicator η (paper §4.3) drops below ``tol``.
    max_iter: iteration cap; reaching it without η < tol is a failure, not an answer.
    relaxation: ω in s ← ω s_new + (1 − ω) s_old after each linear stage (method.md §4:
        without it, statically determined clusters give an eigenvalue −1).
    acceleration: ``"relaxation"`` alone, or ``"anderson"``: Anderson mixing of the last
        ``anderson_depth`` iterates of the fixed point s ↦ linear(local(s)), damped by ω
        (combinations of admissible fields stay admissible).
    tangential_ratio: k_T / k_N on contact interfaces and stops (separate normal and
        tangential search directions).
    macro: solve the macro problem (eq. [14]–[15]); False gives the one-scale LATIN.
    interface_elements: see ``multilatin.interfaces``.
    dirichlet_stiffening: factor on k for prescribed-displacement components.
    """

    kappa: float = 0.5
    tol: float = 1e-5
    max_iter: int = 1000
    relaxation: float = 0.9
    macro: bool = True
    interface_elements: str = "nodal"
    dirichlet_stiffening: float = 10.0
    acceleration: str = "relaxation"
    anderson_depth: int = 3
    tangential_ratio: float = 1.0

    def __post_init__(self) -> None:
        if not self.kappa > 0:
            raise ModelError(f"kappa: the search direction must be > 0, got {self.kappa!r}")
        if not self.tol > 0:
            raise ModelError(f"tol: must be > 0, got {self.tol!r}")
        if self.max_iter < 1:
            raise ModelError(f"max_iter: must be >= 1, got {self.max_iter!r}")
        if not 0 < self.relaxation <= 1:
            raise ModelError(f"relaxation: must lie in (0, 1], got {self.relaxation!r}")
        if self.interface_elements not in INTERFACE_ELEMENTS:
            raise ModelError(
                f"interface_elements: expected one of {INTERFACE_ELEMENTS}, "
                f"got {self.interface_elements!r}"
            )
        if self.acceleration not in ("relaxation", "anderson"):
            raise ModelError(f"acceleration: expected 'relaxation' or 'anderson', "
                             f"got {self.acceleration!r}")
        if not self.tangential_ratio > 0:
            raise ModelError(f"tangential_ratio: must be > 0, got {self.tangential_ratio!r}")
        if self.anderson_depth < 1:
            raise ModelError(f"anderson_depth: must be >= 1, got {self.anderson_depth!r}")
        if not self.dirichlet_stiffening >= 1:
            raise ModelError(
                f"dirichlet_stiffening: must be >= 1, got {self.dirichlet_stiffening!r}"
            )


def operator_signature(assembly: Assembly, options: LatinOptions) -> str:
    """A digest of everything the linear-stage operators depend on: the substructures'
    meshes and materials, the interface topology and kinds, and the search direction.
    Friction coefficients, gaps and loads are not in it: they change no operator."""
    interfaces = [(itf.kind, itf.sides, itf.condition.kinds if itf.condition else None,
                   itf.contact is not None) for itf in assembly.interfaces]
    choices = (options.kappa, options.macro, options.interface_elements,
               options.dirichlet_stiffening, options.tangential_ratio)
    text = repr(([s.signature() for s in assembly.substructures], interfaces, choices))
    return hashlib.sha1(text.encode()).hexdigest()


@dataclass(frozen=True)
class SubstructureOperators:
    """What one substructure contributes to the linear stage: the factorised
    S_E = K_E + T_Eᵀ M0 k T_E (eq. [13]), the condensed C_E = T_E S_E⁻¹ T_Eᵀ M0, and its
    share of the macro problem: the response Q_E = C_E k Ẽ_E to unit macro unknowns and the
    homogenised operator L_E = Ẽ_Eᵀ M0 k Ẽ_E − (M0 k Ẽ_E)ᵀ Q_E (eq. [14])."""

    key: str
    factor: spla.SuperLU
    condensed: FloatArray
    macro_columns: npt.NDArray[np.int64]  # the macro unknowns of E's interfaces
    macro_response: FloatArray  # Q_E on those columns (2 P_E × n_E)
    homogenised: FloatArray  # L_E on those columns (n_E × n_E)


def _digest(*parts: object) -> str:
    hasher = hashlib.sha1()
    for part in parts:
        if isinstance(part, np.ndarray):
            hasher.update(np.ascontiguousarray(part).tobytes())
            hasher.update(repr(part.shape).encode())
        elif isinstance(part, sp.spmatrix | sp.sparray):
            matrix = sp.csr_matrix(part)
            for array in (matrix.data, matrix.indices, matrix.indptr):
                hasher.update(np.ascontiguousarray(array).tobytes())
            hasher.update(repr(matrix.shape).encode())
        else:
            hasher.update(repr(part).encode())
    return hasher.hexdigest()


class LatinOperators:
    """Everything of the linear stage that depends on the geometry only: factorised
    substructure operators, the condensed block-diagonal operator C, the macro basis and the
    factorised homogenised macro operator (eq. [15]).

    reuse: operators of another assembly; every substructure whose geometry, interface
        discretisation, search direction and macro basis are unchanged takes its operators
        from there (paper §6: when a hole changes, only its substructure is rebuilt).
        ``rebuilt`` names the substructures built here.
    """

    def __init__(self, assembly: Assembly, options: LatinOptions,
                 reuse: LatinOperators | None = None) -> None:
        self.assembly = assembly
        self.options = options
        self.signature = operator_signature(assembly, options)
        self.points: InterfacePoints = build_points(assembly, options.interface_elements)
        pts = self.points
        self.search_direction = self._search_direction()
        k_flat = self.search_direction.reshape(-1)
        self.m0 = np.repeat(pts.weights, 2)  # diagonal of M0 on flat (2P) vectors
        basis = macro_basis(assembly, pts) if options.macro else None
        if basis is not None and not basis.shape[1]:
            basis = None
        available = reuse.blocks if reuse is not None else {}

        self.blocks: dict[str, SubstructureOperators] = {}
        self.substructure_operators: list[SubstructureOperators] = []
        rebuilt = []
        for s, sub in enumerate(assembly.substructures):
            lo, hi = 2 * pts.offsets[s], 2 * pts.offsets[s + 1]
            rows = basis[lo:hi] if basis is not None else None
            key = _digest(sub.signature(), pts.traces[s], k_flat[lo:hi], self.m0[lo:hi], rows)
            block = available.get(key) or self.blocks.get(key)
            if block is None:
                block = self._substructure(sub.stiffness(), pts.traces[s], self.m0[lo:hi],
                                           k_flat[lo:hi], rows, key)
                rebuilt.append(sub.name)
            self.blocks[key] = block
            self.substructure_operators.append(block)
        self.rebuilt = tuple(rebuilt)
        self.factors = [b.factor for b in self.substructure_operators]
        self.condensed = sp.block_diag([b.condensed for b in self.substructure_operators],
                                       format="csr")

        self.macro_basis = basis
        if basis is not None:
            n_macro = basis.shape[1]
            macro_response = np.zeros((k_flat.size, n_macro))
            homogenised = np.zeros((n_macro, n_macro))
            for s, block in enumerate(self.substructure_operators):
                lo, hi = 2 * pts.offsets[s], 2 * pts.offsets[s + 1]
                columns = block.macro_columns
                macro_response[lo:hi, columns] = block.macro_response
                # L = Σ_E L_E, the assembled homogenised operator (eq. [14]–[15])
                homogenised[np.ix_(columns, columns)] += block.homogenised
            homogenised = 0.5 * (homogenised + homogenised.T)
            factor = self._factorise_macro(homogenised)
            inverse = sla.cho_solve(factor, np.eye(homogenised.shape[0]))
            # residual of macro admissibility -> interface displacement and force corrections
            self.macro_to_displacement = macro_response @ inverse
            self.macro_to_force = k_flat[:, None] * (
                np.asarray(basis @ inverse) - self.macro_to_displacement)
            self.project = (basis.T @ sp.diags(self.m0)).tocsr()

    @staticmethod
    def _substructure(stiffness: sp.csr_matrix, trace: sp.csr_matrix, m0: FloatArray,
                      k: FloatArray, basis_rows: sp.csr_matrix | None,
                      key: str) -> SubstructureOperators:
        operator = (stiffness + trace.T @ sp.diags(m0 * k) @ trace).tocsc()
        factor = spla.splu(operator)
        rhs = (trace.T @ sp.diags(m0)).toarray()
        condensed = trace @ factor.solve(rhs)  # C_E = T S⁻¹ Tᵀ M0, dense
        if basis_rows is None:
            empty = np.zeros((0, 0))
            return SubstructureOperators(key, factor, condensed, np.zeros(0, dtype=np.int64),
                                         np.zeros((condensed.shape[0], 0)), empty)
        columns = np.unique(basis_rows.indices).astype(np.int64)  # E's own macro unknowns
        own_basis = basis_rows[:, columns]
        k_basis = (sp.diags(k) @ own_basis).toarray()
        response = condensed @ k_basis  # Q_E = C_E k Ẽ_E
        mk_basis = m0[:, None] * k_basis
        homogenised = (own_basis.T @ mk_basis) - mk_basis.T @ response
        return SubstructureOperators(key, factor, condensed, columns, response,
                                     np.asarray(homogenised))

    def _search_direction(self) -> FloatArray:
        """k per interface point and component: κ E / L (stiffer on prescribed displacements)."""
        opts = self.options
        pts = self.points
        k = np.zeros((pts.n_points, 2))
        for i, itf in enumerate(self.assembly.interfaces):
            subs = [self.assembly.substructures[r.substructure] for r in itf.sides]
            young = float(np.mean([s.material.young for s in subs]))
            x0, x1, y0, y1 = self.assembly.body_box(subs[0].body)
            value = opts.kappa * young / min(x1 - x0, y1 - y0)
            for side_index in range(len(itf.sides)):
                k[pts.side_points[(i, side_index)]] = value
            if itf.contact is not None:
                tangential = 1 - normal_axis(itf.sides[0].side)
                for side_index in range(len(itf.sides)):
                    k[pts.side_points[(i, side_index)], tangential] *= opts.tangential_ratio
            elif itf.condition is not None:
                for comp, kind in enumerate(itf.condition.kinds):
                    if kind == DISPLACEMENT:
                        k[pts.side_points[(i, 0)], comp] *= opts.dirichlet_stiffening
        return k

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

    def linear_stage(
        self, displacement_hat: FloatArray, force_hat: FloatArray, macro_force_data: FloatArray
    ) -> tuple[FloatArray, FloatArray]:
        """s = (W, F) in A_d from ŝ, for all steps at once (eq. [12]–[15])."""
        n_steps = displacement_hat.shape[0]
        k = self.search_direction
        rhs = (force_hat + k * displacement_hat).reshape(n_steps, -1).T
        displacement = np.asarray(self.condensed @ rhs).T.reshape(displacement_hat.shape)
        force = force_hat + k * (displacement_hat - displacement)
        if self.macro_basis is not None:
            # W̃ᴹ = L⁻¹ (F_dᴹ − Π F) (eq. [15]); its effect on W and F, precomputed as maps
            residual = macro_force_data - self.project @ force.reshape(n_steps, -1).T
            displacement = displacement + (self.macro_to_displacement @ residual).T.reshape(
                force.shape)
            force = force + (self.macro_to_force @ residual).T.reshape(force.shape)
        return displacement, force

    def recover(self, displacement: FloatArray, force: FloatArray) -> dict[str, FloatArray]:
        """Interior displacements u_E = S_E⁻¹ T_Eᵀ M0 (F + k W) of every substructure."""
        n_steps = displacement.shape[0]
        k = self.search_direction
        g = (force + k * displacement).reshape(n_steps, -1).T * self.m0[:, None]
        out = {}
        for s, sub in enumerate(self.assembly.substructures):
            lo, hi = 2 * self.points.offsets[s], 2 * self.points.offsets[s + 1]
            u = self.factors[s].solve(np.ascontiguousarray(self.points.traces[s].T @ g[lo:hi]))
            out[sub.name] = u.T.reshape(n_steps, -1, 2)
        return out


def _norm(weights: FloatArray, k: FloatArray, displacement: FloatArray, force: FloatArray) -> float:
    """‖s‖² = Σ_t Σ_points ∫ (k⁻¹ F·F + k W·W) dΓ (paper §4.3)."""
    return float(np.sqrt(np.sum(weights[:, None] * (force**2 / k + k * displacement**2))))


def solve_latin(assembly: Assembly, options: LatinOptions | None = None,
                operators: LatinOperators | None = None, check: bool = True,
                initial: tuple[FloatArray, FloatArray] | None = None) -> SolveResult:
    """Solve ``assembly`` with the micro-macro LATIN method.

    operators: reuse the operators of an assembly with the same geometry (checked by
        signature), e.g. across friction coefficients, gaps or loads.
    initial: start from these interface fields ŝ = (Ŵ, F̂), shapes ``(n_steps, n_points,
        2)`` — typically a neighbouring converged solution (multiresolution, paper §6) —
        beginning with a linear stage; None starts from ŝ = 0.

    Raises ``NotConvergedError`` (with the unconverged result attached) when η ≥ tol after
    ``max_iter`` iterations, unless ``check`` is False.
    """
    if operators is not None:
        options = options or operators.options
        if operators.signature != operator_signature(assembly, options):
            raise ModelError("operators: they were built for another geometry or search "
                             "direction than this assembly's")
    options = options or LatinOptions()
    t0 = time.perf_counter()
    ops = operators or LatinOperators(assembly, options)
    t_setup = time.perf_counter() - t0
    # friction and gaps live on the points: take them from this assembly
    pts = ops.points if ops.assembly is assembly else build_points(
        assembly, options.interface_elements)
    if initial is not None:
        expected = (assembly.n_steps, pts.n_points, 2)
        if any(np.shape(field) != expected for field in initial):
            raise ModelError(f"initial: interface fields must have shape {expected}, got "
                             f"{[np.shape(field) for field in initial]}")
    k = ops.search_direction
    local = LocalStage(assembly, pts, k)
    n_steps = assembly.n_steps
    macro_data = (ops.project @ local.prescribed_force_field(pts.n_points)
                  .reshape(n_steps, -1).T) if ops.macro_basis is not None else None

    history: list[float] = []
    t1 = time.perf_counter()
    # the iteration is many small dense products: BLAS threads cost more than they give
    # (measured 3x slower per iteration with 2 OpenBLAS threads on b1-9)
    with threadpool_limits(limits=1, user_api="blas"):
        w, f, w_hat, f_hat, t_linear, t_local = _iterate(ops, local, options, macro_data,
                                                         history, initial)
    t_iter = time.perf_counter() - t1
    converged = history[-1] < options.tol

    t2 = time.perf_counter()
    displacements = ops.recover(w, f)
    reactions = _reactions(assembly, pts, f_hat)
    a = pts.contact_pairs[0]
    pressures = ContactPressures(
        bodies=[_body_pair(assembly, pts, i) for i in pts.interface[a]],
        extents=pts.extents[a],
        pressure=-np.sum(f_hat[:, a] * pts.normals[a], axis=2),
    )
    qoi = evaluate_qois(assembly, displacements, reactions, pressures)
    t_post = time.perf_counter() - t2
    timings = {
        "setup": t_setup,
        "iterations": t_iter,
        "linear_stage": t_linear,
        "local_stage": t_local,
        "per_iteration": t_iter / len(history),
        "postprocess": t_post,
        "total": time.perf_counter() - t0,
    }
    result = SolveResult(
        method="latin",
        assembly=assembly,
        converged=converged,
        iterations=len(history),
        indicator=history[-1],
        history=np.array(history),
        timings=timings,
        displacements=displacements,
        reactions=reactions,
        qoi=qoi,
        interface=InterfaceFields(pts.coords, pts.weights, pts.interface, pts.substructure,
                                  w, f, w_hat, f_hat),
        options=asdict(options),
    )
    log.info("%s: %s after %d iterations, eta = %.2e, %.3f s", assembly.name,
             "converged" if converged else "NOT converged", len(history), history[-1],
             timings["total"])
    if check and not converged:
        raise NotConvergedError(
            f"LATIN did not converge: eta = {history[-1]:.3e} >= tol = {options.tol:g} after "
            f"{len(history)} iterations (max_iter)", result)
    return result


def _iterate(
    ops: LatinOperators,
    local: LocalStage,
    options: LatinOptions,
    macro_data: FloatArray | None,
    history: list[float],
    initial: tuple[FloatArray, FloatArray] | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, float, float]:
    """LATIN iterations from ŝ = ``initial`` (or 0) until η < tol or the cap; η is appended
    to ``history``.

    Returns s = (W, F), ŝ = (Ŵ, F̂) and the time spent in the linear and local stages.
    """
    pts = ops.points
    k = ops.search_direction
    n_steps = local.prescribed.shape[0]
    if initial is None:
        w_hat = np.zeros((n_steps, pts.n_points, 2))
        f_hat = np.zeros_like(w_hat)
    else:
        w_hat, f_hat = (np.array(field, dtype=np.float64) for field in initial)
    w = f = None
    t_linear = t_local = 0.0
    mixer = (Anderson(options.anderson_depth, options.relaxation,
                       np.sqrt(pts.weights[:, None] * k), np.sqrt(pts.weights[:, None] / k))
             if options.acceleration == "anderson" else None)
    for iteration in range(1, options.max_iter + 1):
        ta = time.perf_counter()
        w_new, f_new = ops.linear_stage(w_hat, f_hat, macro_data)  # type: ignore[arg-type]
        if w is None or f is None or options.relaxation == 1.0 and mixer is None:
            w, f = w_new, f_new
        elif mixer is not None:
            w, f = mixer(w, f, w_new, f_new)
        else:
            omega = options.relaxation
            w = omega * w_new + (1.0 - omega) * w
            f = omega * f_new + (1.0 - omega) * f
        tb = time.perf_counter()
        w_hat, f_hat = local(w, f)
        t_local += time.perf_counter() - tb
        t_linear += tb - ta
        gap = _norm(pts.weights, k, w - w_hat, f - f_hat)
        size = 0.5 * (_norm(pts.weights, k, w, f) + _norm(pts.weights, k, w_hat, f_hat))
        eta = gap / size if size > 0 else 0.0
        history.append(eta)
        if iteration % 50 == 0:
            log.debug("iteration %d: eta = %.3e", iteration, eta)
        if eta < options.tol:
            break
    assert w is not None and f is not None
    return w, f, w_hat, f_hat, t_linear, t_local


def _reactions(assembly: Assembly, pts: InterfacePoints, force_hat: FloatArray
               ) -> dict[str, FloatArray]:
    """Resultant force of each named boundary on the structure, per step."""
    out: dict[str, FloatArray] = {}
    for i, itf in enumerate(assembly.interfaces):
        if itf.condition is None:
            continue
        p = pts.side_points[(i, 0)]
        total = np.einsum("p,tpc->tc", pts.weights[p], force_hat[:, p])
        name = itf.condition.name
        out[name] = out.get(name, 0.0) + total
    return out


def _body_pair(assembly: Assembly, pts: InterfacePoints, interface: int) -> frozenset[str]:
    itf = assembly.interfaces[interface]
    return frozenset(assembly.substructures[r.substructure].body for r in itf.sides)
