"""What the tail's places are worth (issue 15, session 57): cold solves in which, after every
local stage, ŝ = (Ŵ, F̂) at a chosen set of interface points is replaced by the tightly
converged solve's (η < 1e-11) — an oracle, not a method: it says how many iterations a
perfect treatment of those points could save at most, and so where a new treatment would
pay. Exact values are the fixed point's own, so the solve still converges to the same
answer; nothing of the library is changed (the engine's local stage is wrapped here).

    python benchmarks/exact_points.py                       # b1, b1-9, b3, four pairs
    python benchmarks/exact_points.py --models b1 --parts W F   # Ŵ alone, F̂ alone too
    python benchmarks/exact_points.py --models b1 --warm 0.05   # warm starts along μ2
    python benchmarks/exact_points.py --models b1 --warm 0.05 --at-start
    python benchmarks/exact_points.py --models b1-9 b3 --kinds --parts WF W

Sets of points: the stop's corners (the points at (50, 50) and (50, 100), where the
bottom|centre and centre|top contacts end on the stop: the slowest modes of
``tail_modes.py``), every point where a *corner node* sits (a substructure's node that
carries points of two or more interfaces), as ``operators.corner_factors`` finds them, the
whole stop, the contacts between bodies, the perfect and macro-only interfaces; with
``--kinds`` (session 59) the corner nodes sorted by the interfaces that meet there instead
(with a stop; a perfect interface ending on a contact — and that set's contact points, its
perfect points —; a contact with another boundary; perfect with macro-only interfaces;
perfect interfaces only; a perfect interface on the outer boundary). Printed:
iterations under the studies' QoI rule and to η < 1e-6, per pair and set (a Markdown
table). ``--warm D``: each case starts from the tight ŝ of its neighbour at μ2 − D (μ2 +
D where that is below 0), as a study's nearest-neighbour start would (issue 16: what holds
a warm case). ``--at-start`` (with ``--warm``): the exact values only in the start, the
neighbour's elsewhere, and the library's local stage unwrapped — what a start that
predicted those points would give.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOperators, LatinOptions, solve_latin
from multilatin.latin.engine import NumpyFields
from multilatin.latin.operators import corner_factors
from multilatin.latin.options import STUDY_QOI_RTOL

PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]
STOP_CORNERS = np.array([[50.0, 50.0], [50.0, 100.0]])


def interface_kinds(operators: LatinOperators) -> np.ndarray:
    """Per interface point, its interface's kind: stop, contact, perfect, macro, boundary."""
    return np.array([("stop" if itf.is_stop else "contact" if itf.contact is not None
                      else itf.kind) for itf in operators.assembly.interfaces]
                    )[operators.points.interface]


def point_sets(operators: LatinOperators) -> dict[str, np.ndarray]:
    """The sets of interface points the oracle is tried on (module docstring)."""
    points, kind = operators.points, interface_kinds(operators)
    # the points corner_factors stiffens, within a reach too short to leave their positions
    at_corners = corner_factors(points, 2.0, np.full(points.n_points, 1e-9)) > 1.0
    near = np.linalg.norm(points.coords[:, None, :] - STOP_CORNERS, axis=2).min(axis=1) < 1e-9
    return {"none": np.zeros(0, dtype=np.int64),
            "stop's corners": np.flatnonzero(near),
            "corner nodes": np.flatnonzero(at_corners),
            "stop": np.flatnonzero(kind == "stop"),
            "contacts": np.flatnonzero(kind == "contact"),
            "perfect": np.flatnonzero(kind == "perfect"),
            "macro-only": np.flatnonzero(kind == "macro")}


def corner_kinds(operators: LatinOperators) -> dict[str, np.ndarray]:
    """The corner nodes' points (``point_sets``) sorted by the kinds of interface whose
    points sit at their position (``--kinds``)."""
    points, kind = operators.points, interface_kinds(operators)
    corners = point_sets(operators)["corner nodes"]
    position = [tuple(xy) for xy in np.round(points.coords, 6)]
    kinds_at: dict[tuple[float, ...], set[str]] = {}
    for p, key in enumerate(position):
        kinds_at.setdefault(key, set()).add(str(kind[p]))

    def label(p: int) -> str:
        there = kinds_at[position[p]]
        if "stop" in there:
            return "with a stop"
        if {"contact", "perfect"} <= there:
            return "perfect ending on a contact"
        if "contact" in there:
            return "contact with another boundary"
        if "perfect" in there and "macro" in there:
            return "perfect with macro-only"
        if there == {"perfect"}:
            return "perfect only"
        if "perfect" in there:
            return "perfect on the boundary"
        return "other"

    labels = np.array([label(int(p)) for p in corners])
    out = {"none": np.zeros(0, dtype=np.int64), "corner nodes": corners}
    for name in dict.fromkeys(labels.tolist()):
        out[name] = corners[labels == name]
    junctions = out.get("perfect ending on a contact", np.zeros(0, dtype=np.int64))
    out["… its contact points"] = junctions[kind[junctions] == "contact"]
    out["… its perfect points"] = junctions[kind[junctions] == "perfect"]
    return out


def exact_stage(chosen: np.ndarray, w_exact: np.ndarray, f_exact: np.ndarray,
                parts: str) -> Callable[[NumpyFields], None]:
    """The engine's local stage, then the chosen points' Ŵ and/or F̂ set to the exact."""
    original = NumpyFields.local_stage

    def stage(self: NumpyFields) -> None:
        original(self)
        if "W" in parts:
            self.w_hat[:, :, chosen] = w_exact[None, :, chosen]
        if "F" in parts:
            self.f_hat[:, :, chosen] = f_exact[None, :, chosen]

    return stage


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=["b1", "b1-9", "b3"])
    parser.add_argument("--parts", nargs="+", default=["WF"], choices=["WF", "W", "F"],
                        help="what the oracle sets: both, Ŵ alone, F̂ alone")
    parser.add_argument("--warm", type=float, default=None,
                        help="start from the tight solve at mu2 - WARM (a neighbour's)")
    parser.add_argument("--at-start", action="store_true",
                        help="with --warm: exact values in the start only")
    parser.add_argument("--kinds", action="store_true",
                        help="the corner nodes sorted by the interfaces that meet there")
    args = parser.parse_args()
    if args.warm is not None and not args.warm > 0.0:
        parser.error(f"--warm: the step to the neighbour must be > 0, got {args.warm}")
    if args.at_start and args.warm is None:
        parser.error("--at-start: needs --warm (the start it changes)")
    original = NumpyFields.local_stage
    print("| model | μ1, μ2 | exact at (points) | " + " | ".join(
        f"{part}: QoI rule / η < 1e-6" for part in args.parts) + " |")
    print("|---|---|---|" + "---|" * len(args.parts))
    for name in args.models:
        model = ml.load_model(name)
        for mu1, mu2 in PAIRS:
            assembly = model.assemble({"mu1": mu1, "mu2": mu2})
            operators = LatinOperators(assembly, LatinOptions())
            tight = solve_latin(assembly, LatinOptions(tol=1e-11, max_iter=20000),
                                operators=operators)
            assert tight.interface is not None
            w_exact = tight.interface.displacement_hat
            f_exact = tight.interface.force_hat
            initial = None
            if args.warm is not None:
                other = mu2 - args.warm if mu2 - args.warm >= 0.0 else mu2 + args.warm
                neighbour = solve_latin(model.assemble({"mu1": mu1, "mu2": other}),
                                        LatinOptions(tol=1e-11, max_iter=20000),
                                        operators=operators).interface
                assert neighbour is not None
                initial = (neighbour.displacement_hat, neighbour.force_hat)
            sets = corner_kinds(operators) if args.kinds else point_sets(operators)
            for label, chosen in sets.items():
                if label != "none" and chosen.size == 0:
                    continue
                cells = []
                for part in args.parts:
                    start = initial
                    if args.at_start and initial is not None:
                        start = (initial[0].copy(), initial[1].copy())
                        if "W" in part:
                            start[0][:, chosen] = w_exact[:, chosen]
                        if "F" in part:
                            start[1][:, chosen] = f_exact[:, chosen]
                    else:
                        NumpyFields.local_stage = exact_stage(  # type: ignore[method-assign]
                            chosen, w_exact, f_exact, part)
                    try:
                        counts = [solve_latin(assembly, options, operators=operators,
                                              check=False, initial=start).iterations
                                  for options in (LatinOptions(qoi_rtol=STUDY_QOI_RTOL),
                                                  LatinOptions())]
                    finally:
                        NumpyFields.local_stage = original  # type: ignore[method-assign]
                    cells.append(f"{counts[0]} / {counts[1]}")
                print(f"| {name} | {mu1:g}, {mu2:g} | {label} ({chosen.size}) | "
                      + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
