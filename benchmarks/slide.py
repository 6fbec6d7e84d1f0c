"""The bundled ``slide`` model (issue 15): a block pressed on a clamped foundation and pushed
sideways until it slides, at several foundation stiffnesses, search directions κ and rules
for k across the contact (``LatinOptions.search_modulus``); and the same block glued to the
foundation (a perfect interface: the same file with the interface's type changed).

    python benchmarks/slide.py
    python benchmarks/slide.py --ratios 10 1000 --kappas 0.5 --moduli mean neighbour own
    python benchmarks/slide.py --interfaces perfect
    python benchmarks/slide.py --two-sided      # the held-node rule off: before issue 15

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
from multilatin.latin import LatinOptions
from multilatin.model import Model
from multilatin.spec import ModelSpec

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
    args = parser.parse_args()
    ml.load_model("slide").solve()  # warm-up: imports, kernels
    for interface in args.interfaces:
        print(f"\nblock-foundation interface: {interface}\n")
        table(slide_model(interface), interface, args)


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
                                       held_nodes=not args.two_sided)
                result = model.solve(mu, options=options, check=False)
                r_push = np.asarray(result.qoi["R_push"])
                error = np.max(np.abs(r_push - reference) / np.maximum(np.abs(reference), 1.0))
                flag = "" if result.converged else " (not converged)"
                cells.append(f"{result.iterations}{flag}, {error:.1e}")
            print(f"| {ratio:g} | {kappa:g} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
