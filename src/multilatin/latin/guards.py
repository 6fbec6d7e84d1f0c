"""The guards of the LATIN iteration's control (``solver._iterate``) for cases that do not
converge the normal way: a state that grows without end (no equilibrium), one that blows
up (an unstable iteration), and an η that stagnates (the relaxation lowered)."""

from __future__ import annotations

import logging

import numpy as np
import numpy.typing as npt

from ..fem.elasticity import FloatArray, IntArray
from .options import LatinOptions

__all__ = ["BLOWUP", "DRIFT_WINDOW", "blows_up", "damp_stagnating", "drifts"]

log = logging.getLogger(__name__)

#: every so many iterations, a case whose ½(‖s‖ + ‖ŝ‖) grew by as much in the second half of
#: the window as in the first (and by more than 0.1 %) is stopped as having no equilibrium
DRIFT_WINDOW = 100
#: a case whose ½(‖s‖ + ‖ŝ‖) grows beyond this many times its value after the first
#: iteration is stopped as diverging. The first linear stage is already the elastic answer's
#: scale: over the B1 13 × 13 and B3 5 × 5 studies (cold and warm) the size never grew past
#: 1.03 × its first value, over every bundled model 2.4 × (lug), and 4.3 × in the tests'
#: cases with no equilibrium, stopped by ``drifts`` (session 38, ``benchmarks/blowup.py``)
BLOWUP = 1e3


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


def blows_up(size: FloatArray, first_size: FloatArray) -> npt.NDArray[np.bool_]:
    """Per case: its ½(‖s‖ + ‖ŝ‖) ``size`` beyond ``BLOWUP`` times ``first_size``, its
    value after the first iteration. η is relative to that size: an iteration that grows
    without bound in a mode the local stage keeps (s ≈ ŝ there) sees η fall while its
    fields run away (session 37: a trial step reached η < tol with fields of 1e14). A
    first size of zero (no load yet) sets no bound."""
    return np.asarray((first_size > 0.0) & (size > BLOWUP * first_size), dtype=bool)


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
