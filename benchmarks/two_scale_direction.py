"""The design choices of the two-scale search direction (issue 15, session 15;
``LatinOptions.micro_stiffening``, ``multilatin.latin.two_scale``), measured with a
re-implementation by monkeypatching that exposes what the solver fixes: which interface
kinds take the stiff micro part, the κ of the macro part, the inner iterations of the
coupled local stage and their relaxation; and a local stage whose direction differs from
the linear stage's (``--ascent``).

    python benchmarks/two_scale_direction.py                                 # b1, × 4
    python benchmarks/two_scale_direction.py --models b1 b1-9 b3 --factor 4 8
    python benchmarks/two_scale_direction.py --macro 0.25                    # softer macro
    python benchmarks/two_scale_direction.py --stiffen contact               # contact only
    python benchmarks/two_scale_direction.py --perfect                       # two scales there too
    python benchmarks/two_scale_direction.py --inner 1 --theta 1             # a lagged inner stage
    python benchmarks/two_scale_direction.py --ascent 0.5 2 4                # k+ = γ k, no two scales

The baseline column is session 14's default (the diagonal direction with corner
stiffening). H = D (I + (γ − 1) P) with D = k × factor on the kinds of ``--stiffen``, P the
M0-orthogonal projector on each contact side's and stop's constant and linear functions per
component, γ = κ_macro / (κ × factor); the local stage solves F̂ = F + H (Ŵ − W) by ``--inner``
relaxed iterations on Ŵ, F* = F + (H − D)(Ŵ_j − W), from the previous Ŵ. The solver's own
implementation (fewer products, contact part only in the inner iterations) gives the same
iterations at × 4, macro 0.5, 5 inner iterations, θ = 1.6 (its default). Cold solves to
η < tol in the default η norm (κ E / L), and R_stop's relative error against a tight solve.
"""

from __future__ import annotations

import argparse

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import multilatin as ml
from multilatin.decomposition.interfaces import interface_functions
from multilatin.latin import LatinOperators, solver
from multilatin.latin.local_stage import LocalStage
from multilatin.latin.operators import SubstructureOperators

PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]
STATE: dict[str, object] = {}


def side_projector(ops: LatinOperators) -> sp.csr_matrix:
    """P (2P × 2P, flat): per side of every contact interface and stop, per component, the
    M0-orthogonal projector on the side's constant and linear-in-s functions."""
    pts, assembly = ops.points, ops.assembly
    rows, cols, vals = [], [], []
    for i, itf in enumerate(assembly.interfaces):
        if itf.contact is None and not (STATE.get("perfect") and itf.kind == "perfect"):
            continue
        for side in range(len(itf.sides)):
            p = pts.side_points[(i, side)]
            w = pts.weights[p]
            functions = interface_functions(pts, i, len(itf.sides), reference=side)[side]
            for comp in range(2):
                flat = 2 * p + comp
                for e in functions.T:
                    # P += e eᵀ M0 on this side's component
                    rows.append(np.repeat(flat, p.size))
                    cols.append(np.tile(flat, p.size))
                    vals.append(np.outer(e, e * w).ravel())
    n = 2 * pts.n_points
    if not rows:
        return sp.csr_matrix((n, n))
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(n, n))


def two_scale(ops: LatinOperators, gamma: float, norm_k: np.ndarray) -> None:
    """Rebuild ``ops`` (built with k = k_m, no corner stiffening) for H = k_m (I + (γ − 1) P),
    γ = k_M / k_m, and make its linear stage use H."""
    k = ops.search_direction.reshape(-1)
    projector = side_projector(ops)
    h = (sp.diags(k) @ (sp.identity(k.size) + (gamma - 1.0) * projector)).tocsr()
    m0h = (sp.diags(ops.m0) @ h).tocsr()
    m0h = 0.5 * (m0h + m0h.T)  # symmetric to round-off (k is constant along each side)
    pts = ops.points
    blocks = []
    for s, sub in enumerate(ops.assembly.substructures):
        lo, hi = 2 * pts.offsets[s], 2 * pts.offsets[s + 1]
        trace = pts.traces[s]
        operator = (sub.stiffness() + trace.T @ m0h[lo:hi, lo:hi] @ trace).tocsc()
        factor = spla.splu(operator)
        condensed = trace @ factor.solve((trace.T @ sp.diags(ops.m0[lo:hi])).toarray())
        old = ops.substructure_operators[s]
        columns = old.macro_columns
        own_basis = ops.macro_basis[lo:hi][:, columns]
        h_basis = (h[lo:hi, lo:hi] @ own_basis).toarray()
        response = condensed @ h_basis
        mh_basis = ops.m0[lo:hi, None] * h_basis
        homogenised = own_basis.T @ mh_basis - mh_basis.T @ response
        blocks.append(SubstructureOperators(old.key + "-two-scale", factor, condensed, columns,
                                            response, np.asarray(homogenised),
                                            trace_rhs=sp.csc_matrix(
                                                trace.T @ sp.diags(ops.m0[lo:hi]))))
    ops.substructure_operators = blocks
    ops.factors = [b.factor for b in blocks]
    homogenised = np.zeros((ops.macro_basis.shape[1],) * 2)
    for block in blocks:
        homogenised[np.ix_(block.macro_columns, block.macro_columns)] += block.homogenised
    homogenised = 0.5 * (homogenised + homogenised.T)
    ops.homogenised_inverse = sla.cho_solve(sla.cho_factor(homogenised),
                                            np.eye(homogenised.shape[0]))
    ops.indicator_k = norm_k
    ops.two_scale_h = h  # type: ignore[attr-defined]
    ops.two_scale_r = (h - sp.diags(k)).tocsr()  # type: ignore[attr-defined]

    def apply_h(field: np.ndarray) -> np.ndarray:
        flat = field.reshape(field.shape[0], -1)
        return np.asarray((h @ flat.T).T).reshape(field.shape)

    def micro_stage(w_hat: np.ndarray, f_hat: np.ndarray, geometries: object = None
                    ) -> tuple[np.ndarray, np.ndarray]:  # one geometry
        shape = w_hat.shape
        rhs = (f_hat + apply_h(w_hat)).reshape(shape[0], -1)
        flat = np.empty_like(rhs)
        for (lo, hi), block in zip(ops.flat_ranges, ops.substructure_operators, strict=True):
            flat[:, lo:hi] = rhs[:, lo:hi] @ block.condensed_transposed
        w = flat.reshape(shape)
        return w, f_hat + apply_h(w_hat - w)

    def macro_correction(w: np.ndarray, f: np.ndarray, data: np.ndarray,
                         geometries: object = None) -> None:
        shape = w.shape
        residual = data - (ops.project @ f.reshape(shape[0], -1).T).T
        macro = residual @ ops.homogenised_inverse
        correction = np.empty((shape[0], shape[1] * 2))
        for (lo, hi), block in zip(ops.flat_ranges, ops.substructure_operators, strict=True):
            correction[:, lo:hi] = macro[:, block.macro_columns] @ block.macro_response_transposed
        extension = np.asarray((ops.macro_basis @ macro.T).T).reshape(shape)
        field = correction.reshape(shape)
        w += field
        f += apply_h(extension - field)

    def recover(w: np.ndarray, f: np.ndarray) -> dict[str, np.ndarray]:
        n_steps = w.shape[0]
        g = (f + apply_h(w)).reshape(n_steps, -1).T * ops.m0[:, None]
        out = {}
        for s, sub in enumerate(ops.assembly.substructures):
            lo, hi = ops.flat_ranges[s]
            u = ops.factors[s].solve(np.ascontiguousarray(pts.traces[s].T @ g[lo:hi]))
            out[sub.name] = u.T.reshape(n_steps, -1, 2)
        return out

    ops.micro_stage = micro_stage  # type: ignore[method-assign]
    ops.macro_correction = macro_correction  # type: ignore[method-assign]
    ops.recover = recover  # type: ignore[method-assign]


ORIGINAL_CALL = LocalStage.__call__


def coupled_local(self: LocalStage, w: np.ndarray, f: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The local stage with H: inner fixed point on F* = F + R (Ŵ_j − W), R = H − k_m."""
    r = STATE.get("r")
    if r is None:
        return ORIGINAL_CALL(self, w, f)
    previous = getattr(self, "_previous_w_hat", None)
    w_hat, f_hat = ORIGINAL_CALL(self, w, f)
    if previous is not None and previous.shape == w_hat.shape:
        w_hat = previous
    shape = w.shape
    theta = float(STATE.get("theta", 1.0))  # type: ignore[arg-type]
    for _ in range(int(STATE["inner"])):  # type: ignore[call-overload]
        diff = (w_hat - w).reshape(-1, shape[-2] * 2)
        shifted = f + np.asarray((r @ diff.T).T).reshape(shape)  # type: ignore[operator]
        new_w_hat, f_hat = ORIGINAL_CALL(self, w, shifted)
        w_hat = w_hat + theta * (new_w_hat - w_hat)
    w_hat, f_hat = new_w_hat, f_hat
    self._previous_w_hat = w_hat  # type: ignore[attr-defined]
    return w_hat, f_hat


#: session 14's default: the diagonal direction with corner stiffening
BASELINE = {"micro_stiffening": 1.0, "corner_stiffening": 1.5}


def solve(model: ml.Model, mu: dict[str, float], factor: float | None, macro: float,
          inner: int, tol: float) -> ml.SolveResult:
    """The baseline (factor None), or: k × ``factor`` on every interface of the kinds
    ``STATE["stiffen"]`` (contact: with stops), the macro part of contact sides and stops
    back to κ_M = ``macro`` (× E / L)."""
    assembly = model.assemble(mu)
    if factor is None:
        STATE["r"] = None
        return ml.solve_latin(assembly, ml.LatinOptions(tol=tol, max_iter=3000, **BASELINE),
                              check=False)
    base = ml.LatinOptions().kappa
    options = ml.LatinOptions(corner_stiffening=1.0, micro_stiffening=1.0, tol=tol,
                              max_iter=3000)
    ops = LatinOperators(assembly, options)
    norm_k = ops.indicator_k
    stiffen = np.ones(ops.points.n_points)
    for (i, _side), p in ops.points.side_points.items():
        itf = assembly.interfaces[i]
        kind = "contact" if itf.contact is not None else itf.kind
        if kind in STATE["stiffen"]:  # type: ignore[operator]
            stiffen[p] = factor
    ops.search_direction = ops.search_direction * stiffen[:, None]
    two_scale(ops, macro / (base * factor), norm_k)
    STATE["r"], STATE["inner"] = ops.two_scale_r, inner  # type: ignore[attr-defined]
    result = ml.solve_latin(assembly, options, operators=ops, check=False)
    STATE["r"] = None
    return result


def ascent(model: ml.Model, mu: dict[str, float], gamma: float, tol: float) -> ml.SolveResult:
    """The baseline with the local stage's k × γ (E+ ≠ E−), no two scales."""
    original = solver.LocalStage.__init__

    def scaled(self: LocalStage, assemblies: object, points: object, k: np.ndarray,
               *args: object, **kwargs: object) -> None:
        kwargs.pop("macro_only", None)
        original(self, assemblies, points, k * gamma, *args, **kwargs)  # type: ignore[arg-type]

    solver.LocalStage.__init__ = scaled  # type: ignore[method-assign]
    try:
        STATE["r"] = None
        return ml.solve_latin(model.assemble(mu), ml.LatinOptions(
            tol=tol, max_iter=3000, **BASELINE), check=False)
    finally:
        solver.LocalStage.__init__ = original  # type: ignore[method-assign]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=["b1"])
    parser.add_argument("--factor", nargs="+", type=float, default=[4.0],
                        help="k × factor on the interfaces of --stiffen (micro part)")
    parser.add_argument("--stiffen", nargs="+", default=["contact", "perfect", "macro"],
                        help="interface kinds whose k is stiffened (contact: with stops)")
    parser.add_argument("--macro", type=float, default=0.5, help="κ of the macro part")
    parser.add_argument("--inner", type=int, default=10,
                        help="inner iterations of the coupled local stage")
    parser.add_argument("--tol", type=float, default=ml.LatinOptions().tol)
    parser.add_argument("--theta", type=float, default=1.0,
                        help="relaxation of the inner iteration")
    parser.add_argument("--perfect", action="store_true",
                        help="the two scales on perfect interfaces too")
    parser.add_argument("--ascent", nargs="+", type=float, metavar="GAMMA",
                        help="instead: the baseline with the local stage's k × GAMMA")
    args = parser.parse_args()
    STATE["perfect"] = args.perfect
    STATE["stiffen"] = args.stiffen
    STATE["theta"] = args.theta
    LocalStage.__call__ = coupled_local  # type: ignore[method-assign]
    columns = args.ascent if args.ascent else args.factor
    if args.ascent:
        print(f"cold solves to η < {args.tol:g}: session 14's default, and with the local "
              "stage's k × γ; iterations (R_stop's relative error)\n")
        heads = ["session 14"] + [f"γ = {g:g}" for g in args.ascent]
    else:
        print(f"cold solves to η < {args.tol:g}; k × factor on {' '.join(args.stiffen)}, "
              f"macro κ {args.macro:g} on contact sides and stops, {args.inner} inner "
              f"iterations, θ = {args.theta:g}; iterations (R_stop's relative error)\n")
        heads = ["session 14"] + [f"× {f:g}" for f in args.factor]
    print("| model | μ1, μ2 | " + " | ".join(heads) + " |")
    print("|---|---|" + "---|" * len(heads))
    for name in args.models:
        model = ml.load_model(name)
        for mu1, mu2 in PAIRS:
            mu = {"mu1": mu1, "mu2": mu2}
            STATE["r"] = None
            tight = float(ml.solve_latin(model.assemble(mu), ml.LatinOptions(
                tol=1e-10, max_iter=20000), check=False).qoi["R_stop"])  # type: ignore[arg-type]
            cells = []
            for value in [None, *columns]:
                if args.ascent and value is not None:
                    result = ascent(model, mu, value, args.tol)
                else:
                    result = solve(model, mu, value, args.macro, args.inner, args.tol)
                error = abs(float(result.qoi["R_stop"]) - tight) / max(abs(tight), 1.0)  # type: ignore[arg-type]
                cells.append(f"{result.iterations} ({error:.1e})"
                             + ("" if result.converged else " not converged"))
            print(f"| {name} | {mu1:g}, {mu2:g} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
