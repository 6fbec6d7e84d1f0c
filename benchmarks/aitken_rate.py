"""A QoI estimate that extrapolates a slowing tail (session 61; measured, not adopted).

    python benchmarks/aitken_rate.py random_studies.py --axisymmetric --seeds 20 --count 20
    python benchmarks/aitken_rate.py qoi_stopping.py
    python benchmarks/aitken_rate.py qoi_stopping.py --model b3 --grid xc=23:27:5 yc=73:77:5 rc=3

Runs another benchmark script of this folder (its name, then its arguments) with
``tracking.error_estimates`` replaced by a prototype: where the newest two two-iteration
increments' decay from the two before them, read at the last three pairs, rises (r2 < r1 <
r0 < 1), the estimate's rate is at least the Aitken limit of those readings, r0 + (r0 −
r1)² / ((r1 − r2) − (r0 − r1)) (the largest rate where the rise does not slow). Axisymmetric
straps' R_clamp_x stopped 2.7e-3 off with its readings rising 0.903 … 0.940
(docs/tolerance.md, session 61).
"""

from __future__ import annotations

import runpy
import sys
from pathlib import Path
from typing import Any

import numpy as np

from multilatin.latin import iteration, tracking

_TODAY = tracking.error_estimates


def extrapolated(series: Any, eta: Any, window: int = tracking.WINDOW,
                 rate_floor: Any = 0.0) -> Any:
    """Today's estimate, at least the newest increments' envelope over (1 − the Aitken
    limit of their rising decay) where it rises (module docstring)."""
    out = _TODAY(series, eta, window, rate_floor)
    width = min(window, series.shape[0] - 5)
    if width < 2:
        return out
    recent = series[-(width + 4):]
    steps2 = np.abs(recent[2:] - recent[:-2])
    if steps2.shape[0] < 8:
        return out
    pairs = [steps2[len(steps2) - 2 * (k + 1):len(steps2) - 2 * k].sum(axis=0)
             for k in range(4)]
    with np.errstate(divide="ignore", invalid="ignore"):
        r0, r1, r2 = pairs[0] / pairs[1], pairs[1] / pairs[2], pairs[2] / pairs[3]
        rising = (r2 < r1) & (r1 < r0) & (r0 < 1.0) & (pairs[3] > 0.0)
        before, now = r1 - r2, r0 - r1
        limit = np.where(now < before,
                         r0 + now * now / np.where(before > now, before - now, 1.0),
                         tracking.MAX_RATE)
        limit = np.clip(np.where(rising, limit, 0.0), 0.0, tracking.MAX_RATE)
        newer = steps2[-((steps2.shape[0] - 2) // 2):].max(axis=0)
        return np.where(rising, np.maximum(out, newer / (1.0 - limit)), out)


def main() -> None:
    if len(sys.argv) < 2:
        raise SystemExit(__doc__)
    tracking.error_estimates = extrapolated
    iteration.error_estimates = extrapolated  # the QoI rule's own reference to it
    script = Path(__file__).resolve().parent / sys.argv[1]
    if script.suffix != ".py" or not script.is_file():
        raise SystemExit(f"aitken_rate.py: the first argument names a benchmark script of "
                         f"benchmarks/, got {sys.argv[1]!r}")
    sys.argv = [str(script), *sys.argv[2:]]
    runpy.run_path(str(script), run_name="__main__")


if __name__ == "__main__":
    main()
