"""The condensed interface operator C_E = T S_E⁻¹ Tᵀ M0 two ways, per distinct substructure:
by one sparse solve per interface unknown (S_E⁻¹ Tᵀ M0 in full: the way before session 21,
kept below ``condensation.SCHUR_MIN_DOFS``) and from the Schur complement left in the last
block of a factorisation with the trace's unknowns last (``condensation.condense``).

    python benchmarks/condensation.py                       # b1, b3 at refine 1 and 2
    python benchmarks/condensation.py --refine 1 2 4        # b1 at 4: 18 818 unknowns

One BLAS thread (as the iterations and ``condense`` run; ``--threads`` sets it for the
solves' way). Prints a Markdown
table: unknowns, interface unknowns, the best of ``--repeat`` times each way, their ratio
and the largest difference of the two C_E relative to its largest entry.
"""

from __future__ import annotations

import argparse
import os
import sys


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--models", nargs="+", default=["b1", "b3"])
    parser.add_argument("--refine", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--threads", default="1")
    args = parser.parse_args()
    if "numpy" not in sys.modules:
        for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
            os.environ[name] = args.threads
    import timeit

    import numpy as np
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    import multilatin as ml
    from multilatin.latin import LatinOperators, LatinOptions
    from multilatin.latin.condensation import condense

    def by_solves(operator: sp.csc_matrix, trace: sp.csr_matrix, m0: np.ndarray) -> np.ndarray:
        factor = spla.splu(operator)
        return np.asarray(trace @ factor.solve((trace.T @ sp.diags(m0)).toarray(order="F")))

    print("| model | refine | substructure | unknowns | interface unknowns | by solves (ms) "
          "| Schur complement (ms) | ratio | C_E difference |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name in args.models:
        for refine in args.refine:
            assembly = ml.load_model(name).assemble(None, refine=refine)
            ops = LatinOperators(assembly, LatinOptions())
            seen = set()
            for s, sub in enumerate(assembly.substructures):
                stiffness = sub.stiffness()
                trace = ops.points.traces[s].tocsr()
                kind = (stiffness.shape, trace.shape, sub.hole is not None)
                if kind in seen:
                    continue
                seen.add(kind)
                lo, hi = ops.flat_ranges[s]
                m0, k = ops.m0[lo:hi], ops.search_direction.reshape(-1)[lo:hi]
                operator = (stiffness + trace.T @ sp.diags(m0 * k) @ trace).tocsc()
                old = min(timeit.repeat(lambda: by_solves(operator, trace, m0),  # noqa: B023
                                        number=1, repeat=args.repeat))
                new = min(timeit.repeat(lambda: condense(operator, trace, m0, schur=True),  # noqa: B023
                                        number=1, repeat=args.repeat))
                reference = by_solves(operator, trace, m0)
                difference = (np.abs(condense(operator, trace, m0, schur=True)[1] - reference).max()
                              / np.abs(reference).max())
                print(f"| {name} | {refine} | {sub.name} | {stiffness.shape[0]} | "
                      f"{trace.shape[0]} | {1e3 * old:.1f} | {1e3 * new:.1f} | {new / old:.2f} | "
                      f"{difference:.1e} |", flush=True)


if __name__ == "__main__":
    main()
