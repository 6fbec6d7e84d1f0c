"""Experiment (issue 16, session 35): a second-order start across geometries, and the QoI
rule's first stop. B3 (rc = 3), three hole positions xc = 23, 24, 25 mm, a μ1 line of 13 at a
few μ2. The lines at xc = 23 and 24 are solved as a study solves them (the QoI rule, each case
from its friction neighbour); each case of the xc = 25 line after its first then starts from

- (c) the parallelogram of today's studies, ŝ(g, f−1) + ŝ(g−1, f) − ŝ(g−1, f−1)
  (``study.predictors.across_geometries``), or
- (e) the same corrected by the geometry's secant: ŝ(g, f−1) + [2 ŝ(g−1, f) − ŝ(g−2, f)]
  − [2 ŝ(g−1, f−1) − ŝ(g−2, f−1)] — the secant along xc at f, corrected by the secant's own
  miss at f − 1, which the study has already solved at the new geometry,

and is solved under the studies' QoI rule with the first QoI stop (``iteration.EARLY_COUNT``)
at each of ``--early`` (15: today's, no stop before window + 5 iterations). Prints the
iterations summed over the 12 cases and R_stop's largest error against η < 1e-10 solves,
relative (floored at 1 N), per μ2 and start. ``--tight-starts``: instead, each start built
from η < 1e-10 solves of its neighbours (a study's are converged to its own rule only), and
every QoI's largest error over the steps, relative to max(|q|, 1 % of its largest |q|),
after 1, 5, 9 and 15 iterations from it (η < 1e-14 as the tolerance, so that none stops).

    python benchmarks/geometry_second_order.py [--early 15,9] [--margin 0.1] [--mu2 0.1 0.3 0.5]
    python benchmarks/geometry_second_order.py --tight-starts
"""

from __future__ import annotations

import argparse

import numpy as np

import multilatin as ml
from multilatin.decomposition.assembly import Assembly
from multilatin.latin import LatinOperators, LatinOptions, iteration, solve_latin
from multilatin.latin.options import STUDY_QOI_RTOL

Fields = np.ndarray  # (2, n_steps, n_points, 2): Ŵ and F̂


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--early", default="15,9", help="comma-separated EARLY_COUNT values")
    parser.add_argument("--margin", type=float, default=None,
                        help="EARLY_MARGIN (default: the library's)")
    parser.add_argument("--mu2", type=float, nargs="+", default=[0.1, 0.3, 0.5])
    parser.add_argument("--tight-starts", action="store_true")
    args = parser.parse_args()
    if args.tight_starts:
        tight_starts()
        return
    if args.margin is not None:
        if not args.margin > 0:
            raise SystemExit(f"--margin: must be > 0, got {args.margin}")
        iteration.EARLY_MARGIN = args.margin
    earlies = [int(x) for x in args.early.split(",")]
    for value in earlies:
        if not 6 <= value <= iteration.WINDOW + 5:
            raise SystemExit(f"--early: each value must lie in [6, {iteration.WINDOW + 5}], "
                             f"got {value}")
    model = ml.load_model("b3")
    options = LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    tight = LatinOptions(tol=1e-10, max_iter=20000)
    frictions = [float(v) for v in np.round(np.linspace(0.0, 0.6, 13), 2)]
    operators: dict[float, LatinOperators] = {}

    def assembly(xc: float, mu1: float, mu2: float) -> Assembly:
        return model.assemble({"xc": xc, "mu1": mu1, "mu2": mu2, "rc": 3.0})

    def solve(xc: float, mu1: float, mu2: float, start: Fields | None,
              opts: LatinOptions = options) -> tuple[int, Fields, float]:
        case = assembly(xc, mu1, mu2)
        if xc not in operators:
            operators[xc] = LatinOperators(case, opts)
        result = solve_latin(case, opts, operators=operators[xc], check=False,
                             initial=None if start is None else (start[0], start[1]))
        assert result.interface is not None
        return (result.iterations, np.stack([result.interface.displacement_hat,
                                             result.interface.force_hat]),
                float(result.qoi["R_stop"]))

    labels = ["(c) parallelogram", "(e) second order"]
    print(f"first QoI stop at {', '.join(map(str, earlies))} iterations "
          f"(margin {iteration.EARLY_MARGIN:g})\n")
    header = " | ".join(f"{label}, first stop {e}" for label in labels for e in earlies)
    print(f"| μ2 | {header} |")
    print("|---|" + "---|" * (len(labels) * len(earlies)))
    saved = iteration.EARLY_COUNT
    try:
        for mu2 in args.mu2:
            lines: dict[float, dict[float, Fields]] = {}
            iteration.EARLY_COUNT = saved  # the earlier geometries as today's studies
            for xc in (23.0, 24.0):  # as a study's traversal: each from its friction neighbour
                fields, lines[xc] = None, {}
                for mu1 in frictions:
                    _, fields, _ = solve(xc, mu1, mu2, fields)
                    lines[xc][mu1] = fields
            reference = {mu1: solve(25.0, mu1, mu2, None, tight)[2] for mu1 in frictions[1:]}
            cells = []
            for label in labels:
                for early in earlies:
                    iteration.EARLY_COUNT = early
                    _, current, _ = solve(25.0, frictions[0], mu2, lines[24.0][frictions[0]])
                    total, worst = 0, 0.0
                    for previous, mu1 in zip(frictions, frictions[1:], strict=False):
                        g1, g2 = lines[24.0], lines[23.0]
                        if label.startswith("(c)"):
                            start = current + g1[mu1] - g1[previous]
                        else:
                            start = (current + (2 * g1[mu1] - g2[mu1])
                                     - (2 * g1[previous] - g2[previous]))
                        count, current, r_stop = solve(25.0, mu1, mu2, start)
                        total += count
                        worst = max(worst, abs(r_stop - reference[mu1])
                                    / max(abs(reference[mu1]), 1.0))
                    cells.append(f"{total}, {worst:.1e}")
            print(f"| {mu2:g} | " + " | ".join(cells) + " |", flush=True)
    finally:
        iteration.EARLY_COUNT = saved


def tight_starts() -> None:
    """``--tight-starts``: the starts' own accuracy, from tight neighbours."""
    model = ml.load_model("b3")
    tight = LatinOptions(tol=1e-10, max_iter=20000)
    solved: dict[tuple[float, float, float], tuple[ml.SolveResult, Fields]] = {}

    def solve(xc: float, mu1: float, mu2: float) -> tuple[ml.SolveResult, Fields]:
        if (xc, mu1, mu2) not in solved:
            result = solve_latin(model.assemble({"xc": xc, "mu1": mu1, "mu2": mu2,
                                                 "rc": 3.0}), tight)
            assert result.interface is not None
            solved[xc, mu1, mu2] = (result, np.stack([result.interface.displacement_hat,
                                                      result.interface.force_hat]))
        return solved[xc, mu1, mu2]

    def error(result: ml.SolveResult, reference: ml.SolveResult) -> float:
        worst = 0.0
        for name, value in reference.qoi.items():
            exact = np.atleast_1d(np.asarray(value, dtype=float))
            got = np.atleast_1d(np.asarray(result.qoi[name], dtype=float))
            scale = np.maximum(np.abs(exact), 0.01 * np.abs(exact).max() + 1e-300)
            worst = max(worst, float(np.max(np.abs(got - exact) / scale)))
        return worst

    counts = (1, 5, 9, 15)
    print("| μ1, μ2 at xc = 25 | start | QoI error after " + " / ".join(map(str, counts))
          + " iterations |")
    print("|---|---|---|")
    for mu1, mu2 in ((0.3, 0.1), (0.3, 0.25), (0.45, 0.05), (0.1, 0.3), (0.3, 0.4),
                     (0.2, 0.15)):
        previous = round(mu2 - 0.05, 2)
        reference = solve(25.0, mu1, mu2)[0]
        s = {(xc, m): solve(xc, mu1, m)[1] for xc in (23.0, 24.0, 25.0)
             for m in (mu2, previous) if (xc, m) != (25.0, mu2)}
        starts = {"the same frictions at xc = 24": s[24.0, mu2],
                  "(c) parallelogram": s[25.0, previous] + s[24.0, mu2] - s[24.0, previous],
                  "secant along xc": 2 * s[24.0, mu2] - s[23.0, mu2],
                  "(e) second order": (s[25.0, previous] + 2 * s[24.0, mu2] - s[23.0, mu2]
                                       - 2 * s[24.0, previous] + s[23.0, previous])}
        assembly = model.assemble({"xc": 25.0, "mu1": mu1, "mu2": mu2, "rc": 3.0})
        for label, start in starts.items():
            errors = [error(solve_latin(assembly, LatinOptions(tol=1e-14, max_iter=n),
                                        check=False, initial=(start[0], start[1])), reference)
                      for n in counts]
            print(f"| {mu1:g}, {mu2:g} | {label} | "
                  + " / ".join(f"{e:.1e}" for e in errors) + " |", flush=True)


if __name__ == "__main__":
    main()
