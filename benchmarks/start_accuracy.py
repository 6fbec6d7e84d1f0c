"""What a warm start must be worth (issue 16): iterations of B1's sliding cases under the
studies' QoI rule from starts of known accuracy, and how accurate the predictors are.

    python benchmarks/start_accuracy.py                # both tables (about two minutes)
    python benchmarks/start_accuracy.py --curve        # the first table only

Every case of the B1 13 x 13 grid is solved tightly from zero (η < 1e-9) for its interface
fields ŝ* = (Ŵ*, F̂*). Then:

- ``--curve``: a few sliding cases started from ŝ* + ε (ŝ_P − ŝ*), P the neighbour one step
  lower in μ2 (ε = 1: the nearest neighbour's converged fields, as a study starts; ε → 0:
  the answer itself): iterations to the studies' stopping rule (``qoi_rtol`` = 1e-3).
- predictors: every unique case where the block slides (μ1 + μ2 < 0.6) and every start
  below exists, started from the tight fields of its neighbours as they are (one step
  lower in μ2, in μ1), retimed (``study.retiming``: P and the case one step further back in
  μ2), along the anti-diagonal μ1 + μ2 = const (the slide's onset depends on the sum: the
  neighbour (μ1 + h, μ2 − h), the secant through it and (μ1 + 2h, μ2 − 2h), the midpoint of
  the neighbours either side) and the parallelogram ŝ(i, j−1) + ŝ(i−1, j) − ŝ(i−1, j−1):
  the start's error max(‖Ŵ − Ŵ*‖ / ‖Ŵ*‖, ‖F̂ − F̂*‖ / ‖F̂*‖) (median, largest), the
  iterations (sum, median, largest) and R_stop's worst error against the tight solves.

The neighbours' fields here are the tight ones, so the predictors are at their best (a
study holds fields converged to its own rule). Measured: docs/performance.md (session 34).
"""

from __future__ import annotations

import argparse
import warnings
from collections.abc import Callable

import numpy as np

import multilatin as ml
from multilatin.fem.elasticity import FloatArray
from multilatin.latin import LatinOptions, solve_latin_batch
from multilatin.latin.options import STUDY_QOI_RTOL
from multilatin.study.retiming import retimed_fields

Index = tuple[int, int]
Fields = tuple[FloatArray, FloatArray]
VALUES = np.round(np.linspace(0.0, 0.6, 13), 10)
CURVE_CASES = [(2, 6), (6, 2), (4, 4), (2, 3), (6, 4)]
EPSILONS = [1.0, 0.3, 0.1, 0.03, 0.01, 0.003, 0.001]


def tight_fields(model: ml.Model) -> dict[Index, dict[str, object]]:
    """Every case's ŝ*, R_stop and uniqueness from η < 1e-9 solves from zero."""
    index = [(i, j) for i in range(13) for j in range(13)]
    out: dict[Index, dict[str, object]] = {}
    options = LatinOptions(tol=1e-9, max_iter=3000)
    for lo in range(0, len(index), 32):
        chunk = index[lo:lo + 32]
        results = solve_latin_batch([model.assemble({"mu1": VALUES[i], "mu2": VALUES[j]})
                                     for i, j in chunk], options)
        for ij, result in zip(chunk, results, strict=True):
            assert result.interface is not None
            out[ij] = {"fields": (result.interface.displacement_hat,
                                  result.interface.force_hat),
                       "R": float(result.qoi["R_stop"]),  # type: ignore[arg-type]
                       "unique": result.unique}
    return out


def start_error(start: Fields, answer: Fields) -> float:
    return max(float(np.linalg.norm(a - b) / np.linalg.norm(b))
               for a, b in zip(start, answer, strict=True))


def curve(model: ml.Model, tight: dict[Index, dict[str, object]]) -> None:
    options = LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    print("| case (μ1, μ2) | nearest's error | " + " | ".join(f"ε = {e:g}" for e in EPSILONS)
          + " |")
    print("|---|---|" + "---|" * len(EPSILONS))
    for i, j in CURVE_CASES:
        answer: Fields = tight[(i, j)]["fields"]  # type: ignore[assignment]
        nearest: Fields = tight[(i, j - 1)]["fields"]  # type: ignore[assignment]
        starts = [(answer[0] + e * (nearest[0] - answer[0]),
                   answer[1] + e * (nearest[1] - answer[1])) for e in EPSILONS]
        cases = [model.assemble({"mu1": VALUES[i], "mu2": VALUES[j]}) for _ in EPSILONS]
        results = solve_latin_batch(cases, options, initial=starts, check=False)
        cells = " | ".join(str(r.iterations) for r in results)
        print(f"| ({VALUES[i]:g}, {VALUES[j]:g}) | {start_error(nearest, answer):.2f} | "
              f"{cells} |", flush=True)


def predictors(model: ml.Model, tight: dict[Index, dict[str, object]]) -> None:
    def fields(ij: Index) -> Fields:
        return tight[ij]["fields"]  # type: ignore[return-value]

    def inside(*cells: Index) -> bool:
        return all(0 <= a < 13 and 0 <= b < 13 for a, b in cells)

    def line(a: Fields, b: Fields, t: float) -> Fields:
        return a[0] + t * (a[0] - b[0]), a[1] + t * (a[1] - b[1])

    def retimed(i: int, j: int) -> Fields:
        return retimed_fields(fields((i, j - 1)), fields((i, j - 2))) or fields((i, j - 1))

    def parallelogram(i: int, j: int) -> Fields:
        p, q, r = fields((i, j - 1)), fields((i - 1, j)), fields((i - 1, j - 1))
        return p[0] + q[0] - r[0], p[1] + q[1] - r[1]

    starts: dict[str, tuple[Callable[[int, int], Fields], Callable[[int, int], bool]]] = {
        "nearest in μ2": (lambda i, j: fields((i, j - 1)), lambda i, j: inside((i, j - 1))),
        "nearest in μ1": (lambda i, j: fields((i - 1, j)), lambda i, j: inside((i - 1, j))),
        "retimed in μ2": (retimed, lambda i, j: inside((i, j - 2))),
        "anti-diagonal neighbour": (lambda i, j: fields((i + 1, j - 1)),
                                    lambda i, j: inside((i + 1, j - 1))),
        "anti-diagonal secant": (lambda i, j: line(fields((i + 1, j - 1)),
                                                   fields((i + 2, j - 2)), 1.0),
                                 lambda i, j: inside((i + 2, j - 2))),
        "anti-diagonal midpoint": (lambda i, j: line(fields((i + 1, j - 1)),
                                                     fields((i - 1, j + 1)), -0.5),
                                   lambda i, j: inside((i + 1, j - 1), (i - 1, j + 1))),
        "parallelogram": (parallelogram, lambda i, j: inside((i - 1, j - 1))),
    }
    cases = [(i, j) for i in range(13) for j in range(13)
             if VALUES[i] + VALUES[j] < 0.6 - 1e-9 and tight[(i, j)]["unique"]
             and all(has(i, j) for _, has in starts.values())]
    options = LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    print(f"\n{len(cases)} sliding cases with every start\n")
    print("| start | its error: median, largest | iterations: sum, median, largest | "
          "R_stop's worst error |")
    print("|---|---|---|---|")
    for name, (start, _) in starts.items():
        initial = [start(i, j) for i, j in cases]
        errors = np.array([start_error(s, fields(ij)) for s, ij in zip(initial, cases,
                                                                        strict=True)])
        results = solve_latin_batch([model.assemble({"mu1": VALUES[i], "mu2": VALUES[j]})
                                     for i, j in cases], options, initial=initial,
                                    check=False)
        iterations = np.array([r.iterations for r in results])
        worst = max(abs(float(r.qoi["R_stop"]) - float(tight[ij]["R"]))  # type: ignore[arg-type]
                    / max(abs(float(tight[ij]["R"])), 1.0)  # type: ignore[arg-type]
                    for r, ij in zip(results, cases, strict=True))
        print(f"| {name} | {np.median(errors):.3f}, {errors.max():.3f} | "
              f"{iterations.sum()}, {np.median(iterations):g}, {iterations.max()} | "
              f"{worst:.1e} |", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--curve", action="store_true", help="the first table only")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    model = ml.load_model("b1")
    tight = tight_fields(model)
    curve(model, tight)
    if not args.curve:
        predictors(model, tight)


if __name__ == "__main__":
    main()
