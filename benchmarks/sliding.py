"""The extrapolation of steady slidings (``LatinOptions.extrapolate_sliding``, issue 15;
docs/convergence.md), on and off side by side in one run.

    python benchmarks/sliding.py            # b1 and b3, κ = 0.5 and 1
    python benchmarks/sliding.py --models b1 --kappas 1

Cold solves to the default tolerance at the low-friction cases where the centre block
slides to the stop, and at the four pairs of ``benchmarks/convergence.py``: iterations
("!" where the solve did not converge) and R_stop's relative error against a tight solve
(η < 1e-10, κ = 0.5, no extrapolation); then warm starts from a neighbour (μ1 + 0.05 or
μ2 + 0.05), where a crawl may end before the gap closes.
"""

from __future__ import annotations

import argparse

import multilatin as ml
from multilatin.latin import LatinOperators, LatinOptions, solve_latin

COLD = [(0.0, 0.05), (0.05, 0.0), (0.1, 0.25), (0.15, 0.2),
        (0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]
WARM = [((0.0, 0.05), (0.0, 0.1)), ((0.05, 0.05), (0.1, 0.05)), ((0.05, 0.1), (0.1, 0.1))]


def cell(result: ml.SolveResult, tight: float) -> str:
    r_stop = float(result.qoi["R_stop"])  # type: ignore[arg-type]
    flag = "" if result.converged else "!"
    return f"{result.iterations}{flag} ({abs(r_stop - tight) / max(abs(tight), 1.0):.1e})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=["b1", "b3"])
    parser.add_argument("--kappas", nargs="+", type=float, default=[0.5, 1.0])
    args = parser.parse_args()
    print("| model | case | κ | without | with extrapolation |")
    print("|---|---|---|---|---|")
    for name in args.models:
        model = ml.load_model(name)
        tight: dict[tuple[float, float], float] = {}

        def tight_r_stop(mu: tuple[float, float], model: ml.Model = model,
                         tight: dict[tuple[float, float], float] = tight) -> float:
            if mu not in tight:
                options = LatinOptions(tol=1e-10, max_iter=20000, extrapolate_sliding=False)
                result = solve_latin(model.assemble({"mu1": mu[0], "mu2": mu[1]}), options)
                tight[mu] = float(result.qoi["R_stop"])  # type: ignore[arg-type]
            return tight[mu]

        for kappa in args.kappas:
            for mu in COLD:
                assembly = model.assemble({"mu1": mu[0], "mu2": mu[1]})
                cells = [cell(solve_latin(assembly, LatinOptions(
                    kappa=kappa, extrapolate_sliding=sliding), check=False), tight_r_stop(mu))
                    for sliding in (False, True)]
                print(f"| {name} | cold ({mu[0]:g}, {mu[1]:g}) | {kappa:g} | "
                      + " | ".join(cells) + " |", flush=True)
            for source, target in WARM:
                cells = []
                for sliding in (False, True):
                    options = LatinOptions(kappa=kappa, extrapolate_sliding=sliding)
                    first = model.assemble({"mu1": source[0], "mu2": source[1]})
                    ops = LatinOperators(first, options)
                    start = solve_latin(first, options, operators=ops, check=False).interface
                    assert start is not None
                    result = solve_latin(model.assemble({"mu1": target[0], "mu2": target[1]}),
                                         options, operators=ops, check=False,
                                         initial=(start.displacement_hat, start.force_hat))
                    cells.append(cell(result, tight_r_stop(target)))
                print(f"| {name} | warm ({source[0]:g}, {source[1]:g}) → ({target[0]:g}, "
                      f"{target[1]:g}) | {kappa:g} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
