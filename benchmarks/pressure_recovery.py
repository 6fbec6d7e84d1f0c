"""p_B on B1 recovered consistently (default since issue 17) against the lumped dual-cell
average used before, from the same monolithic reference solutions; prints a markdown table.

    python benchmarks/pressure_recovery.py
"""

from __future__ import annotations

from unittest import mock

import numpy as np

import multilatin as ml
from multilatin.decomposition.qoi import ContactPressures

CASES = [(0.0, 0.0), (0.1, 0.3), (0.35, 0.25), (0.3, 0.0), (0.6, 0.6)]


def main() -> None:
    model = ml.load_model("b1")
    print("| μ1, μ2 | p_B step 15, consistent (MPa) | lumped (MPa) | lumped / consistent − 1, "
          "over the 15 steps |")
    print("|---|---|---|---|")
    for mu1, mu2 in CASES:
        values = {}
        for recovery in ("consistent", "lumped"):
            with mock.patch.object(ContactPressures.mean, "__defaults__", (recovery,)):
                values[recovery] = np.array(model.reference({"mu1": mu1, "mu2": mu2}).qoi["p_B"])
        ratio = values["lumped"] / values["consistent"] - 1.0
        print(f"| {mu1}, {mu2} | {values['consistent'][-1]:.4f} | {values['lumped'][-1]:.4f} | "
              f"{100 * ratio.min():+.3f} % … {100 * ratio.max():+.3f} % |")


if __name__ == "__main__":
    main()
