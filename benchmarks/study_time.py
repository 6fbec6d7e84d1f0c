"""The B1 13 × 13 multiresolution study's wall time alone (``run_study``, no cold cases,
no store), twice per process after a warm-up, optionally side by side with another source
tree: whether a change made the study itself faster or slower, apart from the cold side
of a gain. ``--model b3``: B3's 5 × 5 hole positions instead (rc = 3, the default frictions);
``--model b3-lines``: B3's 5 positions xc = 23 … 27 × μ1 (13) × μ2 (``--count``, 4 by
default), rc = 3 — batches that meet every position again at each line.

    python benchmarks/study_time.py
    python benchmarks/study_time.py --baseline /tmp/old/src --rounds 3
    python benchmarks/study_time.py --model b3 --baseline /tmp/old/src --rounds 3
    python benchmarks/study_time.py --model b3-lines --baseline /tmp/old/src --rounds 3

With ``--baseline``, fresh processes alternately with ``PYTHONPATH`` set to that tree and
to this one, ``--rounds`` times; prints each process's two times (and their set-up).
"""

from __future__ import annotations

import argparse
import json
import time

from side_by_side import add_arguments, alternate


def measure(count: int, name: str = "b1") -> list[tuple[float, float]]:
    import numpy as np

    import multilatin as ml
    from multilatin.study.plan import clear_operator_cache

    model = ml.load_model(name.split("-")[0])
    if name == "b3-lines":
        grid = ml.Grid.parse(["xc=23:27:5", "mu1=0:0.6:13", f"mu2=0:0.6:{count}", "rc=3"])
        warm_up = ml.Grid.parse(["xc=23:24:2", "mu1=0.3", "rc=3"])
    elif name == "b3":
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
        result = ml.run_study(model, grid, progress=False)
        times.append((time.perf_counter() - t0, sum(r["setup_s"] for r in result.records)))
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--count", type=int, default=None,
                        help="B1: frictions per axis (13); b3-lines: μ2 values (4)")
    parser.add_argument("--model", choices=("b1", "b3", "b3-lines"), default="b1")
    add_arguments(parser)
    parser.add_argument("--json", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.count is None:
        args.count = 4 if args.model == "b3-lines" else 13
    if args.json or not args.baseline:
        times = measure(args.count, args.model)
        print(json.dumps(times) if args.json else _shown(times))
        return
    arguments = ["--json", "--count", str(args.count), "--model", args.model]
    for label, line in alternate(__file__, arguments, args.baseline, args.rounds):
        print(f"{label}: {_shown(json.loads(line))}", flush=True)


def _shown(times: list[tuple[float, float]]) -> str:
    """Each study's wall time, and in brackets its cases' set-up (assembly, operators,
    starts: Σ ``setup_s``)."""
    return " / ".join(f"{wall:.2f} s (set-up {setup:.2f} s)" for wall, setup in times)


if __name__ == "__main__":
    main()
