"""Experiment (issue 15, item 1, session 35): complete communication at the cross points
of perfect interfaces — one Ŵ per node where perfect pairs of three or more substructures
meet, as the conforming discrete problem has one node there.

At such a node each perfect pair's local stage finds its own Ŵ from its two sides; a force
between two substructures that meet only at the node (diagonal neighbours: b3's centre[1,0]
and centre[2,1] at (33.3, 66.7), the holed substructure's interfaces being macro-only)
passes through the third substructure's two points, and b3 (0.3, 0)'s slowest mode (0.943)
lives there (docs/convergence.md, session 35). Here, after the library's local stage, every
point p of such a *component* (the perfect pairs joined through shared substructure nodes
at one position) takes the node's Ŵ = (Σ k_p W_p − Σ F_p) / Σ k_p, and forces F̂ closest
(in Σ (F̂_p − F⁰_p)² / k_p) to F⁰_p = F_p + k_p (Ŵ − W_p) that are equal and opposite across
each pair and keep each substructure's total at the node (a fixed linear map per component
and component of the field). At the fixed point this is the perfect interfaces' law: the
discrete problem is unchanged. ``--chains``: only components without a loop (three
substructures, two pairs: b3's four corners of the holed substructure); by default also the
loops of four perfect pairs (b1-4, b1-9 and b3's other cross points), where the split around
the loop is not unique and the closest one is taken. Prototype (NumPy, wrapped around
``LocalStage.without_contact``): cold solves at ``convergence.py``'s four pairs, iterations
to η < 1e-6 (``--qoi``: to the studies' QoI rule) and R_stop's error against the library's
η < 1e-10 solve, relative.

    python benchmarks/perfect_cross_points.py [--models b3 b1-9] [--chains] [--qoi]
    python benchmarks/perfect_cross_points.py --chains --study   # B3's 5 x 5 positions

``--study``: the iterations of B3's 5 × 5 hole-position study (``run_study``, its defaults)
with the library's local stage and with the wrapper.
"""

from __future__ import annotations

import argparse
import tempfile
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOperators, LatinOptions, cross_points, solve_latin
from multilatin.latin.local_stage import LocalStage
from multilatin.latin.options import STUDY_QOI_RTOL
from multilatin.study.runner import run_study

PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]
Component = tuple[np.ndarray, list[np.ndarray], np.ndarray]


def components(operators: LatinOperators, chains: bool) -> list[Component]:
    """Per component: its points, the map F⁰ ↦ F̂ per field component, k at its points."""
    points = operators.points
    a, b = points.pairs
    k = operators.search_direction
    node = cross_points.tied_nodes(points)  # a point's node of the discrete problem

    def site(p: int) -> tuple[int, tuple[float, ...]]:  # its substructure's node
        return int(points.substructure[p]), tuple(np.round(points.coords[p], 6).tolist())

    grouped: dict[Any, list[int]] = {}
    for j in range(a.size):
        grouped.setdefault(node(int(a[j])), []).append(j)
    held = ((points.pair_held_side >= 0).any(axis=1) if points.pair_held_side.size
            else np.zeros(a.size, dtype=bool))
    out = []
    for pairs in grouped.values():
        members = sorted({int(p) for j in pairs for p in (a[j], b[j])})
        nodes = sorted({site(p) for p in members})
        if len(pairs) < 2 or held[pairs].any() or (chains and len(pairs) >= len(nodes)):
            continue
        where = {p: i for i, p in enumerate(members)}
        opposite = np.zeros((len(pairs), len(members)))
        for r, j in enumerate(pairs):
            opposite[r, where[a[j]]] = opposite[r, where[b[j]]] = 1.0
        totals = np.zeros((len(nodes), len(members)))
        for p in members:
            totals[nodes.index(site(p)), where[p]] = 1.0
        constraints = np.vstack([opposite, totals])
        maps = []
        for d in range(2):
            weights = np.diag(k[members, d])
            maps.append(np.eye(len(members)) - weights @ constraints.T @ np.linalg.pinv(
                constraints @ weights @ constraints.T) @ np.vstack([opposite,
                                                                    np.zeros_like(totals)]))
        out.append((np.array(members), maps, k[members]))
    return out


def communicating(found: list[Component]) -> Any:
    """``LocalStage.without_contact`` with the components' nodes in common."""
    original = LocalStage.without_contact

    def without_contact(self: LocalStage, displacement: np.ndarray, force: np.ndarray,
                        first: Any = None) -> tuple[np.ndarray, np.ndarray]:
        w_hat, f_hat = original(self, displacement, force, first)
        for members, maps, k in found:
            w, f = displacement[:, :, members], force[:, :, members]
            shared = ((k * w).sum(axis=2) - f.sum(axis=2)) / k.sum(axis=0)
            start = f + k * (shared[:, :, None, :] - w)
            for d in range(2):
                f_hat[:, :, members, d] = start[..., d] @ maps[d].T
            w_hat[:, :, members] = shared[:, :, None, :]
        return w_hat, f_hat

    return without_contact


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=["b3", "b1-9"])
    parser.add_argument("--chains", action="store_true")
    parser.add_argument("--study", action="store_true")
    parser.add_argument("--qoi", action="store_true", help="stop on the studies' QoI rule")
    args = parser.parse_args()
    if args.study:
        study(args.chains)
        return
    tight = LatinOptions(tol=1e-10, max_iter=20000)
    original = LocalStage.without_contact
    print("| model | μ1, μ2 | components (points) | library: iterations, R_stop error | "
          "one node per cross point |")
    print("|---|---|---|---|---|")
    for name in args.models:
        model = ml.load_model(name)
        for mu1, mu2 in PAIRS:
            assembly = model.assemble({"mu1": mu1, "mu2": mu2})
            operators = LatinOperators(assembly, LatinOptions())
            found = components(operators, args.chains)
            exact = float(solve_latin(assembly, tight, operators=operators).qoi["R_stop"])
            cells = []
            try:
                for stage in (original, communicating(found)):
                    LocalStage.without_contact = stage  # type: ignore[method-assign]
                    options = (LatinOptions(qoi_rtol=STUDY_QOI_RTOL) if args.qoi
                               else LatinOptions())
                    result = solve_latin(assembly, options, operators=operators, check=False)
                    error = abs(float(result.qoi["R_stop"]) - exact) / max(abs(exact), 1.0)
                    cells.append(f"{result.iterations}"
                                 f"{'' if result.converged else ' (not converged)'}, "
                                 f"{error:.1e}")
            finally:
                LocalStage.without_contact = original  # type: ignore[method-assign]
            sizes = sorted({len(c[0]) for c in found})
            print(f"| {name} | {mu1:g}, {mu2:g} | {len(found)} ({', '.join(map(str, sizes))}) "
                  f"| {cells[0]} | {cells[1]} |", flush=True)


def study(chains: bool) -> None:
    """``--study``: B3's 5 × 5 positions with the library's local stage, then the wrapper's
    (the interfaces, so the components, are the same at every hole position)."""
    model = ml.load_model("b3")
    grid = ml.Grid.parse(["xc=23:27:5", "yc=73:77:5", "rc=3"])
    found = components(LatinOperators(model.assemble({}), LatinOptions()), chains)
    original = LocalStage.without_contact
    try:
        for label, stage in (("library", original), ("one node per cross point",
                                                      communicating(found))):
            LocalStage.without_contact = stage  # type: ignore[method-assign]
            with tempfile.TemporaryDirectory() as folder:
                data = run_study(model, grid, out=folder, progress=False).dataset
            iterations = int(data.sel(mode="multiresolution")["iterations"].values.sum())
            print(f"B3 5 x 5 positions, {label}: {iterations} iterations", flush=True)
    finally:
        LocalStage.without_contact = original  # type: ignore[method-assign]


if __name__ == "__main__":
    main()
