"""lug — a plate with a hole pulled through a pin: the bearing pressure around the bore for
several friction coefficients, from the bundled ``lug`` model (gmsh meshes, frictional
contact between two curved faces meshed differently: named groups of the mesh files, mortar
along the arc, normals from the geometry).

Run: ``python examples/lug_bearing.py --out results/gallery/lug``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import multilatin as ml

FRICTIONS = (0.0, 0.2, 0.4)
CENTRE = (40.0, 0.0)  # mm, the hole's centre


def bearing_pressure(result: ml.SolveResult) -> tuple[np.ndarray, np.ndarray]:
    """Angles (degrees, 0 on the pull's axis) and contact pressures at the bore's nodes."""
    assert result.contact is not None
    xy = result.contact.positions
    angle = np.degrees(np.arctan2(xy[:, 1] - CENTRE[1], xy[:, 0] - CENTRE[0]))
    order = np.argsort(angle)
    return angle[order], result.contact.pressure[-1, order]


def run(frictions: tuple[float, ...] = FRICTIONS, solver: str = "latin",
        out: Path | None = None) -> list[dict[str, float]]:
    model = ml.load_model("lug")
    rows, profiles = [], []
    for mu in frictions:
        result = (model.reference({"mu": mu}) if solver == "reference"
                  else model.solve({"mu": mu}, options=ml.LatinOptions(tol=1e-8,
                                                                       max_iter=50_000)))
        rows.append({"mu": mu, "F": float(result.qoi["F"]),  # type: ignore[arg-type]
                     "p_axis": float(result.qoi["p_axis"]),  # type: ignore[arg-type]
                     "iterations": float(result.iterations)})
        profiles.append(bearing_pressure(result))
    if out is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        out.mkdir(parents=True, exist_ok=True)
        fig, ax = plt.subplots(figsize=(6, 4))
        for mu, (angle, pressure) in zip(frictions, profiles, strict=True):
            ax.plot(angle, pressure, label=f"μ = {mu:g}")
        ax.set(xlabel="angle from the pull's axis [°]", ylabel="bearing pressure [MPa]",
               title=f"lug: pressure on the bore ({solver}, pull 0.02 mm)")
        ax.legend()
        fig.savefig(out / "lug.png", dpi=100, bbox_inches="tight")
        plt.close(fig)
    return rows


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--solver", choices=["latin", "reference"], default="latin")
    args = parser.parse_args()
    print("| μ | F [N] | bearing pressure on the axis [MPa] | iterations |")
    print("|---|---|---|---|")
    for row in run(solver=args.solver, out=args.out):
        print(f"| {row['mu']:g} | {row['F']:.2f} | {row['p_axis']:.2f} | {row['iterations']:g} |")
