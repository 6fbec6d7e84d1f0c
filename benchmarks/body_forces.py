"""Body forces and temperature changes against closed forms (docs/correctness.md, "Body
forces (session 48)" and "Temperature changes (session 48)"): the models of
``tests/test_body_forces.py`` and ``tests/test_temperature.py`` solved by the reference and
by LATIN (tight, and at the default options), side by side with their closed forms.

Run from the repository root: ``python benchmarks/body_forces.py [--sizes 1 0.5 0.25]``
(the spinning rings and the heated fit need gmsh).
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path

import numpy as np

import multilatin as ml

TESTS = Path(__file__).resolve().parents[1] / "tests"
sys.path.insert(0, str(TESTS))

import test_body_forces as cases  # noqa: E402  (the tests' models and closed forms)
import test_temperature as heated  # noqa: E402


def _line(name: str, exact: float, reference: float, latin: float) -> str:
    return (f"| {name} | {exact:.10g} | {reference:.10g} ({reference / exact - 1:+.1e}) | "
            f"{latin:.10g} ({latin / exact - 1:+.1e}) |")


def bar() -> None:
    model = cases._bar()
    exact = cases._bar_closed_form(0.1, 1.0)
    reference = model.reference()
    latin = model.solve(options=ml.LatinOptions(tol=1e-10))
    default = model.solve()
    print(f"\nhanging bar (step 2; LATIN to eta < 1e-10 in {latin.iterations} iterations, "
          f"{default.iterations} at the defaults)\n")
    print("| QoI | closed form | reference | LATIN |\n|---|---|---|---|")
    for name in exact:
        print(_line(name, exact[name], reference.qoi[name][1], latin.qoi[name][1]))


def slide() -> None:
    model = cases._weighted_slide()
    reference = np.asarray(model.reference({"mu": 0.3}).qoi["R_push"])
    print("\nweighted slide, mu = 0.3: R_push per step (closed form once sliding: 60 N)\n")
    print(f"reference: {np.array2string(reference, precision=4)}")
    for kappa in (0.25, 0.5, 2.0):
        latin = model.solve({"mu": 0.3}, options=ml.LatinOptions(kappa=kappa))
        error = np.abs(np.asarray(latin.qoi["R_push"]) - reference).max()
        print(f"LATIN at kappa = {kappa:g}, the other options the defaults: "
              f"{latin.iterations} iterations, largest |R_push - reference| {error:.1e} N")


def holed_plate() -> None:
    model = ml.Model(ml.ModelSpec.from_string(cases.HOLED_PLATE, name="holed_plate"))
    weight = 0.01 * (60.0 * 40.0 - math.pi * 8.0**2)
    same, conforming = model.reference(mesh="same"), model.reference(mesh="conforming")
    latin = model.solve()
    print(f"\nholed plate's weight {weight:.6f} N: X-FEM reference {same.qoi['R']:.6f} "
          f"({same.qoi['R'] / weight - 1:+.1e}), conforming {conforming.qoi['R']:.6f} "
          f"({conforming.qoi['R'] / weight - 1:+.1e}), LATIN (defaults, {latin.iterations} "
          f"iterations) {latin.qoi['R']:.6f}")


def spinning_rings(sizes: list[float]) -> None:
    spin = cases._spinning_annulus()
    a, b, c, load = 5.0, 10.0, 20.0, 100.0
    omega = math.sqrt(load / spin.RHO)
    exact = {"u_out": spin.free_spin_u(c, b, c, omega), "u_rim": spin.free_spin_u(b, a, b, omega)}
    text = cases.spinning_rings(load)
    print(f"\nspinning rings (rho omega^2 = {load:g}): closed form u_out {exact['u_out']:.6f}, "
          f"u_rim {exact['u_rim']:.6f} mm\n")
    print("| cell size (mm) | reference u_out | u_rim | contact p | LATIN (defaults): "
          "iterations, largest relative difference |\n|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder)
        (path / "rings.toml").write_text(text)
        for size in sizes:
            spin.ring_mesh(path / "inner.msh", a, b, size, ("bore", "rim"))
            spin.ring_mesh(path / "outer.msh", b, c, 1.6 * size, ("seat", None))
            model = ml.load_model(path / "rings.toml")
            reference = model.reference()
            latin = model.solve()
            worst = max(abs(latin.qoi[n] / reference.qoi[n] - 1.0) for n in exact)
            cells = " | ".join(f"{reference.qoi[n]:.6f} ({reference.qoi[n] / exact[n] - 1:+.2%})"
                               for n in exact)
            print(f"| {size:g} | {cells} | {reference.qoi['p_c']:g} | {latin.iterations}, "
                  f"{worst:.1e} |")


def temperatures() -> None:
    e_alpha = heated.E * heated.ALPHA
    walls = heated._walls()
    exact = {"R": -e_alpha * 1000.0, "s_xx": -e_alpha * 100.0, "s_yy": 0.0,
             "v_top": (1.0 + heated.NU) * heated.ALPHA * 1000.0}
    reference, latin = walls.reference(), walls.solve()
    print(f"\nbar heated by 100 K between walls (LATIN at the defaults, {latin.iterations} "
          "iterations)\n")
    print("| QoI | closed form | reference | LATIN |\n|---|---|---|---|")
    for name, value in exact.items():
        print(f"| {name} | {value:.10g} | {reference.qoi[name][1]:.10g} | "
              f"{latin.qoi[name][1]:.10g} |")
    for hypothesis, hole in (("plane_strain", False), ("plane_stress", True)):
        model = heated._free_plate(hypothesis, hole)
        scale = (1.0 + heated.NU) if hypothesis == "plane_strain" else 1.0
        for result in (model.reference(mesh="same"), model.solve()):
            u = result.qoi["u_corner"][1] / (scale * heated.ALPHA * 100.0 * 60.0) - 1.0
            stress = max(abs(v) for name in ("s_xx", "s_yy") for v in result.qoi[name])
            print(f"free plate, {hypothesis}{', hole' if hole else ''}, {result.method} "
                  f"({result.iterations} it.): corner u {u:+.1e} off, largest |stress QoI| "
                  f"{stress:.1e} MPa (E alpha dT = {e_alpha * 100.0:g})")
    spin = cases._spinning_annulus()
    with tempfile.TemporaryDirectory() as folder:
        spin.load(Path(folder))
        text = spin.MODEL.read_text() + ('\n[parameters.dT]\ndefault = 0.0\n[[temperature]]'
                                         '\nname = "heat"\nbodies = ["rim"]\nvalue = "dT"\n')
        model = ml.Model(ml.ModelSpec.from_string(text, name="heated_fit",
                                                  folder=Path(folder)))
        print("\nshrink fit, rim heated by dT (delta = 10 um, alpha = 1.2e-5: opens at "
              "83.3 K)\n\n| dT (K) | closed form p (MPa) | reference | LATIN (defaults) "
              "|\n|---|---|---|---|")
        for heat in (0.0, 40.0, 80.0, 100.0):
            expected = spin.fit_pressure(0.0, 0.01 - 1.2e-5 * heat * spin.SEAT)
            reference, latin = model.reference({"dT": heat}), model.solve({"dT": heat})
            print(f"| {heat:g} | {expected:.3f} | {reference.qoi['p_fit']:.3f} | "
                  f"{latin.qoi['p_fit']:.3f} ({latin.iterations} it.) |")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=float, nargs="+", default=[1.0, 0.5, 0.25])
    args = parser.parse_args()
    bar()
    slide()
    holed_plate()
    spinning_rings(args.sizes)
    temperatures()
