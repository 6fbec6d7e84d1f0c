"""lap — a clamped lap joint pulled until it slips, then pushed back until it slips the other
way: the friction loop, LATIN against the monolithic reference at every step, the plateaus
at the closed form ±μ p A (A = 20 mm × 10 mm, the clamp's footprint).

Run: ``python examples/lap_joint.py --out results/gallery/lap``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import tomllib

import multilatin as ml

MU, PRESSURE, AREA = 0.2, 50.0, 20.0 * 10.0  # –, MPa, mm² (the bundled model's defaults)
STEP = 0.01  # mm of pull per unit of the load factor (the bundled model's)
#: the pull's load factor over the steps: out, back through zero, out the other way, back
CYCLE = (0, 2, 4, 6, 8, 6, 4, 2, 0, -2, -4, -6, -8, -6, -4, -2, 0, 2, 4, 6, 8)


def cycled_model(cycle: tuple[int, ...] = CYCLE) -> ml.Model:
    """The bundled lap joint with the pull's history replaced by ``cycle``."""
    data = tomllib.loads((Path(ml.__file__).parent / "models" / "lap.toml").read_text())
    data["history"]["factors"]["pull"] = list(cycle)
    return ml.Model(ml.ModelSpec.from_dict(data, name="lap-cycle"))


def run(out: Path | None = None, cycle: tuple[int, ...] = CYCLE) -> dict[str, list[float]]:
    model = cycled_model(cycle)
    latin, reference = model.solve(), model.reference()
    found = {"pull": [STEP * f for f in cycle],
             "F_pull": [float(v) for v in latin.qoi["F_pull"]],  # type: ignore[union-attr]
             "F_pull_reference": [float(v) for v in reference.qoi["F_pull"]],  # type: ignore[union-attr]
             "iterations": [float(latin.iterations)]}
    if out is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        out.mkdir(parents=True, exist_ok=True)
        fig, ax = plt.subplots(figsize=(6, 4))
        ax.plot(found["pull"], found["F_pull_reference"], color="0.6", lw=4,
                label="monolithic reference")
        ax.plot(found["pull"], found["F_pull"], marker="o", ms=4, label="LATIN")
        for sign in (1, -1):
            ax.axhline(sign * MU * PRESSURE * AREA, color="k", ls="--",
                       label="± μ p A (slipping)" if sign > 0 else None)
        ax.set(xlabel="pull at the upper plate's end [mm]", ylabel="F_pull [N]",
               title="lap joint: the friction loop")
        ax.legend(loc="center left", bbox_to_anchor=(1.02, 0.5))
        fig.savefig(out / "lap.png", dpi=100, bbox_inches="tight")
        plt.close(fig)
    return found


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None)
    result = run(parser.parse_args().out)
    gap = np.max(np.abs(np.subtract(result["F_pull"], result["F_pull_reference"])))
    print(f"{int(result['iterations'][0])} iterations; F_pull within {gap:.3f} N of the "
          f"reference at every step; at the turns {result['F_pull'][4]:.2f} / "
          f"{result['F_pull'][12]:.2f} N (closed form ±{MU * PRESSURE * AREA:g} N)")
