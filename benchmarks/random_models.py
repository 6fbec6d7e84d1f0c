"""Random user models against the monolithic solution of the same discrete problem (session
60): what a new user's model does at the default settings, beyond the bundled ones.

    python benchmarks/random_models.py                   # seeds 0-39
    python benchmarks/random_models.py --seeds 40 --count 80
    python benchmarks/random_models.py --keep /tmp/models   # the model files too
    python benchmarks/random_models.py --family block       # a block pushed on a base
    python benchmarks/random_models.py --axisymmetric       # the same models about x = 0
    python benchmarks/random_models.py --family stack       # pushed back and forth

Each seed writes a model file: a strap (with a level-set hole or not) pressed on a clamped
base and pulled by a force or a prescribed displacement toward a rigid stop at its other
end, with random splits into substructures (the two bodies' meshes match or not: mortar
contact), materials, friction, gaps (an interference too), the stop's gap and friction, the
number of load steps, plane stress or strain; other families (``--family block``, ``stack``,
``meshed``) in ``random_families.py``. It is
solved by LATIN at the default settings (``Model.solve``), by LATIN to η < 1e-10, and by
the monolithic contact solver on the same assembly (``solve_monolithic``). Printed per
seed: how LATIN ended, its iterations, the tight solve's largest difference from the
monolithic answer and the default solve's error estimates against its true errors
(``compare``); then the counts. A model the tool refuses (a clear
error naming the field) is counted as refused; one the reference cannot solve is counted
apart. Found with it (docs/correctness.md, session 60): a stop at the end of a mortar
contact held a projected point as a node, and 29 of 96 models stalled at η ≈ 1e-5; and
the reference split contact pieces whose slaves lie on two bodies where LATIN joins them.
Session 62: the reference's Newton method cycled on 18 of the 41 stack models LATIN
solved (continuation within a step, then a smaller augmentation), and contact pieces that end
between the nodes of both meshes were refused (a point of the slave's own there).
"""

from __future__ import annotations

import argparse
import logging
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import random_families
from random_families import FAMILIES, axisymmetric

import multilatin as ml
from multilatin.errors import ModelError, NotConvergedError
from multilatin.latin import LatinOptions

#: the converged value each default solve is measured against
TIGHT = LatinOptions(tol=1e-10, max_iter=20000)
#: errors below this fraction of a QoI's largest magnitude are zero to the estimate's
#: accuracy (as in ``qoi_error.py``)
FLOOR = 1e-6


def compare(result: Any, tight: Any, reference: Any) -> tuple[float, int, int, float, str]:
    """The tight solve's largest difference from the monolithic answer (relative to each
    QoI's largest magnitude, at least 1e-6 of its kind's: the forces', the displacement
    field's), and the default solve's error estimates against its true
    errors (against the tight solve): entries above the floor, how many the estimate
    bounds, the smallest estimate / error, and the QoI of the largest difference."""
    worst, which, above, bound, smallest = 0.0, "", 0, 0, np.inf
    # a QoI that is zero (u_corner against a stop at gap 0) is measured on its kind's scale
    forces = max(float(np.abs(np.asarray(reference.qoi[name])).max())
                 for name in reference.qoi if name.startswith("R_"))
    displacements = max(float(np.abs(field).max()) for field in reference.displacements.values())
    for name, values in result.qoi.items():
        kind = displacements if name.startswith("u_") else forces
        scale = max(float(np.abs(np.asarray(reference.qoi[name], dtype=float)).max()),
                    1e-6 * kind, 1e-300)
        exact = np.atleast_1d(np.asarray(tight.qoi[name], dtype=float))
        difference = float(np.abs(exact - np.asarray(reference.qoi[name])).max()) / scale
        if difference >= worst:
            worst, which = difference, name
        error = np.abs(np.atleast_1d(np.asarray(values, dtype=float)) - exact)
        own = result.qoi_error.get(name)
        estimate = (np.broadcast_to(np.asarray(own, dtype=float), error.shape)
                    if own is not None else np.zeros_like(error))
        counted = error > FLOOR * scale  # below: zero to that accuracy (docs/tolerance.md)
        above += int(counted.sum())
        bound += int((estimate[counted] >= error[counted]).sum())
        if counted.any():
            smallest = min(smallest, float((estimate[counted] / error[counted]).min()))
    return worst, above, bound, smallest, which


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=0, help="the first seed")
    parser.add_argument("--count", type=int, default=40)
    parser.add_argument("--keep", type=Path, default=None, help="a folder for the model files")
    parser.add_argument("--family", choices=list(FAMILIES), default="strap",
                        help="strap: pulled toward a stop (default); block: pushed by its "
                        "face; stack: a plate pushed back and forth between two contacts; "
                        "meshed: a strap of gmsh meshes (gmsh needed)")
    parser.add_argument("--axisymmetric", action="store_true",
                        help="every model axisymmetric (x = r; no thickness)")
    args = parser.parse_args()
    family = FAMILIES[args.family]

    def text(seed: int) -> str:
        return axisymmetric(family(seed)) if args.axisymmetric else family(seed)
    logging.disable(logging.WARNING)
    folder = args.keep or Path(tempfile.mkdtemp(prefix="random-models-"))
    folder.mkdir(parents=True, exist_ok=True)
    random_families.MESH_FOLDER = folder.resolve()  # the meshed family's mesh files
    counts = {"converged": 0, "not converged": 0, "refused": 0, "reference failed": 0}
    entries = {"above the floor": 0, "bound": 0, "cases not bound": 0}
    print("| seed | LATIN (default settings) | iterations | tight LATIN − reference "
          "(relative) | estimate bounds the error: entries | smallest estimate / error |")
    print("|---|---|---|---|---|---|")
    for seed in range(args.seeds, args.seeds + args.count):
        path = folder / f"random-{seed}.toml"
        path.write_text(text(seed))
        try:
            model = ml.load_model(str(path))
            result = model.solve(check=False)
        except ModelError as error:
            counts["refused"] += 1
            print(f"| {seed} | refused: {str(error)[:70]}… | | | | |")
            continue
        ended = "converged" if result.converged else "NOT CONVERGED"
        try:
            reference = ml.solve_monolithic(model.assemble({}))
        except NotConvergedError:
            counts["reference failed"] += 1
            print(f"| {seed} | {ended} | {result.iterations} | (the reference did not "
                  "converge) | | |")
            continue
        counts["converged" if result.converged else "not converged"] += 1
        if not result.converged:
            print(f"| {seed} | {ended} | {result.iterations} | | | |", flush=True)
            continue
        tight = model.solve(options=TIGHT, check=False)
        worst, above, bound, smallest, which = compare(result, tight, reference)
        entries["above the floor"] += above
        entries["bound"] += bound
        entries["cases not bound"] += int(bound < above)
        print(f"| {seed} | {ended} | {result.iterations} | {worst:.1e} ({which}) | "
              f"{bound} of {above} | {smallest:.2f} |", flush=True)
    print()
    print(", ".join(f"{k}: {v}" for k, v in counts.items()) + "; error estimates: "
          + ", ".join(f"{k}: {v}" for k, v in entries.items())
          + f" (model files in {folder})")


if __name__ == "__main__":
    main()
