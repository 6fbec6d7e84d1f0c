"""Stops held tangentially at their node (session 43, ``held_nodes.held_stops``): LATIN at
several κ against the monolithic reference on the two test models that have them.

    python benchmarks/held_stops.py [--kappas 0.5 2]

``tests/data/block_sheared_on_a_flat.toml``: a block pressed on a frictional flat, its left
face moved back and forth by a prescribed displacement (the flat's corner node is held by
it); ``tests/data/block_in_a_rigid_corner.toml``: a block on a frictional flat against a
frictional back stop (the corner node is on both). Per model and κ: iterations to η <
1e-10, the first QoI at the first two steps, and the largest difference of every QoI at
every step from the reference's, relative to the QoI's largest magnitude. Run with
``PYTHONPATH`` set to another commit's ``src`` to see that commit's answers.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOptions

DATA = Path(__file__).resolve().parent.parent / "tests" / "data"
MODELS = ["block_sheared_on_a_flat", "block_in_a_rigid_corner"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kappas", nargs="+", type=float, default=[0.5, 2.0])
    args = parser.parse_args()
    print("| model | solver | iterations | first QoI, steps 1 and 2 | largest difference from "
          "the reference |")
    print("|---|---|---|---|---|")
    for name in MODELS:
        model = ml.Model(ml.ModelSpec.from_toml(DATA / f"{name}.toml"))
        reference = model.reference()
        first = next(iter(reference.qoi))
        rows = [("reference", reference)]
        for kappa in args.kappas:
            rows.append((f"LATIN κ = {kappa:g}", model.solve(
                options=LatinOptions(kappa=kappa, tol=1e-10, max_iter=5000), check=False)))
        for label, result in rows:
            difference = max(float(np.max(np.abs(np.asarray(result.qoi[q])
                                                 - np.asarray(reference.qoi[q])))
                                   / np.abs(reference.qoi[q]).max()) for q in reference.qoi)
            values = np.asarray(result.qoi[first])
            print(f"| {name} | {label} | {result.iterations} | {first} = {values[0]:.3f} / "
                  f"{values[1]:.3f} | {difference:.1e} |")


if __name__ == "__main__":
    main()
