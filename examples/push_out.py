"""push_out — an axisymmetric shrink fit pushed out of its rim: the push-out force over the
interference and the friction, a study against the closed form μ p 2π b h with Lamé's
fit pressure p = E δ / (b K) of two open-ended cylinders.

Run: ``python examples/push_out.py --out results/gallery/push-out``
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

import numpy as np

import multilatin as ml

MODEL = Path(__file__).with_name("push_out.toml")
HUB, SEAT, OUTER, HEIGHT, YOUNG = 5.0, 10.0, 20.0, 10.0, 2e5  # mm, MPa (push_out.toml)


def lame_pressure(delta: float) -> float:
    """Lamé's fit pressure of two open-ended cylinders of one material (ν cancels)."""
    compliance = SEAT / YOUNG * ((OUTER**2 + SEAT**2) / (OUTER**2 - SEAT**2)
                                 + (SEAT**2 + HUB**2) / (SEAT**2 - HUB**2))
    return delta / compliance


def push_out_force(delta: float, mu: float) -> float:
    """μ p 2π b h: the fit's grip at Lamé's pressure (N)."""
    return mu * lame_pressure(delta) * 2.0 * math.pi * SEAT * HEIGHT


def run(out: Path | None = None, deltas: int = 3, frictions: tuple[float, ...] = (0.1, 0.2, 0.3)
        ) -> dict[str, Any]:
    model = ml.load_model(MODEL)
    grid = ml.Grid({"delta": np.linspace(0.0025, 0.0075, deltas), "mu": list(frictions)})
    study = ml.run_study(model, grid, out=out, progress=False)
    last = {name: study.dataset[name].sel(mode="multiresolution").isel(step=-1)
            for name in ("R_push", "p_fit")}
    found = {"delta": [float(d) for d in grid["delta"]], "mu": list(frictions),
             "R_push": last["R_push"].values.tolist(), "p_fit": last["p_fit"].values.tolist(),
             "closed_form": [[push_out_force(d, m) for m in frictions] for d in grid["delta"]]}
    if out is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6, 4))
        delta_um = 1e3 * np.array(found["delta"])
        for j, mu in enumerate(frictions):
            ax.plot(delta_um, 1e-3 * last["R_push"].values[:, j], "o",
                    label=f"LATIN study, μ = {mu:g}")
            ax.plot(delta_um, [1e-3 * push_out_force(d, mu) for d in found["delta"]], "k--",
                    lw=0.8)
        ax.set(xlabel="interference δ [µm]", ylabel="push-out force [kN]",
               title="axisymmetric shrink fit (dashed: μ p 2π b h, Lamé's p)")
        ax.legend()
        fig.savefig(out / "push_out.png", dpi=100, bbox_inches="tight")
        plt.close(fig)
    return found


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None)
    result = run(parser.parse_args().out)
    for i, delta in enumerate(result["delta"]):
        cells = ", ".join(f"μ = {mu:g}: {result['R_push'][i][j]:.0f} N "
                          f"({result['closed_form'][i][j]:.0f})"
                          for j, mu in enumerate(result["mu"]))
        print(f"δ = {1e3 * delta:.2f} µm: {cells}")
