"""punch — a flat punch on part of a plate's top side, pressed then pushed until it slides,
at several positions along the plate: where the punch stands changes the stick phase (the
plate is more compliant near its free ends), not the sliding force R_push = μ p × 10 = 60 N;
one position against the monolithic contact reference.

Run: ``python examples/punch_position.py --out results/gallery/punch``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import multilatin as ml

MU, PRESSURE, WIDTH = 0.3, 20.0, 10.0  # –, MPa, mm (the bundled model's defaults)


def run(out: Path | None = None, positions: tuple[float, ...] = (6.0, 10.0, 20.0, 30.0),
        checked: float = 6.0) -> dict[str, list[float]]:
    """R_push per step at each position (a study over the geometric parameter), and the
    reference's at ``checked`` (key ``"reference"``)."""
    model = ml.load_model("punch")
    grid = ml.Grid({"position": list(positions)})
    study = ml.run_study(model, grid, out=out / "study" if out is not None else None,
                         progress=False, options=ml.LatinOptions())
    pushes = {f"{p:g}": [float(v) for v in study.dataset["R_push"]
                         .sel(mode="multiresolution", position=p).values]
              for p in positions}
    reference = model.reference({"position": checked})
    pushes["reference"] = [float(v) for v in reference.qoi["R_push"]]  # type: ignore[union-attr]
    if out is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6, 4))
        for position in positions:
            values = pushes[f"{position:g}"]
            ax.plot(range(1, len(values) + 1), values, marker="o",
                    label=f"punch centre at x = {position:g} mm")
        ax.plot(range(1, len(pushes["reference"]) + 1), pushes["reference"], "k+", ms=10,
                label=f"monolithic reference, x = {checked:g} mm")
        ax.axhline(MU * PRESSURE * WIDTH, color="k", ls="--", label="μ p 10 (sliding)")
        ax.set(xlabel="load step [–]", ylabel="R_push [N]",
               title="punch: push force over the load steps, by position")
        ax.legend(fontsize=8)
        fig.savefig(out / "punch.png", dpi=100, bbox_inches="tight")
        plt.close(fig)
    return pushes


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None)
    for key, values in run(parser.parse_args().out).items():
        print(f"{key}: R_push " + ", ".join(f"{v:.2f}" for v in values) + " N")
