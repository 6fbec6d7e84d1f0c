"""What a new b3 geometry's assembly and operators cost, as a study builds them: 15 hole
positions (the assembly of each from the model file, then its operators), each
after a few iterations of the previous one (so that BLAS's state is a study's); with the
previous geometry's operators reused (``study.plan._operators``) and built whole
(``LatinOperators``, as a cold case does), each with the macro-only interfaces' map its
first solve builds (``LatinOperators.macro_only``). Optionally side by side with another
source tree.

    python benchmarks/operator_build.py
    python benchmarks/operator_build.py --baseline /tmp/old/src --rounds 3
"""

from __future__ import annotations

import argparse
import time

from side_by_side import add_arguments, alternate


def measure() -> str:
    import numpy as np

    import multilatin as ml
    from multilatin.latin import LatinOptions, solve_latin
    from multilatin.latin.operators import LatinOperators
    from multilatin.study.plan import _operators

    model, options = ml.load_model("b3"), LatinOptions(max_iter=20, tol=1e-30)
    first = model.assemble({"xc": 25, "yc": 75, "rc": 3})
    solve_latin(first, options, operators=_operators(first, options)[0], check=False)
    reused, whole, assembled = [], [], []
    for xc in (23, 24, 26, 27, 22):
        for yc in (73, 74, 76):
            before = model.assemble({"xc": xc, "yc": yc, "rc": 3})
            solve_latin(before, options, operators=_operators(before, options)[0], check=False)
            t0 = time.perf_counter()
            assembly = model.assemble({"xc": xc + 0.5, "yc": yc, "rc": 3})
            assembled.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            _operators(assembly, options)[0].macro_only  # noqa: B018 (its first solve's)
            reused.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            LatinOperators(assembly, options).macro_only  # noqa: B018
            whole.append(time.perf_counter() - t0)
    return (f"assembly: median {1e3 * np.median(assembled):.1f} ms; "
            f"reused: median {1e3 * np.median(reused):.1f} ms, mean {1e3 * np.mean(reused):.1f}"
            f"; whole: median {1e3 * np.median(whole):.1f} ms, mean {1e3 * np.mean(whole):.1f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_arguments(parser)
    parser.add_argument("--here", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.here or not args.baseline:
        print(measure(), flush=True)
        return
    for label, line in alternate(__file__, ["--here"], args.baseline, args.rounds):
        print(f"{label}: {line}", flush=True)


if __name__ == "__main__":
    main()
