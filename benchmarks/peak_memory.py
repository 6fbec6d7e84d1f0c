"""Peak memory of one process after a B3 study of 5 × 5 hole positions × three μ1 (75
cases, multiresolution, ``run_study``'s defaults), optionally side by side with another
source tree.

    python benchmarks/peak_memory.py
    python benchmarks/peak_memory.py --baseline /tmp/old/src
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path


def measure() -> int:
    """Peak resident memory (MiB) after the study (Linux: ``ru_maxrss`` in KiB)."""
    import resource

    import numpy as np

    import multilatin as ml

    grid = ml.Grid({"xc": [float(v) for v in np.linspace(23.0, 27.0, 5)],
                    "yc": [float(v) for v in np.linspace(73.0, 77.0, 5)],
                    "mu1": [0.0, 0.3, 0.6]})
    ml.run_study(ml.load_model("b3"), grid, progress=False)
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // 1024


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--baseline", help="another source tree (its src/), side by side")
    parser.add_argument("--one", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.one or not args.baseline:
        print(f"{measure()} MiB")
        return
    here = str(Path(__file__).resolve().parents[1] / "src")
    for label, tree in (("baseline", str(Path(args.baseline).resolve())), ("this", here)):
        done = subprocess.run([sys.executable, __file__, "--one"], capture_output=True,
                              text=True, check=True, env={**os.environ, "PYTHONPATH": tree})
        print(f"{label}: {done.stdout.strip().splitlines()[-1]}")


if __name__ == "__main__":
    main()
