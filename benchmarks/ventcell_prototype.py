"""Prototype (issue 15, item 2, "beyond"): a search direction that is an operator along the
interface, not one number per point — k + q ∂ₛ², a Ventcell / short-range impedance whose
symbol k + q ξ² follows the elastic Dirichlet-to-Neumann map E|ξ| up to the mesh's highest
frequencies (Negrello, Gosselet & Rey 2018).

    python benchmarks/ventcell_prototype.py                 # perfect interfaces, consistent
    python benchmarks/ventcell_prototype.py --diagonal-local  # E+ kept diagonal: diverges

On each side of every *perfect* interface, H = k + M0⁻¹ q K_s with K_s the 1-D stiffness
∫ w' v' ds of the side's points and q = β E h (h: the edge length). The linear stage uses H
(S_E = K_E + Tᵀ M0 H T, F = F̂ + H (Ŵ − W), and the same in the macro problem's L_E and Q_E);
the local stage of perfect interfaces solves (H_E + H_E') Ŵ = H_E W_E + H_E' W_E' − F_E − F_E'
so that E+ = E− there (``--diagonal-local`` keeps today's point-wise local stage). Contact,
stops and boundaries keep the diagonal k. The monkeypatching below is a measurement, not the
solver: cold solves to the default tolerance; iterations and R_stop's relative error against
a tight solve of the default solver.
"""

from __future__ import annotations

import argparse

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import multilatin as ml
from multilatin.latin import LatinOptions, local_stage
from multilatin.latin.operators import LatinOperators, SubstructureOperators

PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]
STATE: dict[str, object] = {"beta": 0.0, "consistent": True}
ORIGINAL_INIT = LatinOperators.__init__
ORIGINAL_LOCAL = local_stage.LocalStage.__call__


def side_operator(ops: LatinOperators, beta: float) -> sp.csr_matrix:
    """H on the flat (2P) point vector: diag(k) + M0⁻¹ q K_s on perfect interfaces."""
    pts, k = ops.points, ops.search_direction
    rows, cols, values = [], [], []
    for (i, _side), p in pts.side_points.items():
        if ops.assembly.interfaces[i].kind != "perfect" or p.size < 2:
            continue
        sub = ops.assembly.substructures[pts.substructure[p[0]]]
        h = np.linalg.norm(np.diff(pts.coords[p], axis=0), axis=1)
        stiffness = beta * sub.material.young * h * sub.material.thickness / h
        first, second = p[:-1], p[1:]
        for component in range(2):
            for r, c, v in ((first, first, stiffness), (second, second, stiffness),
                            (first, second, -stiffness), (second, first, -stiffness)):
                rows.append(2 * r + component)
                cols.append(2 * c + component)
                values.append(v)
    size = 2 * pts.n_points
    ks = (sp.csr_matrix((np.concatenate(values), (np.concatenate(rows), np.concatenate(cols))),
                        shape=(size, size)) if rows else sp.csr_matrix((size, size)))
    return (sp.diags(k.reshape(-1)) + sp.diags(1.0 / ops.m0) @ ks).tocsr()


def patched_init(self: LatinOperators, assembly, options, reuse=None) -> None:  # type: ignore[no-untyped-def]
    ORIGINAL_INIT(self, assembly, options, None)
    h_op = side_operator(self, float(STATE["beta"]))  # type: ignore[arg-type]
    self.h_op = h_op  # type: ignore[attr-defined]
    blocks = []
    for s, sub in enumerate(assembly.substructures):
        lo, hi = self.flat_ranges[s]
        h = h_op[lo:hi, lo:hi]
        m0 = self.m0[lo:hi]
        trace = self.points.traces[s]
        factor = spla.splu((sub.stiffness() + trace.T @ sp.diags(m0) @ h @ trace).tocsc())
        condensed = trace @ factor.solve((trace.T @ sp.diags(m0)).toarray())
        rows = self.macro_basis[lo:hi]
        columns = np.unique(rows.indices).astype(np.int64)
        own = rows[:, columns]
        h_basis = (h @ own).toarray()
        response = condensed @ h_basis
        mh_basis = m0[:, None] * h_basis
        blocks.append(SubstructureOperators("prototype", factor, condensed, columns, response,
                                            np.asarray(own.T @ mh_basis - mh_basis.T @ response),
                                            trace_rhs=sp.csc_matrix(trace.T @ sp.diags(m0))))
    self.substructure_operators = blocks
    self.factors = [b.factor for b in blocks]
    homogenised = np.zeros((self.macro_basis.shape[1],) * 2)
    for b in blocks:
        homogenised[np.ix_(b.macro_columns, b.macro_columns)] += b.homogenised
    factor = self._factorise_macro(0.5 * (homogenised + homogenised.T))
    self.homogenised_inverse = sla.cho_solve(factor, np.eye(homogenised.shape[0]))
    pa, pb = self.points.pairs
    ia = np.column_stack([2 * pa, 2 * pa + 1]).ravel()
    ib = np.column_stack([2 * pb, 2 * pb + 1]).ravel()
    haa, hbb = h_op[ia][:, ia].tocsc(), h_op[ib][:, ib].tocsc()
    STATE["pairs"] = (ia, ib, haa, hbb, spla.splu((haa + hbb).tocsc()))


def apply(ops: LatinOperators, x: np.ndarray) -> np.ndarray:
    flat = x.reshape(x.shape[0], -1)
    return np.asarray((ops.h_op @ flat.T).T).reshape(x.shape)  # type: ignore[attr-defined]


def micro_stage(self: LatinOperators, w_hat: np.ndarray, f_hat: np.ndarray,
                geometries: object = None) -> tuple[np.ndarray, np.ndarray]:  # one geometry
    rhs = (f_hat + apply(self, w_hat)).reshape(w_hat.shape[0], -1)
    out = np.empty_like(rhs)
    for (lo, hi), block in zip(self.flat_ranges, self.substructure_operators, strict=True):
        out[:, lo:hi] = rhs[:, lo:hi] @ block.condensed_transposed
    w = out.reshape(w_hat.shape)
    return w, f_hat + apply(self, w_hat - w)


def macro_correction(self: LatinOperators, w: np.ndarray, f: np.ndarray,
                     data: np.ndarray, geometries: object = None) -> None:
    residual = data - (self.project @ f.reshape(w.shape[0], -1).T).T
    macro = residual @ self.homogenised_inverse
    correction = np.empty((w.shape[0], w.shape[1] * 2))
    for (lo, hi), block in zip(self.flat_ranges, self.substructure_operators, strict=True):
        correction[:, lo:hi] = macro[:, block.macro_columns] @ block.macro_response_transposed
    extension = np.asarray((self.macro_basis @ macro.T).T).reshape(w.shape)
    w += correction.reshape(w.shape)
    f += apply(self, extension - correction.reshape(w.shape))


def recover(self: LatinOperators, w: np.ndarray, f: np.ndarray) -> dict[str, np.ndarray]:
    """Interior displacements u_E = S_E⁻¹ T_Eᵀ M0 (F + H W)."""
    g = (f + apply(self, w)).reshape(w.shape[0], -1).T * self.m0[:, None]
    out = {}
    for s, sub in enumerate(self.assembly.substructures):
        lo, hi = self.flat_ranges[s]
        u = self.factors[s].solve(np.ascontiguousarray(self.points.traces[s].T @ g[lo:hi]))
        out[sub.name] = u.T.reshape(w.shape[0], -1, 2)
    return out


def local(self: local_stage.LocalStage, w: np.ndarray, f: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray]:
    w_hat, f_hat = ORIGINAL_LOCAL(self, w, f)
    if not STATE["consistent"]:
        return w_hat, f_hat
    ia, ib, haa, hbb, lu = STATE["pairs"]  # type: ignore[misc]
    n = w.shape[0] * w.shape[1]
    wf, ff = w.reshape(n, -1), f.reshape(n, -1)
    wa, wb, fa, fb = wf[:, ia].T, wf[:, ib].T, ff[:, ia].T, ff[:, ib].T
    joint = lu.solve(np.ascontiguousarray(haa @ wa + hbb @ wb - fa - fb))
    force = fa + haa @ (joint - wa)
    w_flat, f_flat = w_hat.reshape(n, -1), f_hat.reshape(n, -1)
    w_flat[:, ia] = w_flat[:, ib] = joint.T
    f_flat[:, ia], f_flat[:, ib] = force.T, -force.T
    return w_hat, f_hat


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--models", nargs="+", default=["b1-4", "b1-9"])
    parser.add_argument("--betas", nargs="+", type=float, default=[0.0, 0.2, 0.5, 1.0])
    parser.add_argument("--diagonal-local", action="store_true")
    args = parser.parse_args()
    STATE["consistent"] = not args.diagonal_local
    print("| model | μ1, μ2 | " + " | ".join(f"β = {b:g}: iterations, error" for b in args.betas)
          + " |")
    print("|---|---|" + "---|" * len(args.betas))
    for name in args.models:
        model = ml.load_model(name)
        for mu1, mu2 in PAIRS:
            mu = {"mu1": mu1, "mu2": mu2}
            reference = float(model.solve(mu, options=LatinOptions(tol=1e-9, max_iter=50_000))
                              .qoi["R_stop"])  # type: ignore[arg-type]
            cells = []
            LatinOperators.__init__ = patched_init  # type: ignore[method-assign]
            LatinOperators.micro_stage = micro_stage  # type: ignore[method-assign]
            LatinOperators.macro_correction = macro_correction  # type: ignore[method-assign]
            LatinOperators.recover = recover  # type: ignore[method-assign]
            local_stage.LocalStage.__call__ = local  # type: ignore[method-assign]
            for beta in args.betas:
                STATE["beta"] = beta
                result = model.solve(mu, check=False)
                error = abs(float(result.qoi["R_stop"]) - reference) / max(reference, 1.0)  # type: ignore[arg-type]
                flag = "" if result.converged else " (not converged)"
                cells.append(f"{result.iterations}{flag}, {error:.1e}")
            LatinOperators.__init__ = ORIGINAL_INIT  # type: ignore[method-assign]
            local_stage.LocalStage.__call__ = ORIGINAL_LOCAL  # type: ignore[method-assign]
            LatinOperators.micro_stage = ORIGINAL_MICRO  # type: ignore[method-assign]
            LatinOperators.macro_correction = ORIGINAL_MACRO  # type: ignore[method-assign]
            LatinOperators.recover = ORIGINAL_RECOVER  # type: ignore[method-assign]
            print(f"| {name} | {mu1:g}, {mu2:g} | " + " | ".join(cells) + " |", flush=True)


ORIGINAL_MICRO = LatinOperators.micro_stage
ORIGINAL_MACRO = LatinOperators.macro_correction
ORIGINAL_RECOVER = LatinOperators.recover

if __name__ == "__main__":
    main()
