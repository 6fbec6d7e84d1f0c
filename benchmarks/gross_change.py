"""Would a "gross" estimate of a force QoI have kept the QoI rule from stopping early?
(session 50; measured, not adopted)

A reaction or a mean pressure is a sum of interface forces, q = Σ_p φ_p F̂_p. The rule's
estimate (``tracking.error_estimates``) reads the increments of q itself; where the forces
redistribute while their sum barely moves, the increments of q hide a change that has not
reached it yet (the roller's Q at step 2, docs/tolerance.md). The gross estimate sums the
estimates of the terms, Σ_p |φ_p| e(F̂_p) — a bound by the triangle inequality where each
term converges as estimated.

``--trace``: the roller at (μ, shift) = (0.5, 0.02), Q at step 2, per 20 iterations: its
error, net |Δq| and gross Σ|φ_p ΔF̂_p| over one iteration. Default: per case stopped by the
studies' rule (cold, κ = 0.5), each force QoI's error, net and gross estimates at the stop,
relative to the rule's bound 1e-3 × max(|q|, 1 % of its largest magnitude), worst over the
steps it reports (both estimates read on the rule's own iterates, with η's rate, as
``error_estimates``; jumps not treated apart).

    python benchmarks/gross_change.py [--trace]
"""

from __future__ import annotations

import argparse

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOperators, engine, solve_latin
from multilatin.latin.options import STUDY_QOI_RTOL
from multilatin.latin.tracking import error_estimates, qoi_functionals

RECORDED: list[tuple[np.ndarray, np.ndarray]] = []
CASES = [("roller", {"mu": 0.5, "shift": 0.02}), ("roller", {"mu": 0.3, "shift": 0.04}),
         ("b1", {"mu1": 0.3, "mu2": 0.0}), ("b1", {"mu1": 0.1, "mu2": 0.3}),
         ("b1", {"mu1": 0.35, "mu2": 0.25}), ("b1", {"mu1": 0.3, "mu2": 0.15}),
         ("b1-9", {"mu1": 0.3, "mu2": 0.15}), ("b3", {"mu1": 0.3, "mu2": 0.15}),
         ("lap", {}), ("punch", {}), ("slide", {}), ("lug", {})]


def _record() -> None:
    """Keep every iteration's tracked QoIs and F̂ of the first case."""
    original = engine.NumpyFields.qoi_values

    def recorded(self: engine.NumpyFields) -> np.ndarray:
        values = original(self)
        RECORDED.append((values[0].copy(), self.fields()[3][0].copy()))
        return values

    engine.NumpyFields.qoi_values = recorded  # type: ignore[method-assign]


def trace() -> None:
    model = ml.load_model("roller")
    mu = {"mu": 0.5, "shift": 0.02}
    assembly = model.assemble(mu)
    options = ml.LatinOptions(tol=1e-14, max_iter=440)
    ops = LatinOperators(assembly, options)
    functional = qoi_functionals(ops, assembly, ops.points)
    i = functional.names.index("Q")
    coefficients = functional.on_f_hat[i][None]  # Q reads F̂ alone
    exact = float(np.atleast_1d(model.reference(mu).qoi["Q"])[1])
    RECORDED.clear()
    solve_latin(assembly, options, operators=ops, check=False)
    terms = np.array([(coefficients * f_hat[1]).ravel() for _, f_hat in RECORDED])
    print("| iteration | error of Q at step 2 (N) | net change | gross change | gross / net |")
    print("|---|---|---|---|---|")
    for n in range(100, len(RECORDED), 20):
        net = terms[n].sum() - terms[n - 1].sum()
        gross = np.abs(terms[n] - terms[n - 1]).sum()
        print(f"| {n + 1} | {terms[n].sum() - exact:+.4f} | {net:+.2e} | {gross:.2e} | "
              f"{gross / abs(net):.1f} |")


def case_rows() -> None:
    print("| model | case | QoI | iterations | error / bound | net estimate / bound | "
          "gross estimate / bound |")
    print("|---|---|---|---|---|---|---|")
    for name, mu in CASES:
        model = ml.load_model(name)
        assembly = model.assemble(mu)
        options = ml.LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
        ops = LatinOperators(assembly, options)
        functional = qoi_functionals(ops, assembly, ops.points)
        tight = solve_latin(assembly, ml.LatinOptions(tol=1e-11, max_iter=20000),
                            operators=ops)
        RECORDED.clear()
        ruled = solve_latin(assembly, options, operators=ops, check=False)
        series = np.array([values for values, _ in RECORDED])
        f_hat = np.array([f for _, f in RECORDED])
        eta = np.asarray(ruled.history)[-series.shape[0]:, None, None]
        reported = functional.reported(assembly.n_steps)
        for i, qoi in enumerate(functional.names):
            coefficients = functional.on_f_hat[i].reshape(-1)
            if (np.any(functional.on_w[i]) or np.any(functional.on_f[i])
                    or not np.any(coefficients)):
                continue  # not a sum of forces (a displacement)
            used = np.flatnonzero(coefficients)
            terms = (f_hat.reshape(*f_hat.shape[:2], -1)[:, :, used]
                     * coefficients[used]).transpose(0, 2, 1)  # (n, terms, steps)
            net = error_estimates(series[:, i:i + 1], eta)[0]
            gross = error_estimates(terms, eta).sum(axis=0)
            exact = (np.atleast_1d(np.asarray(tight.qoi[qoi], dtype=float))
                     if functional.steps[i] is None
                     else np.full(assembly.n_steps, float(tight.qoi[qoi])))
            mask = reported[i]
            scale = np.maximum(np.abs(exact), 1e-2 * np.abs(exact[mask]).max())
            bound = STUDY_QOI_RTOL * scale
            error = np.abs(series[-1, i] - exact)
            print(f"| {name} | {', '.join(f'{v:g}' for v in mu.values()) or 'defaults'} | "
                  f"{qoi} | {ruled.iterations} | {(error / bound)[mask].max():.2f} | "
                  f"{(net / bound)[mask].max():.2f} | {(gross / bound)[mask].max():.2f} |",
                  flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--trace", action="store_true")
    args = parser.parse_args()
    _record()
    trace() if args.trace else case_rows()


if __name__ == "__main__":
    main()
