"""Experiment (issue 15, docs/convergence.md): a Jacobian-free Newton–Krylov solve of the
LATIN fixed point s = G(s), G = linear stage ∘ local stage (one LATIN iteration), started
from relaxed iterations once η < the switch (the contact statuses mostly settled).

    python benchmarks/newton_krylov.py b1

Counts the evaluations of G (each costs one LATIN iteration): relaxed ones, then those of
``scipy.optimize.newton_krylov`` (LGMRES inner solves, finite-difference Jacobian-vector
products), with the residual tolerance matched to η ≈ 3e-6; prints the η reached.
Measured: hundreds of evaluations and frequent stalls — the map is only piecewise affine
(contact statuses), so the finite-difference Newton steps are costly; kept as the record of
a lead that failed as tried. The stand-in map runs the diagonal search direction
(``micro_stiffening`` = 1, the default when this was measured): its local stage is the
point-wise one; with the two-scale direction (session 15) the contacts' local stage is
coupled (``two_scale.coupled_local_stage``) and the stand-in's relaxed loop stalls (found
in session 34, as in ``frozen_krylov.py``).
"""

from __future__ import annotations

import sys
from collections.abc import Callable

import numpy as np
from scipy.optimize import NoConvergence, newton_krylov

import multilatin as ml
from multilatin.decomposition.assembly import Assembly
from multilatin.latin import LatinOperators, LatinOptions
from multilatin.latin.engine import norms as _norms
from multilatin.latin.local_stage import LocalStage

Fields = tuple[np.ndarray, np.ndarray]


def fixed_point_map(assembly: Assembly, options: LatinOptions
                    ) -> tuple[Callable[[np.ndarray, np.ndarray], tuple[Fields, Fields]],
                               Callable[[Fields, Fields], float], tuple[int, ...], list[int]]:
    """G(s) = linear(local(s)) with its local-stage fields, the indicator η, the fields'
    shape and an evaluation counter."""
    ops = LatinOperators(assembly, options)
    pts = ops.points
    k = ops.search_direction
    local = LocalStage([assembly], [pts], k, macro_only=ops.macro_only)
    n_steps = assembly.n_steps
    prescribed = local.prescribed_force_field(pts.n_points)
    macro_data = (ops.project @ prescribed.reshape(n_steps, -1).T).T
    displacement_weight = (pts.weights[:, None] * k).ravel()
    force_weight = (pts.weights[:, None] / k).ravel()
    shape = (1, n_steps, pts.n_points, 2)
    count = [0]

    def evaluate(w: np.ndarray, f: np.ndarray) -> tuple[Fields, Fields]:
        count[0] += 1
        w_hat, f_hat = local(w, f)
        w_new, f_new = ops.micro_stage(w_hat.reshape(-1, pts.n_points, 2),
                                       f_hat.reshape(-1, pts.n_points, 2))
        ops.macro_correction(w_new, f_new, macro_data)
        return (w_new.reshape(shape), f_new.reshape(shape)), (w_hat, f_hat)

    def eta(s: Fields, s_hat: Fields) -> float:
        (w, f), (w_hat, f_hat) = s, s_hat
        gap = _norms(displacement_weight, force_weight, w - w_hat, f - f_hat)
        size = 0.5 * (_norms(displacement_weight, force_weight, w, f)
                      + _norms(displacement_weight, force_weight, w_hat, f_hat))
        return float(gap[0] / size[0])

    return evaluate, eta, shape, count


def main() -> None:
    ml.load_model("b1").solve({"mu1": 0.3, "mu2": 0.0})  # warm-up
    for name in sys.argv[1:] or ["b1"]:
        model = ml.load_model(name)
        for mu1, mu2 in ((0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)):
            assembly = model.assemble({"mu1": mu1, "mu2": mu2})
            cells = []
            for switch in (1e-3, 1e-4):
                options = LatinOptions(micro_stiffening=1.0)  # module docstring
                evaluate, eta, shape, count = fixed_point_map(assembly, options)
                w, f = np.zeros(shape), np.zeros(shape)
                omega = options.relaxation
                while True:  # relaxed LATIN iterations from s = 0
                    (w_new, f_new), s_hat = evaluate(w, f)
                    if eta((w, f), s_hat) < switch or count[0] > 3000:
                        break
                    w = omega * w_new + (1 - omega) * w
                    f = omega * f_new + (1 - omega) * f
                relaxed = count[0]
                n = w.size

                def residual(x: np.ndarray, evaluate: Callable[..., tuple[Fields, Fields]]
                             = evaluate, n: int = n, shape: tuple[int, ...] = shape
                             ) -> np.ndarray:
                    (g_w, g_f), _ = evaluate(x[:n].reshape(shape), x[n:].reshape(shape))
                    return np.concatenate([g_w.ravel() - x[:n], g_f.ravel() - x[n:]])

                start = np.concatenate([w.ravel(), f.ravel()])
                try:
                    x = newton_krylov(residual, start, method="lgmres",
                                      f_tol=3e-6 * np.abs(start).max(), maxiter=60,
                                      inner_maxiter=20)
                except NoConvergence as exc:
                    x = exc.args[0]
                s = (x[:n].reshape(shape), x[n:].reshape(shape))
                _, s_hat = evaluate(*s)
                cells.append(f"switch {switch:g}: {relaxed} relaxed + "
                             f"{count[0] - relaxed - 1} Newton–Krylov evaluations, "
                             f"η {eta(s, s_hat):.1e}")
            print(f"| {name} | {mu1:g}, {mu2:g} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
