"""Experiment (issue 16, for the mixed studies: hole positions × frictions): where should
the cases of a new geometry start? B3, two hole positions xc = 24 and 25 mm (rc = 3), a μ1
line (13 values) at a few μ2. The first geometry's line is solved case after case from the
nearest (as studies do); each case of the second geometry's line (after its first) then
starts from (a) its friction neighbour on its own line — what a study's traversal does
today, the geometry outermost —, (b) the same frictions at the previous geometry, (c) the
parallelogram of the two: ŝ(g+1, f−1) + ŝ(g, f) − ŝ(g, f−1) (``study.predictors``). Studies'
QoI stopping (qoi_rtol = 1e-3); iterations summed over the 12 cases, and R_stop's largest
difference from (a).

    python benchmarks/geometry_neighbours.py
"""

from __future__ import annotations

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOperators, LatinOptions, solve_latin
from multilatin.latin.options import STUDY_QOI_RTOL

Fields = tuple[np.ndarray, np.ndarray]


def main() -> None:
    model = ml.load_model("b3")
    options = LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    frictions = [float(v) for v in np.round(np.linspace(0.0, 0.6, 13), 2)]
    operators: dict[float, LatinOperators] = {}

    def solve(xc: float, mu1: float, mu2: float, start: Fields | None
              ) -> tuple[int, Fields, float]:
        assembly = model.assemble({"xc": xc, "mu1": mu1, "mu2": mu2, "rc": 3.0})
        if xc not in operators:
            operators[xc] = LatinOperators(assembly, options)
        result = solve_latin(assembly, options, operators=operators[xc], initial=start)
        assert result.converged and result.interface is not None
        return (result.iterations, (result.interface.displacement_hat,
                                    result.interface.force_hat), result.qoi["R_stop"])

    print("| μ2 | (a) friction neighbour | (b) previous geometry | (c) parallelogram | "
          "R_stop: largest difference from (a) |")
    print("|---|---|---|---|---|")
    for mu2 in (0.1, 0.3, 0.5):
        before: dict[float, Fields] = {}
        fields = None
        for mu1 in frictions:
            _, fields, _ = solve(24.0, mu1, mu2, fields)
            before[mu1] = fields
        totals = [0, 0, 0]
        change = 0.0
        _, current, _ = solve(25.0, frictions[0], mu2, before[frictions[0]])
        for previous, mu1 in zip(frictions, frictions[1:], strict=False):
            parallelogram = (current[0] + before[mu1][0] - before[previous][0],
                             current[1] + before[mu1][1] - before[previous][1])
            runs = [solve(25.0, mu1, mu2, start)
                    for start in (current, before[mu1], parallelogram)]
            for k, (iterations, _, _) in enumerate(runs):
                totals[k] += iterations
            r_stop = [r for _, _, r in runs]
            change = max(change, *(abs(r - r_stop[0]) / max(abs(r_stop[0]), 1.0)
                                   for r in r_stop[1:]))
            current = runs[0][1]
        print(f"| {mu2:g} | {totals[0]} | {totals[1]} | {totals[2]} | {100 * change:.3f} % |",
              flush=True)


if __name__ == "__main__":
    main()
