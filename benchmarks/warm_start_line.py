"""Why a warm start saves little on B1's μ2 line (paper table 1: 25 iterations cold, then
3–12): the error of the QoIs iteration by iteration, warm (from the tightly converged
neighbour one grid step back) against cold, and what stops a case under the studies' QoI
rule.

    python benchmarks/warm_start_line.py [--model b1]

For μ1 = 0.3 and each pair (previous μ2 → μ2): the first η of both starts, and after n
iterations R_stop's relative error and u_A's (the largest over the steps, relative to
u_A's largest magnitude) against a tight solve (η < 1e-10) of the same case. Then, at
``--at`` iterations with the studies' QoI rule (``STUDY_QOI_RTOL``), which QoI and step
have the largest estimated error against its bound (rtol × max(|q|, 1 % of max |q|)), with
the true error at that step beside it.
"""

from __future__ import annotations

import argparse

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOptions, solve_latin, solver
from multilatin.latin.options import STUDY_QOI_RTOL

PAIRS = ((0.0, 0.05), (0.05, 0.1), (0.25, 0.3), (0.4, 0.45))
COUNTS = (5, 10, 15, 20, 30, 40, 50)
TIGHT = LatinOptions(tol=1e-10, max_iter=50_000)


def relative_errors(result: ml.SolveResult, tight: ml.SolveResult) -> tuple[float, float]:
    r_stop = abs(float(result.qoi["R_stop"]) - float(tight.qoi["R_stop"]))  # type: ignore[arg-type]
    u_a = np.asarray(result.qoi["u_A"], dtype=float)
    u_tight = np.asarray(tight.qoi["u_A"], dtype=float)
    return (r_stop / max(abs(float(tight.qoi["R_stop"])), 1.0),  # type: ignore[arg-type]
            float(np.abs(u_a - u_tight).max() / np.abs(u_tight).max()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", default="b1")
    parser.add_argument("--at", type=int, default=30, help="iterations of the QoI diagnosis")
    args = parser.parse_args()
    # the diagnosis reads the estimates after a fixed number of iterations, settled or not
    solver.SETTLED = np.inf
    model = ml.load_model(args.model)
    print("| μ2 (from) | start | η first | " + " | ".join(
        f"after {n}: R_stop, u_A" for n in COUNTS) + " |")
    print("|---|---|---|" + "---|" * len(COUNTS))
    diagnoses = []
    for before, mu2 in PAIRS:
        assembly = model.assemble({"mu1": 0.3, "mu2": mu2})
        neighbour = solve_latin(model.assemble({"mu1": 0.3, "mu2": before}), TIGHT)
        tight = solve_latin(assembly, TIGHT)
        assert neighbour.interface is not None
        initial = (neighbour.interface.displacement_hat, neighbour.interface.force_hat)
        for label, start in (("warm", initial), ("cold", None)):
            cells = []
            first = np.nan
            for n in COUNTS:
                result = solve_latin(assembly, LatinOptions(max_iter=n), initial=start,
                                     check=False)
                first = float(result.history[0])
                r_stop, u_a = relative_errors(result, tight)
                cells.append(f"{r_stop:.1e}, {u_a:.1e}")
            print(f"| {mu2:g} ({before:g}) | {label} | {first:.1e} | " + " | ".join(cells)
                  + " |", flush=True)
            result = solve_latin(assembly, LatinOptions(max_iter=args.at,
                                                        qoi_rtol=STUDY_QOI_RTOL),
                                 initial=start, check=False)
            worst = ("", 0, 0.0, 0.0)
            for name in tight.qoi:
                value = np.atleast_1d(np.asarray(result.qoi[name], dtype=float))
                estimate = np.atleast_1d(np.asarray(result.qoi_error[name], dtype=float))
                truth = np.abs(value - np.atleast_1d(np.asarray(tight.qoi[name], dtype=float)))
                bound = STUDY_QOI_RTOL * np.maximum(np.abs(value), 1e-2 * np.abs(value).max())
                ratio = np.where(bound > 0, estimate / np.where(bound > 0, bound, 1.0), 0.0)
                k = int(np.nanargmax(ratio))
                if ratio[k] > worst[2]:
                    worst = (name, k + 1, float(ratio[k]), float(truth[k] / bound[k]))
            diagnoses.append(f"| {mu2:g} ({before:g}) | {label} | {result.iterations} | "
                             f"{worst[0]} at step {worst[1]} | {worst[2]:.2f} | "
                             f"{worst[3]:.2f} |")
    print(f"\nAt {args.at} iterations, the QoI rule (rtol {STUDY_QOI_RTOL:g}): the largest "
          "estimated error over its bound\n")
    print("| μ2 (from) | start | iterations | QoI | estimate / bound | true error / bound |")
    print("|---|---|---|---|---|---|")
    print("\n".join(diagnoses))


if __name__ == "__main__":
    main()
