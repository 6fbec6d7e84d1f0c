"""The B1 13 × 13 multiresolution study's wall time alone (``run_study``, no cold cases,
no store), twice per process after a warm-up, optionally side by side with another source
tree: whether a change made the study itself faster or slower, apart from the cold side
of a gain.

    python benchmarks/study_time.py
    python benchmarks/study_time.py --baseline /tmp/old/src --rounds 3

With ``--baseline``, fresh processes alternately with ``PYTHONPATH`` set to that tree and
to this one, ``--rounds`` times; prints each process's two times.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path


def measure(count: int) -> list[float]:
    import numpy as np

    import multilatin as ml
    from multilatin.study.plan import clear_operator_cache

    model = ml.load_model("b1")
    values = [float(v) for v in np.linspace(0.0, 0.6, count)]
    ml.run_study(model, ml.Grid({"mu1": [0.1], "mu2": [0.1]}), progress=False)  # kernels
    times = []
    for _ in range(2):
        clear_operator_cache()
        t0 = time.perf_counter()
        ml.run_study(model, ml.Grid({"mu1": values, "mu2": values}), progress=False)
        times.append(time.perf_counter() - t0)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--count", type=int, default=13)
    parser.add_argument("--baseline", help="another source tree (its src/), side by side")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--json", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.json or not args.baseline:
        times = measure(args.count)
        print(json.dumps(times) if args.json else " / ".join(f"{t:.2f} s" for t in times))
        return
    here = str(Path(__file__).resolve().parents[1] / "src")
    command = [sys.executable, __file__, "--json", "--count", str(args.count)]
    for _ in range(args.rounds):
        for label, tree in (("baseline", str(Path(args.baseline).resolve())), ("this", here)):
            done = subprocess.run(command, env={**os.environ, "PYTHONPATH": tree},
                                  capture_output=True, text=True, check=True)
            times = json.loads(done.stdout.strip().splitlines()[-1])
            print(f"{label}: " + " / ".join(f"{t:.2f} s" for t in times), flush=True)


if __name__ == "__main__":
    main()
