"""Relocalised sub-iterations (issue 15, item 4; session 60, measured and not adopted): after
every iteration's local stage, a zone of substructures runs one more linear stage of its own
— the substructure problems alone, without the macro problem, the other substructures'
s = (W, F) frozen — and the local stage runs again on that s (Allix, Kerfriden & Gosselet's
relocalisation, without its event detection: the zone is fixed). Nothing of the library is
changed; the engine's local stage is wrapped here, as in ``exact_points.py``.

    python benchmarks/relocalisation.py                    # b1-9, b3 at two pairs
    python benchmarks/relocalisation.py --models b0 b2     # linear models (no contact)

Zones: the substructures that carry a contact or stop side (where b1-9 and b3 wait,
session 59's oracle: the points where a perfect interface ends on a contact), and every
substructure.
Sub-iterations from the first iteration on, or from iteration 50 on (the tail, η ≈ 7e-4);
ω: the relaxation of the zone's s between its own linear stages (1: none). Printed: cold
solves to η < 1e-6 (cap 300), iterations (each with one sub-iteration), R_stop (or the
model's first QoI) and how the solve ended.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable

import numpy as np

import multilatin as ml
from multilatin.latin import LatinOperators, LatinOptions, solve_latin
from multilatin.latin.engine import NumpyFields

PAIRS = [(0.1, 0.3), (0.3, 0.15)]
ORIGINAL = NumpyFields.local_stage


def relocalised_stage(zone: np.ndarray, omega: float, after: int
                      ) -> Callable[[NumpyFields], None]:
    """The engine's local stage, then (from call ``after`` + 1 on) one sub-iteration on the
    interface points ``zone`` (a mask): s there from the micro stage of ŝ (relaxed by ω
    against the s the local stage just read), s elsewhere as it was, and its local stage."""
    calls = [0]

    def stage(self: NumpyFields) -> None:
        ORIGINAL(self)
        calls[0] += 1
        if calls[0] <= after:
            return
        assert self.w is not None and self.f is not None
        shape = self.w_hat.shape
        live = np.arange(shape[1])[None, :] >= self.first[:, None]  # settled steps stay
        mask = live[:, :, None, None] & zone[None, None, :, None]
        flat = (-1, shape[2], 2)
        w_micro, f_micro = self.ops.micro_stage(np.ascontiguousarray(self.w_hat.reshape(flat)),
                                                np.ascontiguousarray(self.f_hat.reshape(flat)))
        w, f = self.w, self.f
        self.w = np.ascontiguousarray(np.where(
            mask, omega * w_micro.reshape(shape) + (1.0 - omega) * w, w))
        self.f = np.ascontiguousarray(np.where(
            mask, omega * f_micro.reshape(shape) + (1.0 - omega) * f, f))
        ORIGINAL(self)

    return stage


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=["b1-9", "b3"])
    args = parser.parse_args()
    print("| model | case | zone | from iteration | ω in the zone | iterations | QoI | ended |")
    print("|---|---|---|---|---|---|---|---|")
    for name in args.models:
        model = ml.load_model(name)
        friction = "mu1" in model.parameters and "mu2" in model.parameters
        for mu1, mu2 in PAIRS if friction else [(None, None)]:
            assembly = model.assemble({"mu1": mu1, "mu2": mu2} if friction else {})
            options = LatinOptions(max_iter=300)
            operators = LatinOperators(assembly, options)
            points = operators.points
            contact = [i for i, itf in enumerate(assembly.interfaces) if itf.contact is not None]
            zones = {"contact and stop sides": np.unique(points.substructure[
                np.isin(points.interface, contact)]), "all": np.unique(points.substructure)}
            runs: list[tuple[str, np.ndarray | None, int, float]] = [("none", None, 0, 1.0)]
            runs += [(label, subs, after, omega) for label, subs in zones.items()
                     if subs.size for after in (0, 50) for omega in (1.0, 0.5)]
            for label, subs, after, omega in runs:
                if subs is not None:
                    NumpyFields.local_stage = relocalised_stage(  # type: ignore[method-assign]
                        np.isin(points.substructure, subs), omega, after)
                try:
                    result = solve_latin(assembly, options, operators=operators, check=False)
                finally:
                    NumpyFields.local_stage = ORIGINAL  # type: ignore[method-assign]
                qoi = next(iter(result.qoi))
                ended = ("converged" if result.converged else "diverged"
                         if "diverged" in str(result.failure) else "at the cap")
                case = f"{mu1:g}, {mu2:g}" if friction else "default"
                zone = "none" if subs is None else f"{label} ({subs.size} of " \
                    f"{len(assembly.substructures)})"
                print(f"| {name} | {case} | {zone} | {after} | {omega:g} | "
                      f"{result.iterations} | {qoi} = {float(np.max(result.qoi[qoi])):.5g} | "
                      f"{ended} |", flush=True)


if __name__ == "__main__":
    main()
