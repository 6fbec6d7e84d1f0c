"""slide — a block pressed on a clamped foundation 1 to 1 000 times stiffer and pushed
sideways until it slides: the push force against its closed form R_push = μ p 20 = 60 N.

Run: ``python examples/slide_block.py --out results/gallery/slide``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import multilatin as ml

MU, PRESSURE, WIDTH = 0.3, 10.0, 20.0  # –, MPa, mm (the bundled model's defaults)


def run(out: Path | None = None, ratios: tuple[float, ...] = (1.0, 10.0, 100.0, 1000.0)
        ) -> dict[str, list[float]]:
    model = ml.load_model("slide")
    pushes: dict[str, list[float]] = {}
    for ratio in ratios:
        result = model.solve({"stiffness_ratio": ratio})
        pushes[f"{ratio:g}"] = [float(v) for v in result.qoi["R_push"]]  # type: ignore[union-attr]
    if out is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        out.mkdir(parents=True, exist_ok=True)
        fig, ax = plt.subplots(figsize=(6, 4))
        for ratio, values in pushes.items():
            ax.plot(range(1, len(values) + 1), values, marker="o",
                    label=f"E_foundation / E = {ratio}")
        ax.axhline(MU * PRESSURE * WIDTH, color="k", ls="--", label="μ p 20 (sliding)")
        ax.set(xlabel="load step [–]", ylabel="R_push [N]",
               title="slide: push force over the load steps")
        ax.legend()
        fig.savefig(out / "slide.png", dpi=100, bbox_inches="tight")
        plt.close(fig)
    return pushes


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None)
    for ratio, values in run(parser.parse_args().out).items():
        print(f"stiffness ratio {ratio}: R_push at the last step {values[-1]:.3f} N "
              f"(closed form {MU * PRESSURE * WIDTH:g} N)")
