"""Does a study slow down when other cores are busy? The same serial study run alone, then
as N copies at once in N processes (no Dask): where the copies take longer than the one
alone, the machine's shared caches, memory bandwidth or clock (not Dask) cap what N workers
can give (issue 16; docs/performance.md, "Measured on 16 cores").

    python benchmarks/core_contention.py --copies 1 4 8 16     # on a machine with 16 cores

Each copy: the b3 study xc = 23 … 27 × μ1 (13 values) × μ2 (4 values), rc = 3 (260 cases,
default study options), after a warm-up that loads the compiled kernels. Prints per N the
copies' mean and slowest study time against the one alone.
"""

from __future__ import annotations

import argparse
import multiprocessing
import tempfile
import time
from typing import Any

GRID = ["xc=23:27:5", "mu1=0:0.6:13", "mu2=0:0.6:4", "rc=3"]


def one_study(barrier: Any, times: Any) -> None:
    """A warm-up, then (when every copy has warmed up) the study; its wall time to ``times``."""
    import multilatin as ml
    from multilatin.latin import LatinOptions
    from multilatin.latin.options import STUDY_QOI_RTOL

    model, options = ml.load_model("b3"), LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    with tempfile.TemporaryDirectory() as folder:
        ml.run_study(model, ml.Grid.parse(["xc=23:24:2", "mu1=0.3", "rc=3"]), options=options,
                     out=f"{folder}/warm-up", progress=False)
        barrier.wait()
        t0 = time.perf_counter()
        ml.run_study(model, ml.Grid.parse(GRID), options=options, out=f"{folder}/study",
                     progress=False)
        times.put(time.perf_counter() - t0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--copies", type=int, nargs="+", default=[1, 2])
    args = parser.parse_args()
    context = multiprocessing.get_context("spawn")
    alone = None
    print("| copies at once | mean study time (s) | slowest (s) | mean / alone |")
    print("|---|---|---|---|")
    for copies in args.copies:
        barrier, queue = context.Barrier(copies), context.Queue()
        processes = [context.Process(target=one_study, args=(barrier, queue))
                     for _ in range(copies)]
        for process in processes:
            process.start()
        times = [queue.get() for _ in processes]
        for process in processes:
            process.join()
        mean = sum(times) / len(times)
        alone = alone if alone is not None else mean
        print(f"| {copies} | {mean:.1f} | {max(times):.1f} | {mean / alone:.2f} |", flush=True)


if __name__ == "__main__":
    main()
