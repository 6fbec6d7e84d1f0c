"""A rolling batch (``latin.stream``, ``study.rolling``): cases join the running iteration
when they are ready and leave it when they converge. Each case must be iterated exactly as
alone — the same iterations and answers as a batch that starts together — and a study run
as a rolling batch must start every case from the neighbour the line-by-line batches start
it from, so that its answers are theirs."""

from __future__ import annotations

from collections.abc import Hashable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import multilatin as ml
from multilatin.decomposition.result import SolveResult
from multilatin.latin import LatinOptions, solve_latin_batch, stream
from multilatin.latin.operators import LatinOperators
from multilatin.latin.stream import StreamCase, solve_latin_stream
from multilatin.parameters import Grid
from multilatin.study import starts
from multilatin.study.plan import clear_operator_cache
from multilatin.study.rolling import middle_starts, seeded_line_starts, start_neighbours
from multilatin.study.runner import run_study
from multilatin.study.waves import from_the_middle

#: the studies' stopping rule (QoI estimates) and the sliding extrapolation, both of which
#: read each case's own iteration count
OPTIONS = LatinOptions(qoi_rtol=1e-3)


@pytest.fixture(scope="module")
def b1() -> ml.Model:
    return ml.load_model("b1")


class _Feed:
    """Cases handed out in order (when ``chained``, each only once the one before is
    done); results collected."""

    def __init__(self, cases: list[StreamCase], chained: bool = False) -> None:
        self.cases, self.chained = list(cases), chained
        self.pending = list(cases)
        self.results: dict[Hashable, SolveResult] = {}
        self.widths: list[float] = []

    def take(self, count: int) -> list[StreamCase]:
        taken = len(self.cases) - len(self.pending)
        if self.chained and len(self.results) < taken:
            return []  # the one before is still running
        ready = self.pending[:1 if self.chained else count][:count]
        del self.pending[:len(ready)]
        return ready

    def done(self, key: Hashable, result: SolveResult, wall_s: float) -> None:
        assert wall_s > 0
        self.results[key] = result
        self.widths.append(result.timings["batch_size"])

    def finished(self) -> bool:
        return not self.pending and len(self.results) == len(self.cases)


@pytest.mark.parametrize("renumber_after", [4, 0])
def test_cases_joining_a_running_batch_are_iterated_as_alone(
        b1: ml.Model, renumber_after: int, monkeypatch: pytest.MonkeyPatch) -> None:
    """Seven cases of B1's μ2 line from zero, and three from a neighbour's converged fields,
    through rolling batches of width 1, 3 and 10 (cases join as others leave): the same
    iterations, and R_stop and every interface field equal to rounding, as one batch that
    starts together — also when the batch renumbers its cases after every case that leaves
    (``renumber_after`` 0; by default after four times its width)."""
    monkeypatch.setattr(stream, "RENUMBER_AFTER", renumber_after)
    assemblies = [b1.assemble({"mu1": 0.3, "mu2": mu2})
                  for mu2 in (0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.05, 0.15, 0.25)]
    ops = LatinOperators(assemblies[0], OPTIONS)
    first = solve_latin_batch(assemblies[:1], OPTIONS, ops, check=False)[0]
    assert first.interface is not None
    start = (first.interface.displacement_hat, first.interface.force_hat)
    initial = [None] * 7 + [start] * 3
    together = solve_latin_batch(assemblies, OPTIONS, ops, check=False, initial=initial)
    assert len({r.iterations for r in together}) > 3  # cases leave at different times
    for width in (1, 3, 10):
        feed = _Feed([StreamCase(n, a, ops, s)
                      for n, (a, s) in enumerate(zip(assemblies, initial, strict=True))])
        steps = solve_latin_stream(feed, OPTIONS, width)
        assert steps >= max(r.iterations for r in together)
        for n, expected in enumerate(together):
            got = feed.results[n]
            assert got.iterations == expected.iterations, (width, n)
            assert got.converged and got.stopped_on_qoi == expected.stopped_on_qoi
            assert got.qoi["R_stop"] == pytest.approx(expected.qoi["R_stop"], rel=1e-10)
            assert got.interface is not None and expected.interface is not None
            np.testing.assert_allclose(got.interface.force_hat, expected.interface.force_hat,
                                       rtol=0, atol=1e-9 * np.abs(
                                           expected.interface.force_hat).max())
        assert max(feed.widths) == min(width, 10)


def test_a_case_joins_after_its_neighbour_converged(b1: ml.Model) -> None:
    """Chained cases (each ready only after the one before has left) keep the batch at one
    case and still give the batch's answers."""
    assemblies = [b1.assemble({"mu1": 0.1, "mu2": mu2}) for mu2 in (0.0, 0.3)]
    ops = LatinOperators(assemblies[0], OPTIONS)
    feed = _Feed([StreamCase(n, a, ops) for n, a in enumerate(assemblies)], chained=True)
    solve_latin_stream(feed, OPTIONS, 4)
    assert feed.widths == [1.0, 1.0]
    alone = solve_latin_batch(assemblies, OPTIONS, ops, check=False)
    assert [feed.results[n].iterations for n in range(2)] == [r.iterations for r in alone]


def test_a_rolling_batch_refuses_a_zero_width(b1: ml.Model) -> None:
    with pytest.raises(ValueError, match="width"):
        solve_latin_stream(_Feed([]), OPTIONS, 0)


@pytest.mark.parametrize("predicted", [True, False])
def test_a_rolling_study_gives_the_line_by_line_answers(
        b1: ml.Model, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, predicted: bool) -> None:
    """B1 on a 2 × 4 grid that holds cases the discrete problem leaves undetermined ((0,
    0.3) and (0.05, 0.25)): the rolling study starts every case from the same neighbour as
    the line-by-line study (both by the waves' rule, from the middle), with the same
    iterations, the same uniqueness flags and R_stop equal to rounding; cases ran side by
    side. Such a case starts from zero where its neighbour's state foresees it
    (``starts.at_limit``), else its warm attempt is set aside and it is solved again from
    zero (``predicted=False``: the prediction left out)."""
    if not predicted:
        monkeypatch.setattr(starts, "at_limit",
                            lambda assemblies, ops, fields: [False] * len(assemblies))
    grid = Grid({"mu1": [0.0, 0.05], "mu2": [0.15, 0.2, 0.25, 0.3]})
    runs = {}
    for rolling in (False, True):
        clear_operator_cache()
        runs[rolling] = run_study(b1, grid, out=tmp_path / str(rolling), progress=False,
                                  rolling=rolling, batch=4)
    lines = sorted(runs[False].records, key=lambda r: r["number"])
    rolled = sorted(runs[True].records, key=lambda r: r["number"])
    assert [r["start"] for r in rolled] == [r["start"] for r in lines]
    assert [r["iterations"] for r in rolled] == [r["iterations"] for r in lines]
    assert [r["unique"] for r in rolled] == [r["unique"] for r in lines]
    set_aside = sum("not unique" in r["start"] for r in rolled)
    foreseen = sum(r["start"] == "zero" and not r["unique"] for r in rolled[1:])
    assert (foreseen >= 1 and set_aside == 0) if predicted else set_aside >= 1
    for got, expected in zip(rolled, lines, strict=True):
        # a state the problem leaves undetermined has a neutral direction: rounding (the
        # products grouped otherwise) moves it along it (within 1e-6); a case started from such
        # a state inherits a trace of it (1.2e-9 on (0.05, 0.3)); the others to 1e-14
        rel = 1e-8 if got["unique"] else 1e-6
        assert got["qoi"]["R_stop"] == pytest.approx(expected["qoi"]["R_stop"], rel=rel)
    assert max(r["batch"] for r in rolled) > 1


def test_start_neighbours_follow_the_line_rule(b1: ml.Model) -> None:
    """The first line goes case after case, each from the one before; every later line
    from the line before it, one grid step away; a resumed chain's finished cases count."""
    grid = Grid({"mu1": [0.0, 0.1, 0.2], "mu2": [0.0, 0.3, 0.6]})
    from multilatin.study.plan import plan_study

    plan = plan_study(b1, grid, OPTIONS, 1)
    chain = plan.chains[0]
    parents = start_neighbours(plan, chain, set())
    by_number = {c.number: c for c in chain}
    for number, parent in parents.items():
        case = by_number[number]
        if number == 0:
            assert parent is None
            continue
        assert parent is not None
        assert sum(abs(a - b) for a, b in zip(parent, case.index, strict=True)) == 1
        if case.index[0] > 0:  # a later line: from the line before, same μ2
            assert parent == (case.index[0] - 1, case.index[1])
    resumed = start_neighbours(plan, chain, {0, 1, 2})
    assert set(resumed) == set(range(3, 9))
    assert all(resumed[n] == parents[n] for n in resumed)


def test_a_line_starts_from_seeds(b1: ml.Model) -> None:
    """A study along one parameter: n // 4 seeds evenly spaced start from zero (at most
    half the batch's width), every other case from its neighbour one step nearer its
    nearest seed; too short a line, or too narrow a batch, goes from its first value."""
    from multilatin.study.plan import plan_study

    plan = plan_study(b1, Grid.parse(["mu1=0.3", "mu2=0:0.6:13"]), OPTIONS, 1)
    chain = plan.chains[0]
    seeded = seeded_line_starts(plan, chain, 16)
    assert seeded is not None
    parents, distance = seeded
    position = {c.number: c.index[1] for c in chain}
    seeds = sorted(position[n] for n, parent in parents.items() if parent is None)
    assert seeds == [2, 6, 10]
    for number, parent in parents.items():
        p = position[number]
        nearest = min(seeds, key=lambda q: (abs(q - p), q))
        assert distance[number] == abs(p - nearest) <= 2
        if parent is not None:
            assert parent[1] == p + (1 if nearest > p else -1)
    assert seeded_line_starts(plan, chain, 2) is None  # one seed: from the first value
    short = plan_study(b1, Grid.parse(["mu1=0.3", "mu2=0:0.3:7"]), OPTIONS, 1)
    assert seeded_line_starts(short, short.chains[0], 16) is None
    square = plan_study(b1, Grid.parse(["mu1=0:0.6:13", "mu2=0:0.6:13"]), OPTIONS, 1)
    assert seeded_line_starts(square, square.chains[0], 16) is None


def test_a_seeded_line_resumes_with_its_starts_and_gives_one_chains_answers(
        b1: ml.Model, tmp_path: Path) -> None:
    """An 8-case line (two seeds, every case unique): the rolling batch holds several
    cases; interrupted after three cases it resumes with every case started from the same
    neighbour, the same iterations and answers; R_stop within 0.1 % of the line solved
    case after case from its first value (``rolling=False``)."""
    grid = Grid.parse(["mu1=0.33", "mu2=0:0.21:8"])
    straight = _straight_and_resumed(b1, grid, tmp_path, 3)
    assert sum(r["start"] == "zero" for r in straight) == 2
    assert max(r["batch"] for r in straight) > 2
    chained = sorted(run_study(b1, grid, out=tmp_path / "chained", progress=False,
                               rolling=False).records, key=lambda r: r["number"])
    assert sum(r["start"] == "zero" for r in chained) == 1
    for got, one_chain in zip(straight, chained, strict=True):
        assert got["qoi"]["R_stop"] == pytest.approx(one_chain["qoi"]["R_stop"], rel=1e-3)


def _straight_and_resumed(model: ml.Model, grid: Grid, folder: Path, after: int
                          ) -> list[dict[str, Any]]:
    """The study run straight, then again interrupted after ``after`` cases and resumed:
    every case of the resumed run started from the same neighbour, with the same
    iterations and answers, all unique; returns the straight run's records by number."""
    clear_operator_cache()
    straight = sorted(run_study(model, grid, out=folder / "straight", progress=False).records,
                      key=lambda r: r["number"])

    class Interrupted(Exception):
        pass

    seen: list[dict[str, object]] = []

    def interrupt(record: dict[str, object]) -> None:
        seen.append(record)
        if len(seen) == after:
            raise Interrupted

    with pytest.raises(Interrupted):
        run_study(model, grid, out=folder / "cut", progress=False, on_case=interrupt)
    resumed = sorted(run_study(model, grid, out=folder / "cut", progress=False).records,
                     key=lambda r: r["number"])
    assert [r["start"] for r in resumed] == [r["start"] for r in straight]
    assert [r["iterations"] for r in resumed] == [r["iterations"] for r in straight]
    for got, expected in zip(resumed, straight, strict=True):
        assert got["unique"]
        assert got["qoi"]["R_stop"] == pytest.approx(expected["qoi"]["R_stop"], rel=1e-9)
    return straight


def test_middle_starts_halve_the_chain_of_starts(b1: ml.Model) -> None:
    """A study of one geometry over two parameters starts its middle line's middle case
    from zero, every other case from a case one grid step nearer it: the deepest case of a
    5 × 5 grid is 4 starts from zero (8 from a corner). So do hole positions alone; a line
    alone, several chains and studies over geometries and frictions keep the traversal's
    rule."""
    from multilatin.study.plan import plan_study

    plan = plan_study(b1, Grid({"mu1": [0.0, 0.1, 0.2, 0.3, 0.4],
                                "mu2": [0.0, 0.15, 0.3, 0.45, 0.6]}), OPTIONS, 1)
    assert from_the_middle(plan)
    chain = plan.chains[0]
    parents, depth = middle_starts(plan, chain)
    by_number = {c.number: c for c in chain}
    (root,) = [n for n, parent in parents.items() if parent is None]
    assert by_number[root].index == (2, 2)
    for number, parent in parents.items():
        index = by_number[number].index
        assert depth[number] == sum(abs(i - 2) for i in index)  # nearer by one step each
        if parent is not None:
            assert sum(abs(a - b) for a, b in zip(parent, index, strict=True)) == 1
            assert sum(abs(i - 2) for i in parent) == depth[number] - 1
    assert max(depth.values()) == 4
    assert not from_the_middle(plan_study(b1, Grid({"mu1": [0.3], "mu2": [0.0, 0.3]}),
                                          OPTIONS, 1))
    assert not from_the_middle(plan_study(b1, Grid({"mu1": [0.0, 0.3], "mu2": [0.0, 0.3]}),
                                          OPTIONS, 2))
    b3 = ml.load_model("b3")
    assert not from_the_middle(plan_study(b3, Grid.parse(["xc=24:26:2", "mu1=0:0.3:2"]),
                                          OPTIONS, 1))
    assert from_the_middle(plan_study(b3, Grid.parse(["xc=24:26:2", "yc=74:76:2"]), OPTIONS, 1))


def test_an_interrupted_rolling_study_resumes_with_the_same_starts(
        b1: ml.Model, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The chain's stored state holds, beyond its latest converged cases, those that cases
    still to start from them need: a study interrupted after four cases (the state's
    capacity cut to one case here, its records stored case by case) resumes with every
    case started from the same neighbour as an uninterrupted run, and the same answers."""
    from multilatin.study import rolling

    monkeypatch.setattr(rolling, "_retained_capacity", lambda grid: 1)
    monkeypatch.setattr(rolling, "STATE_EVERY", 1)
    grid = Grid({"mu1": [0.25, 0.33, 0.41], "mu2": [0.0, 0.1, 0.2]})  # all unique
    _straight_and_resumed(b1, grid, tmp_path, 4)


def test_hole_positions_join_a_rolling_batch_with_their_own_operators(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """B3's hole positions: every case has its own holed substructure (operators sharing
    the interfaces), so cases of several geometries iterate side by side in the rolling
    batch. The same starts, iterations and R_stop (to rounding) as the line-by-line study,
    and several geometries ran together; the batch renumbers its cases (and their
    operators) whenever a case leaves. From the nearest neighbours alone: the rolling
    batch's parallelogram starts wait for a case of their own line, which the line batches
    solve together (``tests/test_predictors.py``)."""
    model = ml.load_model("b3")
    grid = Grid.parse(["xc=24:26:3", "yc=74:76:2", "rc=3"])
    monkeypatch.setattr(stream, "RENUMBER_AFTER", 0)  # cases renumbered as others leave
    runs = {}
    for rolling in (False, True):
        clear_operator_cache()
        runs[rolling] = sorted(run_study(model, grid, out=tmp_path / str(rolling),
                                         progress=False, rolling=rolling,
                                         start="nearest").records,
                               key=lambda r: r["number"])
    assert [r["start"] for r in runs[True]] == [r["start"] for r in runs[False]]
    assert [r["iterations"] for r in runs[True]] == [r["iterations"] for r in runs[False]]
    for got, expected in zip(runs[True], runs[False], strict=True):
        assert got["qoi"]["R_stop"] == pytest.approx(expected["qoi"]["R_stop"], rel=1e-9)
    assert max(r["batch"] for r in runs[True]) >= 2


def test_cases_of_other_interfaces_wait_for_the_running_batch(b1: ml.Model) -> None:
    """A feed that mixes two interface discretisations (b1 and b1-4): the b1-4 case waits
    until the b1 cases have left, then runs in a batch of its own; every answer is the one
    of its own batch."""
    b1_4 = ml.load_model("b1-4")
    first = [b1.assemble({"mu1": 0.3, "mu2": mu2}) for mu2 in (0.1, 0.4, 0.6)]
    other = b1_4.assemble({"mu1": 0.3, "mu2": 0.4})
    ops, ops_4 = LatinOperators(first[0], OPTIONS), LatinOperators(other, OPTIONS)
    cases = [StreamCase(0, first[0], ops), StreamCase(1, first[1], ops),
             StreamCase(2, other, ops_4), StreamCase(3, first[2], ops)]
    feed = _Feed(cases)
    solve_latin_stream(feed, OPTIONS, 4)
    expected = solve_latin_batch(first, OPTIONS, ops, check=False)
    alone = solve_latin_batch([other], OPTIONS, ops_4, check=False)[0]
    for key, result in zip((0, 1, 3), expected, strict=True):
        assert feed.results[key].iterations == result.iterations
        assert feed.results[key].qoi["R_stop"] == pytest.approx(result.qoi["R_stop"],
                                                                rel=1e-10)
    assert feed.results[2].iterations == alone.iterations
    assert feed.results[2].qoi["R_stop"] == pytest.approx(alone.qoi["R_stop"], rel=1e-10)
    assert feed.results[2].timings["batch_size"] == 1.0  # after the b1 cases left
    assert list(feed.results)[-1] == 2
