"""The guards of the LATIN iteration's control (``solver._iterate``) for cases that do not
converge the normal way: a state that grows without end (no equilibrium), and an η that
stagnates (the relaxation lowered)."""

from __future__ import annotations

import logging

from ..fem.elasticity import FloatArray, IntArray
from .options import LatinOptions

__all__ = ["DRIFT_WINDOW", "damp_stagnating", "drifts"]

log = logging.getLogger(__name__)

#: every so many iterations, a case whose ½(‖s‖ + ‖ŝ‖) grew by as much in the second half of
#: the window as in the first (and by more than 0.1 %) is stopped as having no equilibrium
DRIFT_WINDOW = 100


def drifts(sizes: list[float]) -> bool:
    """The state's norm grows at a steady rate over the last ``DRIFT_WINDOW`` iterations: a
    rigid sliding that never ends, not a convergence (whose growth decays geometrically:
    B1's slowest tails, 0.985 per iteration, halve it over half a window)."""
    if len(sizes) < DRIFT_WINDOW + 1:
        return False
    half = DRIFT_WINDOW // 2
    first = sizes[-1 - half] - sizes[-1 - DRIFT_WINDOW]
    second = sizes[-1] - sizes[-1 - half]
    return bool(first > 0.0 and second >= 0.9 * first and second > 1e-3 * sizes[-1])


def damp_stagnating(histories: list[list[float]], active: IntArray, relaxation: FloatArray,
                    options: LatinOptions) -> None:
    """Lower ω (in place, by 0.1, down to 0.5) of the active cases whose η stagnated over
    the last ``stagnation_window`` iterations (see ``LatinOptions``)."""
    window = options.stagnation_window
    for position, case in enumerate(active):
        history = histories[case]
        if len(history) < 2 * window or relaxation[position] <= 0.5 + 1e-12:
            continue
        latest, before = min(history[-window:]), min(history[-2 * window:-window])
        if latest > options.stagnation_ratio * before:
            relaxation[position] = max(relaxation[position] - 0.1, 0.5)
            log.info("case %d of the batch: eta stagnates (%.2e after %.2e), relaxation "
                     "lowered to %.1f", case, latest, before, relaxation[position])
