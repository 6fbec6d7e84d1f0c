"""What a study spends outside the iterations, and session 16's cuts of it, side by side.

    python benchmarks/study_overheads.py [--studies b3 b1] [--repeat 2]

Each study (B3: the 5 × 5 hole positions of paper table 2, rc = 3; B1: the 13 × 13
friction grid) runs with ``run_study``'s default options in one process, once with
everything as it is and once with each of these switched back, one at a time:

- ``interfaces rebuilt``: a new hole position rebuilds the interface points, the search
  direction and the macro basis (before: only the substructure operators were reused;
  now the interfaces are taken over when only a hole moved, ``signatures.interface_signature``);
- ``recovery by factorisation``: the interior displacements from a solve with each
  substructure's sparse factorisation (now one dense product with S⁻¹ Tᵀ M0, kept from the
  operators' construction: ``condensation.RECOVERY_ENTRIES``);
- ``positions case by case`` (B3 only): ``batch=1`` (now the lines along the innermost hole
  coordinate are solved as batches of several geometries on NumPy).

It prints the multiresolution wall time of each variant (median over ``--repeat`` runs,
the variants interleaved), its iterations, and, once, Σ cold and the gain.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import multilatin as ml
from multilatin.latin import condensation, operators, signatures
from multilatin.parameters import Grid
from multilatin.study.plan import clear_operator_cache
from multilatin.study.runner import run_study

GRIDS = {"b3": ["xc=23:27:5", "yc=73:77:5", "rc=3"],
         "b1": ["mu1=0:0.6:13", "mu2=0:0.6:13"]}


@contextmanager
def interfaces_rebuilt() -> Iterator[None]:
    """Every geometry its own interfaces: their signature takes the holes in."""
    original = signatures.interface_signature

    def with_holes(assembly: Any, options: Any) -> str:
        return original(assembly, options) + repr([s.hole for s in assembly.substructures])

    # where the operators and the study's plan (``operator_signature``) call it
    for module in (operators, signatures):
        module.interface_signature = with_holes  # type: ignore[attr-defined]
    try:
        yield
    finally:
        for module in (operators, signatures):
            module.interface_signature = original  # type: ignore[attr-defined]


@contextmanager
def recovery_by_factorisation() -> Iterator[None]:
    saved = condensation.RECOVERY_ENTRIES
    condensation.RECOVERY_ENTRIES = 0
    try:
        yield
    finally:
        condensation.RECOVERY_ENTRIES = saved


@contextmanager
def unchanged() -> Iterator[None]:
    yield


def run(name: str, variant: Callable[[], Any], batch: int, modes: tuple[str, ...]
        ) -> Any:
    clear_operator_cache()
    with variant(), tempfile.TemporaryDirectory() as folder:
        return run_study(ml.load_model(name), Grid.parse(GRIDS[name]), modes=modes,
                         out=folder, progress=False, batch=batch)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--studies", nargs="+", default=["b3", "b1"], choices=sorted(GRIDS))
    parser.add_argument("--repeat", type=int, default=2)
    args = parser.parse_args()
    print("| study | variant | multiresolution (s), median | runs (s) | iterations |")
    print("|---|---|---|---|---|")
    for name in args.studies:
        variants: list[tuple[str, Callable[[], Any], int]] = [
            ("as it is", unchanged, 16),
            ("interfaces rebuilt", interfaces_rebuilt, 16),
            ("recovery by factorisation", recovery_by_factorisation, 16)]
        if name == "b3":
            variants.append(("positions case by case", unchanged, 1))
        times: dict[str, list[float]] = {label: [] for label, _, _ in variants}
        iterations: dict[str, int] = {}
        cold: Any = None
        for repeat in range(args.repeat):
            for label, variant, batch in variants:
                first = repeat == 0 and label == "as it is"
                modes = ("multiresolution", "cold") if first else ("multiresolution",)
                result = run(name, variant, batch, modes)
                times[label].append(result.elapsed_s["multiresolution"])
                iterations[label] = sum(r["iterations"]
                                        for r in result.mode_records("multiresolution"))
                if first:
                    cold = result
        for label, _, _ in variants:
            print(f"| {name} | {label} | {statistics.median(times[label]):.2f} | "
                  + ", ".join(f"{t:.2f}" for t in times[label]) + f" | {iterations[label]} |")
        cold_records = cold.mode_records("cold")
        gains = cold.gains or {}
        print(f"| {name} | Σ cold (first run) | {sum(r['wall_s'] for r in cold_records):.2f} | "
              f"gain {gains.get('gain', float('nan')):.2f} | "
              f"{sum(r['iterations'] for r in cold_records)} |")


if __name__ == "__main__":
    main()
