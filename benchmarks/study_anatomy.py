"""Where a multiresolution study's wall time goes, and what bounds its gain (issue 16,
session 31): the main job's 13 × 13 B1 study (or B3's 5 × 5 hole positions) run with
``run_study``'s defaults, its parts timed from outside the library.

    python benchmarks/study_anatomy.py                  # B1 13 x 13: the parts of the clock
    python benchmarks/study_anatomy.py --model b3       # B3 5 x 5 positions (rc = 3)
    python benchmarks/study_anatomy.py --widths         # batch width against cost per case-iteration
    python benchmarks/study_anatomy.py --floors 0.01,0.1,1  # the QoI rule's floor, against tight solves
    python benchmarks/study_anatomy.py --windows 10,8,6 --model b3  # the QoI estimate's window
    python benchmarks/study_anatomy.py --steady 0.02,0.05,0.1  # the crawl jump's test
    python benchmarks/study_anatomy.py --without-state-guard   # the state's own change

Default: the study once to load everything, then once measured: its clock (``elapsed_s``),
the rolling batch's iterations (``BatchIterations.step``) by batch width, the uniqueness
readings (the free motions of every converged case, ``free_motions_batch``; the friction
limit read before each start, ``limit_motions_batch``), a new geometry's operators and the
cases' assembly; the rest of the clock is the stream's other per-case work and the store.
The cold cases run after it (Σ cold, the gain's numerator), for the ceiling: the gain with
the iterations alone on the clock, and the iterations per case a gain of 10 would allow at
today's cost per case-iteration with nothing else on the clock.

``--widths``: ``solve_latin_batch`` of the first w cases of the B1 grid, 40 iterations each,
sharing operators: the cost per case-iteration at widths 1 … 169 (is a wider batch cheaper
per case?). ``--floors``: the study under the studies' QoI rule with the rule's floor
(``iteration.QOI_FLOOR``: rtol × max(|q|, floor × the largest |q|)) at each value; iterations in
all, R_stop's worst error against η < 1e-9 solves of every case, relative (floored at 1 N).
``--windows``: the same with the QoI estimate's window (``tracking.WINDOW``, 10: a case
stops on its QoIs after at least window + 5 iterations) at each value; ``--steady``: with
the sliding extrapolation's ``STEADY`` at each value; ``--without-state-guard``: with and
without ``iteration.state_settled`` (the state's own remaining change) in the QoI rule.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from collections import defaultdict
from collections.abc import Callable
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.latin import (
    LatinOptions,
    case_state,
    iteration,
    sliding,
    solve_latin_batch,
    solver,
    stream,
)
from multilatin.latin.operators import LatinOperators
from multilatin.model import Model
from multilatin.study import plan, predictors, rolling
from multilatin.study.runner import run_study

GRIDS = {"b1": ["mu1=0:0.6:13", "mu2=0:0.6:13"],
         "b3": ["xc=23:27:5", "yc=73:77:5", "rc=3"],
         "b3-frictions": ["mu1=0:0.6:13", "mu2=0:0.6:13", "xc=23:27:3"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--model", default="b1", choices=sorted(GRIDS))
    parser.add_argument("--widths", action="store_true")
    parser.add_argument("--floors", default=None, help="comma-separated floors")
    parser.add_argument("--windows", default=None, help="comma-separated windows")
    parser.add_argument("--steady", default=None, help="comma-separated values")
    parser.add_argument("--without-state-guard", action="store_true")
    parser.add_argument("--early", default=None,
                        help="comma-separated EARLY_COUNT values (15: off)")
    parser.add_argument("--margin", type=float, default=None,
                        help="EARLY_MARGIN for --early (default: the library's)")
    parser.add_argument("--early-rate", type=float, default=None,
                        help="EARLY_RATE for --early (default: the library's)")
    args = parser.parse_args()
    if args.widths:
        widths()
    elif args.floors:
        floors([float(x) for x in args.floors.split(",")])
    elif args.windows:
        windows(args.model, [int(x) for x in args.windows.split(",")])
    elif args.early:
        counts = [int(x) for x in args.early.split(",")]
        if bad := [c for c in counts if not 6 <= c <= iteration.WINDOW + 5]:
            raise SystemExit(f"--early: each value must lie in [6, {iteration.WINDOW + 5}], "
                             f"got {bad[0]}")
        if args.margin is not None:
            if not args.margin > 0:
                raise SystemExit(f"--margin: must be > 0, got {args.margin}")
            iteration.EARLY_MARGIN = args.margin
        if args.early_rate is not None:
            if not 0 <= args.early_rate < 1:
                raise SystemExit(f"--early-rate: must lie in [0, 1), got {args.early_rate}")
            iteration.EARLY_RATE = args.early_rate
        variants(args.model, f"first QoI stop (margin {iteration.EARLY_MARGIN:g}, rate "
                             f"≥ {iteration.EARLY_RATE:g})",
                 [(str(c), iteration, "EARLY_COUNT", c) for c in counts])
    elif args.steady:
        variants(args.model, "STEADY", [(f"{x}", sliding, "STEADY", float(x))
                                        for x in args.steady.split(",")])
    elif args.without_state_guard:
        def always(state: Any, active: Any, counts: Any, rtol: float, window: int = 0) -> Any:
            return np.ones(active.size, dtype=bool)

        variants(args.model, "state guard", [("on", iteration, "state_settled",
                                               iteration.state_settled),
                                              ("off", iteration, "state_settled", always)])
    else:
        anatomy(args.model)


class Timed:
    """Wraps ``owner.name`` to add its wall time to ``totals[label]`` and count its calls
    while ``when()`` holds; ``undo`` puts it back."""

    def __init__(self, owner: Any, name: str, label: str, totals: dict[str, float],
                 counts: dict[str, int], when: Callable[[], bool]) -> None:
        self.owner, self.name, self.original = owner, name, getattr(owner, name)
        original = self.original

        def timed(*args: Any, **kwargs: Any) -> Any:
            t0 = time.perf_counter()
            try:
                return original(*args, **kwargs)
            finally:
                if when():
                    totals[label] += time.perf_counter() - t0
                    counts[label] += 1

        setattr(owner, name, timed)

    def undo(self) -> None:
        setattr(self.owner, self.name, self.original)


def _study(model: Model, grid: ml.Grid, modes: tuple[str, ...] = ("multiresolution",)
           ) -> Any:
    with tempfile.TemporaryDirectory() as folder:
        return run_study(model, grid, modes=modes, out=folder)


def anatomy(name: str) -> None:
    model = ml.load_model(name.removesuffix("-frictions"))
    grid = ml.Grid.parse(GRIDS[name])
    _study(model, grid)  # loads and compiles everything once
    plan.clear_operator_cache()
    totals: dict[str, float] = defaultdict(float)
    counts: dict[str, int] = defaultdict(int)
    steps: list[tuple[int, float]] = []
    in_stream = [False]
    step = iteration.BatchIterations.step

    def timed_step(self: Any) -> Any:
        width, t0 = int(self.active.size), time.perf_counter()
        out = step(self)
        if in_stream[0]:
            steps.append((width, time.perf_counter() - t0))
        return out

    solve_stream = stream.solve_latin_stream

    def timed_stream(*args: Any, **kwargs: Any) -> Any:
        in_stream[0] = True
        t0 = time.perf_counter()
        try:
            return solve_stream(*args, **kwargs)
        finally:
            totals["stream"] += time.perf_counter() - t0
            in_stream[0] = False

    def streaming() -> bool:
        return in_stream[0]

    patches = [Timed(solver, "free_motions_batch", "free motions", totals, counts, streaming),
               Timed(predictors, "limit_motions_batch", "friction limit", totals, counts,
                     streaming),
               Timed(rolling, "_operators", "operators", totals, counts, streaming),
               Timed(Model, "assemble", "assembly", totals, counts, streaming),
               Timed(stream, "results_of", "results", totals, counts, streaming),
               Timed(stream, "_join", "joining the batch", totals, counts, streaming),
               Timed(rolling.ChainFeed, "flush", "the store's writes", totals, counts,
                     streaming)]
    iteration.BatchIterations.step = timed_step  # type: ignore[method-assign]
    rolling.solve_latin_stream = timed_stream  # type: ignore[assignment]
    try:
        study = _study(model, grid, ("multiresolution", "cold"))
    finally:
        for patch in patches:
            patch.undo()
        iteration.BatchIterations.step = step  # type: ignore[method-assign]
        rolling.solve_latin_stream = solve_stream  # type: ignore[assignment]
    clock = float(study.elapsed_s["multiresolution"])
    widths_ = np.array([w for w, _ in steps])
    times = np.array([t for _, t in steps])
    case_iterations = int(widths_.sum())
    iterating = float(times.sum())
    print(f"{name}: {grid.size} cases, {case_iterations} case-iterations in "
          f"{len(steps)} batch iterations; the study's clock {clock:.2f} s\n")
    print("| part | s | share of the clock | calls |")
    print("|---|---|---|---|")
    print(f"| iterations (``BatchIterations.step``) | {iterating:.3f} | "
          f"{iterating / clock:.0%} | {len(steps)} |")
    totals["results"] -= totals["free motions"]  # its part: a row of its own
    named = 0.0
    for label in ("free motions", "friction limit", "operators", "assembly", "results",
                  "joining the batch", "the store's writes"):
        named += totals[label]
        print(f"| {label} | {totals[label]:.3f} | {totals[label] / clock:.0%} | "
              f"{counts[label]} |")
    rest = totals["stream"] - iterating - named
    print(f"| the stream's other per-case work | {rest:.3f} | {rest / clock:.0%} | |")
    outside = max(clock - totals["stream"], 0.0)
    print(f"| outside the stream (plan, store) | {outside:.3f} | {outside / clock:.0%} | |")
    print("\n| batch width | batch iterations | case-iterations | ms per case-iteration |")
    print("|---|---|---|---|")
    for lo, hi in ((1, 1), (2, 3), (4, 7), (8, 12), (13, 16)):
        chosen = (widths_ >= lo) & (widths_ <= hi)
        if chosen.any():
            print(f"| {lo}–{hi} | {int(chosen.sum())} | {int(widths_[chosen].sum())} | "
                  f"{1e3 * times[chosen].sum() / widths_[chosen].sum():.3f} |")
    per_case_iteration = iterating / case_iterations
    gains = study.gains
    cold = gains["gain"] * clock  # Σ cold (every case converged in both modes here)
    print(f"\nΣ cold {cold:.2f} s, gain {gains['gain']:.2f} (iterations ratio "
          f"{gains['iterations_ratio']:.2f}); with the iterations alone on the clock the gain "
          f"would be {cold / iterating:.2f}; a gain of 10 needs the clock at {cold / 10:.2f} s:"
          f" at {1e3 * per_case_iteration:.3f} ms per case-iteration and nothing else, "
          f"{cold / 10 / per_case_iteration:.0f} case-iterations "
          f"({cold / 10 / per_case_iteration / grid.size:.1f} per case; today "
          f"{case_iterations / grid.size:.1f})")


def widths() -> None:
    model = ml.load_model("b1")
    grid = ml.Grid.parse(GRIDS["b1"])
    assemblies = [model.assemble({"mu1": a, "mu2": b}) for a in grid["mu1"]
                  for b in grid["mu2"]]
    options = LatinOptions(max_iter=40)
    operators = LatinOperators(assemblies[0], options)
    solve_latin_batch(assemblies[:2], options, operators, check=False)  # loads the kernels
    print("| width | case-iterations | ms per case-iteration |")
    print("|---|---|---|")
    for width in (1, 4, 16, 32, 64, 169):
        done, t0 = 0, time.perf_counter()
        for _ in range(max(1, 64 // width)):
            results = solve_latin_batch(assemblies[:width], options, operators, check=False)
            done += sum(r.iterations for r in results)
        print(f"| {width} | {done} | {1e3 * (time.perf_counter() - t0) / done:.3f} |",
              flush=True)


def _tight_r_stop(model: Model, grid: ml.Grid) -> np.ndarray:
    """R_stop of every case of ``grid`` (in the study's order) at η < 1e-9."""
    names = list(grid)
    assemblies = [model.assemble(dict(zip(names, values, strict=True)))
                  for values in np.stack(np.meshgrid(*[grid[n] for n in names],
                                                     indexing="ij"), -1).reshape(-1, len(names))]
    tight = solve_latin_batch(assemblies, LatinOptions(tol=1e-9, max_iter=20000), check=False)
    return np.array([r.qoi["R_stop"] for r in tight])


def _row(label: str, model: Model, grid: ml.Grid, reference: np.ndarray) -> None:
    data = _study(model, grid).dataset.sel(mode="multiresolution")
    r_stop = np.asarray(data["R_stop"].values).ravel()
    error = np.abs(r_stop - reference) / np.maximum(np.abs(reference), 1.0)
    print(f"| {label} | {int(data['iterations'].values.sum())} | {error.max():.2e} | "
          f"{int((error > 1e-3).sum())} |", flush=True)


def floors(values: list[float]) -> None:
    model = ml.load_model("b1")
    grid = ml.Grid.parse(GRIDS["b1"])
    reference = _tight_r_stop(model, grid)
    original = iteration.QOI_FLOOR
    print("| floor | iterations | R_stop's worst error | cases above 0.1 % |")
    print("|---|---|---|---|")
    try:
        for floor in values:
            iteration.QOI_FLOOR = floor
            _row(f"{floor:g}", model, grid, reference)
    finally:
        iteration.QOI_FLOOR = original


def variants(name: str, title: str, settings: list[tuple[str, Any, str, Any]]) -> None:
    """The study with ``owner.attribute = value`` for each (label, owner, attribute,
    value) of ``settings`` in turn (put back after each)."""
    model = ml.load_model(name.removesuffix("-frictions"))
    grid = ml.Grid.parse(GRIDS[name])
    reference = _tight_r_stop(model, grid)
    print(f"{name}\n\n| {title} | iterations | R_stop's worst error | cases above 0.1 % |")
    print("|---|---|---|---|")
    for label, owner, attribute, value in settings:
        saved = getattr(owner, attribute)
        setattr(owner, attribute, value)
        try:
            _row(label, model, grid, reference)
        finally:
            setattr(owner, attribute, saved)


def windows(name: str, values: list[int]) -> None:
    model = ml.load_model(name.removesuffix("-frictions"))
    grid = ml.Grid.parse(GRIDS[name])
    reference = _tight_r_stop(model, grid)
    saved = iteration.WINDOW, iteration.RECENT
    print(f"{name}\n\n| window | iterations | R_stop's worst error | cases above 0.1 % |")
    print("|---|---|---|---|")
    try:
        for window in values:  # the QoI history's ring buffer follows (RECENT)
            iteration.WINDOW, iteration.RECENT = window, window + 5
            case_state.RECENT = window + 5  # its buffers, as the iteration's
            _row(str(window), model, grid, reference)
    finally:
        iteration.WINDOW, iteration.RECENT = saved
        case_state.RECENT = saved[1]


if __name__ == "__main__":
    main()
