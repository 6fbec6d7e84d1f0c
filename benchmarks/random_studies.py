"""Random user models' parametric studies against the monolithic solution of every case
(session 61): what multiresolution does on models it was not tuned on.

    python benchmarks/random_studies.py                      # strap seeds 0-19
    python benchmarks/random_studies.py --family block --seeds 20 --count 10
    python benchmarks/random_studies.py --family stack   # pushed back and forth (session 62)
    python benchmarks/random_studies.py --family meshed  # gmsh meshes (gmsh needed)
    python benchmarks/random_studies.py --axisymmetric
    python benchmarks/random_studies.py --growing off   # the estimate as before session 61

Each seed's model is ``random_models.py``'s with the contact's friction made a parameter
``mu`` (5 values, 0 to 0.6) and a second one: the hole's centre ``xc`` (a geometric
parameter: operators per position, predictors along it) where the strap has a hole, else
the stop's gap ``g`` (strap) or the push ``d`` (block, stack), 4 values each. The 20 cases run as a
study in both modes (``run_study``, multiresolution and cold) and each case by the
monolithic contact solver (``solve_monolithic``). Printed per seed: the cases that
converged in each mode, the iterations summed, each mode's largest error against the
reference (relative to the QoI's largest magnitude over the study; a QoI below 1e-6 of its
kind's, the forces' or the displacement field's, over the whole study is zero and left out,
as are entries the solve reports undetermined), how many entries above 1e-6 of that scale
(``random_models.compare``'s floor) the case's own error estimate bounds; then, in the totals,
the cases outside 0.1 % (the studies' QoI rule, ``STUDY_QOI_RTOL``) and the warm cases
outside it whose error exceeds 10 × the cold one's and is not bounded by its estimate
(another fixed point than the cold solve's: a silent wrong answer).
"""

from __future__ import annotations

import argparse
import logging
import re
import sys
from pathlib import Path
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.errors import ModelError, NotConvergedError
from multilatin.latin import tracking

sys.path.insert(0, str(Path(__file__).resolve().parent))

from random_families import FAMILIES, axisymmetric  # noqa: E402
from random_models import FLOOR  # noqa: E402

MU = (0.0, 0.15, 0.3, 0.45, 0.6)
#: what the studies' QoI rule promises (``STUDY_QOI_RTOL``), here of each QoI's largest
#: magnitude over the study
PROMISE = 1e-3


def parametrised(text: str, family: str) -> tuple[str, dict[str, list[float]]] | None:
    """``text`` with the contact's friction the parameter ``mu`` and a second parameter
    (module docstring), and the grid; None where the model has no such field."""
    text = re.sub(r"^friction = ([-\d.e]+)$", 'friction = "mu"', text, count=1, flags=re.M)
    hole = re.search(r"^centre = \[([-\d.e]+), ([-\d.e]+)\]$", text, flags=re.M)
    if hole:
        x = float(hole.group(1))
        text = text.replace(hole.group(0), f'centre = ["xc", {hole.group(2)}]')
        second, values = "xc", [round(x + d, 3) for d in (-1.5, -0.5, 0.5, 1.5)]
    elif family in ("strap", "meshed"):
        stop = re.search(r"(type = \"stop\"\ngap = )([-\d.e]+)", text)
        if stop is None:
            return None
        text = text.replace(stop.group(0), stop.group(1) + '"g"')
        second, values = "g", [-0.002, 0.0, 0.005, 0.01]
    else:
        push = re.search(r"(value = \[)([-\d.e]+)(, 0.0\]\nfactor = \"push\")", text)
        if push is None:
            return None
        text = text.replace(push.group(0), push.group(1) + '"d"' + push.group(3))
        second, values = "d", [0.002, 0.006, 0.012, 0.02]
    header = (f"[parameters.mu]\ndefault = 0.3\nmin = 0.0\nmax = 1.0\n"
              f"[parameters.{second}]\ndefault = {values[1]}\n")
    text = re.sub(r"^(title = .*)$", r"\1\n" + header, text, count=1, flags=re.M)
    return text, {"mu": list(MU), second: values}


def errors(records: list[dict[str, Any]], references: dict[int, Any]
           ) -> tuple[float, list[float], list[bool], int, int]:
    """Over ``records`` with a reference: the largest relative error, each case's and
    whether its estimate bounds it, and the entries above the floor and how many of them
    the case's estimate bounds."""
    scales: dict[str, float] = {}  # at least 1e-6 of the kind's: below, a QoI is zero
    largest: dict[str, float] = {}
    for reference in references.values():
        forces = max(float(np.abs(np.asarray(reference.qoi[n])).max())
                     for n in reference.qoi if not n.startswith("u_"))
        shift = max(float(np.abs(f).max()) for f in reference.displacements.values())
        for name, value in reference.qoi.items():
            kind = shift if name.startswith("u_") else forces
            size = float(np.abs(np.asarray(value)).max())
            largest[name] = max(largest.get(name, 0.0), size)
            scales[name] = max(scales.get(name, 0.0), size, 1e-6 * kind, 1e-300)
    worst, each, bounded, above, bound = 0.0, [], [], 0, 0
    for record in records:
        reference = references.get(record["number"])
        if reference is None or not record["converged"]:
            each.append(np.nan)
            bounded.append(True)
            continue
        case, held = 0.0, True
        for name, value in record["qoi"].items():
            error = np.abs(np.atleast_1d(np.asarray(value, dtype=float))
                           - np.asarray(reference.qoi[name], dtype=float)) / scales[name]
            # entries the solve reports undetermined (a free motion: docs/uniqueness) are
            # no answer, in either solver
            error = np.where(np.asarray(record["qoi_determined"].get(name, True)), error, 0.0)
            estimate = np.broadcast_to(np.asarray(record["qoi_error"].get(name, 0.0),
                                                  dtype=float), error.shape) / scales[name]
            counted = error > FLOOR
            above += int(counted.sum())
            bound += int((estimate[counted] >= error[counted]).sum())
            held &= bool(np.all(estimate[counted] >= error[counted]))
            if largest[name] >= scales[name]:  # a QoI zero over the whole study: no share
                case = max(case, float(error.max()))
        each.append(case)
        bounded.append(held)
        worst = max(worst, case)
    return worst, each, bounded, above, bound


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=0, help="the first seed")
    parser.add_argument("--count", type=int, default=20)
    parser.add_argument("--family", choices=list(FAMILIES), default="strap")
    parser.add_argument("--axisymmetric", action="store_true",
                        help="every model axisymmetric (x = r; no thickness)")
    parser.add_argument("--growing", choices=["on", "off"], default="on",
                        help="tracking.GROWING_CHECK (off: as before session 61)")
    args = parser.parse_args()
    tracking.GROWING_CHECK = args.growing == "on"
    logging.disable(logging.WARNING)
    family = FAMILIES[args.family]
    totals = {"models": 0, "refused": 0, "cases": 0, "warm not converged": 0,
              "cold not converged": 0, "warm outside 0.1 %": 0, "cold outside 0.1 %": 0,
              "other fixed point": 0, "above": 0, "bound": 0}
    print("| seed | grid | converged warm / cold | iterations warm / cold | largest error "
          "warm / cold | estimate bounds (warm) | warm ≫ cold |")
    print("|---|---|---|---|---|---|---|")
    for seed in range(args.seeds, args.seeds + args.count):
        text = axisymmetric(family(seed)) if args.axisymmetric else family(seed)
        made = parametrised(text, args.family)
        if made is None:
            continue
        try:
            model = ml.Model(ml.ModelSpec.from_string(made[0], name=f"random-{seed}"))
            grid = ml.Grid(made[1])
            study = ml.run_study(model, grid, modes=("multiresolution", "cold"),
                                 progress=False)
        except ModelError as error:
            totals["refused"] += 1
            print(f"| {seed} | refused: {str(error)[:60]}… | | | | | |")
            continue
        warm, cold = study.mode_records("multiresolution"), study.mode_records("cold")
        references = {}
        for record in cold:
            try:
                references[record["number"]] = ml.solve_monolithic(
                    model.assemble(record["params"]))
            except NotConvergedError:
                pass
        worst_warm, each_warm, held, above, bound = errors(warm, references)
        worst_cold, each_cold, _, _, _ = errors(cold, references)
        other = sum(1 for w, c, h in zip(each_warm, each_cold, held, strict=True)
                    if w > PROMISE and w > 10 * max(c, FLOOR) and not h)
        totals["models"] += 1
        totals["cases"] += len(warm)
        totals["warm not converged"] += sum(not r["converged"] for r in warm)
        totals["cold not converged"] += sum(not r["converged"] for r in cold)
        totals["other fixed point"] += other
        totals["warm outside 0.1 %"] += sum(1 for w in each_warm if w > PROMISE)
        totals["cold outside 0.1 %"] += sum(1 for c in each_cold if c > PROMISE)
        totals["above"] += above
        totals["bound"] += bound
        print(f"| {seed} | {' × '.join(f'{k} {len(v)}' for k, v in grid.items())} | "
              f"{sum(r['converged'] for r in warm)} / {sum(r['converged'] for r in cold)} | "
              f"{sum(r['iterations'] for r in warm)} / {sum(r['iterations'] for r in cold)} | "
              f"{worst_warm:.1e} / {worst_cold:.1e} | {bound} of {above} | {other} |",
              flush=True)
    print()
    print(", ".join(f"{k}: {v}" for k, v in totals.items()))


if __name__ == "__main__":
    main()
