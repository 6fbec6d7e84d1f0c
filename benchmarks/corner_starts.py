"""Does a cold solve's count depend on where it starts? B1's four pairs of issue 15, under
the studies' QoI rule, from ŝ = 0 and from the tightly converged fields of three other
friction pairs (frictionless, stuck, the middle of the grid) and of its neighbour on the
B1 13 × 13 grid (μ2 − 0.05, or + 0.05 at μ2 = 0: what a study starts it from): iterations,
and R_stop's error against an η < 1e-10 solve.

    python benchmarks/corner_starts.py
"""

from __future__ import annotations

import multilatin as ml
from multilatin.latin import LatinOptions, solve_latin
from multilatin.latin.options import STUDY_QOI_RTOL

PAIRS = ((0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15))
STARTS = {"frictionless (0, 0)": (0.0, 0.0), "stuck (0.6, 0.6)": (0.6, 0.6),
          "middle (0.3, 0.3)": (0.3, 0.3)}


def main() -> None:
    model = ml.load_model("b1")
    rule, tight = LatinOptions(qoi_rtol=STUDY_QOI_RTOL), LatinOptions(tol=1e-10, max_iter=5000)
    fields = {}
    for name, (mu1, mu2) in STARTS.items():
        interface = model.solve({"mu1": mu1, "mu2": mu2}, options=tight).interface
        assert interface is not None
        fields[name] = (interface.displacement_hat, interface.force_hat)
    print("| μ1, μ2 | from zero | " + " | ".join(f"from {n}" for n in STARTS)
          + " | from the neighbour |")
    print("|---" * (3 + len(STARTS)) + "|")
    for mu1, mu2 in PAIRS:
        mu = {"mu1": mu1, "mu2": mu2}
        exact = float(model.solve(mu, options=tight).qoi["R_stop"])  # type: ignore[arg-type]
        near = {"mu1": mu1, "mu2": round(mu2 - 0.05 if mu2 > 0 else 0.05, 2)}
        neighbour = model.solve(near, options=tight).interface
        assert neighbour is not None
        cells = []
        for start in (None, *fields.values(),
                      (neighbour.displacement_hat, neighbour.force_hat)):
            result = solve_latin(model.assemble(mu), rule, initial=start)
            error = abs(float(result.qoi["R_stop"]) - exact) / max(exact, 1.0)  # type: ignore[arg-type]
            cells.append(f"{result.iterations} ({error:.1e})")
        print(f"| {mu1}, {mu2} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
