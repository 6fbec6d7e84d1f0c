"""B0 — a cantilever beam in 10 substructures: LATIN against the monolithic solution of the
same mesh and against Timoshenko beam theory.

Run: ``python examples/b0_cantilever.py --out results/gallery/b0``
"""

from __future__ import annotations

import argparse
from pathlib import Path

import multilatin as ml

#: Timoshenko tip deflection of the B0 beam under P = 100 N (benchmarks.md), mm
TIMOSHENKO_V_TIP = -2.016


def run(out: Path | None = None, split: tuple[int, int] = (10, 1)) -> dict[str, float]:
    model = ml.load_model("b0")
    latin = model.solve({"P": 100.0}, options=ml.LatinOptions(tol=1e-8),
                        split={"beam": split})
    reference = model.reference({"P": 100.0})
    if out is not None:
        from multilatin.io.output import write_result

        write_result(latin, out)
    return {"v_tip": float(latin.qoi["v_tip"]),                 # type: ignore[arg-type]
            "v_tip_reference": float(reference.qoi["v_tip"]),   # type: ignore[arg-type]
            "v_tip_timoshenko": TIMOSHENKO_V_TIP, "iterations": latin.iterations}


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None)
    for key, value in run(parser.parse_args().out).items():
        print(f"{key}: {value}")
