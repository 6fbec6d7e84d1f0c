"""Two rules around the sliding extrapolation's jumps (``latin.iteration``, session 37):
no jump for a case whose QoIs are about to settle (``JUMP_HOLD``: a jump holds a case
``RECENT`` iterations), and a leading step that settles soon after a jump keeps an estimate
read after the jump alone (``ESTIMATE_AFTER_JUMPS``). Each test runs with the rule off
too and shows that it changes what it says it changes."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

import multilatin as ml
from multilatin.latin import LatinOperators, LatinOptions, iteration, solve_latin
from multilatin.latin.options import STUDY_QOI_RTOL

TIGHT = LatinOptions(tol=1e-10, max_iter=20000)


@pytest.fixture
def restore_rules() -> Iterator[None]:
    saved = iteration.JUMP_HOLD, iteration.ESTIMATE_AFTER_JUMPS
    yield
    iteration.JUMP_HOLD, iteration.ESTIMATE_AFTER_JUMPS = saved


def test_no_jump_just_before_the_qois_settle(restore_rules: None) -> None:
    """b1-9 at (0.3, 0.15) from zero under the studies' QoI rule: at iteration 80 R_stop's
    estimate is 1.1 × its bound (falling by ~0.93 per iteration); a jump there held the
    case until η < 1e-7 (96 iterations). Without the jump it stops on its QoIs, within
    0.1 % of the tight R_stop."""
    assembly = ml.load_model("b1-9").assemble({"mu1": 0.3, "mu2": 0.15})
    ops = LatinOperators(assembly, LatinOptions())
    exact = float(solve_latin(assembly, TIGHT, operators=ops).qoi["R_stop"])
    counts = {}
    for hold in (False, True):
        iteration.JUMP_HOLD = hold
        result = solve_latin(assembly, LatinOptions(qoi_rtol=STUDY_QOI_RTOL), operators=ops)
        counts[hold] = result.iterations
        assert float(result.qoi["R_stop"]) == pytest.approx(exact, rel=1e-3)
        assert result.stopped_on_qoi == hold
    assert counts[True] <= counts[False] - 10


def test_no_step_settles_on_an_estimate_that_reads_a_jump(restore_rules: None) -> None:
    """b1 at (0.3, 0.1) warm from the tight answer at μ2 = 0.05 under the QoI rule: a
    geometric jump at iteration 40; load step 1 settled four iterations later kept an
    estimate read across the jump, 4 000 × its error, just above its bound, and held the
    case until η < 1e-7 (71 iterations). With its estimate read after the jump alone, the
    case stops 15 iterations after the jump, within 0.1 % of the tight R_stop."""
    model = ml.load_model("b1")
    neighbour = model.assemble({"mu1": 0.3, "mu2": 0.05})
    ops = LatinOperators(neighbour, LatinOptions())
    start = solve_latin(neighbour, TIGHT, operators=ops).interface
    assert start is not None
    assembly = model.assemble({"mu1": 0.3, "mu2": 0.1})
    exact = float(solve_latin(assembly, TIGHT, operators=ops).qoi["R_stop"])
    counts = {}
    for rule in (False, True):
        iteration.ESTIMATE_AFTER_JUMPS = rule
        result = solve_latin(assembly, LatinOptions(qoi_rtol=STUDY_QOI_RTOL), operators=ops,
                             initial=(start.displacement_hat, start.force_hat))
        counts[rule] = result.iterations
        assert float(result.qoi["R_stop"]) == pytest.approx(exact, rel=1e-3)
    assert counts[True] <= counts[False] - 10


def test_without_qoi_stopping_no_jump_is_held(restore_rules: None) -> None:
    """Without QoI stopping the hold does not apply: b1-9 at (0.3, 0.15) to η < 1e-6 jumps
    as before, with the same iterations and answer as with the hold off."""
    assembly = ml.load_model("b1-9").assemble({"mu1": 0.3, "mu2": 0.15})
    ops = LatinOperators(assembly, LatinOptions())
    results = []
    for hold in (False, True):
        iteration.JUMP_HOLD = hold
        results.append(solve_latin(assembly, LatinOptions(), operators=ops))
    assert results[1].iterations == results[0].iterations
    assert results[1].qoi["R_stop"] == results[0].qoi["R_stop"]
