"""B3: R_stop against the hole radius (paper fig. 15), four ways side by side.

    python benchmarks/b3_radius.py [--out results/b3-radius]

For rc = 0, 1, ..., 7 at the centre (25, 75), μ1 = 0.35, μ2 = 0.25:
- LATIN on ``b3`` (3 x 3 substructures per body, the holed one meshed 24 x 24 and joined by
  macro-only interfaces, hole by level set);
- the same joined by mortar interfaces (``Model.with_mortar``: micro forces too);
- LATIN on ``b3`` with one substructure per body (``split``: each body one 24 x 24 mesh, the
  hole by level set on that coarser mesh);
- the monolithic contact solution on a conforming mesh (the holed body meshed by gmsh).
Every LATIN solve is converged to η < 1e-6. Prints a Markdown table and writes
``r_stop_radius.png`` and, for rc = 5, the deformed assembly ``deformed_rc5.png`` (fig. 16).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import multilatin as ml  # noqa: E402
from multilatin.io.plots import plot_deformed  # noqa: E402

RADII = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]
ONE_PER_BODY = {"bottom": (1, 1), "centre": (1, 1), "top": (1, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("results/b3-radius"))
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    model = ml.load_model("b3")
    mortar_model = model.with_mortar()
    options = ml.LatinOptions(tol=1e-6)
    rows = []
    for radius in RADII:
        mu = {"rc": radius}
        nine = model.solve(mu, options=options)
        mortar = mortar_model.solve(mu, options=options)
        one = model.solve(mu, options=options, split=ONE_PER_BODY)
        reference = model.reference(mu, mesh="conforming")
        rows.append((radius, nine, one, reference, mortar))
        if radius == 5.0:
            plot_deformed(nine, args.out / "deformed_rc5.png")
    print("| rc | 9 per body, macro-only | 9 per body, mortar | 1 per body | "
          "conforming reference | macro-only vs ref. | mortar vs ref. |")
    print("|---|---|---|---|---|---|---|")
    for radius, nine, one, reference, mortar in rows:
        r9, r1, rr, rm = (float(x.qoi["R_stop"]) for x in (nine, one, reference, mortar))
        print(f"| {radius:g} | {r9:.2f} N ({nine.iterations} it.) | {rm:.2f} N "
              f"({mortar.iterations} it.) | {r1:.2f} N ({one.iterations} it.) | {rr:.2f} N | "
              f"{100 * (r9 / rr - 1):+.2f} % | {100 * (rm / rr - 1):+.2f} % |")
    fig, ax = plt.subplots(figsize=(6, 4))
    for index, label, style in ((1, "LATIN, 3 x 3 substructures per body, macro-only", "o-"),
                                (4, "LATIN, 3 x 3 substructures per body, mortar", "d-"),
                                (2, "LATIN, 1 substructure per body", "s--"),
                                (3, "monolithic, conforming mesh (gmsh)", "k^:")):
        ax.plot(RADII, [float(row[index].qoi["R_stop"]) for row in rows], style, label=label)
    ax.set_xlabel("hole radius rc (mm)")
    ax.set_ylabel("R_stop (N)")
    ax.set_title("B3: stop reaction against the hole radius (paper fig. 15)")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(args.out / "r_stop_radius.png", dpi=120)
    print(f"\nfigures in {args.out}/: r_stop_radius.png, deformed_rc5.png")


if __name__ == "__main__":
    main()
