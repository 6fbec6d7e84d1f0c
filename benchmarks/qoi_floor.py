"""The QoI rule where a start's transient is far larger than the answer, and its failure
verdicts (session 42, docs/correctness.md "A start's transient under the QoI rule").

    python benchmarks/qoi_floor.py
    PYTHONPATH=/tmp/old/src python benchmarks/qoi_floor.py      # another commit's
    python benchmarks/qoi_floor.py --bundled     # and the bundled models' iterations
    python benchmarks/qoi_floor.py --kappas      # and B1's, B3's cold studies at κ 0.5, 2, 10

1. The moved block of ``tests/data/block_on_moved_foundation.toml`` as a study (the
   studies' defaults: multiresolution, ``qoi_rtol`` = 1e-3) over q = 0.5 … 2.95 (8) ×
   shift = 0, 1, 100 mm: per case its start, iterations and R_base's relative difference
   from the monolithic reference at the last step; the worst, and the iterations in all.
   A case's first reactions to a base moved by 1 mm are ~2e6 N (through k × 10, the
   prescribed displacements' search direction) against an answer of 10–59 N.
2. Drift under both rules: the block held by friction on a flat
   (``tests/data/block_on_flat.toml``) pushed beyond what friction holds (65 N against
   60 N): the iteration where the drift check reports "no equilibrium".
   And a study of ``tests/data/holed_block_on_foundation.toml`` over xc = 6 … 14 (5) × rc
   = 0, 2, 3, 4 × μ = 0.2, 0.4, 0.6 (the studies' defaults): 40 of its 60 cases have no
   equilibrium (the push passes μ × 200 N); its wall time, the iterations in all, those of
   the failed cases, and the converged cases' worst QoI difference from the monolithic
   reference on the same meshes (X-FEM too), per step relative to max(|q|, 1 % of its
   largest).
3. A force mode η does not see: the moved block (q = 2.9) at shift = 0, 1, 10, 100 mm,
   solved to η < 1e-6 and 1e-10: iterations, η, and R_base at step 1 (zero: no push yet).
4. ``--bundled``: every bundled model's iterations and first QoI (at the last step) under
   η < tol and the QoI rule; b1, b1-4, b1-9 and b3 at ``convergence.py``'s four pairs.
5. ``--kappas``: B1's 13 × 13 and B3's 5 × 5 hole positions, every case cold, at κ = 0.5, 2
   and 10 under both rules: the iterations in all and the cases reported as failed, by the
   drift check ("no equilibrium", and after how many iterations) or at the cap (a drift
   check that looks more often must find no slide where there is none; ~20 min).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOptions

DATA = Path(__file__).parents[1] / "tests" / "data"


def moved_study() -> None:
    model = ml.Model(ml.ModelSpec.from_toml(DATA / "block_on_moved_foundation.toml"))
    grid = ml.Grid({"q": [float(q) for q in np.linspace(0.5, 2.95, 8)],
                    "shift": [0.0, 1.0, 100.0]})
    with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        study = ml.run_study(model, grid, out=folder, progress=False)
    print("| case | start | iterations | stopped on QoIs | R_base | reference | difference |")
    print("|---|---|---|---|---|---|---|")
    worst = 0.0
    for record in study.mode_records("multiresolution"):
        params = record["params"]
        reference = model.reference(params).qoi["R_base"][-1]  # type: ignore[index]
        found = record["qoi"]["R_base"][-1]
        difference = abs(found - reference) / abs(reference)
        worst = max(worst, difference)
        print(f"| q = {params['q']:.3g}, shift = {params['shift']:g} | {record['start']} | "
              f"{record['iterations']} | {record['stopped_on_qoi']} | {found:.5f} | "
              f"{reference:.5f} | {difference:.1e} |")
    iterations = sum(r["iterations"] for r in study.mode_records("multiresolution"))
    print(f"\nworst R_base difference over {grid.size} cases: {worst:.2e} "
          f"({'within' if worst <= 1e-3 else 'OUTSIDE'} the rule's 0.1 %); {iterations} "
          "iterations in all\n")


def drift() -> None:
    model = ml.Model(ml.ModelSpec.from_toml(DATA / "block_on_flat.toml"))
    print("| rule | converged | iterations | failure |")
    print("|---|---|---|---|")
    for rtol in (None, 1e-3):
        result = model.solve({"q": 6.5}, options=LatinOptions(qoi_rtol=rtol), check=False)
        print(f"| {'η < tol' if rtol is None else f'qoi_rtol {rtol:g}'} | {result.converged} | "
              f"{result.iterations} | {(result.failure or '')[:40]}… |")


def holed_study() -> None:
    model = ml.Model(ml.ModelSpec.from_toml(DATA / "holed_block_on_foundation.toml"))
    grid = ml.Grid({"xc": [6.0, 8.0, 10.0, 12.0, 14.0], "rc": [0.0, 2.0, 3.0, 4.0],
                    "mu": [0.2, 0.4, 0.6]})
    with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        study = ml.run_study(model, grid, out=folder, progress=False)
    records = study.mode_records("multiresolution")
    failed = [r for r in records if not r["converged"]]
    worst = 0.0
    for record in records:
        if not record["converged"]:
            continue
        reference = model.reference(record["params"], mesh="same")
        for name, values in reference.qoi.items():
            exact = np.atleast_1d(np.asarray(values, dtype=float))
            found = np.atleast_1d(np.asarray(record["qoi"][name], dtype=float))
            floor = 1e-2 * np.abs(exact).max()
            worst = max(worst, float(np.max(np.abs(found - exact)
                                            / np.maximum(np.abs(exact), floor))))
    print(f"holed block study: {study.elapsed_s['multiresolution']:.1f} s, "
          f"{sum(r['iterations'] for r in records)} iterations in all, "
          f"{len(failed)} cases with no equilibrium found after "
          f"{sorted({r['iterations'] for r in failed})} iterations, the converged cases' "
          f"worst QoI difference from the same-mesh reference {worst:.1e}")


def offset() -> None:
    model = ml.Model(ml.ModelSpec.from_toml(DATA / "block_on_moved_foundation.toml"))
    print("\n| shift (mm) | tol | iterations | η | R_base at step 1 (N) |")
    print("|---|---|---|---|---|")
    for shift in (0.0, 1.0, 10.0, 100.0):
        for tol in (1e-6, 1e-10):
            result = model.solve({"shift": shift}, options=LatinOptions(tol=tol))
            print(f"| {shift:g} | {tol:g} | {result.iterations} | {result.indicator:.1e} | "
                  f"{result.qoi['R_base'][0]:.2e} |")  # type: ignore[index]


def bundled() -> None:
    from force_guard import PAIRS  # convergence.py's four friction pairs

    print("\n| model | rule | iterations, first QoI |")
    print("|---|---|---|")
    for name in ["b0", "b2", "slide", "punch", "lug", "roller", "b1", "b1-4", "b1-9", "b3"]:
        model = ml.load_model(name)
        for rtol in (None, 1e-3):
            cells = []
            for mu in (PAIRS if name.startswith("b1") or name == "b3" else [{}]):
                result = model.solve(mu, options=LatinOptions(qoi_rtol=rtol), check=False)
                first = np.atleast_1d(next(iter(result.qoi.values())))[-1]
                cells.append(f"{result.iterations}, {first:.9g}")
            print(f"| {name} | {'η < tol' if rtol is None else f'qoi_rtol {rtol:g}'} | "
                  f"{' / '.join(cells)} |")


def kappas() -> None:
    print("\n| model | κ | rule | iterations | failed: no equilibrium (at iterations) | "
          "failed: not converged at the cap |")
    print("|---|---|---|---|---|---|")
    from study_anatomy import GRIDS  # B1's 13 × 13, B3's 5 × 5 hole positions

    for name in ("b1", "b3"):
        model, grid = ml.load_model(name), ml.Grid.parse(GRIDS[name])
        for kappa in (0.5, 2.0, 10.0):
            for rtol in (None, 1e-3):
                options = LatinOptions(kappa=kappa, qoi_rtol=rtol)
                with tempfile.TemporaryDirectory() as folder, warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    study = ml.run_study(model, grid, options=options, modes=("cold",),
                                         out=folder, progress=False)
                records = study.mode_records("cold")
                drifted = sorted({r["iterations"] for r in records
                                  if not r["converged"] and "no equilibrium" in r["log"]})
                count = sum(not r["converged"] and "no equilibrium" in r["log"]
                            for r in records)
                capped = sum(not r["converged"] and "no equilibrium" not in r["log"]
                             for r in records)
                print(f"| {name} | {kappa:g} | {'η < tol' if rtol is None else 'QoI rule'} | "
                      f"{sum(r['iterations'] for r in records)} | {count} {drifted or ''} | "
                      f"{capped} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--bundled", action="store_true",
                        help="also the bundled models' iterations and first QoI")
    parser.add_argument("--kappas", action="store_true",
                        help="also B1's and B3's cold studies at κ 0.5, 2, 10 (~20 min)")
    args = parser.parse_args()
    sys.path.insert(0, str(Path(__file__).parent))  # the other benchmarks' PAIRS, GRIDS
    moved_study()
    drift()
    holed_study()
    offset()
    if args.bundled:
        bundled()
    if args.kappas:
        kappas()


if __name__ == "__main__":
    main()
