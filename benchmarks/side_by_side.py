"""Fresh processes alternated between another source tree and this one, for the benchmarks
that compare code side by side (``--baseline <tree>/src --rounds N``)."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

HERE = str(Path(__file__).resolve().parents[1] / "src")


def add_arguments(parser: argparse.ArgumentParser, rounds: int = 3) -> None:
    parser.add_argument("--baseline", help="another source tree (its src/), side by side")
    parser.add_argument("--rounds", type=int, default=rounds)


def alternate(script: str, arguments: list[str], baseline: str, rounds: int
              ) -> Iterator[tuple[str, str]]:
    """``rounds`` times the script's last output line with ``PYTHONPATH`` set to
    ``baseline``, then to this tree: (label, line)."""
    for _ in range(rounds):
        for label, tree in (("baseline", str(Path(baseline).resolve())), ("this", HERE)):
            done = subprocess.run([sys.executable, script, *arguments], capture_output=True,
                                  env={**os.environ, "PYTHONPATH": tree}, text=True,
                                  check=True)
            yield label, done.stdout.strip().splitlines()[-1]
