"""press_fit — an interference fit (a negative contact gap) pushed sideways until it slides:
its holding capacity over the interference and the friction, a study against the closed
form μ N, N = 20 δ / (10 / E + 20 / E).

Run: ``python examples/press_fit.py --out results/gallery/press-fit``
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

import multilatin as ml

MODEL = Path(__file__).with_name("press_fit.toml")
YOUNG, HEIGHTS, WIDTH = 2e5, (10.0, 20.0), 20.0  # MPa, mm, mm (press_fit.toml)


def capacity(delta: float, mu: float) -> float:
    """μ N: the fit's holding capacity (N per mm of thickness)."""
    return mu * WIDTH * delta / sum(h / YOUNG for h in HEIGHTS)


def run(out: Path | None = None, deltas: int = 4, frictions: tuple[float, ...] = (0.1, 0.2, 0.3)
        ) -> dict[str, Any]:
    model = ml.load_model(MODEL)
    grid = ml.Grid({"delta": np.linspace(0.0005, 0.002, deltas), "mu": list(frictions)})
    study = ml.run_study(model, grid, out=out, progress=False)
    push = study.dataset["R_push"].sel(mode="multiresolution").isel(step=-1)
    found = {"delta": [float(d) for d in grid["delta"]], "mu": list(frictions),
             "R_push": push.values.tolist(),
             "closed_form": [[capacity(d, m) for m in frictions] for d in grid["delta"]]}
    if out is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6, 4))
        delta_um = 1e3 * np.array(found["delta"])
        for j, mu in enumerate(frictions):
            ax.plot(delta_um, push.values[:, j], "o", label=f"LATIN study, μ = {mu:g}")
            ax.plot(delta_um, [capacity(d, mu) for d in found["delta"]], "k--", lw=0.8)
        ax.set(xlabel="interference δ [µm]", ylabel="holding force R_push [N/mm]",
               title="press fit: holding capacity (dashed: μ N)")
        ax.legend()
        fig.savefig(out / "press_fit.png", dpi=100, bbox_inches="tight")
        plt.close(fig)
    return found


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None)
    result = run(parser.parse_args().out)
    for i, delta in enumerate(result["delta"]):
        cells = ", ".join(f"μ = {mu:g}: {result['R_push'][i][j]:.3f} N "
                          f"({result['closed_form'][i][j]:.3f})"
                          for j, mu in enumerate(result["mu"]))
        print(f"δ = {1e3 * delta:.2f} µm: {cells}")
