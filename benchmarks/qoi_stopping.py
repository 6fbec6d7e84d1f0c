"""Stopping on the QoIs' estimated errors (``LatinOptions.qoi_rtol``) against stopping on
η alone, on a study grid: iterations, study time, and R_stop's error against tight solves
(η < 1e-10), for multiresolution and cold; prints a markdown table.

    python benchmarks/qoi_stopping.py --model b1 --rtols 3e-3 1e-3
    python benchmarks/qoi_stopping.py --model b1 --kappa 1 --tol 1e-5
    python benchmarks/qoi_stopping.py --corner-stiffening 1     # k alike (before session 14)
    python benchmarks/qoi_stopping.py --micro-stiffening 1      # diagonal k (before session 15)
    python benchmarks/qoi_stopping.py --model b3 --grid xc=23:27:5 yc=73:77:5 rc=3 --rtols 1e-3
    python benchmarks/qoi_stopping.py --growing both   # the estimate's growth check off, on
"""

from __future__ import annotations

import argparse
import tempfile

import numpy as np

import multilatin as ml
from multilatin.latin import tracking


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="b1")
    parser.add_argument("--grid", nargs="*", default=["mu1=0:0.6:13", "mu2=0:0.6:13"],
                        help="grid items as on the command line (default: B1's 13 x 13)")
    parser.add_argument("--rtols", nargs="*", type=float, default=[1e-3])
    parser.add_argument("--kappa", type=float, default=ml.LatinOptions().kappa,
                        help="search direction of the studies (the tight solves keep the "
                             "default)")
    parser.add_argument("--tol", type=float, default=ml.LatinOptions().tol,
                        help="η tolerance of the studies")
    parser.add_argument("--acceleration", default=ml.LatinOptions().acceleration,
                        help="LatinOptions.acceleration of the studies")
    parser.add_argument("--corner-stiffening", type=float,
                        default=ml.LatinOptions().corner_stiffening,
                        help="LatinOptions.corner_stiffening of the studies")
    parser.add_argument("--micro-stiffening", type=float,
                        default=ml.LatinOptions().micro_stiffening,
                        help="LatinOptions.micro_stiffening of the studies")
    parser.add_argument("--growing", choices=["on", "off", "both"], default="on",
                        help="tracking.GROWING_CHECK of the QoI rule's studies (session 61)")
    args = parser.parse_args()
    model = ml.load_model(args.model)
    grid = ml.Grid.parse(args.grid)
    names = list(grid)
    tight_options = ml.LatinOptions(tol=1e-10, max_iter=10000)
    tight = np.empty(grid.shape)
    for index in np.ndindex(*grid.shape):
        mu = {n: grid[n][i] for n, i in zip(names, index, strict=True)}
        tight[index] = float(model.solve(mu, options=tight_options).qoi["R_stop"])  # type: ignore[arg-type]
    print(f"{args.model}, grid {' '.join(args.grid)}, κ = {args.kappa:g}, "
          f"{args.acceleration}, corners × {args.corner_stiffening:g}, micro × "
          f"{args.micro_stiffening:g}, R_stop against "
          "η < 1e-10")
    print("| stopping | growth check | mode | iterations | mean per case | study (s) | "
          "R_stop within 0.1 % | worst R_stop error | stopped on QoIs |")
    print("|---|---|---|---|---|---|---|---|---|")
    # RRE gives no QoI error estimates (LatinOptions.acceleration): η alone
    rtols = [] if args.acceleration == "rre" else args.rtols
    checks = {"on": [True], "off": [False], "both": [False, True]}[args.growing]
    for rtol, growing in [(None, True), *((r, g) for r in rtols for g in checks)]:
        tracking.GROWING_CHECK = growing
        options = ml.LatinOptions(qoi_rtol=rtol, kappa=args.kappa, tol=args.tol,
                                  acceleration=args.acceleration,
                                  corner_stiffening=args.corner_stiffening,
                                  micro_stiffening=args.micro_stiffening)
        with tempfile.TemporaryDirectory() as folder:
            study = ml.run_study(model, grid, options=options, modes=("multiresolution", "cold"),
                                 out=folder, progress=False)
        for mode in ("multiresolution", "cold"):
            records = study.mode_records(mode)
            found = study.dataset["R_stop"].sel(mode=mode).transpose(*names).values
            error = np.abs(found - tight) / np.maximum(np.abs(tight), 1.0)
            iterations = sum(r["iterations"] for r in records)
            on_qoi = sum(bool(r.get("stopped_on_qoi")) for r in records)
            label = (f"η < {args.tol:g}" if rtol is None
                     else f"qoi_rtol {rtol:g} (or η < {args.tol:g})")
            check = "" if rtol is None else "on" if growing else "off"
            print(f"| {label} | {check} | {mode} | {iterations} | {iterations / len(records):.0f} | "
                  f"{study.elapsed_s[mode]:.2f} | {int(np.sum(error <= 1e-3))}/{error.size} | "
                  f"{100 * float(np.nanmax(error)):.3f} % | {on_qoi} |")


if __name__ == "__main__":
    main()
