"""Reduced-rank extrapolation under the studies' QoI rule (session 38, measured, not
adopted): RRE (``acceleration="rre"``) refuses ``qoi_rtol`` because its steps break the
contraction the QoIs' error estimate reads. Here, a prototype: RRE extrapolates a case only
while its η is above ``UNTIL``, and each of its steps counts as a jump of the sliding
extrapolation (no stop within ``iteration.RECENT`` iterations after it; the estimate then
reads the iterates after it alone). Cold solves at the four pairs of
``benchmarks/convergence.py``, iterations and R_stop's error against a tight solve
(η < 1e-10), relative, beside the library's default (relaxation) under the same rule.

    python benchmarks/rre_under_qoi_rule.py [--models b1 b1-9 b3] [--until 1e-3 1e-4 1e-5]
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np
from rigid_balance import PAIRS  # this script's folder

import multilatin as ml
from multilatin.latin import LatinOptions, extrapolation, iteration, solve_latin
from multilatin.latin.options import STUDY_QOI_RTOL

UNTIL = [1e-4]


class _Rows:
    """The fields of some of a batch's active cases, as ``ReducedRankExtrapolation`` reads
    and moves them."""

    def __init__(self, engine: Any, rows: np.ndarray) -> None:
        self.engine, self.rows = engine, rows

    def fields(self) -> tuple[Any, ...]:
        return tuple(x[self.rows] for x in self.engine.fields())

    def shift(self, cases: Any, dw: Any, df: Any) -> None:
        self.engine.shift(self.rows[cases], dw, df)

    def local_stage_of(self, cases: Any) -> None:
        self.engine.local_stage_of(self.rows[cases])

    def __getattr__(self, name: str) -> Any:
        return getattr(self.engine, name)


def patch() -> None:
    """RRE only while η > ``UNTIL[0]``, its steps recorded as jumps."""
    init = iteration.BatchIterations.__init__
    call = extrapolation.ReducedRankExtrapolation.__call__

    def owned(self: Any, *args: Any, **kwargs: Any) -> None:
        init(self, *args, **kwargs)
        if self.rre is not None:
            self.rre.owner = self

    def limited(self: Any, active: np.ndarray, engine: Any) -> list[int]:
        owner = self.owner
        eligible = np.array([owner.state.histories[c][-1] > UNTIL[0]
                             for c in active.tolist()], dtype=bool)
        for case in active[~eligible].tolist():
            self.forget(case)
        rows = np.flatnonzero(eligible)
        moved = call(self, active[rows], _Rows(engine, rows)) if rows.size else []
        if owner.sliding is not None:
            for case in moved:
                owner.sliding.jumped_at[case] = owner.counts[case]
        return moved

    iteration.BatchIterations.__init__ = owned  # type: ignore[method-assign]
    extrapolation.ReducedRankExtrapolation.__call__ = limited  # type: ignore[method-assign]


def options(acceleration: str) -> LatinOptions:
    out = LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    object.__setattr__(out, "acceleration", acceleration)  # past the refusal: the prototype
    return out


def cell(result: Any, tight: float) -> str:
    """Iterations and R_stop's error against ``tight``, relative (floored at 1 N)."""
    error = abs(float(result.qoi["R_stop"]) - tight) / max(abs(tight), 1.0)
    return f"{result.iterations}{'' if result.converged else ' (failed)'}, {error:.1e}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--models", nargs="+", default=["b1", "b1-9", "b3"])
    parser.add_argument("--until", type=float, nargs="+", default=[1e-3, 1e-4, 1e-5])
    args = parser.parse_args()
    patch()
    print("| model | μ1, μ2 | relaxation (default) | "
          + " | ".join(f"RRE while η > {u:g}" for u in args.until) + " |")
    print("|---|---|---|" + "---|" * len(args.until))
    for name in args.models:
        model = ml.load_model(name)
        for mu1, mu2 in PAIRS:
            assembly = model.assemble({"mu1": mu1, "mu2": mu2})
            tight = float(solve_latin(assembly, LatinOptions(tol=1e-10, max_iter=20000))
                          .qoi["R_stop"])

            cells = [cell(solve_latin(assembly, options("relaxation"), check=False), tight)]
            for until in args.until:
                UNTIL[0] = until
                cells.append(cell(solve_latin(assembly, options("rre"), check=False), tight))
            print(f"| {name} | {mu1:g}, {mu2:g} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
