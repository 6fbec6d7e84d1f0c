"""The bundled ``slide`` model (issue 15): a block pressed on a clamped foundation and pushed
sideways until it slides, at several foundation stiffnesses, search directions κ and rules
for k across the contact (``LatinOptions.search_modulus``); and the same block glued to the
foundation (a perfect interface: the same file with the interface's type changed).

    python benchmarks/slide.py
    python benchmarks/slide.py --ratios 10 1000 --kappas 0.5 --moduli mean neighbour own
    python benchmarks/slide.py --interfaces perfect
    python benchmarks/slide.py --two-sided      # the held-node rule off: before issue 15
    python benchmarks/slide.py --locate         # where the error of a two-sided solve sits
    python benchmarks/slide.py --interfaces contact --ratios 10 --moduli own --acceleration rre

For each case, one cold LATIN solve at the default tolerance and iteration cap (what a user
gets from ``multilatin solve slide``) and the monolithic contact-Newton reference of the
same discrete problem: iterations, whether it converged, and R_push's worst relative error
over the 10 steps (|R − R_ref| / max(|R_ref|, 1 N)); the closed form R_push = μ p 20 = 60 N
of the sliding steps is checked on the reference. Prints a Markdown table.
"""

from __future__ import annotations

import argparse
from importlib import resources

import numpy as np

import multilatin as ml
from multilatin.io.modelfile import ModelSpec
from multilatin.latin import LatinOptions
from multilatin.model import Model

CONTACT = 'type = "contact"\nfriction = "mu"\ngap = 0.0'


def slide_model(interface: str) -> Model:
    """The bundled ``slide``, or with the block glued to the foundation (``"perfect"``)."""
    if interface == "contact":
        return ml.load_model("slide")
    text = (resources.files("multilatin") / "models" / "slide.toml").read_text(encoding="utf-8")
    if CONTACT not in text:
        raise SystemExit("slide.toml: its contact interface is not written as expected")
    return Model(ModelSpec.from_string(text.replace(CONTACT, 'type = "perfect"'), name="glued"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--ratios", nargs="+", type=float, default=[1, 10, 100, 1000])
    parser.add_argument("--kappas", nargs="+", type=float, default=[0.1, 0.25, 0.5, 1, 2])
    parser.add_argument("--moduli", nargs="+", default=["mean", "neighbour", "own"])
    parser.add_argument("--two-sided", action="store_true",
                        help="LatinOptions(held_nodes=False): the rule before issue 15")
    parser.add_argument("--max-iter", type=int, default=LatinOptions().max_iter)
    parser.add_argument("--interfaces", nargs="+", default=["contact", "perfect"])
    parser.add_argument("--acceleration", default=LatinOptions().acceleration,
                        choices=["relaxation", "anderson", "rre"],
                        help="LatinOptions.acceleration (session 58: the block at κ = 0.1)")
    parser.add_argument("--locate", action="store_true",
                        help="ratio 1000, κ 1, two-sided rule: the points that carry the "
                             "error at the default tolerance against a tight solve")
    args = parser.parse_args()
    ml.load_model("slide").solve()  # warm-up: imports, kernels
    if args.locate:
        locate()
        return
    for interface in args.interfaces:
        print(f"\nblock-foundation interface: {interface}\n")
        table(slide_model(interface), interface, args)


def locate() -> None:
    """The interface points whose force F̂ (times the point's weight) differs most between
    a solve at the default tolerance and a tight one, at step 1, with the two-sided rule."""
    model = ml.load_model("slide")
    mu = {"stiffness_ratio": 1000.0}
    results = [model.solve(mu, options=LatinOptions(kappa=1.0, held_nodes=False, tol=tol,
                                                    max_iter=200_000), check=False)
               for tol in (LatinOptions().tol, 1e-11)]
    loose, tight = results
    assert loose.interface is not None and tight.interface is not None
    print(f"iterations: {loose.iterations} to the default tolerance, {tight.iterations} to "
          f"1e-11; R_push at step 1: {loose.qoi['R_push'][0]:.4f} N against "  # type: ignore[index]
          f"{tight.qoi['R_push'][0]:.4f} N")  # type: ignore[index]
    from multilatin.latin.operators import LatinOperators
    assembly = model.assemble(mu)
    points = LatinOperators(assembly, LatinOptions(kappa=1.0, held_nodes=False)).points
    force = (loose.interface.force_hat - tight.interface.force_hat)[0] * points.weights[:, None]
    moved = (loose.interface.displacement_hat - tight.interface.displacement_hat)[0]
    for p in np.argsort(-np.abs(force).max(axis=1))[:4]:
        name = assembly.interfaces[points.interface[p]].name
        print(f"  {name} at ({points.coords[p, 0]:g}, {points.coords[p, 1]:g}), substructure "
              f"{assembly.substructures[points.substructure[p]].name}: force error "
              f"({force[p, 0]:+.4f}, {force[p, 1]:+.4f}) N, displacement error "
              f"{np.abs(moved[p]).max():.1e} mm")


def table(model: Model, interface: str, args: argparse.Namespace) -> None:
    print("| E_foundation / E_block | κ | " + " | ".join(
        f"{m}: iterations, worst R_push error" for m in args.moduli) + " |")
    print("|---|---|" + "---|" * len(args.moduli))
    for ratio in args.ratios:
        mu = {"mu": 0.3, "p": 10.0, "stiffness_ratio": ratio}
        reference = np.asarray(model.reference(mu).qoi["R_push"])
        if interface == "contact" and np.abs(reference).max() > 60.0 * (1 + 1e-9):
            raise SystemExit(f"ratio {ratio:g}: the reference exceeds the sliding limit "
                             f"μ p 20 = 60 N: {np.abs(reference).max():.6g} N")
        for kappa in args.kappas:
            cells = []
            for modulus in args.moduli:
                options = LatinOptions(kappa=kappa, search_modulus=modulus,
                                       max_iter=args.max_iter,
                                       held_nodes=not args.two_sided,
                                       acceleration=args.acceleration)
                result = model.solve(mu, options=options, check=False)
                r_push = np.asarray(result.qoi["R_push"])
                error = np.max(np.abs(r_push - reference) / np.maximum(np.abs(reference), 1.0))
                flag = "" if result.converged else " (not converged)"
                cells.append(f"{result.iterations}{flag}, {error:.1e}")
            print(f"| {ratio:g} | {kappa:g} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
