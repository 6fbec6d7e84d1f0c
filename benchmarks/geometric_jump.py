"""The sliding extrapolation's geometric jump (issue 15, session 31) side by side with the
rule before it (crawl jumps only), in one process: the same solves with
``sliding.GEOMETRIC`` as it is and emptied.

    python benchmarks/geometric_jump.py                 # bundled models, B1 family, slide
    python benchmarks/geometric_jump.py --studies       # B1 13 x 13 and B3 5 x 5 studies
    python benchmarks/geometric_jump.py --trace         # r and the misfit at every mark
    python benchmarks/geometric_jump.py --slow-on-qois 0.02   # fast modes jump on QoIs too
    python benchmarks/geometric_jump.py --aligned 0.2   # a looser alignment test
    python benchmarks/geometric_jump.py --aligned-slow 0.2   # looser for r >= 0.5 only
    python benchmarks/geometric_jump.py --two-modes     # one-mode jumps against two-mode
    python benchmarks/geometric_jump.py --two-modes --several-slowest 0.4   # its bound
    python benchmarks/geometric_jump.py --modes 3       # up to three modes (five marks)

Every ``WINDOW`` = 10 iterations the extrapolation compares the last two windows'
increments d₁, d₂ of the state; where d₂ = r d₁ to 5 % with 0.02 < r < 0.85 — one slow
mode left — it jumps by r / (1 − r) d₂ (``latin.sliding``; r > 0.2 when cases stop on
their QoIs), and the case does not stop in the 15 iterations after a jump. Rows: each model at its
defaults under the default stopping rule (η < 1e-6) and the studies' QoI rule
(``qoi_rtol`` = 1e-3): iterations, and the QoIs' worst error against the monolithic
reference (relative to each QoI's largest magnitude over the steps); the B1 family at
issue 15's four friction pairs, R_stop against η < 1e-10 solves; the sliding block over
κ and its foundation's stiffness. ``--studies``: ``run_study``'s defaults, R_stop against
η < 1e-9 solves of every case. ``--trace``: the two slowest cold b1 pairs and the sliding
block at κ = 0.1, r and ‖d₂ − r d₁‖ / ‖d₂‖ at every mark. ``--two-modes``: the columns
are the geometric jump of one mode alone (``sliding.MODES`` = 1, session 31) and with the
two-mode fit from four marks (``MODES`` = 2, the default since session 34).
"""

from __future__ import annotations

import argparse
import sys
import warnings
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOptions, sliding, solve_latin_batch
from multilatin.latin.options import STUDY_QOI_RTOL

PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]
NONE = (1.0, 0.0)  # an empty interval: no geometric jump
RULES = {"η < 1e-6": LatinOptions(), "QoI rule": LatinOptions(qoi_rtol=STUDY_QOI_RTOL)}
#: what ``_both`` compares: (GEOMETRIC, MODES) per column; ``--two-modes`` sets one mode
#: against two
COLUMNS = [(NONE, sliding.MODES), (sliding.GEOMETRIC, sliding.MODES)]
HEADERS = ["before", "geometric jump"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--studies", action="store_true")
    parser.add_argument("--trace", action="store_true")
    parser.add_argument("--slow-on-qois", type=float, default=None,
                        help="sliding.SLOW_ON_QOIS for this run (the library's: 0.2)")
    parser.add_argument("--aligned", type=float, default=None,
                        help="sliding.ALIGNED for this run (the library's: 0.05)")
    parser.add_argument("--aligned-slow", type=float, default=None,
                        help="a looser alignment for slow modes (r >= 0.5) only")
    parser.add_argument("--two-modes", action="store_true",
                        help="columns: one-mode jumps (MODES = 1) and two-mode (MODES = 2)")
    parser.add_argument("--several-slowest", type=float, default=None,
                        help="sliding.SEVERAL_SLOWEST for this run (the library's: 0.5)")
    parser.add_argument("--modes", type=int, default=None,
                        help="sliding.MODES for this run (the library's: 2)")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    if args.modes is not None and args.modes < 1:
        parser.error(f"--modes: at least 1, got {args.modes}")
    if args.several_slowest is not None and not 0.0 < args.several_slowest < 1.0:
        parser.error(f"--several-slowest: between 0 and 1, got {args.several_slowest}")
    if args.modes is not None:
        sliding.MODES = args.modes
        COLUMNS[:] = [(NONE, args.modes), (sliding.GEOMETRIC, args.modes)]
    if args.several_slowest is not None:
        sliding.SEVERAL_SLOWEST = args.several_slowest
    if args.two_modes:
        COLUMNS[:] = [(sliding.GEOMETRIC, 1), (sliding.GEOMETRIC, 2)]
        HEADERS[:] = ["one mode", "two modes"]
    if args.aligned is not None:
        sliding.ALIGNED = args.aligned
    if args.aligned_slow is not None:
        loosen_for_slow_modes(args.aligned_slow)
    if args.slow_on_qois is not None:
        sliding.SLOW_ON_QOIS = args.slow_on_qois
    if args.trace:
        trace()
    elif args.studies:
        studies()
    else:
        solves()


def loosen_for_slow_modes(aligned: float, slow: float = 0.5) -> None:
    """Also jump where r ≥ ``slow`` and the increments are aligned to ``aligned`` (the
    library's test: ``sliding.ALIGNED``, 5 %, for every r)."""
    geometric = sliding.SlidingExtrapolation._geometric

    def looser(engine: Any, dw: Any, df: Any, before_w: Any, before_f: Any, step: Any,
               bend: Any, ratios: tuple[float, float] = sliding.GEOMETRIC) -> Any:
        ratio, misfit, strict = geometric(engine, dw, df, before_w, before_f, step, bend,
                                          ratios)
        loose = ((step > 0.0) & (ratio >= max(slow, ratios[0])) & (ratio < ratios[1])
                 & (misfit <= aligned))
        return ratio, misfit, strict | loose

    sliding.SlidingExtrapolation._geometric = staticmethod(looser)  # type: ignore[method-assign]


def _both(solve: Callable[[], Any]) -> list[Any]:
    """``solve()`` without the geometric jump, then with it (``COLUMNS``)."""
    kept = sliding.GEOMETRIC, sliding.MODES
    out = []
    for interval, modes in COLUMNS:
        sliding.GEOMETRIC, sliding.MODES = interval, modes
        try:
            out.append(solve())
        finally:
            sliding.GEOMETRIC, sliding.MODES = kept
    return out


def _qoi_error(result: Any, reference: Any) -> float:
    return max(float(np.max(np.abs(np.asarray(result.qoi[k]) - np.asarray(reference.qoi[k])))
                     / max(float(np.max(np.abs(np.asarray(reference.qoi[k])))), 1e-12))
               for k in reference.qoi)


def solves() -> None:
    print(f"| model | case | rule | {HEADERS[0]}: iterations, worst error | {HEADERS[1]} |")
    print("|---|---|---|---|---|")
    for name in ("b0", "b2", "punch", "lug", "roller", "slide"):
        model = ml.load_model(name)
        reference = model.reference({})
        for rule, options in RULES.items():
            results = _both(lambda m=model, o=options: solve_latin_batch(
                [m.assemble({})], o, check=False)[0])
            cells = [f"{r.iterations}, {_qoi_error(r, reference):.1e}" for r in results]
            print(f"| {name} | defaults | {rule} | {cells[0]} | {cells[1]} |", flush=True)
    for name in ("b1", "b1-4", "b1-9", "b3"):
        model = ml.load_model(name)
        cases = [model.assemble({"mu1": a, "mu2": b}) for a, b in PAIRS]
        tight = solve_latin_batch(cases, LatinOptions(tol=1e-10, max_iter=20000),
                                  check=False)
        reference = np.array([r.qoi["R_stop"] for r in tight])
        for rule, options in RULES.items():
            cells = []
            for results in _both(lambda cs=cases, o=options: [
                    solve_latin_batch([c], o, check=False)[0] for c in cs]):
                error = max(abs(r.qoi["R_stop"] - q) / max(abs(q), 1.0)
                            for r, q in zip(results, reference, strict=True))
                cells.append(f"{' / '.join(str(r.iterations) for r in results)}, "
                             f"{error:.1e}")
            print(f"| {name} | four pairs | {rule} | {cells[0]} | {cells[1]} |", flush=True)
    model = ml.load_model("slide")
    for ratio in (10.0, 1000.0):
        reference = model.reference({"stiffness_ratio": ratio})
        for kappa in (0.1, 0.25, 0.5, 1.0, 2.0):
            for rule, options in RULES.items():
                chosen = replace(options, kappa=kappa)
                results = _both(lambda r=ratio, o=chosen: solve_latin_batch(
                    [model.assemble({"stiffness_ratio": r})], o, check=False)[0])
                cells = [f"{r.iterations}, {_qoi_error(r, reference):.1e}" for r in results]
                print(f"| slide | E ratio {ratio:g}, κ {kappa:g} | {rule} | {cells[0]} | "
                      f"{cells[1]} |", flush=True)


def studies() -> None:
    sys.path.insert(0, str(Path(__file__).parent))
    import study_anatomy

    print(f"| study | {HEADERS[0]}: iterations, R_stop's worst error, above 0.1 % | "
          f"{HEADERS[1]} |")
    print("|---|---|---|")
    for name in ("b1", "b3"):
        model = ml.load_model(name)
        grid = ml.Grid.parse(study_anatomy.GRIDS[name])
        reference = study_anatomy._tight_r_stop(model, grid)
        cells = []
        for dataset in _both(lambda m=model, g=grid: study_anatomy._study(m, g).dataset):
            data = dataset.sel(mode="multiresolution")
            r_stop = np.asarray(data["R_stop"].values).ravel()
            error = np.abs(r_stop - reference) / np.maximum(np.abs(reference), 1.0)
            cells.append(f"{int(data['iterations'].values.sum())}, {error.max():.2e}, "
                         f"{int((error > 1e-3).sum())}")
        print(f"| {name} | {cells[0]} | {cells[1]} |", flush=True)


def trace() -> None:
    geometric = sliding.SlidingExtrapolation._geometric

    def traced(engine: Any, dw: Any, df: Any, before_w: Any, before_f: Any, step: Any,
               bend: Any, ratios: tuple[float, float] = sliding.GEOMETRIC) -> Any:
        ratio, misfit, aligned = geometric(engine, dw, df, before_w, before_f, step, bend,
                                           ratios)
        for r, m, a in zip(ratio, misfit, aligned, strict=True):
            print(f"  r = {r:.3f}, misfit {m:.3f}{' (jump)' if a else ''}")
        return ratio, misfit, aligned

    modes = sliding.SlidingExtrapolation._modes

    def traced_modes(engine: Any, increments: Any, ratios: tuple[float, float]
                     = sliding.GEOMETRIC) -> Any:
        coefficients, held, slowest = modes(engine, increments, ratios)
        _, misfit, _, roots = sliding.SlidingExtrapolation._mode_fit(engine, increments)
        for row in range(len(held)):
            print(f"  {len(increments) - 1} modes: roots {np.round(roots[row], 3)}, misfit "
                  f"{misfit[row]:.3f}{' (jump)' if held[row] else ''}")
        return coefficients, held, slowest

    sliding.SlidingExtrapolation._geometric = staticmethod(traced)  # type: ignore[method-assign]
    sliding.SlidingExtrapolation._modes = staticmethod(traced_modes)  # type: ignore[method-assign]
    for name, parameters, kappa in (("b1", {"mu1": 0.1, "mu2": 0.25}, 0.5),
                                    ("b1", {"mu1": 0.0, "mu2": 0.1}, 0.5),
                                    ("slide", {}, 0.1)):
        print(f"{name} {parameters} κ = {kappa} (marks every 10 iterations from the 30th):")
        result = solve_latin_batch([ml.load_model(name).assemble(parameters)],
                                   LatinOptions(kappa=kappa, qoi_rtol=STUDY_QOI_RTOL),
                                   check=False)[0]
        print(f"  {result.iterations} iterations")


if __name__ == "__main__":
    main()
