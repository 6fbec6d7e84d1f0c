"""B0 benchmarks: LATIN cost per iteration against the number of unknowns, and iterations
against the number of substructures with and without the macro problem.

    python benchmarks/b0_scaling.py            # prints two Markdown tables

Times are measured side by side in one run; compare ratios, not absolute values.
"""

from __future__ import annotations

import argparse
import time

import multilatin as ml


def cost_per_iteration(model: ml.Model, refinements: list[int], tol: float) -> None:
    print("| refine | substructures | unknowns | interface points | iterations | "
          "setup (s) | per iteration (ms) | LATIN total (s) | monolithic (s) |")
    print("|---|---|---|---|---|---|---|---|---|")
    options = ml.LatinOptions(tol=tol)
    for refine in refinements:
        latin = model.solve(options=options, refine=refine)
        t0 = time.perf_counter()
        model.reference(refine=refine)
        t_ref = time.perf_counter() - t0
        assert latin.interface is not None
        print(f"| {refine} | {len(latin.assembly.substructures)} | {latin.assembly.n_dofs} | "
              f"{latin.interface.weights.size} | {latin.iterations} | "
              f"{latin.timings['setup']:.3f} | {1e3 * latin.timings['per_iteration']:.3f} | "
              f"{latin.wall_s:.3f} | {t_ref:.3f} |")


def macro_scalability(model: ml.Model, splits: list[int], tol: float, cap: int) -> None:
    print(f"\nIterations to η < {tol:g} (cap {cap}):\n")
    print("| substructures | with macro problem | without macro problem (η at the cap) |")
    print("|---|---|---|")
    for n in splits:
        with_macro = model.solve(options=ml.LatinOptions(tol=tol, max_iter=cap),
                                 split={"beam": (n, 1)}, check=False)
        plain = model.solve(options=ml.LatinOptions(tol=tol, max_iter=cap, macro=False),
                            split={"beam": (n, 1)}, check=False)
        plain_text = (str(plain.iterations) if plain.converged
                      else f"> {cap} (η = {plain.indicator:.1e})")
        print(f"| {n} | {with_macro.iterations} | {plain_text} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--refine", type=int, nargs="+", default=[1, 2, 4, 8])
    parser.add_argument("--tol", type=float, default=1e-5)
    parser.add_argument("--cap", type=int, default=3000)
    args = parser.parse_args()
    model = ml.load_model("b0")
    cost_per_iteration(model, args.refine, args.tol)
    macro_scalability(model, [5, 10, 20, 40], args.tol, args.cap)


if __name__ == "__main__":
    main()
