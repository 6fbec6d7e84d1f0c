"""The 845-case B3 study (hole positions xc = 23 … 27 × μ1 (13) × μ2 (13), rc = 3), serial,
with the nearest neighbour's starts (``start="nearest"``) and with the default extrapolated
ones (``study.predictors``: here the parallelogram across geometries): iterations, the
study's wall time, and R_stop's worst error against η < 1e-9 solves of every case whose
answer is unique (about 15 min on 2 cores: the tight solves).

    python benchmarks/mixed_study_accuracy.py
    python benchmarks/mixed_study_accuracy.py --count 5     # 5 × 5 frictions, quicker
    python benchmarks/mixed_study_accuracy.py --workers 2 --frictions-first \
        --tight tight.json          # Dask's line tasks; the tight values kept for a rerun

``--frictions-first`` lists the grid as the 21 125-case study does (μ1, μ2, xc): the
traversal is the same, but Dask's line tasks start a line from the neighbouring hole
position's rather than the neighbouring μ1's (``waves.line_graph``).
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

import multilatin as ml
from multilatin.latin import LatinOptions
from multilatin.study.plan import clear_operator_cache


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--count", type=int, default=13, help="frictions per axis (13)")
    parser.add_argument("--workers", type=int, default=0,
                        help="Dask workers (0: serial, the rolling batch)")
    parser.add_argument("--frictions-first", action="store_true",
                        help="grid listed μ1, μ2, xc (the 21 125-case study's order)")
    parser.add_argument("--tight", type=Path,
                        help="JSON file of the tight R_stop values: read where present, "
                             "written after")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    model = ml.load_model("b3")
    frictions = [f"mu1=0:0.6:{args.count}", f"mu2=0:0.6:{args.count}"]
    grid = ml.Grid.parse(frictions + ["xc=23:27:5", "rc=3"] if args.frictions_first
                         else ["xc=23:27:5", *frictions, "rc=3"])
    ml.run_study(model, ml.Grid.parse(["xc=25", "rc=3"]), progress=False)  # kernels
    runs = {}
    for start in ("nearest", "neighbour"):
        clear_operator_cache()
        t0 = time.perf_counter()
        study = ml.run_study(model, grid, start=start, progress=False,
                             workers=args.workers)
        runs[start] = (time.perf_counter() - t0, {r["number"]: r for r in study.records})
    tight = {}
    options = LatinOptions(tol=1e-9, max_iter=4000)
    known = json.loads(args.tight.read_text()) if args.tight and args.tight.exists() else {}
    for number, record in runs["nearest"][1].items():
        if record["unique"]:
            key = ",".join(f"{k}={v:g}" for k, v in sorted(record["params"].items()))
            if key not in known:
                known[key] = model.solve(record["params"], options=options).qoi["R_stop"]
            tight[number] = known[key]
    if args.tight:
        args.tight.write_text(json.dumps(known, indent=0))
    print("| start | iterations | study (s) | extrapolated starts | unique cases | R_stop "
          "worst error vs tight | cases over 0.1 % |")
    print("|---|---|---|---|---|---|---|")
    for start, (wall, records) in runs.items():
        errors = [abs(records[n]["qoi"]["R_stop"] - t) / max(abs(t), 1.0)
                  for n, t in tight.items()]
        extrapolated = sum(("secant" in r["start"]) or ("parallelogram" in r["start"])
                           for r in records.values())
        print(f"| {start} | {sum(r['iterations'] for r in records.values())} | {wall:.1f} | "
              f"{extrapolated} | {len(tight)} | {100 * max(errors):.3f} % | "
              f"{sum(e > 1e-3 for e in errors)} |", flush=True)


if __name__ == "__main__":
    main()
