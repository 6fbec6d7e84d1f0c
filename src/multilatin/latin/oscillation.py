"""A case caught in a mode near −1 has its relaxation lowered (issue 15; session 56).

ω = 0.9 turns a mode of eigenvalue λ into 0.9 λ + 0.1: a mode at −1 (statically determined
clusters, method.md §4) decays at −0.8 per iteration, but one a little beyond −1 hardly at
all. b1-9 at gap 0, μ2 = 0.15, warm-started from gap 0.01 under the studies' rule: from
iteration 75 its η alternated between 1.35e-5 and 1.33e-5 (≈ −0.9995 per iteration,
unrelaxed ≈ −1.22) until the stagnation check (``guards.damp_stagnating``, every
``stagnation_window`` = 100 iterations) lowered ω to 0.8 at iteration 200; 50 iterations
later it had converged: 252 in all, against 66 cold.

η alone does not tell that cycle from a *crawl* — a body sliding at the friction limit
moves by the same increment every iteration while η sits still with a small wobble (B1's
cold (0.1, 0.25): η 6.36e-4 ± 0.1 %), which a smaller ω would slow (damped on η alone, three
of the main job's cold cases took 9–15 more iterations, docs/convergence.md). The state
does: consecutive increments of s point opposite ways in a cycle (cosine −1.00 from
iteration 60 on in the b1-9 case) and the same way in a crawl (+0.99 to +1.00). So every
``WINDOW`` iterations a case whose η turned at every one of them without falling (its
smallest over the second half not below ``stagnation_ratio`` × its smallest over the first)
and whose last two increments of s, in the indicator's norm, have a cosine below
``OPPOSITE`` gets ω − 0.1, down to 0.5 (``guards.lowered``). The converged answer does not
depend on ω.
"""

from __future__ import annotations

import logging
from typing import Any

import numpy as np

from ..fem.elasticity import FloatArray, IntArray
from .field_engine import FieldEngine
from .guards import can_lower, lowered
from .options import LatinOptions

__all__ = ["OPPOSITE", "WINDOW", "OscillationWatch", "alternating"]

log = logging.getLogger(__name__)

#: iterations between two looks (even: a cycle's two phases alike at both ends)
WINDOW = 20
#: the cosine of the last two increments of s below which they point opposite ways
OPPOSITE = -0.5


def alternating(history: list[float], n: int, ratio: float) -> bool:
    """Whether η (``history``) turned up or down at every one of its last ``n`` iterations
    and its smallest value over their second half is not below ``ratio`` × its smallest
    over the first."""
    if len(history) < n + 1:
        return False
    recent = np.asarray(history[-n - 1:])
    steps = np.diff(recent)
    half = n // 2
    return bool(np.all(steps[1:] * steps[:-1] < 0.0)
                and recent[-half:].min() > ratio * recent[:half + 1].min())


class OscillationWatch:
    """Looks at the active cases every ``WINDOW`` iterations (``__call__`` after each):
    keeps s at the window's last two iterations before its end for the cases whose η
    alternates, and at its end lowers ω of those whose last two increments point opposite
    ways."""

    def __init__(self) -> None:
        self.kept: dict[int, list[tuple[Any, Any]]] = {}  # case → s at phases −2, −1

    def __call__(self, engine: FieldEngine, active: IntArray, counts: IntArray,
                 histories: list[list[float]], relaxation: FloatArray,
                 options: LatinOptions) -> None:
        phase = counts % WINDOW
        ratio = options.stagnation_ratio
        if self.kept:  # the cases that left the batch within a window
            for case in set(self.kept) - set(active.tolist()):
                del self.kept[case]
        for position in np.flatnonzero(phase == WINDOW - 2).tolist():
            case = int(active[position])
            if can_lower(relaxation[position]) and alternating(
                    histories[case], WINDOW - 2, ratio):
                self.kept[case] = [engine.state(np.array([position]))]
        for position in np.flatnonzero(phase == WINDOW - 1).tolist():
            if int(active[position]) in self.kept:
                self.kept[int(active[position])].append(engine.state(np.array([position])))
        for position in np.flatnonzero(phase == 0).tolist():
            case = int(active[position])
            kept = self.kept.pop(case, None)
            if kept is None or len(kept) != 2 or not alternating(histories[case], WINDOW,
                                                                 ratio):
                continue
            (w0, f0), (w1, f1) = kept
            w2, f2 = engine.state(np.array([position]))
            cosine = _cosine(engine, (w1 - w0, f1 - f0), (w2 - w1, f2 - f1))
            if cosine < OPPOSITE:
                relaxation[position] = lowered(relaxation[position])
                log.info("case %d of the batch: eta oscillates (increments at cosine %.2f), "
                         "relaxation lowered to %.1f", case, cosine, relaxation[position])


def _cosine(engine: FieldEngine, first: tuple[Any, Any], second: tuple[Any, Any]) -> float:
    """The cosine of two increments (dW, dF) of one case in the indicator's norm:
    (‖a + b‖² − ‖a‖² − ‖b‖²) / (2 ‖a‖ ‖b‖)."""
    a, b = engine.state_norms(*first)[0], engine.state_norms(*second)[0]
    both = engine.state_norms(first[0] + second[0], first[1] + second[1])[0]
    return float((both ** 2 - a ** 2 - b ** 2) / (2.0 * a * b)) if a * b > 0 else 1.0
