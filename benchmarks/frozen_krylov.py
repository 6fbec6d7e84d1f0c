"""Experiment (issue 15, item 3: "a Krylov method on the fixed point once the contact status
stops changing"; docs/convergence.md): GMRES on the LATIN fixed point s = G(s) with the
contact statuses frozen, in an active-set loop that freezes them again after each solve.

    python benchmarks/frozen_krylov.py              # b1, b1-9, b3 at the four pairs
    python benchmarks/frozen_krylov.py b1 -v        # with each outer step
    python benchmarks/frozen_krylov.py --warm       # warm, along B1's μ2 line at μ1 = 0.3

The local stage is piecewise affine in (W, F); ``local_stage.BranchTape`` records the
branches it takes (contact or open, stop closed, stick or slip and its direction) at the
current iterate and replays them, which makes G affine: G_f(s) = A s + c. Each outer step
solves (I − A) s = c by restarted GMRES in the indicator's inner product (one evaluation of
G_f per product, i.e. one LATIN iteration) from the current iterate, to a forcing term θ
times its initial residual, then evaluates the true G there (new statuses) until η < 3e-6.
It starts after relaxed iterations have brought η below 1e-3. Printed per case: relaxed
iterations (this stand-in's, to the default tolerance), the iteration of the last status
change in that relaxed run, and evaluations of G (relaxed + frozen, outer steps) for θ =
0.1 and 0.01. ``--warm``: the active-set loop started at once (θ = 0.1) from the linear stage
of the tight (η < 1e-9) fields of the case one step lower in μ2, as they are and retimed
(``study.retiming``, with the case two steps lower), along B1's μ2 line at μ1 = 0.3.

The stand-in runs the diagonal search direction (``micro_stiffening`` = 1, session 14's and
before): its local stage is point-wise, what ``LocalStage`` computes and the tape records.
The default two-scale direction (session 15) has a coupled local stage on contacts
(``two_scale.coupled_local_stage``), which this stand-in does not call: with it, G is not
the solver's iteration and the relaxed loop stalls at η ≈ 0.2 (found in session 34).
"""

from __future__ import annotations

import sys
from collections.abc import Callable

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOperators, LatinOptions, solve_latin_batch
from multilatin.latin.engine import indicator_weights, norms
from multilatin.latin.local_stage import BranchTape, LocalStage

PAIRS = ((0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15))
SWITCH = 1e-3
CAP = 2000


def gmres(matvec: Callable[[np.ndarray], np.ndarray], rhs: np.ndarray, x0: np.ndarray,
          forcing: float, dot: Callable[[np.ndarray, np.ndarray], float], restart: int = 60,
          maxiter: int = 400) -> tuple[np.ndarray, int]:
    """Restarted GMRES (modified Gram–Schmidt) in the inner product ``dot``, until the
    residual is ``forcing`` times the first one; returns x and the products used."""
    x = x0.copy()
    count = 0
    target = None
    while count < maxiter:
        r = rhs - matvec(x)
        count += 1
        beta = np.sqrt(dot(r, r))
        target = forcing * beta if target is None else target
        if beta <= target:
            break
        basis = [r / beta]
        h = np.zeros((restart + 1, restart))
        y = np.zeros(0)
        residual = beta
        for j in range(restart):
            v = matvec(basis[j])
            count += 1
            for i in range(j + 1):
                h[i, j] = dot(v, basis[i])
                v = v - h[i, j] * basis[i]
            h[j + 1, j] = np.sqrt(dot(v, v))
            e1 = np.zeros(j + 2)
            e1[0] = beta
            y = np.linalg.lstsq(h[:j + 2, :j + 1], e1, rcond=None)[0]
            residual = float(np.linalg.norm(h[:j + 2, :j + 1] @ y - e1))
            if residual <= target or h[j + 1, j] == 0.0 or count >= maxiter:
                break
            basis.append(v / h[j + 1, j])
        x = x + sum((c * v for c, v in zip(y, basis, strict=False)), np.zeros_like(x))
        if residual <= target:
            break
    return x, count


class FixedPoint:
    """G(s) = linear(local(s)) of one case on flat s = (W, F), with η and a counter."""

    def __init__(self, name: str, mu1: float, mu2: float) -> None:
        assembly = ml.load_model(name).assemble({"mu1": mu1, "mu2": mu2})
        self.options = LatinOptions(micro_stiffening=1.0)  # module docstring
        self.ops = ops = LatinOperators(assembly, self.options)
        pts = ops.points
        k = ops.search_direction
        self.local = LocalStage([assembly], [pts], k, compiled=False,
                                macro_only=ops.macro_only)
        n_steps = assembly.n_steps
        prescribed = self.local.prescribed_force_field(pts.n_points)
        self.macro_data = (ops.project @ prescribed.reshape(n_steps, -1).T).T
        self.dw, self.fw = indicator_weights(pts.weights, k)
        self.shape = (1, n_steps, pts.n_points, 2)
        self.n = int(np.prod(self.shape))
        self.weight = np.concatenate([np.tile(self.dw, n_steps), np.tile(self.fw, n_steps)])
        self.count = 0

    def __call__(self, x: np.ndarray) -> tuple[np.ndarray, float]:
        self.count += 1
        n, shape, pts = self.n, self.shape, self.ops.points
        w, f = x[:n].reshape(shape), x[n:].reshape(shape)
        w_hat, f_hat = self.local(w, f)
        w_new, f_new = self.ops.micro_stage(w_hat.reshape(-1, pts.n_points, 2),
                                            f_hat.reshape(-1, pts.n_points, 2))
        self.ops.macro_correction(w_new, f_new, self.macro_data)
        gap = norms(self.dw, self.fw, w - w_hat, f - f_hat)
        size = 0.5 * (norms(self.dw, self.fw, w, f) + norms(self.dw, self.fw, w_hat, f_hat))
        eta = float(gap[0] / size[0]) if size[0] > 0 else 1.0
        return np.concatenate([w_new.ravel(), f_new.ravel()]), eta

    def dot(self, a: np.ndarray, b: np.ndarray) -> float:
        return float(np.sum(a * b * self.weight))


def relaxed(name: str, mu1: float, mu2: float) -> tuple[int, int]:
    """Today's relaxed iteration from zero: iterations to η < tol, last status change."""
    g = FixedPoint(name, mu1, mu2)
    x = np.zeros(2 * g.n)
    previous: BranchTape | None = None
    last = 0
    omega = g.options.relaxation
    while g.count < CAP:
        tape = BranchTape()
        g.local.tape = tape
        new, eta = g(x)
        if previous is not None and not previous.same_statuses(tape):
            last = g.count
        previous = tape
        if g.count > 1 and eta < g.options.tol:
            break
        x = new if g.count == 1 else omega * new + (1 - omega) * x
    return g.count, last


def frozen_krylov(name: str, mu1: float, mu2: float, forcing: float, verbose: bool
                  ) -> tuple[int, int, int, float]:
    """Relaxed iterations to η < SWITCH, then the active-set loop of frozen GMRES solves:
    (relaxed evaluations, frozen evaluations, outer steps, final η)."""
    g = FixedPoint(name, mu1, mu2)
    x = np.zeros(2 * g.n)
    omega = g.options.relaxation
    while g.count < CAP:
        new, eta = g(x)
        if eta < SWITCH:
            break
        x = new if g.count == 1 else omega * new + (1 - omega) * x
    first = g.count
    x, outer, eta = active_set(g, x, forcing, verbose)
    return first, g.count - first, outer, eta


def active_set(g: FixedPoint, x: np.ndarray, forcing: float, verbose: bool = False
               ) -> tuple[np.ndarray, int, float]:
    """The active-set loop from ``x``: freeze the statuses there, solve the frozen affine
    map by GMRES to ``forcing``, freeze again, until η < the tolerance (or ``CAP``
    evaluations); returns the iterate, the outer steps and the final η."""
    outer = 0
    tape = BranchTape()
    g.local.tape = tape
    _, eta = g(x)
    while eta >= g.options.tol and g.count < CAP:
        outer += 1
        tape.replay()
        c = g(np.zeros_like(x))[0]
        x, used = gmres(lambda v, c=c: v - (g(v)[0] - c), c, x, forcing, g.dot)
        previous, tape = tape, BranchTape()
        g.local.tape = tape
        _, eta = g(x)
        if verbose:
            changes = sum(int(np.sum(a != b))
                          for a, b in zip(previous.entries, tape.entries, strict=False)
                          if a.dtype == np.bool_)
            print(f"    outer {outer}: {used} products, then eta {eta:.2e}, "
                  f"{changes} status changes")
    return x, outer, eta


def warm() -> None:
    """``--warm`` (module docstring): evaluations of G and outer steps per case and start."""
    from multilatin.study.retiming import retimed_fields

    model, values = ml.load_model("b1"), np.round(np.linspace(0.0, 0.6, 13), 10)
    tight = solve_latin_batch([model.assemble({"mu1": 0.3, "mu2": v}) for v in values],
                                 LatinOptions(micro_stiffening=1.0, tol=1e-9, max_iter=5000))
    fields = [(r.interface.displacement_hat, r.interface.force_hat)  # type: ignore[union-attr]
              for r in tight]
    print("| μ2 | from the nearest: evaluations (outer) | retimed |")
    print("|---|---|---|")
    for j in range(2, 13):
        cells = []
        for start in (fields[j - 1], retimed_fields(fields[j - 1], fields[j - 2])
                      or fields[j - 1]):
            g = FixedPoint("b1", 0.3, float(values[j]))
            pts = g.ops.points
            w, f = g.ops.micro_stage(start[0].reshape(-1, pts.n_points, 2),
                                     start[1].reshape(-1, pts.n_points, 2))
            g.ops.macro_correction(w, f, g.macro_data)
            _, outer, _ = active_set(g, np.concatenate([w.ravel(), f.ravel()]), 0.1)
            cells.append(f"{g.count} ({outer})")
        print(f"| {values[j]:g} | {cells[0]} | {cells[1]} |", flush=True)


def main() -> None:
    if "--warm" in sys.argv:
        warm()
        return
    verbose = "-v" in sys.argv
    names = [a for a in sys.argv[1:] if a != "-v"] or ["b1", "b1-9", "b3"]
    print("| model | μ1, μ2 | relaxed (today) | last status change | frozen GMRES, θ = 0.1 "
          "| frozen GMRES, θ = 0.01 |")
    print("|---|---|---|---|---|---|")
    for name in names:
        for mu1, mu2 in PAIRS:
            plain, last = relaxed(name, mu1, mu2)
            cells = []
            for forcing in (0.1, 0.01):
                first, frozen, outer, eta = frozen_krylov(name, mu1, mu2, forcing, verbose)
                flag = "" if eta < LatinOptions().tol else f", η {eta:.1e}: not converged"
                cells.append(f"{first} + {frozen} = {first + frozen} ({outer} outer{flag})")
            print(f"| {name} | {mu1:g}, {mu2:g} | {plain} | {last} | " + " | ".join(cells)
                  + " |", flush=True)


if __name__ == "__main__":
    main()
