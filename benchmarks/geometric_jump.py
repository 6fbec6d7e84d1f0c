"""A geometric (Aitken) jump of the slowest mode, beside the sliding crawl jump: tried in
session 31 (issue 15), not adopted.

    python benchmarks/geometric_jump.py            # cold b1 at eight pairs, with and without
    python benchmarks/geometric_jump.py --trace    # what the window increments look like

The sliding extrapolation (``latin.sliding``) keeps a mark of every case's state s = (W, F)
every ``WINDOW`` = 10 iterations and jumps where two windows' increments agree (a crawl,
ratio 1). A mode that decays geometrically, ρ per iteration, gives increments
d₂ ≈ r d₁ with r = ρ¹⁰; the jump s + r / (1 − r) d₂ would remove it (an affine
combination of admissible fields, then a local stage, as the crawl jump). Here it is
taken where 0.02 < r < 0.85 and ‖d₂ − r d₁‖ ≤ 5 % of ‖d₂‖ (in the indicator's norm), with
the crawl jump's take-back check. ``--trace`` prints r and that misfit at every mark of
two slow cold cases.
"""

from __future__ import annotations

import argparse
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOptions, iteration, sliding, solve_latin_batch
from multilatin.latin.options import STUDY_QOI_RTOL

PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15), (0.1, 0.25), (0.05, 0.05),
         (0.0, 0.1), (0.2, 0.05)]
ALIGNED = 0.05
RATIO = (0.02, 0.85)


class GeometricJump(sliding.SlidingExtrapolation):
    """The sliding extrapolation, and at each mark a geometric jump where it applies."""

    trace = False
    jumps = 0

    def __call__(self, counts: Any, active: Any, eta: Any, engine: Any) -> list[int]:
        moved = super().__call__(counts, active, eta, engine)
        counts = np.broadcast_to(np.asarray(counts), active.shape)
        positions, shifts_w, shifts_f = [], [], []
        for i, case in enumerate(active.tolist()):
            marks = self.marks.get(case, [])
            if (counts[i] % sliding.WINDOW or case in moved or case in self.pending
                    or self.taken_back[case] or len(marks) != 3):
                continue
            (w0, f0), (w1, f1), (w2, f2) = (
                (engine.take(s[0], np.array([r])), engine.take(s[1], np.array([r])))
                for s, r in marks)
            d1w, d1f, d2w, d2f = w1 - w0, f1 - f0, w2 - w1, f2 - f1
            size1 = engine.state_norms(d1w, d1f)[0]
            if not size1 > 0.0:
                continue
            plus = engine.state_norms(d2w + d1w, d2f + d1f)[0]
            minus = engine.state_norms(d2w - d1w, d2f - d1f)[0]
            ratio = (plus ** 2 - minus ** 2) / 4.0 / size1 ** 2  # ⟨d₂, d₁⟩ / ‖d₁‖²
            misfit = (engine.state_norms(d2w - ratio * d1w, d2f - ratio * d1f)[0]
                      / max(engine.state_norms(d2w, d2f)[0], 1e-300))
            if self.trace:
                print(f"  iteration {int(counts[i])}: r = {ratio:.3f}, misfit {misfit:.3f}, "
                      f"η = {eta[i]:.2e}")
            if not (RATIO[0] < ratio < RATIO[1] and misfit <= ALIGNED):
                continue
            factor = ratio / (1.0 - ratio)
            positions.append(i)
            shifts_w.append(factor * d2w[0])
            shifts_f.append(factor * d2f[0])
            self.pending[case] = (float(eta[i]), shifts_w[-1], shifts_f[-1])
            marks.clear()
            moved.append(case)
            self.jumped_at[case] = int(counts[i])
            self.jumps[case] += 1
            GeometricJump.jumps += 1
        if positions:
            engine.shift(np.array(positions), shifts_w, shifts_f)
            engine.local_stage()
        return moved


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--trace", action="store_true")
    args = parser.parse_args()
    model = ml.load_model("b1")
    options = LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    original = iteration.SlidingExtrapolation
    if args.trace:
        GeometricJump.trace = True
        iteration.SlidingExtrapolation = GeometricJump  # type: ignore[misc]
        for pair in [(0.1, 0.25), (0.0, 0.1)]:
            print(f"b1 {pair}:")
            result = solve_latin_batch([model.assemble({"mu1": pair[0], "mu2": pair[1]})],
                                       options, check=False)[0]
            print(f"  {result.iterations} iterations")
        iteration.SlidingExtrapolation = original  # type: ignore[misc]
        return
    assemblies = [model.assemble({"mu1": a, "mu2": b}) for a, b in PAIRS]
    tight = solve_latin_batch(assemblies, LatinOptions(tol=1e-9, max_iter=20000),
                              check=False)
    reference = np.array([r.qoi["R_stop"] for r in tight])
    print("| variant | iterations (per pair) | jumps | R_stop's worst error |")
    print("|---|---|---|---|")
    for label, extrapolation in (("today", original), ("geometric jump", GeometricJump)):
        iteration.SlidingExtrapolation = extrapolation  # type: ignore[misc]
        try:
            results = [solve_latin_batch([a], options, check=False)[0] for a in assemblies]
        finally:
            iteration.SlidingExtrapolation = original  # type: ignore[misc]
        error = max(abs(r.qoi["R_stop"] - q) / max(abs(q), 1.0)
                    for r, q in zip(results, reference, strict=True))
        print(f"| {label} | {sum(r.iterations for r in results)} "
              f"({', '.join(str(r.iterations) for r in results)}) | "
              f"{GeometricJump.jumps if extrapolation is GeometricJump else '—'} | "
              f"{error:.2e} |", flush=True)


if __name__ == "__main__":
    main()
