"""Axisymmetric parts against closed forms (docs/correctness.md, "Axisymmetric parts
(session 48)"): the models of ``tests/test_axisymmetric.py`` — Lamé's open-ended thick
cylinder under an internal pressure and a shrink-fitted hub in its rim, without friction
(Lamé's fit) and pushed out with friction — solved by the reference under refinement and by
LATIN at the default options.

Run from the repository root: ``python benchmarks/axisymmetric.py``
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

import multilatin as ml

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import test_axisymmetric as cases  # noqa: E402  (the tests' models and closed forms)


def main() -> None:
    p, a, b = 100.0, 5.0, 10.0
    big_a, big_b = p * a**2 / (b**2 - a**2), p * a**2 * b**2 / (b**2 - a**2)
    exact = ((1 - cases.NU) * big_a * a + (1 + cases.NU) * big_b / a) / cases.E
    tube = ml.Model(ml.ModelSpec.from_string(cases.TUBE + cases.PRESSURE, name="tube"))
    print(f"thick cylinder, internal pressure 100 MPa: u(a) closed form {exact:.8f} mm, "
          f"resultant 2 pi a h p = {2 * math.pi * a * 10.0 * p:.4f} N\n")
    print("| refinement | reference u(a) (error) | R_p | LATIN (defaults): iterations, "
          "u(a) against the reference |\n|---|---|---|---|")
    for refine in (1, 2, 4):
        reference = tube.reference(refine=refine)
        latin = tube.solve(refine=refine)
        print(f"| {refine} | {reference.qoi['u_in']:.8f} "
              f"({reference.qoi['u_in'] / exact - 1:+.1e}) | {reference.qoi['R_p']:.4f} | "
              f"{latin.iterations}, {latin.qoi['u_in'] / reference.qoi['u_in'] - 1:+.1e} |")
    frictionless = (cases.FIT.replace("default = 0.2", "default = 0.0")
                    .replace('type = "mixed"\ncomponents = ["force", "displacement"]\n'
                             'value = [0.0, -1.0]\nfactor = "push"\n',
                             'type = "force"\nvalue = [0.0, 0.0]\n')
                    + '\n[[boundary]]\nname = "hub_floor"\nface = "hub.bottom"\n'
                      'type = "mixed"\ncomponents = ["force", "displacement"]\n'
                      'value = [0.0, 0.0]\n')
    print(f"\nshrink fit (delta = 5 um): Lame's pressure {cases.LAME:.4f} MPa\n")
    print("| model | refinement | reference p_fit per step | LATIN (defaults) | push "
          "against mu p 2 pi b h |\n|---|---|---|---|---|")
    for label, text in (("frictionless", frictionless), ("mu = 0.2, pushed", cases.FIT)):
        model = ml.Model(ml.ModelSpec.from_string(text, name="fit"))
        for refine in (1, 2):
            reference = model.reference(refine=refine)
            pressure = np.asarray(reference.qoi["p_fit"])
            latin = model.solve(refine=refine)
            grip = 0.2 * pressure * 2 * math.pi * cases.B * cases.H
            push = np.asarray(reference.qoi["R_push"])
            print(f"| {label} | {refine} | {np.array2string(pressure, precision=4)} | "
                  f"{latin.iterations} it., p_fit within "
                  f"{np.abs(np.asarray(latin.qoi['p_fit']) / pressure - 1).max():.1e} | "
                  f"{np.array2string(push / grip, precision=6)} |")


if __name__ == "__main__":
    main()
