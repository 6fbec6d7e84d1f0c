"""SuperLU's column ordering for the substructures' factorisations (``LatinOperators``):
SciPy's default COLAMD against a minimum-degree ordering of the symmetric pattern, the
operators' build timed in one process, alternately (median of ``--repeat``).

    python benchmarks/factor_ordering.py --models b1 b1-9 b3 [--repeat 7]
"""

from __future__ import annotations

import argparse
import statistics
import time
from typing import Any

import scipy.sparse.linalg as spla

import multilatin as ml
from multilatin.latin import LatinOptions, operators

SPECS = ("COLAMD", "MMD_AT_PLUS_A")


class _Ordered:
    """Stands in for ``scipy.sparse.linalg`` in ``operators``: ``splu`` with ``spec``."""

    spec = SPECS[0]

    @staticmethod
    def splu(matrix: Any, **options: Any) -> Any:
        return spla.splu(matrix, permc_spec=_Ordered.spec, **options)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--models", nargs="+", default=["b1", "b1-9", "b3"])
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    operators.spla = _Ordered  # type: ignore[assignment]
    print("| model | " + " | ".join(f"{s} (ms)" for s in SPECS) + " | ratio |")
    print("|---|---|---|---|")
    for name in args.models:
        model = ml.load_model(name)
        times: dict[str, list[float]] = {s: [] for s in SPECS}
        for _ in range(args.repeat):
            for spec in SPECS:
                _Ordered.spec = spec
                t0 = time.perf_counter()
                operators.LatinOperators(model.assemble({"mu1": 0.3, "mu2": 0.2}),
                                         LatinOptions())
                times[spec].append(1e3 * (time.perf_counter() - t0))
        medians = [statistics.median(times[s]) for s in SPECS]
        print(f"| {name} | {medians[0]:.1f} | {medians[1]:.1f} | "
              f"{medians[1] / medians[0]:.2f} |")


if __name__ == "__main__":
    main()
