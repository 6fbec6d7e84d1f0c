"""The blow-up guard's margin (session 38, ``guards.BLOWUP``): how far ½(‖s‖ + ‖ŝ‖), the
size η is relative to, grows over its value after a case's first iteration, in the cases
that converge — the studies (multiresolution and cold), the four pairs of
``benchmarks/convergence.py`` under both stopping rules, every other bundled model, and the
slide across κ — against a deliberately unstable iteration (every local stage's ŝ
multiplied by ``--factor``), which the guard stops.

    python benchmarks/blowup.py [--quick]
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
from rigid_balance import BUNDLED, PAIRS  # this script's folder

import multilatin as ml
from multilatin.latin import LatinOptions, engine, guards, iteration, solve_latin
from multilatin.latin.options import STUDY_QOI_RTOL
from multilatin.parameters import Grid
from multilatin.study.runner import run_study

STUDIES = {"B1 13 × 13": ("b1", ["mu1=0:0.6:13", "mu2=0:0.6:13"]),
           "B3 5 × 5 positions": ("b3", ["xc=23:27:5", "yc=73:77:5", "rc=3"])}


@contextmanager
def growth() -> Iterator[list[float]]:
    """The largest size over first size of every case stepped meanwhile (appended)."""
    seen = [0.0]
    step: Callable[[Any], Any] = iteration.BatchIterations.step

    def measured(self: iteration.BatchIterations) -> Any:
        active = self.active.copy()
        left = step(self)
        first = self.state.first_size[active]
        sizes = np.array([self.state.sizes[c][-1] for c in active.tolist()])
        if (first > 0).any():
            seen[0] = max(seen[0], float(np.max(sizes[first > 0] / first[first > 0])))
        return left

    iteration.BatchIterations.step = measured  # type: ignore[method-assign]
    try:
        yield seen
    finally:
        iteration.BatchIterations.step = step  # type: ignore[method-assign]


@contextmanager
def unstable(factor: float) -> Iterator[None]:
    """Every local stage's ŝ multiplied by ``factor``: an iteration that diverges."""
    local_stage = engine.NumpyFields.local_stage

    def grown(self: engine.NumpyFields) -> None:
        local_stage(self)
        self.w_hat, self.f_hat = factor * self.w_hat, factor * self.f_hat

    engine.NumpyFields.local_stage = grown  # type: ignore[method-assign]
    try:
        yield
    finally:
        engine.NumpyFields.local_stage = local_stage  # type: ignore[method-assign]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="no studies")
    parser.add_argument("--factor", type=float, default=1.5)
    args = parser.parse_args()
    print(f"guards.BLOWUP = {guards.BLOWUP:g}\n\n| cases | largest size / first size |\n"
          "|---|---|")
    if not args.quick:
        for label, (name, spec) in STUDIES.items():
            with growth() as seen:
                run_study(ml.load_model(name), Grid.parse(spec),
                          options=LatinOptions(qoi_rtol=STUDY_QOI_RTOL),
                          modes=("multiresolution", "cold"), progress=False)
            print(f"| {label} study, multiresolution and cold | {seen[0]:.3f} |", flush=True)
    for name in ("b1", "b1-4", "b1-9", "b3"):
        model = ml.load_model(name)
        with growth() as seen:
            for mu1, mu2 in PAIRS:
                assembly = model.assemble({"mu1": mu1, "mu2": mu2})
                for rtol in (None, STUDY_QOI_RTOL):
                    solve_latin(assembly, LatinOptions(qoi_rtol=rtol), check=False)
        print(f"| {name} at the four pairs, η < 1e-6 and QoI rule | {seen[0]:.3f} |",
              flush=True)
    for name in BUNDLED:
        with growth() as seen:
            solve_latin(ml.load_model(name).assemble({}), LatinOptions(), check=False)
        print(f"| {name} | {seen[0]:.3f} |", flush=True)
    with growth() as seen:
        for kappa in (0.1, 0.2, 0.5, 1.0, 2.0):
            solve_latin(ml.load_model("slide").assemble({}), LatinOptions(kappa=kappa),
                        check=False)
    print(f"| slide, κ = 0.1 … 2 | {seen[0]:.3f} |")
    with unstable(args.factor):
        result = solve_latin(ml.load_model("b0").assemble({}), LatinOptions(), check=False)
    print(f"\nb0 with every ŝ × {args.factor:g}: converged {result.converged} after "
          f"{result.iterations} iterations: {result.failure}")


if __name__ == "__main__":
    main()
