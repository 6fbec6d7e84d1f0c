"""A GPU run's first check (issue 19): the torch backend on ``--device`` against the NumPy
path on batches whose cases leave at different iterations (padding, compaction, the local
stage's and the whole iteration's graphs re-captured), b1 and b3; then which of the
device's fast paths ran (the CUDA contact kernels, the graphs) — a warning in the log
says where one fell back to the operations.

    python benchmarks/gpu_check.py --device cuda

Exits non-zero where an answer differs (iterations by more than 2, R_stop by more than
1e-9 relative).
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from dataclasses import replace
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOptions, solve_latin_batch, torch_engine


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--device", default="cuda")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    captures: list[tuple[str, int]] = []
    original = torch_engine.DeviceGraph._capture

    def counted(graph: Any, inputs: Any) -> bool:
        done = original(graph, inputs)
        captures.append((getattr(graph.compute, "__name__", "?"), int(inputs[0].shape[0])))
        return bool(done)

    torch_engine.DeviceGraph._capture = counted  # type: ignore[method-assign]
    failed = False
    for name, extra in (("b1", {}), ("b3", {"rc": 3.0})):
        model = ml.load_model(name)
        batch = [model.assemble({**extra, "mu1": a, "mu2": b})
                 for a in (0.0, 0.15, 0.3, 0.45, 0.6) for b in (0.0, 0.3, 0.6)]
        options = LatinOptions(qoi_rtol=1e-3)
        reference = solve_latin_batch(batch, options)
        t0 = time.perf_counter()
        got = solve_latin_batch(batch, replace(options, backend="torch", device=args.device))
        wall = time.perf_counter() - t0
        worst = max(float(np.max(np.abs(np.asarray(x.qoi["R_stop"]) - y.qoi["R_stop"])
                              / np.maximum(np.abs(x.qoi["R_stop"]), 1e-9)))
                    for x, y in zip(reference, got, strict=True))
        steps = [(x.iterations, y.iterations) for x, y in zip(reference, got, strict=True)]
        ok = all(abs(a - b) <= 2 for a, b in steps) and worst < 1e-9
        failed |= not ok
        print(f"{name}: {'same answers' if ok else 'ANSWERS DIFFER'}; iterations (NumPy, "
              f"torch) {steps}; R_stop worst relative difference {worst:.1e}; torch "
              f"{wall:.2f} s; graphs captured (function, width): {captures}", flush=True)
        captures.clear()
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
