"""A two-scale search direction whose macro part follows the contact statuses, per load
step and contact interface (issue 15, session 27): a prototype, outside the library.

    python benchmarks/status_direction.py [--soft 0.5]

Session 27 found that a softer macro part on contact sides speeds B1's slides and slows
the cases where those sides stick (``soft_directions.py``). Here the macro part (k on the
constant and linear functions of each side, ``two_scale``) is multiplied by ``--soft`` only
where and when the local stage fixes the force: on an interface's tangent at the load steps
where at least 90 % of its closed pairs slip, on both components where all its pairs are
open; on a (frictionless) stop's tangent always, its normal too while it is open. The
statuses are read from ŝ after every local stage ("dynamic"), or taken from the tightly
converged solution ("oracle"). Each load step's columns of the linear stage then take the
operators of their pattern of statuses (built once per pattern), and the coupled local
stage takes each row's G: the fixed point is unchanged (the R_stop errors against η <
1e-10 in the table show it). It wraps
``iteration.make_engine`` and ``operators.two_scale_direction``; the library is not
changed. Prints, per case (cold, or warm from the tightly converged neighbour at the third
number), the iterations to η < 1e-6 with today's direction ("off") and the two others, and
R_stop's relative error against η < 1e-10.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

import numpy as np

import multilatin as ml
from multilatin.fem.mesh import normal_axis
from multilatin.latin import LatinOptions, iteration, operators, solve_latin
from multilatin.latin.engine import NumpyFields
from multilatin.latin.two_scale import coupled_local_stage

#: (model, μ1, μ2, the neighbour's μ2 for a warm start or None)
CASES = [("b1", 0.3, 0.1, None), ("b1", 0.1, 0.3, None), ("b1", 0.35, 0.25, None),
         ("b1", 0.3, 0.1, 0.05), ("b1-9", 0.3, 0.15, None), ("b1-9", 0.35, 0.25, None),
         ("b1-9", 0.3, 0.1, 0.05), ("b3", 0.1, 0.3, None), ("b3", 0.35, 0.25, None)]
TIGHT = LatinOptions(tol=1e-10, max_iter=20_000)


class StatusDirection:
    """The operators per pattern of statuses of one assembly, and the patterns of ŝ."""

    def __init__(self, assembly: Any, soft: float) -> None:
        self.assembly, self.soft = assembly, soft
        self.contacts = [i for i, itf in enumerate(assembly.interfaces) if itf.contact]
        self.built: dict[tuple[int, ...], operators.LatinOperators] = {}
        self.current: tuple[int, ...] = ()
        self.base = self.operators(tuple(0 for _ in self.contacts))
        points = self.base.points
        self.points = points
        self.pair_interface = points.interface[points.contact_pairs[0]]
        self.stop_interface = points.interface[points.stops]

    def direction(self, original: Callable[..., Any]) -> Callable[..., Any]:
        """``two_scale_direction`` with the macro part softened as ``current`` says."""
        def wrapped(assembly: Any, points: Any, k: Any, stiff: Any) -> Any:
            k = k.copy()
            for i, code in zip(self.contacts, self.current, strict=True):
                interface = assembly.interfaces[i]
                normal = normal_axis(interface.sides[0].side)
                for side in range(len(interface.sides)):
                    at = points.side_points[(i, side)]
                    if code >= 1:
                        k[at, 1 - normal] *= self.soft
                    if code == 2:
                        k[at, normal] *= self.soft
            return original(assembly, points, k, stiff)
        return wrapped

    def operators(self, pattern: tuple[int, ...]) -> operators.LatinOperators:
        if pattern not in self.built:
            original = operators.two_scale_direction
            self.current = pattern
            operators.two_scale_direction = self.direction(original)  # type: ignore[assignment]
            try:
                self.built[pattern] = operators.LatinOperators(self.assembly, LatinOptions())
            finally:
                operators.two_scale_direction = original
        return self.built[pattern]

    def patterns(self, f_hat: np.ndarray) -> np.ndarray:
        """Per row (case × step) and contact interface: 0 stick or closed, 1 slip (soft
        tangent), 2 open (soft tangent and normal)."""
        points = self.points
        rows = f_hat.reshape(-1, points.n_points, 2)
        out = np.zeros((rows.shape[0], len(self.contacts)), dtype=np.int64)
        for j, i in enumerate(self.contacts):
            interface = self.assembly.interfaces[i]
            stop = interface.kind != "contact"
            chosen = (points.stops[self.stop_interface == i] if stop
                      else points.contact_pairs[0][self.pair_interface == i])
            normals = points.normals[chosen]
            normal = np.einsum("rpk,pk->rp", rows[:, chosen], normals)
            closed = normal < -1e-9 * max(float(np.abs(normal).max(initial=0.0)), 1e-300)
            if stop:
                out[:, j] = np.where(closed.any(axis=1), 1, 2)
                continue
            tangent = rows[:, chosen] - normal[..., None] * normals
            slip = closed & (np.linalg.norm(tangent, axis=2)
                             >= (1 - 1e-6) * interface.contact.friction * np.abs(normal))
            mostly = slip.sum(axis=1) >= 0.9 * np.maximum(closed.sum(axis=1), 1)
            out[:, j] = np.where(~closed.any(axis=1), 2, np.where(mostly, 1, 0))
        return out


class PerRowDirection:
    """What ``coupled_local_stage`` asks of a direction, with each row's G."""

    def __init__(self, directions: list[Any], rows: list[np.ndarray]) -> None:
        self.first, self.directions, self.rows = directions[0], directions, rows
        self.ratio = min(d.ratio for d in directions)

    def project(self, flat: np.ndarray) -> np.ndarray:
        return np.asarray(self.first.project(flat))

    def gather(self, flat: np.ndarray) -> np.ndarray:
        return np.asarray(self.first.gather(flat))

    def scatter(self, flat: np.ndarray, values: np.ndarray, add: bool = False) -> None:
        self.first.scatter(flat, values, add)

    def expand(self, coordinates: np.ndarray) -> np.ndarray:
        out = np.empty((coordinates.shape[0], self.first.support.size))
        for direction, rows in zip(self.directions, self.rows, strict=True):
            out[rows] = direction.expand(coordinates[rows])
        return out


def engine_class(status: StatusDirection, mode: str, oracle: np.ndarray) -> type:
    class PatternFields(NumpyFields):
        """Per load step the operators of its statuses; ``mode`` "off": today's."""

        patterns: np.ndarray

        def groups(self) -> list[tuple[operators.LatinOperators, np.ndarray]]:
            by: dict[tuple[int, ...], list[int]] = {}
            for row, pattern in enumerate(map(tuple, self.patterns)):
                by.setdefault(pattern, []).append(row)
            return [(status.operators(p), np.array(rows)) for p, rows in by.items()]

        def linear_stage(self, relaxation: np.ndarray) -> None:
            shape, flat = self.w_hat.shape, (-1, status.points.n_points, 2)
            w_hat, f_hat = self.w_hat.reshape(flat), self.f_hat.reshape(flat)
            w_new, f_new = np.empty_like(w_hat), np.empty_like(f_hat)
            assert self.macro_data is not None
            data = self.macro_data.reshape(-1, self.macro_data.shape[2])
            for ops, rows in self.groups():
                w, f = ops.micro_stage(w_hat[rows], f_hat[rows])
                ops.macro_correction(w, f, np.ascontiguousarray(data[rows]))
                w_new[rows], f_new[rows] = w, f
            w_new, f_new = w_new.reshape(shape), f_new.reshape(shape)
            if self.w is None or self.f is None:
                self.w, self.f = w_new, f_new
                return
            omega = relaxation[:, None, None, None]
            self.w = omega * w_new + (1.0 - omega) * self.w
            self.f = omega * f_new + (1.0 - omega) * self.f

        def local_stage(self) -> None:
            groups = self.groups()
            direction = PerRowDirection([ops.two_scale for ops, _ in groups],
                                        [rows for _, rows in groups])
            assert self.side_macro is not None
            self.w_hat, self.f_hat, self.side_macro = coupled_local_stage(
                self.local, self.local.contact_stage, direction, self.w, self.f,
                self.side_macro)
            if mode == "dynamic":
                self.patterns = status.patterns(self.f_hat)

    def make(ops: Any, local: Any, options: Any, w_hat: np.ndarray, f_hat: np.ndarray,
             macro_data: Any, functionals: Any, geometries: Any) -> NumpyFields:
        engine = PatternFields(ops, local, options, w_hat, f_hat, macro_data, functionals,
                               geometries)
        n_rows = w_hat.shape[0] * w_hat.shape[1]
        engine.patterns = (np.tile(oracle, (w_hat.shape[0], 1)) if mode == "oracle"
                           else status.patterns(f_hat) if mode == "dynamic"
                           else np.zeros((n_rows, len(status.contacts)), dtype=np.int64))
        return engine

    return make  # type: ignore[return-value]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--soft", type=float, default=0.5)
    args = parser.parse_args()
    print("| model | μ1, μ2 (start) | off: iterations, R_stop error | oracle | dynamic |")
    print("|---|---|---|---|---|")
    original = iteration.make_engine
    for name, mu1, mu2, warm in CASES:
        model = ml.load_model(name)
        assembly = model.assemble({"mu1": mu1, "mu2": mu2})
        tight = solve_latin(assembly, TIGHT)
        initial = None
        if warm is not None:
            before = solve_latin(model.assemble({"mu1": mu1, "mu2": warm}), TIGHT)
            assert before.interface is not None
            initial = (before.interface.displacement_hat, before.interface.force_hat)
        status = StatusDirection(assembly, args.soft)
        assert tight.interface is not None
        oracle = status.patterns(tight.interface.force_hat)
        cells = []
        for mode in ("off", "oracle", "dynamic"):
            iteration.make_engine = engine_class(status, mode, oracle)  # type: ignore[assignment]
            try:
                result = solve_latin(assembly, LatinOptions(tol=1e-6, max_iter=3000),
                                     operators=status.base, check=False, initial=initial)
            finally:
                iteration.make_engine = original
            reference = float(tight.qoi["R_stop"])  # type: ignore[arg-type]
            error = abs(float(result.qoi["R_stop"]) - reference) / max(abs(reference), 1.0)  # type: ignore[arg-type]
            cells.append(f"{result.iterations}{'' if result.converged else ' (not converged)'}"
                         f", {error:.1e}")
        start = f" (from μ2 = {warm})" if warm is not None else ""
        print(f"| {name} | {mu1}, {mu2}{start} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
