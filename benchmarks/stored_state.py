"""What a multiresolution chain's state costs to keep, per batch: the state a torch
wavefront retains (two batches' worth of converged B3 cases, ``run_batch``) written whole
to the study's store and pickled for Dask's client, against the bounded state the store
keeps since session 39 (``ChainState.stored``: the 64 most recent cases).

    python benchmarks/stored_state.py [--cases 400 3250]

B3's interface fields (15 steps × 955 points × 2, Ŵ and F̂: 0.46 MB a case), random
values; one write and one pickle per row, into a temporary folder. 3 250 cases are what a
1 625-case wavefront batch of the 21 125-case study retains (125 geometries × a line of 13).
"""

from __future__ import annotations

import argparse
import pickle
import tempfile
import time
from collections import OrderedDict
from pathlib import Path

import numpy as np

from multilatin.study.chain_state import ChainState
from multilatin.study.store import StudyStore

SHAPE = (15, 955, 2)  # B3: load steps × interface points × components


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", type=int, nargs="+", default=[400, 3250])
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    fields = (rng.standard_normal(SHAPE), rng.standard_normal(SHAPE))
    print("| retained cases | kept | written (MB) | write (s) | pickled for the client (MB) "
          "| pickle (s) |")
    print("|---|---|---|---|---|---|")
    for n in args.cases:
        retained = OrderedDict(((i, 0, 0, 0, 0), (fields[0] + i, fields[1] - i))
                               for i in range(n))
        state = ChainState(2 * n).keeping(retained)
        for label, kept in (("whole", state), ("stored", state.stored())):
            with tempfile.TemporaryDirectory() as folder:
                store = StudyStore(folder, {"model": "benchmark"})
                record = {"mode": "multiresolution", "number": 0, "chain": 0}
                t0 = time.perf_counter()
                if label == "whole":  # what add_batch wrote before: the state as it is
                    store.add_batch([record], None)
                    np.savez(f"{folder}/whole.npz", **kept.to_arrays())
                else:
                    store.add_batch([record], kept)
                write = time.perf_counter() - t0
                size = sum(p.stat().st_size for p in Path(folder).rglob("*.npz")) / 1e6
                store.close()
            t0 = time.perf_counter()
            blob = pickle.dumps(kept, protocol=5)
            pickled = time.perf_counter() - t0
            print(f"| {n} | {label} ({len(kept.retained)}) | {size:.0f} | {write:.2f} | "
                  f"{len(blob) / 1e6:.0f} | {pickled:.2f} |", flush=True)


if __name__ == "__main__":
    main()
