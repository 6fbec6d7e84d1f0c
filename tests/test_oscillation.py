"""A case caught in a mode near −1 has its relaxation lowered, a crawl does not
(``multilatin.latin.oscillation``, session 56): η alternating without falling, and
consecutive increments of s pointing opposite ways."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

import multilatin as ml
from multilatin.latin import LatinOperators, LatinOptions, iteration, solve_latin
from multilatin.latin.engine import norms
from multilatin.latin.options import STUDY_QOI_RTOL
from multilatin.latin.oscillation import WINDOW, OscillationWatch, alternating


def test_alternating_is_an_eta_that_turns_every_iteration_without_falling() -> None:
    n = WINDOW + 1
    wobble = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    flat = list(1.35e-5 + 1e-7 * wobble)  # the b1-9 case: 1.35e-5 / 1.33e-5 in turn
    assert alternating(flat, WINDOW, 0.7)
    assert not alternating(flat[1:], WINDOW, 0.7)  # too short to tell
    falling = list(1e-5 * 0.9 ** np.arange(n) * (1.0 + 0.3 * wobble))
    assert np.all(np.diff(falling)[1:] * np.diff(falling)[:-1] < 0)  # turns, but falls
    assert not alternating(falling, WINDOW, 0.7)
    assert not alternating(list(1e-5 * 0.999 ** np.arange(n)), WINDOW, 0.7)  # no turns
    once = flat.copy()
    once[10] = once[11]
    assert not alternating(once, WINDOW, 0.7)


class _Fields:
    """A stand-in engine: one case whose s is ``path(iteration)``."""

    def __init__(self, path: Any) -> None:
        self.path, self.iteration = path, 0
        self.weights = (np.ones(4), np.full(4, 1e-4))  # ∫ k, ∫ k⁻¹ per (point, component)

    def state(self, cases: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        w = self.path(self.iteration)
        return w.copy(), 100.0 * w

    def state_norms(self, dw: np.ndarray, df: np.ndarray) -> np.ndarray:
        return norms(*self.weights, dw, df)


@pytest.mark.parametrize(("path", "lowered"), [
    (lambda i: np.full((1, 1, 2, 2), 1.0 + 1e-3 * (-1.0) ** i), True),  # back and forth
    (lambda i: np.full((1, 1, 2, 2), 1.0 + 1e-3 * i), False),  # a crawl
])
def test_the_relaxation_is_lowered_only_where_s_goes_back_and_forth(path: Any,
                                                                    lowered: bool) -> None:
    """Both with the same η, alternating and flat: the cycle's ω goes 0.9 → 0.8 → 0.7 at
    the ends of the second and third windows (the first is too short a history), the
    crawl's stays."""
    engine, watch = _Fields(path), OscillationWatch()
    history: list[float] = []
    relaxation = np.array([0.9])
    for i in range(1, 3 * WINDOW + 1):
        engine.iteration = i
        history.append(1.35e-5 + 1e-7 * (-1.0) ** i)
        watch(engine, np.array([0]), np.array([i]), [history], relaxation,  # type: ignore[arg-type]
              LatinOptions())
    assert relaxation[0] == pytest.approx(0.7 if lowered else 0.9)
    watch.kept[0] = [engine.state(np.array([0]))]  # kept within a window, then it leaves
    watch(engine, np.zeros(0, np.int64), np.zeros(0, np.int64), [history], relaxation,  # type: ignore[arg-type]
          LatinOptions())
    assert not watch.kept


def test_b1_9_warm_started_across_the_stop_closing_leaves_its_cycle_sooner(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """b1-9 at gap 0 (μ2 = 0.15) warm-started from gap 0.01, under the studies' rule: η
    alternated between 1.35e-5 and 1.33e-5 from iteration 75 until the stagnation check
    lowered ω at 200 (252 iterations); with the watch 152 (measured). The answer is the
    cold solve's within the rule's accuracy."""
    model = ml.load_model("b1-9")
    options = LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    target = model.assemble({"gap": 0.0, "mu2": 0.15})
    operators = LatinOperators(target, options)
    start = solve_latin(model.assemble({"gap": 0.01, "mu2": 0.15}), options).interface
    assert start is not None
    runs = {}
    for watching in (True, False):
        monkeypatch.setattr(iteration, "OSCILLATIONS", watching)
        runs[watching] = solve_latin(target, options, operators=operators,
                                     initial=(start.displacement_hat, start.force_hat))
    assert runs[True].iterations <= runs[False].iterations - 50
    cold = solve_latin(target, options, operators=operators)
    for result in runs.values():
        assert result.qoi["R_stop"] == pytest.approx(cold.qoi["R_stop"], rel=2 * STUDY_QOI_RTOL)


def test_a_crawl_at_the_friction_limit_is_left_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    """B1 (0.1, 0.25) cold: η sits at 6.36e-4 with a 0.1 % wobble while a body crawls; on
    η alone its ω was lowered and it took 107 iterations instead of 96. Its increments point
    the same way: the same iterations with the watch as without."""
    assembly = ml.load_model("b1").assemble({"mu1": 0.1, "mu2": 0.25})
    options = LatinOptions(qoi_rtol=STUDY_QOI_RTOL)
    operators = LatinOperators(assembly, options)
    iterations = []
    for watching in (True, False):
        monkeypatch.setattr(iteration, "OSCILLATIONS", watching)
        iterations.append(solve_latin(assembly, options, operators=operators).iterations)
    assert iterations[0] == iterations[1]
