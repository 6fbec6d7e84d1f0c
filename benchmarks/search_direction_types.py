"""Search directions by interface type (issue 15, item 2; scills' ``optimisation_direction.h``):
k multiplied by a factor on one kind of interface at a time, measured by what the user gets —
R_stop's error against the tightly converged value after a fixed number of iterations — so
that the indicator's norm (which weighs every point by its own k) does not enter.

    python benchmarks/search_direction_types.py
    python benchmarks/search_direction_types.py --models b1 b1-9 --iterations 50 100 150

Variants (factor on k, other points unchanged): ``force``: prescribed-force components (scills:
÷ 1000); ``stop-normal``: the normal of rigid stops; ``contact-normal`` / ``contact-tangent``:
the components of frictional contact interfaces (scills: k_T = μ k_N). Prints a Markdown
table: per model and variant, the worst relative R_stop error over four friction pairs after
each iteration count.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable

import numpy as np

import multilatin as ml
from multilatin.decomposition.assembly import FORCE
from multilatin.fem.mesh import normal_axis
from multilatin.latin import LatinOptions
from multilatin.latin.operators import LatinOperators as Operators

PAIRS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.15)]
VARIANTS: dict[str, dict[str, float]] = {
    "default": {},
    "force ÷ 1000": {"force": 1e-3},
    "stop-normal × 2": {"stop-normal": 2.0},
    "stop-normal × 0.5": {"stop-normal": 0.5},
    "contact-normal × 2": {"contact-normal": 2.0},
    "contact-tangent × 2": {"contact-tangent": 2.0},
    "contact-tangent × 0.5": {"contact-tangent": 0.5},
    "contact both × 2": {"contact-normal": 2.0, "contact-tangent": 2.0},
}
ORIGINAL = Operators._search_direction


def scaled(factors: dict[str, float]) -> Callable[[Operators], np.ndarray]:
    """``_search_direction`` with ``factors`` applied by interface type."""
    def direction(self: Operators) -> np.ndarray:
        k: np.ndarray = ORIGINAL(self)
        for i, itf in enumerate(self.assembly.interfaces):
            first = self.points.side_points[(i, 0)]
            axis = normal_axis(itf.sides[0].side)
            if itf.is_stop:
                k[first, axis] *= factors.get("stop-normal", 1.0)
            elif itf.contact is not None:
                for side in range(2):
                    points = self.points.side_points[(i, side)]
                    k[points, axis] *= factors.get("contact-normal", 1.0)
                    k[points, 1 - axis] *= factors.get("contact-tangent", 1.0)
            elif itf.condition is not None:
                for component, kind in enumerate(itf.condition.kinds):
                    if kind == FORCE:
                        k[first, component] *= factors.get("force", 1.0)
        return k
    return direction


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--models", nargs="+", default=["b1", "b1-9"])
    parser.add_argument("--iterations", nargs="+", type=int, default=[50, 100, 150])
    args = parser.parse_args()
    print("| model | variant | " + " | ".join(f"error after {n}" for n in args.iterations)
          + " |")
    print("|---|---|" + "---|" * len(args.iterations))
    for name in args.models:
        model = ml.load_model(name)
        tight = {}
        for mu1, mu2 in PAIRS:
            mu = {"mu1": mu1, "mu2": mu2}
            result = model.solve(mu, options=LatinOptions(tol=1e-9, max_iter=50_000))
            tight[(mu1, mu2)] = float(result.qoi["R_stop"])  # type: ignore[arg-type]
        for label, factors in VARIANTS.items():
            Operators._search_direction = scaled(factors)  # type: ignore[method-assign]
            cells = []
            for n in args.iterations:
                worst = 0.0
                for (mu1, mu2), reference in tight.items():
                    options = LatinOptions(tol=1e-300, max_iter=n)
                    result = model.solve({"mu1": mu1, "mu2": mu2}, options=options,
                                         check=False)
                    r_stop = float(result.qoi["R_stop"])  # type: ignore[arg-type]
                    worst = max(worst, abs(r_stop - reference) / max(reference, 1.0))
                cells.append(f"{worst:.1e}")
            Operators._search_direction = ORIGINAL  # type: ignore[method-assign]
            print(f"| {name} | {label} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
