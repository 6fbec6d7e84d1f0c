"""The B1 13 × 13 multiresolution study's wall time alone (``run_study``, no cold cases,
no store), twice per process after a warm-up, optionally side by side with another source
tree: whether a change made the study itself faster or slower, apart from the cold side
of a gain. ``--model b3``: B3's 5 × 5 hole positions instead (rc = 3, the default frictions).

    python benchmarks/study_time.py
    python benchmarks/study_time.py --baseline /tmp/old/src --rounds 3
    python benchmarks/study_time.py --model b3 --baseline /tmp/old/src --rounds 3

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


def measure(count: int, name: str = "b1") -> list[float]:
    import numpy as np

    import multilatin as ml
    from multilatin.study.plan import clear_operator_cache

    model = ml.load_model(name)
    if name == "b3":
        grid = ml.Grid.parse(["xc=23:27:5", "yc=73:77:5"])
        warm_up = ml.Grid.parse(["xc=25", "yc=75"])
    else:
        values = [float(v) for v in np.linspace(0.0, 0.6, count)]
        grid = ml.Grid({"mu1": values, "mu2": values})
        warm_up = ml.Grid({"mu1": [0.1], "mu2": [0.1]})
    ml.run_study(model, warm_up, progress=False)  # kernels
    times = []
    for _ in range(2):
        clear_operator_cache()
        t0 = time.perf_counter()
        ml.run_study(model, grid, progress=False)
        times.append(time.perf_counter() - t0)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--count", type=int, default=13)
    parser.add_argument("--model", choices=("b1", "b3"), default="b1")
    parser.add_argument("--baseline", help="another source tree (its src/), side by side")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--json", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.json or not args.baseline:
        times = measure(args.count, args.model)
        print(json.dumps(times) if args.json else " / ".join(f"{t:.2f} s" for t in times))
        return
    here = str(Path(__file__).resolve().parents[1] / "src")
    command = [sys.executable, __file__, "--json", "--count", str(args.count),
               "--model", args.model]
    for _ in range(args.rounds):
        for label, tree in (("baseline", str(Path(args.baseline).resolve())), ("this", here)):
            done = subprocess.run(command, env={**os.environ, "PYTHONPATH": tree},
                                  capture_output=True, text=True, check=True)
            times = json.loads(done.stdout.strip().splitlines()[-1])
            print(f"{label}: " + " / ".join(f"{t:.2f} s" for t in times), flush=True)


if __name__ == "__main__":
    main()
