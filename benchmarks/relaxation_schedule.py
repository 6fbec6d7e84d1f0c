"""A relaxation that cycles through several values (a polynomial over the cycle against the
relaxation's −1 mode and the slow positive ones), against the constant ω = 0.9: cold b1
solves at the four pairs of ``benchmarks/convergence.py``, default tolerance.

    python benchmarks/relaxation_schedule.py --schedules 0.9 0.6,1.8 0.55,1.9 0.5,2.0

The schedule replaces ω from the second linear stage on (the first is not relaxed), one
value per iteration in turn. Prints iterations (or "no" when not converged within 1 000) and
R_stop per pair.
"""

from __future__ import annotations

import argparse

import numpy as np

import multilatin as ml
from multilatin.latin.engine import NumpyFields

PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="b1")
    parser.add_argument("--schedules", nargs="+",
                        default=["0.9", "1.0", "0.6,1.8", "0.55,1.9", "0.65,1.7", "0.6,2.0",
                                 "0.5,2.0", "0.5,1.6", "0.7,1.4"])
    args = parser.parse_args()
    model = ml.load_model(args.model)
    original = NumpyFields.linear_stage
    print("| schedule | " + " | ".join(f"({a:g}, {b:g})" for a, b in PAIRS) + " |")
    print("|---|" + "---|" * len(PAIRS))
    for text in args.schedules:
        cycle = np.array([float(v) for v in text.split(",")])
        calls = {"n": 0}

        def linear_stage(self: NumpyFields, relaxation: np.ndarray,
                         cycle: np.ndarray = cycle, calls: dict[str, int] = calls) -> None:
            calls["n"] += 1
            if calls["n"] > 1:
                relaxation = np.full_like(relaxation, cycle[calls["n"] % cycle.size])
            original(self, relaxation)

        NumpyFields.linear_stage = linear_stage  # type: ignore[method-assign]
        cells = []
        try:
            for mu1, mu2 in PAIRS:
                calls["n"] = 0
                result = model.solve({"mu1": mu1, "mu2": mu2}, check=False)
                r_stop = float(result.qoi["R_stop"])  # type: ignore[arg-type]
                cells.append(f"{result.iterations if result.converged else 'no'} "
                             f"({r_stop:.3f})")
        finally:
            NumpyFields.linear_stage = original  # type: ignore[method-assign]
        print(f"| {text} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
