"""One answer per parameter set whatever the path: the B1 13 x 13 friction grid in both
traversal orders and cold, every case against the reference solver (issue 14, item 1).

    python benchmarks/path_independence.py                  # b1, 13 x 13 (~4 min, 2 cores)
    python benchmarks/path_independence.py --count 5        # a coarser grid
    python benchmarks/path_independence.py --no-guard       # the warm starts alone, as before

Runs the multiresolution study with μ1 outermost, then with μ2 outermost, then every case
cold, then the monolithic reference (semi-smooth Newton, an independent solver) case by
case. Prints a Markdown summary (per path: cases within 0.1 % of the reference, the worst
error, the cases flagged not unique) and every case that is off or flagged.
``--no-guard`` keeps the warm-started answer of a case that is not unique instead of solving
it again from zero (what the study did before): the path then changes the answer.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import multilatin as ml
from multilatin.parameters import Grid
from multilatin.study import starts
from multilatin.study.plan import clear_operator_cache
from multilatin.study.runner import run_study

Key = tuple[float, float]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--model", default="b1")
    parser.add_argument("--count", type=int, default=13, help="values per friction coefficient")
    parser.add_argument("--no-guard", action="store_true",
                        help="keep warm answers of non-unique cases, and start no case "
                             "from zero at the friction limit (the old behaviour)")
    args = parser.parse_args()
    if args.no_guard:
        starts.set_aside = lambda result, start: None  # type: ignore[assignment]
        starts.at_limit = (  # type: ignore[assignment]
            lambda assemblies, ops, fields: [False] * len(assemblies))
    model = ml.load_model(args.model)
    values = [float(v) for v in np.round(np.linspace(0.0, 0.6, args.count), 12)]
    paths = {
        "multiresolution, μ1 outer": (Grid({"mu1": values, "mu2": values}), "multiresolution"),
        "multiresolution, μ2 outer": (Grid({"mu2": values, "mu1": values}), "multiresolution"),
        "cold": (Grid({"mu1": values, "mu2": values}), "cold"),
    }
    answers: dict[str, dict[Key, tuple[float, bool, str]]] = {}
    times: dict[str, float] = {}
    for label, (grid, mode) in paths.items():
        clear_operator_cache()
        start = time.perf_counter()
        result = run_study(model, grid, modes=(mode,), progress=False, on_failure="ignore")
        times[label] = time.perf_counter() - start
        answers[label] = {(r["params"]["mu1"], r["params"]["mu2"]):
                          (r["qoi"]["R_stop"] if r["converged"] else float("nan"),
                           bool(r["unique"]), r["start"]) for r in result.records}
    start = time.perf_counter()
    reference = {key: float(model.reference({"mu1": key[0], "mu2": key[1]}).qoi["R_stop"])
                 for key in answers["cold"]}
    times["reference"] = time.perf_counter() - start

    def error(value: float, key: Key) -> float:
        return abs(value - reference[key]) / max(abs(reference[key]), 1.0)

    print(f"{model.name}, {args.count} x {args.count} grid, μ1, μ2 in [0, 0.6]"
          f"{' (no guard: warm answers kept)' if args.no_guard else ''}\n")
    print("| path | cases | within 0.1 % of the reference | worst error | flagged not unique "
          "| time (s) |")
    print("|---|---|---|---|---|---|")
    for label, found in answers.items():
        errors = [error(v, k) for k, (v, _, _) in found.items()]
        within = sum(e <= 1e-3 for e in errors)
        flagged = sum(not u for _, u, _ in found.values())
        print(f"| {label} | {len(found)} | {within} | {max(errors):.2e} | {flagged} "
              f"| {times[label]:.1f} |")
    print(f"| reference, case by case | {len(reference)} | – | – | – "
          f"| {times['reference']:.1f} |")
    spread = max(max(found[k][0] for found in answers.values())
                 - min(found[k][0] for found in answers.values()) for k in reference)
    print(f"\nlargest spread of R_stop between the three paths: {spread:.3g} N\n")
    print("| μ1 | μ2 | reference R_stop (N) | " + " | ".join(answers) + " |")
    print("|---|---|---|" + "---|" * len(answers))
    for key in sorted(reference):
        rows = [answers[label][key] for label in answers]
        if all(u for _, u, _ in rows) and all(error(v, key) <= 1e-3 for v, _, _ in rows):
            continue
        cells = [f"{v:.3f}{'' if u else ' (not unique)'}"
                 + (" **off**" if error(v, key) > 1e-3 else "") for v, u, _ in rows]
        print(f"| {key[0]:g} | {key[1]:g} | {reference[key]:.3f} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
