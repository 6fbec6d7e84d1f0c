"""What a case costs besides its iterations (issue 19: the host's share of a GPU study;
issue 16: a CPU study's), optionally side by side with another source tree.

    python benchmarks/case_overheads.py
    python benchmarks/case_overheads.py --baseline /tmp/old/src --rounds 2

Per case, CPU time (best of 3 loops): the assembly of a case whose geometry the model
already holds (a study over frictions: b1 and b3), and the operators' signature. Then the
post-processing of a batch (``solve_latin_batch``'s ``timings["postprocess"]``: recovery,
QoIs, free motions, results; the better of 2 solves) for B1's 13 × 13 frictions (169
cases) and a 5 × 5 B3 grid (25 cases), both at ``qoi_rtol = 1e-3``: with the interior
displacements recovered (what ``solve`` does) and without (what a study does,
``LatinOptions.recover_displacements``; a tree without that option recovers them). Then a
b3 geometry's 169 frictions as one batch, as a GPU study runs them: its macro force data
and its free motions. With
``--baseline``: fresh processes alternately with ``PYTHONPATH`` set to that tree and to
this one, ``--rounds`` times.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
import warnings
from dataclasses import fields
from pathlib import Path


def measure() -> dict[str, float]:
    import numpy as np

    import multilatin as ml
    from multilatin.latin import LatinOptions, operator_signature, solve_latin_batch

    warnings.simplefilter("ignore")
    out: dict[str, float] = {}
    for name in ("b1", "b3"):
        model = ml.load_model(name)
        model.assemble({})
        assemblies = [model.assemble({"mu1": 0.01 * k, "mu2": 0.3}) for k in range(50)]
        best = best_signature = float("inf")
        for _ in range(3):
            t0 = time.process_time()
            for k in range(50):
                model.assemble({"mu1": 0.01 * k, "mu2": 0.2})
            best = min(best, (time.process_time() - t0) / 50)
            fresh = [model.assemble({"mu1": 0.01 * k, "mu2": 0.25}) for k in range(50)]
            t0 = time.process_time()
            for assembly in fresh:
                operator_signature(assembly, LatinOptions())
            best_signature = min(best_signature, (time.process_time() - t0) / 50)
        out[f"{name} assembly"] = 1e3 * best
        out[f"{name} signature"] = 1e3 * best_signature
        del assemblies
    has_option = any(f.name == "recover_displacements" for f in fields(LatinOptions))
    for name, count in (("b1", 13), ("b3", 5)):
        model = ml.load_model(name)
        values = np.linspace(0.0, 0.6, count)
        batch = [model.assemble({"mu1": a, "mu2": b}) for a in values for b in values]
        for recover in (True, False):
            extra = {"recover_displacements": recover} if has_option else {}
            options = LatinOptions(qoi_rtol=1e-3, **extra)
            solve_latin_batch(batch[:2], options, check=False)
            post = min(solve_latin_batch(batch, options, check=False)[0].timings["postprocess"]
                       for _ in range(2))
            label = "recovered" if recover else "study (no recovery)"
            out[f"{name} post-processing, {label}"] = 1e3 * post / len(batch)
    out.update(geometry_batch())
    return out


def geometry_batch() -> dict[str, float]:
    """A b3 geometry's 169 frictions as one batch (how a GPU study runs them): the batch's
    macro force data F_dᴹ (``BatchIterations._macro_data``) and the free motions of its 169
    states (``free_motions_batch``, on the states after 40 iterations), best of 3."""
    import numpy as np

    import multilatin as ml
    from multilatin.decomposition.interfaces import with_contact_data
    from multilatin.decomposition.uniqueness import free_motions_batch
    from multilatin.latin import LatinOperators, LatinOptions, solve_latin_batch
    from multilatin.latin.iteration import BatchIterations
    from multilatin.latin.local_stage import LocalStage

    model, values = ml.load_model("b3"), np.linspace(0.0, 0.6, 13)
    batch = [model.assemble({"mu1": a, "mu2": b}) for a in values for b in values]
    ops = LatinOperators(batch[0], LatinOptions())
    local = LocalStage(batch, [ops.points] * len(batch), ops.search_direction,
                       macro_only=ops.macro_only)
    iterations = BatchIterations.__new__(BatchIterations)
    iterations.ops = ops
    states = [r.interface for r in solve_latin_batch(batch, LatinOptions(max_iter=40),
                                                     check=False)]
    points = [with_contact_data(ops.points, assembly) for assembly in batch]
    best = {"b3 169-case batch: macro force data": float("inf"),
            "b3 169-case batch: free motions": float("inf")}
    for _ in range(3):
        t0 = time.process_time()
        iterations._macro_data(local, len(batch))
        t1 = time.process_time()
        free_motions_batch(batch, points, [s.displacement_hat for s in states],
                           [s.force_hat for s in states])
        t2 = time.process_time()
        for key, value in zip(best, (t1 - t0, t2 - t1), strict=True):
            best[key] = min(best[key], 1e3 * value / len(batch))
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--baseline", help="another source tree (its src/), side by side")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--json", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.json or not args.baseline:
        found = measure()
        if args.json:
            print(json.dumps(found))
        else:
            for key, value in found.items():
                print(f"{key}: {value:.2f} ms per case")
        return
    here = str(Path(__file__).resolve().parents[1] / "src")
    runs: dict[str, list[dict[str, float]]] = {"baseline": [], "this": []}
    for _ in range(args.rounds):
        for label, tree in (("baseline", str(Path(args.baseline).resolve())), ("this", here)):
            done = subprocess.run([sys.executable, __file__, "--json"],
                                  env={**os.environ, "PYTHONPATH": tree},
                                  capture_output=True, text=True, check=True)
            runs[label].append(json.loads(done.stdout.strip().splitlines()[-1]))
    print("| ms per case | baseline | this |\n|---|---|---|")
    for key in runs["this"][0]:
        cells = [" / ".join(f"{run[key]:.2f}" for run in runs[label]) for label in runs]
        print(f"| {key} | {cells[0]} | {cells[1]} |")


if __name__ == "__main__":
    main()
