"""The sliding extrapolation's take-back rule side by side (issue 15, session 29): a jump
taken back when η one window after it is above its value at the jump (``TAKE_BACK = 1``,
the rule until session 29) against ``TAKE_BACK = 2`` (today's), on 13 × 13 friction grids.

    python benchmarks/take_back.py                          # the docs/convergence.md table
    python benchmarks/take_back.py --rows b1:0.5:zero --tight

Each row: a study (``run_study``, the studies' QoI rule) of a model at a κ and start, once
per rule, in this process; its iterations in all (the slowest case's), the cases that did
not converge, every checked jump's rise of η (η one window later / η at the jump), and with
``--tight`` R_stop's worst error against η < 1e-9 solves at the default κ (relative,
floored at 1 N: R_stop is 0 where the block does not reach the stop); ``--worst N``
prints the N worst cases with their error estimates.
"""

from __future__ import annotations

import argparse
import tempfile
import warnings
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOptions, sliding, solve_latin_batch
from multilatin.latin.options import STUDY_QOI_RTOL

GRID = ["mu1=0:0.6:13", "mu2=0:0.6:13"]
ROWS = ("b1:0.5:zero,b1:0.5:neighbour,b1-4:0.5:zero,b1-4:0.5:neighbour,b1-9:0.5:neighbour,"
        "b1:1:neighbour,b1:1:zero,b1:2:neighbour,b1:2:zero,b1:0.1:neighbour,b1:0.1:zero")


class Rises:
    """Records η's rise at every checked jump (wraps ``SlidingExtrapolation.__call__``)."""

    def __init__(self) -> None:
        self.values: list[float] = []
        self._call = sliding.SlidingExtrapolation.__call__
        rises = self

        def call(self: Any, counts: Any, active: Any, eta: Any, engine: Any) -> Any:
            due = np.broadcast_to(np.asarray(counts), active.shape) % sliding.WINDOW == 0
            for i, case in enumerate(active.tolist()):
                if due[i] and case in self.pending:
                    rises.values.append(float(eta[i] / self.pending[case][0]))
            return rises._call(self, counts, active, eta, engine)

        sliding.SlidingExtrapolation.__call__ = call  # type: ignore[method-assign]


def tight_values(model: ml.Model) -> np.ndarray:
    """R_stop at η < 1e-9 with the default κ (a converged answer does not depend on κ; at κ
    = 2 such solves stop at a false "no equilibrium"), NaN where a solve did not converge."""
    grid = ml.Grid.parse(GRID)
    assemblies = [model.assemble({"mu1": a, "mu2": b}) for a in grid["mu1"] for b in grid["mu2"]]
    results = solve_latin_batch(assemblies, LatinOptions(tol=1e-9, max_iter=20000), check=False)
    return np.array([r.qoi["R_stop"] if r.converged else np.nan for r in results])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", default=ROWS, help="model:kappa:start, comma-separated")
    parser.add_argument("--tight", action="store_true", help="R_stop's error against tight")
    parser.add_argument("--worst", type=int, default=0,
                        help="with --tight, print the N worst cases (value, estimate)")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    rises = Rises()
    references: dict[str, np.ndarray] = {}
    print("| model | κ | start | TAKE_BACK | iterations (slowest) | not converged | rises of η "
          "at the checks | worst R_stop error |")
    print("|---|---|---|---|---|---|---|---|")
    for item in args.rows.split(","):
        name, kappa_text, start = item.split(":")
        model, kappa = ml.load_model(name), float(kappa_text)
        if args.tight and name not in references:
            references[name] = tight_values(model)
        tight = references.get(name)
        for take_back in (1.0, 2.0):
            sliding.TAKE_BACK = take_back
            rises.values.clear()
            with tempfile.TemporaryDirectory() as folder:
                result = ml.run_study(model, ml.Grid.parse(GRID), out=folder, progress=False,
                                      options=LatinOptions(qoi_rtol=STUDY_QOI_RTOL,
                                                           kappa=kappa),
                                      start=start, on_failure="ignore")
            iterations = [r["iterations"] for r in result.records]
            failed = sum(not r["converged"] for r in result.records)
            error, worst = "—", []
            if tight is not None:
                values = np.asarray(result.dataset["R_stop"].values, dtype=float).ravel()
                errors = np.abs(values - tight) / np.maximum(np.abs(tight), 1.0)
                error = f"{np.nanmax(errors):.2e}"
                by_index = {tuple(r["index"]): r for r in result.records}
                shape = [len(v) for v in ml.Grid.parse(GRID).values()]
                for n in np.argsort(-np.nan_to_num(errors))[:args.worst]:
                    record = by_index[tuple(int(i) for i in np.unravel_index(n, shape))]
                    worst.append(f"    {record['params']}: R_stop {values[n]:.3f} N, tight "
                                 f"{tight[n]:.3f}, off {abs(values[n] - tight[n]):.3f} "
                                 f"({errors[n]:.2e}), estimate "
                                 f"{record['qoi_error'].get('R_stop')}")
            shown = ", ".join(f"{r:.2f}" for r in sorted(rises.values) if r > 1.0)
            print(f"| {name} | {kappa:g} | {start} | {take_back:g} | {sum(iterations)} "
                  f"({max(iterations)}) | {failed} | {len(rises.values)} checks; above 1: "
                  f"{shown or 'none'} | {error} |", flush=True)
            for line in worst:
                print(line, flush=True)


if __name__ == "__main__":
    main()
