"""Why a warm start saves nothing on B1's sliding cases, and what softer search directions
on the contact sides do about it (issue 15 / 16, session 27).

    python benchmarks/soft_directions.py --diagnose          # where a warm start's error sits
    python benchmarks/soft_directions.py --line              # the variants on the μ2 line
    python benchmarks/soft_directions.py --grid              # ... on the B1 13 x 13 grid
    python benchmarks/soft_directions.py --cold              # ... cold b1, b1-9, b3 solves
    python benchmarks/soft_directions.py --oracle            # the better of two per case

``--diagnose``: b1 at μ1 = 0.3, μ2 = 0.1, started from μ2 = 0.05's tightly converged ŝ
(warm), from zero (cold), and from one field of each (own Ŵ with the neighbour's F̂, and the
other way round): u_A's largest error over the steps (relative to its largest magnitude)
after n iterations, and the step where it sits, against a tight solve (η < 1e-10).

The variants change the two-scale search direction (``multilatin.latin.two_scale``) by
wrapping what ``LatinOperators`` calls, not the library: ``soft-macro F``: the macro part
(k on the constant and linear functions of each contact side and stop) times F on every
contact side and stop; ``soft-stop F``: on the stops' sides only; ``soft-tangent F``: the
contacts' tangential component only; ``micro-tangent F``: D on the contacts' tangential
component = k × F instead of k × ``micro_stiffening``; ``degree D``: the soft (macro)
space of each contact side holds polynomials up to degree D along it instead of 1.
``--line`` and ``--grid`` run the multiresolution study under the studies' rule
(``STUDY_QOI_RTOL``) and print its iterations and R_stop's worst error against η < 1e-9
solves of every case (|ΔR| / max(|R|, 1 N)); ``--cold`` runs cold solves under the same
rule at the four pairs of ``benchmarks/convergence.py``. ``--oracle``: cold b1 solves on
the 7 x 7 grid μ1, μ2 ∈ {0, 0.1, …, 0.6} with the default and with ``--oracle-variant``,
and the total if each case took the better of the two.
"""

from __future__ import annotations

import argparse
import contextlib
import tempfile
from collections.abc import Iterator
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.fem.mesh import normal_axis
from multilatin.latin import LatinOptions, operators, solve_latin, two_scale
from multilatin.latin.options import STUDY_QOI_RTOL
from multilatin.parameters import Grid
from multilatin.study.plan import clear_operator_cache
from multilatin.study.runner import run_study

VARIANTS = ("default", "soft-macro 0.5", "soft-stop 0.5", "soft-tangent 0.5",
            "micro-tangent 1", "micro-tangent 8", "degree 3")
PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]


def _contact_columns(assembly: Any, points: Any, which: str) -> Iterator[tuple[Any, int]]:
    """(points, component) of the contact sides and stops the variant changes."""
    for i, itf in enumerate(assembly.interfaces):
        if itf.contact is None:
            continue
        normal = normal_axis(itf.sides[0].side)
        for side in range(len(itf.sides)):
            at = points.side_points[(i, side)]
            if which == "all" or (which == "stop" and itf.kind != "contact"):
                yield at, 0
                yield at, 1
            elif which == "tangent" and itf.kind == "contact":
                yield at, 1 - normal


@contextlib.contextmanager
def variant(name: str) -> Iterator[None]:
    """The search direction of ``name`` for the operators built inside the block."""
    kind, _, value = name.partition(" ")
    original = operators.two_scale_direction
    original_functions = two_scale.interface_functions

    def direction(assembly: Any, points: Any, k: Any, stiff: Any) -> Any:
        k = k.copy()
        if kind.startswith("soft-"):
            which = {"soft-macro": "all", "soft-stop": "stop", "soft-tangent": "tangent"}[kind]
            for at, component in _contact_columns(assembly, points, which):
                k[at, component] *= float(value)
        elif kind == "micro-tangent":  # D is the operators' own array: changed in place
            for at, component in _contact_columns(assembly, points, "tangent"):
                stiff[at, component] = k[at, component] * float(value)
        return original(assembly, points, k, stiff)

    def functions(points: Any, interface: int, n_sides: int, reference: int = 0) -> Any:
        out = original_functions(points, interface, n_sides, reference)
        xy = points.coords[points.side_points[(interface, reference)]]
        w = points.weights[points.side_points[(interface, reference)]]
        s = (xy - xy[0]) @ ((xy[-1] - xy[0]) / np.linalg.norm(xy[-1] - xy[0]))
        s = 2.0 * s / s.max() - 1.0
        columns = [out[reference][:, j] for j in range(out[reference].shape[1])]
        for degree in range(2, int(value) + 1):  # Gram–Schmidt in the side's M0 product
            v = s ** degree
            for c in columns:
                v = v - (w @ (v * c)) * c
            columns.append(v / np.sqrt(w @ (v * v)))
        out[reference] = np.column_stack(columns)
        return out

    operators.two_scale_direction = direction  # type: ignore[assignment]
    if kind == "degree":
        two_scale.interface_functions = functions  # type: ignore[assignment]
    clear_operator_cache()
    try:
        yield
    finally:
        operators.two_scale_direction = original
        two_scale.interface_functions = original_functions
        clear_operator_cache()


def diagnose() -> None:
    model = ml.load_model("b1")
    tight = LatinOptions(tol=1e-10, max_iter=50_000)
    before, case = (model.assemble({"mu1": 0.3, "mu2": mu2}) for mu2 in (0.05, 0.1))
    neighbour, own = solve_latin(before, tight), solve_latin(case, tight)
    assert neighbour.interface is not None and own.interface is not None
    u_tight = np.asarray(own.qoi["u_A"], dtype=float)
    print("u_A (µm) at μ2 = 0.05:", np.round(1e3 * np.asarray(neighbour.qoi["u_A"]), 1))
    print("u_A (µm) at μ2 = 0.1: ", np.round(1e3 * u_tight, 1))
    n, o = neighbour.interface, own.interface
    starts = {"warm": (n.displacement_hat, n.force_hat), "cold": None,
              "own Ŵ, neighbour's F̂": (o.displacement_hat, n.force_hat),
              "neighbour's Ŵ, own F̂": (n.displacement_hat, o.force_hat)}
    counts = (1, 5, 10, 20, 30, 40)
    print("\n| start | " + " | ".join(f"after {c}" for c in counts) + " |")
    print("|" + "---|" * (len(counts) + 1))
    for name, initial in starts.items():
        cells = []
        for count in counts:
            result = solve_latin(case, LatinOptions(tol=1e-14, max_iter=count), check=False,
                                 initial=initial)
            error = np.abs(np.asarray(result.qoi["u_A"], dtype=float) - u_tight)
            error /= np.abs(u_tight).max()
            cells.append(f"{error.max():.1e} (step {error.argmax() + 1})")
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)


def studies(grid_text: list[str], names: list[str]) -> None:
    model = ml.load_model("b1")
    grid = Grid.parse(grid_text)
    tight: dict[int, float] = {}
    print(f"\n| variant ({' '.join(grid_text)}) | iterations | warm cases: median / max | "
          "R_stop worst error (case: error, its estimate, iterations) | converged |")
    print("|---|---|---|---|---|")
    for name in names:
        with variant(name), tempfile.TemporaryDirectory() as folder:
            result = run_study(ml.load_model("b1"), grid, out=folder, progress=False,
                               options=LatinOptions(qoi_rtol=STUDY_QOI_RTOL))
        records = result.mode_records("multiresolution")
        if not tight:
            tight = {r["number"]: float(model.solve(r["params"], options=LatinOptions(
                tol=1e-9, max_iter=4000)).qoi["R_stop"]) for r in records}
        def error(r: dict[str, Any], tight: dict[int, float] = tight) -> float:
            return abs(r["qoi"]["R_stop"] - tight[r["number"]])

        worst = max(records, key=lambda r: error(r) / max(abs(tight[r["number"]]), 1.0))
        warm = [r["iterations"] for r in records if r["start"] != "zero"]
        print(f"| {name} | {sum(r['iterations'] for r in records)} | "
              f"{np.median(warm):.0f} / {max(warm)} | "
              f"{100 * error(worst) / max(abs(tight[worst['number']]), 1.0):.3f} % "
              f"({', '.join(f'{v:g}' for v in worst['params'].values())}: {error(worst):.3f} N "
              f"off, estimate {worst['qoi_error']['R_stop']:.3f} N, {worst['iterations']} "
              f"iterations) | {'yes' if all(r['converged'] for r in records) else 'NO'} |",
              flush=True)


def cold(names: list[str]) -> None:
    print("\n| model | variant | iterations at the four pairs | R_stop worst error |")
    print("|---|---|---|---|")
    options = LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    for model_name in ("b1", "b1-9", "b3"):
        model = ml.load_model(model_name)
        tight = [float(model.solve({"mu1": a, "mu2": b}, options=LatinOptions(
            tol=1e-9, max_iter=4000)).qoi["R_stop"]) for a, b in PAIRS]
        for name in names:
            with variant(name):
                results = [model.solve({"mu1": a, "mu2": b}, options=options) for a, b in PAIRS]
            worst = max(abs(float(r.qoi["R_stop"]) - t) / max(abs(t), 1.0)  # type: ignore[arg-type]
                        for r, t in zip(results, tight, strict=True))
            print(f"| {model_name} | {name} | {' / '.join(str(r.iterations) for r in results)} "
                  f"| {100 * worst:.3f} % |", flush=True)


def oracle(name: str) -> None:
    model = ml.load_model("b1")
    options = LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    pairs = [(a / 10, b / 10) for a in range(7) for b in range(7)]
    counts = []
    for variant_name in ("default", name):
        with variant(variant_name):
            counts.append([model.solve({"mu1": a, "mu2": b}, options=options).iterations
                           for a, b in pairs])
    print(f"\ncold b1, 7 x 7: default {sum(counts[0])}, {name} {sum(counts[1])}, the better "
          f"of the two per case {int(np.minimum(*counts).sum())} iterations")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--diagnose", action="store_true")
    parser.add_argument("--line", action="store_true")
    parser.add_argument("--grid", action="store_true")
    parser.add_argument("--cold", action="store_true")
    parser.add_argument("--oracle", action="store_true")
    parser.add_argument("--oracle-variant", default="soft-tangent 0.5")
    parser.add_argument("--variants", nargs="+", default=list(VARIANTS))
    args = parser.parse_args()
    if args.diagnose:
        diagnose()
    if args.line:
        studies(["mu1=0.3", "mu2=0:0.6:13"], args.variants)
    if args.grid:
        studies(["mu1=0:0.6:13", "mu2=0:0.6:13"], args.variants)
    if args.cold:
        cold(args.variants)
    if args.oracle:
        oracle(args.oracle_variant)


if __name__ == "__main__":
    main()
