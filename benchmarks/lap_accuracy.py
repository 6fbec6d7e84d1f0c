"""The QoI error estimate and the studies' QoI rule on a model they were not tuned on
(session 49): the bundled lap joint, every case and load step against the monolithic
reference (the same discrete problem, solved directly).

    python benchmarks/lap_accuracy.py [--kappa 0.5] [--solves] [--trace] [--model PATH]

(``--model src/multilatin/models/lap.toml`` with ``PYTHONPATH=<an older checkout>/src``
measures a commit from before the model was bundled.)

The study: ``multilatin study lap --grid mu=0.1:0.4:7 --grid p=20:80:7 --compare`` at κ, both
modes under the studies' rule (``qoi_rtol`` = 1e-3); F_pull's error per entry relative to
max(|reference|, 1 % of the case's largest |F_pull|), the rule's own floor; how many entries
are off by more than the rule's 0.1 %, and how many estimates lie below their error (among
errors above 1e-6). ``--solves``: also single solves at η < 1e-6 on a 3 × 2 grid at κ =
0.25, 0.5, 1, the largest error / estimate ratio of each over the steps whose error is
above 1e-6 of the largest |F_pull| (``qoi_error.py``'s floor). ``--trace``: the cold case (0.25,
20) under the rule, then stopped at iterations 78, 81, …, 120 (``max_iter``): F_pull's error
and estimate at the last step, to see what the estimate reads after a jump.
"""

from __future__ import annotations

import argparse

import numpy as np
from rule_accuracy import ruled_study, trace  # this script's folder

import multilatin as ml
from multilatin.latin import LatinOptions

FLOOR = 1e-6


def study_table(name: str, kappa: float) -> None:
    model = ml.load_model(name)
    grid = ml.Grid({"mu": list(np.linspace(0.1, 0.4, 7)), "p": list(np.linspace(20, 80, 7))})
    data = ruled_study(model, grid, kappa)
    rows = []
    references = {(mu, p): np.asarray(model.reference({"mu": mu, "p": p}).qoi["F_pull"])
                  for mu in data.mu.values.tolist() for p in data.p.values.tolist()}
    for mode in data.mode.values.tolist():
        for (mu, p), reference in references.items():
            case = data.sel(mode=mode, mu=mu, p=p)
            value, estimate = case["F_pull"].values, case["F_pull_err"].values
            scale = np.maximum(np.abs(reference), 1e-2 * np.abs(reference).max())
            error = np.abs(value - reference)
            for step in range(reference.size):
                rows.append((error[step] / scale[step], mode, mu, p, step + 1,
                             error[step], estimate[step], int(case["iterations"])))
    rows.sort(key=lambda row: -row[0])
    print(f"lap joint 7 × 7 study at κ = {kappa:g} under the studies' rule: "
          f"{sum(int(data['iterations'].sel(mode=m).sum()) for m in ('multiresolution',)):d}"
          f" iterations with multiresolution, "
          f"{int(data['iterations'].sel(mode='cold').sum()):d} cold")
    above = [row for row in rows if row[0] > 1e-3]
    below = [row for row in rows if row[0] > FLOOR and row[5] > row[6]]
    print(f"  entries: {len(rows)}; off by more than 0.1 %: {len(above)}; "
          f"estimate below the error: {len(below)}")
    for rel, mode, mu, p, step, error, estimate, iterations in rows[:3]:
        print(f"  worst: {rel:.2e} ({mode}, mu = {mu:.2f}, p = {p:.0f}, step {step}: error "
              f"{error:.3g} N, estimate {estimate:.3g} N, {iterations} iterations)")
    if below:
        worst = max(below, key=lambda row: row[5] / row[6])
        print(f"  largest error / estimate: {worst[5] / worst[6]:.2f} ({worst[1]}, mu = "
              f"{worst[2]:.2f}, p = {worst[3]:.0f}, step {worst[4]}, relative error "
              f"{worst[0]:.1e})")


def solves_table(name: str) -> None:
    model = ml.load_model(name)
    print("\nsingle solves at η < 1e-6: iterations, the largest F_pull error / estimate over "
          "the steps (errors above the floor)")
    print("| μ, p | κ = 0.25 | κ = 0.5 | κ = 1 |")
    print("|---|---|---|---|")
    for mu in (0.1, 0.2, 0.3):
        for p in (20.0, 50.0):
            reference = np.asarray(model.reference({"mu": mu, "p": p}).qoi["F_pull"])
            cells = []
            for kappa in (0.25, 0.5, 1.0):
                result = model.solve({"mu": mu, "p": p}, options=LatinOptions(kappa=kappa))
                error = np.abs(np.asarray(result.qoi["F_pull"]) - reference)
                estimate = np.asarray(result.qoi_error["F_pull"], dtype=float)
                above = error > FLOOR * np.abs(reference).max()  # as qoi_error.py counts
                ratio = f"{np.max(error[above] / estimate[above]):.2f}" if above.any() else "—"
                cells.append(f"{result.iterations}, {ratio}")
            print(f"| {mu:g}, {p:g} | " + " | ".join(cells) + " |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--kappa", type=float, default=0.5)
    parser.add_argument("--solves", action="store_true")
    parser.add_argument("--trace", action="store_true")
    parser.add_argument("--model", default="lap", help="the lap joint's name or path")
    args = parser.parse_args()
    if args.trace:
        trace(args.model, "F_pull", 9, {"mu": 0.25, "p": 20.0}, range(78, 121, 3),
              args.kappa)
        return
    study_table(args.model, args.kappa)
    if args.solves:
        solves_table(args.model)


if __name__ == "__main__":
    main()
