"""Where the slow tail of the LATIN iteration lives: the dominant modes of the fixed point.

    python benchmarks/tail_modes.py [--models b1 b1-4 b1-9] [--window 40] [--modes 3]
    python benchmarks/tail_modes.py --models b1-9 --point 50 50 --step 13
    python benchmarks/tail_modes.py --models b1-9 --pairs 0.1,0.3 --at 33.333 100 --each-pair

Near convergence the contact statuses settle and the iteration s ↦ s' (linear stage, then
relaxation, then local stage) is affine, so the differences d_n = s_{n+1} − s_n of its
iterates follow d_{n+1} = G d_n. A dynamic-mode decomposition of the last ``--window``
differences before the default tolerance (in the indicator's norm, ∫ k W·W + k⁻¹ F·F)
estimates eigenvalues of G (the convergence rate per iteration of the tail) and their
modes. For each case this prints the eigenvalues of the modes that make up most of the last
difference and, for the first of them, their share in W and F, the load steps and the
interface points that carry them. With ``--point X Y --step T``, it also follows the contact
pair at (X, Y) in step T over the last ``--window`` iterations, in the same solve: ŝ's
normal force N and |F_T| / μ|N| (1: slip). With ``--at X Y``: the first mode's F at every
interface point at (X, Y), in its busiest step, beside the converged F there (a cross
point's forces, point by point); ``--each-pair``: the contact pairs of a cross point each
on its own (``cross_points.MERGE`` off, the rule before session 35); ``--pairs``: the
friction pairs (default: three of ``convergence.py``'s); ``--defaults``: any model once, at
its parameters' defaults (``--models lap --defaults --window 26``: session 49); ``--set
gap=0``: other parameters for every case (session 55); ``--kappa``: the search
direction's κ (session 58: the sliding block at κ = 0.1).
Uses only the solver's own iteration (``solve_latin(observer=...)``) and local stage.
"""

from __future__ import annotations

import argparse

import numpy as np

import multilatin as ml
from multilatin.decomposition.assembly import Assembly
from multilatin.latin import LatinOperators, cross_points, solve_latin
from multilatin.latin.local_stage import LocalStage

CASES = ((0.3, 0.0), (0.1, 0.3), (0.3, 0.15))


def dominant_modes(states: np.ndarray, rank_tol: float = 1e-6
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues and modes (columns) of the linear map that takes each difference of
    consecutive ``states`` (rows) to the next one (exact DMD), ordered by their share of
    the last difference (what the iteration is still changing at the end)."""
    differences = np.diff(states, axis=0).T
    before, after = differences[:, :-1], differences[:, 1:]
    u, sigma, vt = np.linalg.svd(before, full_matrices=False)
    rank = int(np.sum(sigma > rank_tol * sigma[0]))
    u, sigma, vt = u[:, :rank], sigma[:rank], vt[:rank]
    reduced = u.T @ after @ vt.T / sigma
    values, vectors = np.linalg.eig(reduced)
    modes = after @ vt.T / sigma @ vectors
    modes /= np.linalg.norm(modes, axis=0)
    amplitude = np.abs(np.linalg.lstsq(modes, differences[:, -1], rcond=None)[0])
    order = np.argsort(-amplitude)
    return values[order], modes[:, order]


class PairTrace:
    """ŝ at the contact pair at ``point`` in ``step`` (from 1), iteration after iteration:
    the local stage applied to each s the solver shows its observer."""

    def __init__(self, assembly: Assembly, operators: LatinOperators, point: list[float],
                 step: int) -> None:
        points = operators.points
        side_a = points.contact_pairs[0]
        found = np.flatnonzero(np.all(np.isclose(points.coords[side_a], point), axis=1))
        if not found.size:
            raise SystemExit(f"--point: no contact pair at {point}")
        if not 1 <= step <= assembly.n_steps:
            raise SystemExit(f"--step: expected 1 to {assembly.n_steps}, got {step}")
        self.point, self.step = point, step
        self.index = int(side_a[found[0]])
        self.normal = points.normals[self.index]
        self.friction = float(points.contact_friction[found[0]])
        self.local = LocalStage([assembly], [points], operators.search_direction,
                                macro_only=operators.macro_only)
        self.rows: list[tuple[int, float, float]] = []

    def __call__(self, iteration: int, w: np.ndarray, f: np.ndarray) -> None:
        force = self.local(w.copy(), f.copy())[1][0, self.step - 1, self.index]
        normal_force = float(force @ self.normal)
        tangential = float(np.linalg.norm(force - normal_force * self.normal))
        self.rows.append((iteration, normal_force,
                          tangential / max(self.friction * abs(normal_force), 1e-300)))

    def report(self, window: int) -> None:
        print(f"  contact pair at ({self.point[0]:g}, {self.point[1]:g}), step {self.step}, "
              f"μ = {self.friction:g}:")
        for iteration, normal_force, ratio in self.rows[-window::4]:
            print(f"    iteration {iteration}: N = {normal_force:.3f}, "
                  f"|F_T| / μ|N| = {ratio:.3f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=["b1", "b1-4", "b1-9"])
    parser.add_argument("--window", type=int, default=40)
    parser.add_argument("--modes", type=int, default=3)
    parser.add_argument("--point", type=float, nargs=2, help="a contact pair to follow")
    parser.add_argument("--step", type=int, default=13, help="its load step (from 1)")
    parser.add_argument("--at", type=float, nargs=2, help="a cross point to read")
    parser.add_argument("--each-pair", action="store_true",
                        help="a cross point's contact pairs each on its own")
    parser.add_argument("--pairs", nargs="+", default=None, help="μ1,μ2 pairs")
    parser.add_argument("--rigid-balance", action="store_true",
                        help="LatinOptions(rigid_balance=True): the tail that is left")
    parser.add_argument("--set", nargs="+", default=[], metavar="NAME=VALUE",
                        help="other parameters for every case (--set gap=0: session 55)")
    parser.add_argument("--defaults", action="store_true",
                        help="each model once, at its parameters' defaults (any model)")
    parser.add_argument("--kappa", type=float, default=ml.LatinOptions().kappa,
                        help="the search direction's κ (--models slide --defaults --kappa "
                             "0.1: session 58)")
    args = parser.parse_args()
    for item in args.set:
        name, _, value = item.partition("=")
        try:
            float(value)
        except ValueError:
            parser.error(f"--set {item!r}: expected NAME=VALUE with a number")
    if args.each_pair:
        cross_points.MERGE = False
    cases: list[tuple[float, ...]] = (
        [()] if args.defaults else list(CASES) if args.pairs is None else
        [tuple(float(x) for x in pair.split(",")) for pair in args.pairs])
    options = ml.LatinOptions(rigid_balance=args.rigid_balance, kappa=args.kappa)
    for name in args.models:
        model = ml.load_model(name)
        for pair in cases:
            values = {**dict(zip(("mu1", "mu2"), pair, strict=False)),
                      **{k: float(v) for k, v in (item.split("=") for item in args.set)}}
            assembly = model.assemble(values)
            operators = LatinOperators(assembly, options)
            points = operators.points
            k = operators.search_direction
            scale_w = np.sqrt(points.weights[:, None] * k)
            scale_f = np.sqrt(points.weights[:, None] / k)
            states: list[np.ndarray] = []
            trace = (PairTrace(assembly, operators, args.point, args.step)
                     if args.point is not None else None)

            def record(iteration: int, active: np.ndarray, w: np.ndarray, f: np.ndarray,
                       scale_w: np.ndarray = scale_w, scale_f: np.ndarray = scale_f,
                       states: list[np.ndarray] = states,
                       trace: PairTrace | None = trace) -> None:
                states.append(np.concatenate([(w[0] * scale_w).ravel(),
                                              (f[0] * scale_f).ravel()]))
                if trace is not None:
                    trace(iteration, w, f)

            result = solve_latin(assembly, operators=operators, observer=record, check=False)
            window = np.array(states[-args.window - 1:])
            values, vectors = dominant_modes(window)
            at = f"(μ1, μ2) = ({pair[0]:g}, {pair[1]:g})" if pair else "its defaults"
            print(f"\n{name} at {at}: {result.iterations} iterations; "
                  f"eigenvalues (largest share of the last change first): "
                  + ", ".join(f"{v.real:.3f}" + (f"{v.imag:+.3f}i" if abs(v.imag) > 1e-3
                                                   else "") for v in values[:6]))
            n_steps, n_points = assembly.n_steps, points.n_points
            for j in range(min(args.modes, values.size)):
                mode = np.abs(vectors[:, j]) ** 2
                mode /= mode.sum()
                w_part, f_part = (part.reshape(n_steps, n_points, 2)
                                  for part in np.split(mode, 2))
                busiest = np.argsort(-(w_part + f_part).sum(axis=(1, 2)))[:3] + 1
                per_point = (w_part + f_part).sum(axis=(0, 2))
                top = np.argsort(-per_point)[:4]
                where = "; ".join(
                    f"({points.coords[p][0]:.1f}, {points.coords[p][1]:.1f}) "
                    f"{assembly.interfaces[points.interface[p]].name} "
                    f"{per_point[p]:.0%}" for p in top)
                print(f"  mode {j + 1}, eigenvalue {values[j].real:.3f}: F {f_part.sum():.0%}, "
                      f"W {w_part.sum():.0%}; steps {', '.join(map(str, busiest))}; {where}")
            if trace is not None:
                trace.report(args.window)
            if args.at is not None:
                at_point(assembly, points, vectors[:, 0], args.at, scale_f, states)


def at_point(assembly: Assembly, points: object, mode: np.ndarray, at: list[float],
             scale_f: np.ndarray, states: list[np.ndarray]) -> None:
    """``--at``: the mode's F (normalised to its largest entry) at the points at ``at``."""
    n_steps, n_points = assembly.n_steps, points.n_points  # type: ignore[attr-defined]
    mode = mode / mode[np.argmax(np.abs(mode))]
    w_part, f_part = (np.real(x).reshape(n_steps, n_points, 2) for x in np.split(mode, 2))
    f_part = f_part / scale_f[None]  # back to force units
    final = (states[-1][n_steps * n_points * 2:].reshape(n_steps, n_points, 2)
             / scale_f[None])
    step = int(np.argmax(np.abs(f_part).sum(axis=(1, 2))))
    coords = points.coords  # type: ignore[attr-defined]
    near = np.flatnonzero(np.hypot(coords[:, 0] - at[0], coords[:, 1] - at[1]) < 1e-2)
    print(f"  at ({at[0]:g}, {at[1]:g}), step {step + 1}: the mode's F (its units) and the "
          f"converged F at each point")
    for p in near:
        itf = assembly.interfaces[points.interface[p]].name  # type: ignore[attr-defined]
        sub = assembly.substructures[points.substructure[p]].name  # type: ignore[attr-defined]
        print(f"    {itf:26s} on {sub:12s} mode F ({f_part[step, p, 0]:+8.2f}, "
              f"{f_part[step, p, 1]:+8.2f})  F ({final[step, p, 0]:+8.2f}, "
              f"{final[step, p, 1]:+8.2f})")


if __name__ == "__main__":
    main()
