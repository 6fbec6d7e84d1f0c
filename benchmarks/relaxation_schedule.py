"""A relaxation that cycles through several values (a polynomial over the cycle against the
relaxation's −1 mode and the slow positive ones), against the constant ω = 0.9: cold b1
solves at the four pairs of ``benchmarks/convergence.py``, default tolerance.

    python benchmarks/relaxation_schedule.py --schedules 0.9 0.6,1.8 0.55,1.9 0.5,2.0
    python benchmarks/relaxation_schedule.py --momentum 0 0.2 0.3 0.4 --omegas 0.9 1

The schedule replaces ω from the second linear stage on (the first is not relaxed), one
value per iteration in turn. Prints iterations (or "no" when not converged within 1 000) and
R_stop per pair. ``--momentum``: instead, a heavy-ball step s_{k+1} = s_k + ω (T(s_k) −
s_k) + β (s_k − s_{k−1}) (T: the unrelaxed linear stage) for each β and ω, R_stop's error
against η < 1e-10 solves in brackets (session 34).
"""

from __future__ import annotations

import argparse

import numpy as np

import multilatin as ml
from multilatin.latin.engine import NumpyFields

PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="b1")
    parser.add_argument("--schedules", nargs="+",
                        default=["0.9", "1.0", "0.6,1.8", "0.55,1.9", "0.65,1.7", "0.6,2.0",
                                 "0.5,2.0", "0.5,1.6", "0.7,1.4"])
    parser.add_argument("--momentum", nargs="+", type=float, default=None)
    parser.add_argument("--omegas", nargs="+", type=float, default=[0.9, 1.0])
    args = parser.parse_args()
    model = ml.load_model(args.model)
    if args.momentum is not None:
        momentum(model, args.momentum, args.omegas)
        return
    original = NumpyFields.linear_stage
    print("| schedule | " + " | ".join(f"({a:g}, {b:g})" for a, b in PAIRS) + " |")
    print("|---|" + "---|" * len(PAIRS))
    for text in args.schedules:
        cycle = np.array([float(v) for v in text.split(",")])
        calls = {"n": 0}

        def linear_stage(self: NumpyFields, relaxation: np.ndarray,
                         cycle: np.ndarray = cycle, calls: dict[str, int] = calls) -> None:
            calls["n"] += 1
            if calls["n"] > 1:
                relaxation = np.full_like(relaxation, cycle[calls["n"] % cycle.size])
            original(self, relaxation)

        NumpyFields.linear_stage = linear_stage  # type: ignore[method-assign]
        cells = []
        try:
            for mu1, mu2 in PAIRS:
                calls["n"] = 0
                result = model.solve({"mu1": mu1, "mu2": mu2}, check=False)
                r_stop = float(result.qoi["R_stop"])  # type: ignore[arg-type]
                cells.append(f"{result.iterations if result.converged else 'no'} "
                             f"({r_stop:.3f})")
        finally:
            NumpyFields.linear_stage = original  # type: ignore[method-assign]
        print(f"| {text} | " + " | ".join(cells) + " |")


def momentum(model: ml.Model, betas: list[float], omegas: list[float]) -> None:
    """The heavy-ball step (module docstring): s_k is what ``linear_stage`` starts from,
    s_{k−1} the one before; β (s_k − s_{k−1}) is added after the relaxed stage."""
    original = NumpyFields.linear_stage
    beta = [0.0]
    before: dict[int, tuple[np.ndarray, np.ndarray] | None] = {}

    def linear_stage(self: NumpyFields, relaxation: np.ndarray) -> None:
        now = None if self.w is None or self.f is None else (np.array(self.w),
                                                             np.array(self.f))
        original(self, relaxation)
        last = before.get(id(self))
        if beta[0] and now is not None and last is not None and last[0].shape == now[0].shape:
            assert self.w is not None and self.f is not None
            self.w = np.array(self.w) + beta[0] * (now[0] - last[0])
            self.f = np.array(self.f) + beta[0] * (now[1] - last[1])
        before[id(self)] = now

    cases = [model.assemble({"mu1": a, "mu2": b}) for a, b in PAIRS]
    tight = [float(model.solve({"mu1": a, "mu2": b}, options=ml.LatinOptions(
        tol=1e-10, max_iter=5000)).qoi["R_stop"]) for a, b in PAIRS]  # type: ignore[arg-type]
    print("| ω | β | " + " | ".join(f"({a:g}, {b:g})" for a, b in PAIRS) + " |")
    print("|---|---|" + "---|" * len(PAIRS))
    NumpyFields.linear_stage = linear_stage  # type: ignore[method-assign]
    try:
        for omega in omegas:
            for b in betas:
                beta[0] = b
                cells = []
                for case, reference in zip(cases, tight, strict=True):
                    before.clear()
                    result = ml.solve_latin(case, ml.LatinOptions(relaxation=omega),
                                            check=False)
                    error = abs(float(result.qoi["R_stop"]) - reference) / reference  # type: ignore[arg-type]
                    cells.append(f"{result.iterations if result.converged else 'no'} "
                                 f"({error:.0e})")
                print(f"| {omega:g} | {b:g} | " + " | ".join(cells) + " |", flush=True)
    finally:
        NumpyFields.linear_stage = original  # type: ignore[method-assign]


if __name__ == "__main__":
    main()
