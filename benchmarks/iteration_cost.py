"""What one LATIN iteration costs: a single case (a line study's cases, a cold solve) and a
batch of cases (a grid study's rolling batch), the operators built beforehand; and what
building the operators costs (a cold solve's setup, a new geometry's in a study).

    python benchmarks/iteration_cost.py                          # this checkout
    python benchmarks/iteration_cost.py --baseline /tmp/old/src  # side by side with another

For each model: cold solves at the four friction pairs of ``benchmarks/convergence.py``,
one at a time (per iteration: the solve's wall time over its iterations, the operators
given), then the same four cases together as one batch (``solve_latin_batch``) twice over
(eight cases); the operators of each of the four cases built anew (``LatinOperators``, the
model's assembly included), and for a model with a hole (xc, yc) its operators after the hole
moved to four positions, the other substructures' reused (a positions study). Each
measurement is the median of ``--repeat`` runs. With
``--baseline``, the script runs itself alternately with ``PYTHONPATH`` set to that source
tree and to this one, ``--rounds`` times, in fresh processes, and prints both medians and
their ratio; the iterations and R_stop must agree (the same algorithm, only faster), else it says so.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]
#: hole positions (B3's 5 × 5 positions grid's corners): a new geometry in a study
HOLES = [(23.0, 73.0), (27.0, 77.0), (23.0, 77.0), (27.0, 73.0)]


def measure(models: list[str], repeat: int) -> dict[str, dict[str, float | list[float]]]:
    """Per model: ms per iteration (single, batch of 8), iterations and R_stop per pair."""
    import multilatin as ml
    from multilatin.latin import LatinOptions
    from multilatin.latin.operators import LatinOperators
    from multilatin.latin.solver import solve_latin, solve_latin_batch

    out: dict[str, dict[str, float | list[float]]] = {}
    for name in models:
        model = ml.load_model(name)
        options = LatinOptions()
        assemblies = [model.assemble({"mu1": a, "mu2": b}) for a, b in PAIRS]
        ops = LatinOperators(assemblies[0], options)
        solve_latin(assemblies[0], options, ops)  # warm-up: kernels loaded, caches filled
        single, batch, setup, rebuild = [], [], [], []
        moves = "xc" in model.parameters and "yc" in model.parameters
        iterations: list[float] = []
        r_stop: list[float] = []
        for _ in range(repeat):
            its, wall = 0, 0.0
            iterations, r_stop = [], []
            for assembly in assemblies:
                t0 = time.perf_counter()
                result = solve_latin(assembly, options, ops)
                wall += time.perf_counter() - t0
                its += result.iterations
                iterations.append(result.iterations)
                r_stop.append(float(np.asarray(result.qoi["R_stop"])))
            single.append(1e3 * wall / its)
            for a, b in PAIRS:
                t0 = time.perf_counter()
                LatinOperators(model.assemble({"mu1": a, "mu2": b}), options)
                setup.append(1e3 * (time.perf_counter() - t0))
            for xc, yc in HOLES if moves else ():
                # a hole moved: only its substructure built anew, as in a positions study
                t0 = time.perf_counter()
                LatinOperators(model.assemble({"xc": xc, "yc": yc}), options, reuse=ops)
                rebuild.append(1e3 * (time.perf_counter() - t0))
            t0 = time.perf_counter()
            results = solve_latin_batch(assemblies * 2, options, ops)
            wall = time.perf_counter() - t0
            # a batch step costs as its cases do: per case-iteration
            batch.append(1e3 * wall / sum(r.iterations for r in results))
        out[name] = {"single_ms": statistics.median(single),
                     "batch_ms": statistics.median(batch),
                     "setup_ms": statistics.median(setup),
                     **({"rebuild_ms": statistics.median(rebuild)} if rebuild else {}),
                     "iterations": iterations, "R_stop": r_stop}
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--models", nargs="+", default=["b1", "b3"])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--baseline", help="another source tree (its src/), side by side")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--json", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.json:
        print(json.dumps(measure(args.models, args.repeat)))
        return
    if not args.baseline:
        for name, row in measure(args.models, args.repeat).items():
            print(f"{name}: {row['single_ms']:.3f} ms per iteration alone, "
                  f"{row['batch_ms']:.3f} per case-iteration in a batch of 8, "
                  f"{row['setup_ms']:.1f} per operators' build"
                  + (f", {row['rebuild_ms']:.1f} per moved hole's" if "rebuild_ms" in row
                     else "") + "; "
                  f"iterations {row['iterations']}")
        return
    here = str(Path(__file__).resolve().parents[1] / "src")
    trees = {"baseline": str(Path(args.baseline).resolve()), "this": here}
    runs: dict[str, list[dict[str, dict[str, float | list[float]]]]] = {k: [] for k in trees}
    command = [sys.executable, __file__, "--json", "--repeat", str(args.repeat),
               "--models", *args.models]
    for _ in range(args.rounds):
        for label, tree in trees.items():
            env = {**os.environ, "PYTHONPATH": tree}
            done = subprocess.run(command, env=env, capture_output=True, text=True,
                                  check=True)
            runs[label].append(json.loads(done.stdout.strip().splitlines()[-1]))
    print("| model | measure | baseline (ms) | this (ms) | this / baseline |")
    print("|---|---|---|---|---|")
    for name in args.models:
        for key, what in (("single_ms", "per iteration, one case"),
                          ("batch_ms", "per case-iteration, batch of 8"),
                          ("setup_ms", "operators' build (assembly included)"),
                          ("rebuild_ms", "a moved hole's operators (others reused)")):
            if key not in runs["this"][0][name] or key not in runs["baseline"][0][name]:
                continue
            old = statistics.median(float(r[name][key]) for r in runs["baseline"])  # type: ignore[arg-type]
            new = statistics.median(float(r[name][key]) for r in runs["this"])  # type: ignore[arg-type]
            print(f"| {name} | {what} | {old:.3f} | {new:.3f} | {new / old:.2f} |")
        a, b = runs["baseline"][0][name], runs["this"][0][name]
        same_its = a["iterations"] == b["iterations"]
        worst = max(abs(x - y) / max(abs(x), 1e-300)
                    for x, y in zip(a["R_stop"], b["R_stop"], strict=True))  # type: ignore[arg-type]
        print(f"\n{name}: iterations {b['iterations']} "
              f"({'the same' if same_its else 'DIFFER from ' + str(a['iterations'])}), "
              f"R_stop relative difference {worst:.1e}")


if __name__ == "__main__":
    main()
