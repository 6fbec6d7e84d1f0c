"""The forces' own indicator at the stop (session 41, docs/correctness.md "A displacement
far larger than the deformation"): η_F = ‖F − F̂‖ / ½(‖F‖ + ‖F̂‖), the force part of η's
norm, against η, where each case stopped; and the moved block of
``tests/data/block_on_moved_foundation.toml`` against the monolithic reference of the unmoved
one.

    python benchmarks/force_guard.py                 # both tables, this checkout
    PYTHONPATH=/tmp/old/src python benchmarks/force_guard.py --moved   # another commit's
    python benchmarks/force_guard.py --references new.json [--against old.json]
    python benchmarks/force_guard.py --lifted        # session 45: answers with no force
    python benchmarks/force_guard.py --solves new.json [--against old.json]

Bundled models at their defaults, b1, b1-9 and b3 at ``convergence.py``'s four friction
pairs, each under η < tol and under the studies' QoI rule (``qoi_rtol`` = 1e-3): the largest
η_F / η and η_F at the stop. The moved block (base moved by 100 mm, deforming by ~1e-3 mm):
pushed by 58 N (friction holds 60 N) and 62 N (no equilibrium), each rule: outcome,
iterations, and R_base's and u_right − 100's relative differences from the unmoved block's
reference. ``--references``: the bundled models' monolithic references (B1's four pairs,
b1-9, slide at two stiffness ratios, punch, b2, b0, lug, roller) written to a JSON file, and
with ``--against`` (the same written by another commit) each one's largest relative QoI
difference. ``--lifted`` (session 45, ``guards.FORCE_FLOOR``): the lifted block of
``tests/data/lifted_block.toml`` (moved 4 µm toward a base ``gap`` below it) at gaps
0.001–0.01 mm and ``slide`` at p = 0, each rule: outcome, iterations, the largest reaction
and its difference from the reference. ``--solves``: LATIN's iterations, η and QoIs on
the bundled models (B1's and B3's four pairs), each rule, written to a JSON file, and with
``--against`` the entries that differ.
"""

from __future__ import annotations

import argparse
import json
import warnings
from pathlib import Path

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOperators, LatinOptions, solve_latin
from multilatin.latin.engine import indicator_weights
from multilatin.latin.guards import force_indicator

PAIRS = [{"mu1": 0.3, "mu2": 0.0}, {"mu1": 0.1, "mu2": 0.3}, {"mu1": 0.35, "mu2": 0.25},
         {"mu1": 0.3, "mu2": 0.15}]
MODELS = ["b0", "b2", "slide", "punch", "lug", "roller", "b1", "b1-9", "b3"]
MOVED = Path(__file__).parents[1] / "tests" / "data" / "block_on_moved_foundation.toml"
LIFTED = Path(__file__).parents[1] / "tests" / "data" / "lifted_block.toml"


def eta_force(result: ml.SolveResult, ops: LatinOperators) -> float:
    """η_F of a result's interface fields, weighted as η's force part (∫ k⁻¹ F·F)."""
    assert result.interface is not None
    weight = indicator_weights(ops.points.weights, ops.indicator_k)[1]
    return float(force_indicator(weight, result.interface.force[None],
                                 result.interface.force_hat[None])[0])


def ratios() -> None:
    print("| model | rule | cases | largest η_F / η at the stop | largest η_F |")
    print("|---|---|---|---|---|")
    for name in MODELS:
        model = ml.load_model(name)
        cases = PAIRS if name.startswith("b1") or name == "b3" else [{}]
        for rule, qoi_rtol in (("η < tol", None), ("QoI rule", 1e-3)):
            options = LatinOptions(qoi_rtol=qoi_rtol)
            rows = []
            for params in cases:
                assembly = model.assemble(params)
                ops = LatinOperators(assembly, options)
                result = solve_latin(assembly, options, operators=ops)
                value = eta_force(result, ops)
                rows.append((value / result.indicator, value))
            worst = np.max(rows, axis=0)
            print(f"| {name} | {rule} | {len(cases)} | {worst[0]:.1f} | {worst[1]:.1e} |",
                  flush=True)


def moved() -> None:
    model = ml.Model(ml.ModelSpec.from_toml(MOVED))
    unmoved = model.reference({"q": 2.9, "shift": 0.0})
    print("| push | rule | outcome, iterations | R_base, u_right − 100 vs the unmoved "
          "reference |")
    print("|---|---|---|---|")
    for q in (2.9, 3.1):
        for rule, qoi_rtol in (("η < tol", None), ("QoI rule", 1e-3)):
            result = model.solve({"q": q, "shift": 100.0}, check=False,
                                 options=LatinOptions(qoi_rtol=qoi_rtol))
            outcome = "converged" if result.converged else f"not converged ({result.failure[:60]}…)"
            cell = "—"
            if result.converged and q < 3.0:
                r = result.qoi["R_base"][-1] / unmoved.qoi["R_base"][-1] - 1  # type: ignore[index]
                u = ((result.qoi["u_right"][-1] - 100.0)  # type: ignore[index]
                     / unmoved.qoi["u_right"][-1] - 1)  # type: ignore[index]
                cell = f"{r:.1e}, {u:.1e}"
            print(f"| {20 * q:g} N | {rule} | {outcome}, {result.iterations} | {cell} |",
                  flush=True)


REFERENCES = [("b1", PAIRS), ("b1-9", PAIRS[1:2]), ("slide", [{}, {"stiffness_ratio": 1000}]),
              ("punch", [{}]), ("b2", [{}]), ("b0", [{}]), ("lug", [{}]), ("roller", [{}])]


def references(path: str, against: str | None) -> None:
    found = {}
    for name, cases in REFERENCES:
        model = ml.load_model(name)
        for params in cases:
            found[f"{name} {json.dumps(params)}"] = model.reference(params).qoi
    Path(path).write_text(json.dumps(found), encoding="utf-8")
    if against is None:
        return
    other = json.loads(Path(against).read_text(encoding="utf-8"))
    for key, qois in found.items():
        worst = max(float(np.max(np.abs(np.subtract(qois[q], other[key][q]))
                                 / max(float(np.max(np.abs(other[key][q]))), 1e-300)))
                    for q in qois)
        print(f"{key}: largest relative QoI difference {worst:.1e}")


def lifted() -> None:
    cases = [(ml.Model(ml.ModelSpec.from_toml(LIFTED)), "R_top", {"gap": g})
             for g in (0.001, 0.003, 0.004, 0.005, 0.01)]
    cases.append((ml.load_model("slide"), "R_push", {"p": 0.0}))
    print("| model | parameters | rule | outcome, iterations | largest reaction | "
          "difference from the reference |")
    print("|---|---|---|---|---|---|")
    for model, qoi, params in cases:
        reference = np.asarray(model.reference(params).qoi[qoi])
        for rule, rtol in (("η < tol", None), ("QoI rule", 1e-3)):
            result = model.solve(params, options=LatinOptions(qoi_rtol=rtol), check=False)
            value = np.asarray(result.qoi[qoi])
            outcome = "converged" if result.converged else "not converged"
            print(f"| {model.name} | {params} | {rule} | {outcome}, {result.iterations} | "
                  f"{np.abs(value).max():.3g} | {np.abs(value - reference).max():.2g} |")


def solves(path: str, against: str | None) -> None:
    found = {}
    for name in MODELS:
        model = ml.load_model(name)
        for params in (PAIRS if name in ("b1", "b1-9", "b3") else [{}]):
            for rtol in (None, 1e-3):
                result = model.solve(params, options=LatinOptions(qoi_rtol=rtol), check=False)
                found[f"{name} {json.dumps(params)} {rtol}"] = [
                    result.iterations, result.indicator,
                    {q: np.asarray(v).tolist() for q, v in result.qoi.items()}]
    Path(path).write_text(json.dumps(found), encoding="utf-8")
    if against is not None:
        other = json.loads(Path(against).read_text(encoding="utf-8"))
        differ = [key for key in found if other.get(key) != found[key]]
        print(f"{len(found)} solves, {len(differ)} differ: {differ}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--moved", action="store_true", help="the moved block alone")
    parser.add_argument("--references", help="write the references' QoIs to this JSON file")
    parser.add_argument("--against", help="with --references or --solves: compare with "
                                          "this one")
    parser.add_argument("--lifted", action="store_true", help="answers with no force")
    parser.add_argument("--solves", help="write LATIN's solves of the bundled models here")
    args = parser.parse_args()
    warnings.filterwarnings("ignore")
    if args.lifted:
        lifted()
        return
    if args.solves:
        solves(args.solves, args.against)
        return
    if args.references:
        references(args.references, args.against)
        return
    if not args.moved:
        ratios()
        print()
    moved()


if __name__ == "__main__":
    main()
