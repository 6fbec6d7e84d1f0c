"""Cases at the friction limit started from zero at once (issue 16, session 30), side by side
with the rule before: a warm start whose answer is not unique is set aside and the case
solved again from zero (``starts.set_aside``); now a case whose start neighbour's
converged state, read with the case's friction coefficients, leaves a rigid motion at
its friction limit (``predictors.at_friction_limit``) starts from zero without a warm
attempt.

    python benchmarks/friction_limit.py                     # the docs/performance.md table
    python benchmarks/friction_limit.py --rows b1 --tight
    python benchmarks/friction_limit.py --cost              # what the readings cost a case
    python benchmarks/friction_limit.py --motions out.txt   # every reading, to compare trees

Each row: a multiresolution study (``run_study``'s defaults: the studies' QoI rule) over
13 x 13 frictions (``--grid``), without and with the prediction, in this process: its
iterations, the warm attempts set aside (their iterations), the cases predicted (of them
not unique), and with ``--tight`` R_stop's worst error against η < 1e-9 solves
(``take_back.tight_values``: relative, floored at 1 N).
"""

from __future__ import annotations

import argparse
import tempfile
import warnings
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.study import starts

GRID = ["mu1=0:0.6:13", "mu2=0:0.6:13"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", default="b1,b1-4,b1-9,b3", help="models, comma-separated")
    parser.add_argument("--grid", nargs="+", default=GRID)
    parser.add_argument("--tight", action="store_true", help="R_stop's error against tight")
    parser.add_argument("--cost", action="store_true",
                        help="time the reading per case, one at a time and 200 together")
    parser.add_argument("--motions", default=None,
                        help="write every reading of the grids' states to this file")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    if args.cost:
        cost(args.rows.split(","))
        return
    if args.motions:
        motions(args.rows.split(","), ml.Grid.parse(args.grid), args.motions)
        return
    predicting = starts.at_limit
    grid = ml.Grid.parse(args.grid)
    print("| model | prediction | iterations (slowest) | warm attempts set aside "
          "(their iterations in all) | cases predicted (zero starts not unique) | worst R_stop "
          "error |")
    print("|---|---|---|---|---|---|")
    for name in args.rows.split(","):
        model = ml.load_model(name)
        tight = None
        if args.tight:
            from take_back import tight_values  # the same references as take_back.py

            tight = tight_values(model) if args.grid == GRID else None
        for label, rule in (("off", lambda a, o, f: [False] * len(a)), ("on", predicting)):
            predicted: list[str] = []

            def counted(assemblies: Any, operators: Any, fields: Any, rule: Any = rule,
                        predicted: list[str] = predicted) -> list[bool]:
                flags: list[bool] = rule(assemblies, operators, fields)
                predicted.extend(a.name for a, flag in zip(assemblies, flags, strict=True)
                                 if flag)
                return flags

            starts.at_limit = counted  # type: ignore[assignment]
            try:
                with tempfile.TemporaryDirectory() as folder:
                    result = ml.run_study(model, grid, out=folder, progress=False,
                                          modes=("multiresolution",))
            finally:
                starts.at_limit = predicting
            records = result.records
            iterations = [r["iterations"] for r in records]
            set_aside = [r for r in records if "set aside" in str(r["start"])]
            attempts = sum(r["iterations"] for r in set_aside)  # warm attempt + from zero
            zero_starts = sum(r["start"] == "zero" and not r["unique"] for r in records)
            error = "—"
            if tight is not None:
                values = np.asarray(result.dataset["R_stop"].values, dtype=float).ravel()
                errors = np.abs(values - tight) / np.maximum(np.abs(tight), 1.0)
                error = f"{np.nanmax(errors):.2e}"
            print(f"| {name} | {label} | {sum(iterations)} ({max(iterations)}) | "
                  f"{len(set_aside)} ({attempts}) | {len(predicted)} ({zero_starts}) | "
                  f"{error} |", flush=True)


def cost(names: list[str]) -> None:
    """``at_friction_limit`` on 200 cases read from one neighbour's state ((0.05, 0.3), the
    cases at μ2 = 0.25 + 0…0.002: a third of them at the limit), one at a time as the
    rolling batch asks and all together as a line batch does; then ``free_motions_batch``
    of that state, 200 times, one at a time (a case leaving the rolling batch) and
    together; best of three."""
    import time

    from multilatin.decomposition.interfaces import with_contact_data
    from multilatin.decomposition.uniqueness import free_motions_batch
    from multilatin.latin import LatinOperators, LatinOptions
    from multilatin.study.predictors import at_friction_limit

    for name in names:
        model = ml.load_model(name)
        result = model.solve({"mu1": 0.05, "mu2": 0.3})
        assert result.interface is not None
        fields = (result.interface.displacement_hat, result.interface.force_hat)
        cases = [model.assemble({"mu1": 0.05, "mu2": 0.25 + 0.001 * (i % 3)})
                 for i in range(200)]
        points = LatinOperators(cases[0], LatinOptions()).points
        alone, together = [], []
        for _ in range(3):
            t0 = time.perf_counter()
            for case in cases:
                at_friction_limit([case], [points], [fields])
            alone.append((time.perf_counter() - t0) / len(cases))
            t0 = time.perf_counter()
            found = at_friction_limit(cases, [points] * len(cases), [fields] * len(cases))
            together.append((time.perf_counter() - t0) / len(cases))
        print(f"{name}: {1e3 * min(alone):.2f} ms a case one at a time, "
              f"{1e3 * min(together):.2f} ms in a batch of {len(cases)} "
              f"({sum(m is not None for m in found)} at the limit)", flush=True)
        # the free motions of a converged state, read as every case leaves a batch
        own = with_contact_data(points, model.assemble({"mu1": 0.05, "mu2": 0.3}))
        alone, together = [], []
        for _ in range(3):
            t0 = time.perf_counter()
            for case in cases:
                free_motions_batch([case], [own], [fields[0]], [fields[1]])
            alone.append((time.perf_counter() - t0) / len(cases))
            t0 = time.perf_counter()
            free_motions_batch(cases, [own] * len(cases), [fields[0]] * len(cases),
                               [fields[1]] * len(cases))
            together.append((time.perf_counter() - t0) / len(cases))
        print(f"{name}: free motions {1e3 * min(alone):.2f} ms a case one at a time, "
              f"{1e3 * min(together):.2f} ms in a batch of {len(cases)}", flush=True)


def motions(names: list[str], grid: ml.Grid, path: str) -> None:
    """Every case of the grid solved cold (η < 1e-6); its free motions read alone and all
    together, and its friction limit read from each of up to six neighbours' states (the
    four along the grid lines, two diagonals), written as text to ``path``: run with two
    source trees (``PYTHONPATH``) and compare the files to check that a change of the
    readings finds the same motions."""
    from multilatin.decomposition.interfaces import with_contact_data
    from multilatin.decomposition.uniqueness import free_motions_batch, limit_motions_batch
    from multilatin.latin import LatinOperators, LatinOptions, solve_latin_batch

    lines, found = [], 0
    first, second = list(grid)
    size = (len(grid[first]), len(grid[second]))
    for name in names:
        model = ml.load_model(name)
        cases = [model.assemble({first: a, second: b}) for a in grid[first]
                 for b in grid[second]]
        operators = LatinOperators(cases[0], LatinOptions())
        results = solve_latin_batch(cases, LatinOptions(), check=False)
        w = [r.interface.displacement_hat for r in results if r.interface is not None]
        f = [r.interface.force_hat for r in results if r.interface is not None]
        points = [with_contact_data(operators.points, case) for case in cases]
        together = free_motions_batch(cases, points, w, f)
        lines.append(repr(together))
        lines += [repr(free_motions_batch([c], [p], [a], [b]))
                  for c, p, a, b in zip(cases, points, w, f, strict=True)]
        found += sum(len(m) for m in together)
        for i in range(size[0]):
            for j in range(size[1]):
                for di, dj in ((0, 1), (0, -1), (1, 0), (-1, 0), (1, 1), (-1, -1)):
                    if 0 <= i + di < size[0] and 0 <= j + dj < size[1]:
                        k, n = i * size[1] + j, (i + di) * size[1] + j + dj
                        lines.append(repr(limit_motions_batch([cases[k]], [points[k]],
                                                              [w[n]], [f[n]])))
    with open(path, "w", encoding="utf-8") as out:
        out.write("\n".join(lines) + "\n")
    print(f"{len(lines)} readings, {found} free motions, "
          f"{sum('FreeMotion' in line for line in lines)} readings with motions: {path}")


if __name__ == "__main__":
    main()
