"""roller — a roller pressed on a plate, the plate's base then shifted sideways: the stick
zone against Cattaneo–Mindlin's closed form, and the sliding force μ P.

The bundled ``roller`` model (gmsh meshes, a curved face in frictional contact with a flat
one, non-matching meshes joined by mortar projection). One solve follows the load history:
pressed down, then the base shifted in five steps. At each step the contact nodes tell
where the contact sticks (|q| < μ p) and where it slips; Cattaneo–Mindlin (equal materials,
a ≪ R): the stick zone's half-width c = a √(1 − Q / (μ P)), and Q = μ P once it slides.

Run: ``python examples/roller_mindlin.py --out results/gallery/roller``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import multilatin as ml

MU = 0.3
SHIFT = 0.15  # mm at the last step: enough to slide


def stick_zone(result: ml.SolveResult, step: int, mu: float = MU) -> tuple[float, float]:
    """(a, c) at ``step``: the half-widths of the zone in contact and of the zone that
    sticks, each halfway between its last node and the next one (nodal contact forces)."""
    assert result.contact is not None
    order = np.argsort(result.contact.positions[:, 0])
    x = result.contact.positions[order, 0]
    pressure = result.contact.pressure[step, order]
    shear = result.contact.shear[step, order]
    closed = pressure > 1e-9 * pressure.max()
    stick = closed & (np.abs(shear) < mu * pressure * (1.0 - 1e-6))

    def half_width(mask: np.ndarray) -> float:
        inside = np.flatnonzero(mask)
        if inside.size == 0:
            return 0.0
        first, last = int(inside[0]), int(inside[-1])
        left = 0.5 * (x[first] + x[first - 1]) if first > 0 else x[first]
        right = 0.5 * (x[last] + x[last + 1]) if last + 1 < x.size else x[last]
        return float(0.5 * (right - left))

    return half_width(closed), half_width(stick)


def run(solver: str = "latin", out: Path | None = None, shift: float = SHIFT
        ) -> list[dict[str, float]]:
    """Per shifted step: Q / (μ P), c / a found and by Cattaneo–Mindlin."""
    model = ml.load_model("roller")
    mu = {"mu": MU, "shift": shift}
    result = (model.reference(mu) if solver == "reference"
              else model.solve(mu, options=ml.LatinOptions(tol=1e-8, max_iter=50_000)))
    rows = []
    load, force = result.qoi["P"], result.qoi["Q"]
    assert isinstance(load, list) and isinstance(force, list)
    for step in range(2, len(load)):
        a, c = stick_zone(result, step)
        ratio = abs(force[step]) / (MU * load[step])
        rows.append({"step": step + 1, "Q": force[step], "P": load[step], "ratio": ratio,
                     "c_over_a": c / a, "mindlin": float(np.sqrt(max(1.0 - ratio, 0.0))),
                     "iterations": float(result.iterations)})
    if out is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        out.mkdir(parents=True, exist_ok=True)
        fig, ax = plt.subplots(figsize=(6, 4))
        ratios = np.linspace(0.0, 1.0, 101)
        ax.plot(ratios, np.sqrt(1.0 - ratios), "k--", label="Cattaneo–Mindlin √(1 − Q/μP)")
        ax.plot([r["ratio"] for r in rows], [r["c_over_a"] for r in rows], "o",
                label=f"{solver}, roller model")
        ax.set(xlabel="Q / (μ P) [–]", ylabel="stick zone c / a [–]",
               title="roller: the stick zone as the plate is shifted")
        ax.legend()
        fig.savefig(out / "roller.png", dpi=100, bbox_inches="tight")
        plt.close(fig)
    return rows


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--solver", choices=["latin", "reference"], default="latin")
    args = parser.parse_args()
    print("| step | Q [N/mm] | P [N/mm] | Q / (μ P) | c / a | Cattaneo–Mindlin |")
    print("|---|---|---|---|---|---|")
    for row in run(args.solver, args.out):
        print(f"| {row['step']:g} | {row['Q']:.1f} | {row['P']:.1f} | {row['ratio']:.4f} | "
              f"{row['c_over_a']:.3f} | {row['mindlin']:.3f} |")
