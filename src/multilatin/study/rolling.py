"""A multiresolution chain as one rolling batch (``latin.stream``): every case joins the
running iteration as soon as the neighbour it starts from has converged, and leaves it —
recorded in the study's journal — as soon as it converges itself.

Which neighbour a case starts from is fixed before the chain runs. A study over two or
more parameters, all geometric or none (``waves.from_the_middle``), starts by the rule of
Dask's waves (``middle_starts``): the line nearest the middle of the grid from its middle
case outward, every other line's case from its parent line's, one grid step nearer the
middle — the chain of starts half as deep as from a corner (B1 13 × 13: 12 cases after the
one from zero, 24 before), so the batch fills sooner. Other studies start by the
traversal's rule of the line-by-line batches (``start_neighbours``, ``plan.run_batch``): a
grid line whose every case has a finished neighbour one grid step away starts each case
from the nearest finished case of the earlier lines (ties: the most recent); another line
(a chain's first) goes case by case, each from the nearest finished case before it.
Either way every case starts from the same neighbour as in the line-by-line study
(``rolling=False``), whatever the batch's width: the answers are the same, and only the
grouping of the products changes — but for a study over one parameter (a line), which the
rolling batch starts from several *seeds* (``seeded_line_starts``: on B1's μ2 line one
chain from the first value kept one case at a time in the batch; three seeds solve the line
in 0.27–0.28 s instead of 0.37–0.38, for 557 iterations instead of 511). Ready cases join
nearest a case from zero first (their dependants are the most).

A warm-started case whose answer the discrete problem does not determine, or whose failure
the start may have caused, is solved again from zero (``starts.set_aside``, the line
batches' rule) inside the same rolling batch; the cases that start from it wait for that
answer.
"""

from __future__ import annotations

import heapq
import logging
import time
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Any

from ..decomposition.result import SolveResult
from ..fem.elasticity import FloatArray
from ..latin import LatinOptions
from ..latin.stream import StreamCase, solve_latin_stream
from ..model import Model
from ..parameters import Grid
from . import starts
from .chain_state import ChainState, nearest_index
from .plan import Case, StudyPlan, _operators, _retain, _retained_capacity
from .predictors import (
    across_geometries,
    along_geometry,
    extrapolated_fields,
    not_unique_beside,
    parallelogram_partners,
    retimed_from,
    retimed_partner,
    secant_partner,
)
from .records import case_record
from .waves import from_the_middle, line_graph

log = logging.getLogger(__name__)

Index = tuple[int, ...]
#: finished cases are handed to the store (journal and the chain's state, written with an
#: fsync) so many at a time, and when the chain ends or is interrupted
STATE_EVERY = 16
#: a line's cases per seed (``seeded_line_starts``; docs/performance.md, session 37)
SEED_SPACING = 4


def seeded_line_starts(plan: StudyPlan, chain: tuple[Case, ...], width: int
                       ) -> tuple[dict[int, Index | None], dict[int, int]] | None:
    """For a chain along one parameter (a line of n cases): k = n // ``SEED_SPACING``
    cases evenly spaced along it (at most half the batch's ``width``) start from zero —
    seeds — and every other case from its neighbour one step nearer its nearest seed (ties:
    the lower), so that the rolling batch holds up to 2k cases instead of one. Per case
    number the grid index of the neighbour it starts from (None: zero) and its distance
    from its seed (the order in which ready cases join). None where this is no such chain or
    k < 2 (the line then goes from its first value onward, ``start_neighbours``). The
    starts do not depend on which cases a resumed study has finished. Measured on B1's and
    B1-4's μ2 lines (``benchmarks/line_seeds.py``, three runs): from the first value onward
    511 / 509 iterations in 0.37–0.38 / 0.52–0.53 s, three seeds 557 / 570 in 0.27–0.28 /
    0.40–0.41 s, every case from zero 687 / 697 in 0.26 / 0.44–0.46 s — on these lines a
    warm start saves little against a batch's width."""
    varying = [d for d, name in enumerate(plan.grid) if len(plan.grid[name]) > 1]
    if len(varying) != 1:
        return None
    axis = varying[0]
    order = sorted(chain, key=lambda case: case.index[axis])
    n = len(order)
    seeds = min(n // SEED_SPACING, max(width // 2, 1))
    if seeds < 2:
        return None
    at = sorted({min(n - 1, round((i + 0.5) * n / seeds - 0.5)) for i in range(seeds)})
    parents: dict[int, Index | None] = {}
    distance: dict[int, int] = {}
    for p, case in enumerate(order):
        seed = min(at, key=lambda q: (abs(q - p), q))
        parents[case.number] = (None if p == seed else
                                order[p + (1 if seed > p else -1)].index)
        distance[case.number] = abs(p - seed)
    return parents, distance


def start_neighbours(plan: StudyPlan, chain: tuple[Case, ...], finished: set[int]
                     ) -> dict[int, Index | None]:
    """Per case number of ``chain``, the grid index of the neighbour it starts from (None:
    zero), by the line-by-line rule (module docstring) among the latest cases a chain
    retains (``plan._retained_capacity``); ``finished``: the case numbers a resumed study
    has, which count as earlier."""
    capacity = _retained_capacity(plan.grid)
    before: list[Index] = [c.index for c in chain if c.number in finished]
    out: dict[int, Index | None] = {}
    for line in plan.batches(chain, len(chain), "line"):
        todo = [c for c in line if c.number not in finished]
        if not todo:
            continue
        nearest = [nearest_index(before[-capacity:], c.index) for c in todo]
        together = len(todo) > 1 and all(d is not None and d <= 1 for _, d in nearest)
        for case, (index, _) in zip(todo, nearest, strict=True):
            # a line that goes case after case: each from the nearest before it, its own
            # line's cases included
            out[case.number] = index if together else nearest_index(before[-capacity:],
                                                                    case.index)[0]
            if not together:
                before.append(case.index)
        if together:
            before.extend(c.index for c in todo)
        del before[:-capacity]
    return out


def middle_starts(plan: StudyPlan, chain: tuple[Case, ...]
                  ) -> tuple[dict[int, Index | None], dict[int, int]]:
    """Per case number of ``chain``, the grid index of the neighbour it starts from by the
    rule of Dask's waves (``waves.line_graph``): the line nearest the middle of the grid
    from its middle case outward, each case from the one before it; every other line's
    case from its parent line's case at the nearest value along the lines (the same
    value on a full grid: one grid step). And per case number, its depth: the chain of
    starts that leads to it from the one case started from zero."""
    graph = line_graph(plan, chain)
    out: dict[int, Index | None] = {}
    depth: dict[int, int] = {}
    by_index = {case.index: case for case in chain}
    for n in graph.order:
        line = sorted(graph.lines[n], key=graph.along)
        parent = graph.parent[n]
        if parent is None:
            centre = len(line) // 2
            out[line[centre].number], depth[line[centre].number] = None, 0
            for i in [*range(centre + 1, len(line)), *range(centre - 1, -1, -1)]:
                before = line[i - 1 if i > centre else i + 1]
                out[line[i].number] = before.index
                depth[line[i].number] = depth[before.number] + 1
            continue
        candidates = [case.index for case in graph.lines[parent]]
        for case in line:
            index, _ = nearest_index(candidates, case.index)
            assert index is not None
            out[case.number] = index
            depth[case.number] = depth[by_index[index].number] + 1
    return out, depth


class ChainFeed:
    """The cases of one chain for ``solve_latin_stream``: ready when their start neighbour
    has finished; their records handed to ``on_records`` as they finish."""

    def __init__(self, model: Model, grid: Grid, plan: StudyPlan, chain: tuple[Case, ...],
                 mode: str, options: LatinOptions, state: ChainState | None,
                 pending: set[int],
                 on_records: Callable[[list[dict[str, Any]], ChainState | None], None],
                 width: int = 1) -> None:
        """``width``: the rolling batch's, which a line's seeds fill
        (``seeded_line_starts``)."""
        self.model, self.grid, self.mode, self.options = model, grid, mode, options
        self.on_records = on_records
        finished = {c.number for c in chain} - pending
        middle = from_the_middle(plan)
        seeded = None if middle else seeded_line_starts(plan, chain, width)
        if middle:  # half as deep a chain of starts as from a corner
            self.parent, self.priority = middle_starts(plan, chain)
        elif seeded is not None:  # a line from several seeds: the batch holds more cases
            self.parent, self.priority = seeded
        else:  # the traversal's rule: each geometry's operators built once, in turn
            self.parent = start_neighbours(plan, chain, finished)
            self.priority = {c.number: c.number for c in chain}
        self.by_index = {c.index: c for c in chain}
        self.done_numbers = set(finished)
        #: per case number, the other neighbours of its start (``predictors``): the secant's
        #: (the case its start neighbour started from, on the same geometric line) or the
        #: parallelogram's (Q, R): such a start waits for Q too
        self.extra: dict[int, tuple[Index, ...]] = {}
        #: the cases whose (Q, R) are the same frictions at the previous geometry: they wait
        #: for both, and the chain's stored state does not carry them (a geometry's worth)
        self.across: set[int] = set()
        parent_of = {c.index: self.parent.get(c.number) for c in chain}
        number_of = {c.index: c.number for c in chain}
        for case in chain:
            start = self.parent.get(case.number)
            partner = secant_partner(case.index, start, case.axes, grid.shape)
            if partner is not None and start is not None and partner == parent_of.get(start):
                self.extra[case.number] = (partner,)
                continue
            pair = parallelogram_partners(case.index, start, case.axes, grid.shape, parent_of)
            if pair is not None and pair[0] in self.by_index:
                self.extra[case.number] = pair
                continue
            pair = (across_geometries(case.index, start, case.axes, number_of)
                    if not middle else None)
            if pair is not None:
                self.extra[case.number] = pair
                self.across.add(case.number)
                continue
            # along a friction line: the start neighbour's history retimed (``retiming``)
            partner = (retimed_partner(case.index, start, case.axes, grid.shape)
                       if case.retime else None)
            if partner is not None and start is not None and partner == parent_of.get(start):
                self.extra[case.number] = (partner,)
        #: per case number, the pending cases that start from it (or wait for it)
        self.dependants: dict[int, list[Case]] = {}
        self.unmet: dict[int, int] = {}  # per pending case, its unfinished predecessors
        self.ready: list[tuple[int, int, Case]] = []  # a heap: priority, then traversal
        self.n_waiting = 0
        for case in chain:
            if case.number not in pending:
                continue
            self.n_waiting += 1
            index = self.parent[case.number]
            extra = self.extra.get(case.number, ())
            # a parallelogram's Q is no ancestor of P (nor, across geometries, R): the case
            # waits for them too
            needed = ([index, *extra] if case.number in self.across else
                      [index, extra[0]] if len(extra) == 2 else [index])
            waits = [self.by_index[i] for i in needed if i is not None and i in self.by_index]
            waits = [c for c in waits if c.number not in self.done_numbers]
            self.unmet[case.number] = len(waits)
            if not waits:
                heapq.heappush(self.ready, (self.priority[case.number], case.number, case))
            for earlier in waits:
                self.dependants.setdefault(earlier.number, []).append(case)
        self.state = state if state is not None else ChainState(_retained_capacity(grid))
        #: the finished cases flagged not unique (``predictors.not_unique_beside``)
        self.unsettled: set[Index] = set(self.state.unsettled)
        #: the fields of finished cases that cases still to start from them need
        self.fields: dict[Index, tuple[FloatArray, FloatArray]] = {}
        self.children: dict[Index, int] = {}  # pending cases per start neighbour (or partner)
        #: the same, without the partners across geometries: what a stored state carries
        self.essential: dict[Index, int] = {}
        for number in pending:
            for index in self._needs(number):
                self.children[index] = self.children.get(index, 0) + 1
            for index in self._needs(number, essential=True):
                self.essential[index] = self.essential.get(index, 0) + 1
        for index in self.children:  # a resumed chain's: its state stored them
            if index in self.state.retained:
                self.fields[index] = self.state.retained[index]
        self.running: dict[Hashable, tuple[Case, Index | None, tuple[Index, ...], float, bool,
                                            int, float]] = {}
        #: set aside from a warm start, solved again from zero (``starts.set_aside``):
        #: (case, its warm iterations, their wall time)
        self.again: list[tuple[Case, int, float]] = []
        self.set_aside: dict[int, str] = {}  # per case number: why, where set aside
        self.unsaved: list[dict[str, Any]] = []  # finished, not yet handed on

    def take(self, count: int) -> list[StreamCase]:
        out: list[StreamCase] = []
        while self.again and len(out) < count:
            case, spent, spent_s = self.again.pop(0)
            out.append(self._stream_case(case, None, spent, spent_s))
        while self.ready and len(out) < count:
            _, _, case = heapq.heappop(self.ready)
            self.n_waiting -= 1
            out.append(self._stream_case(case, self._start(case), 0, 0.0))
        return out

    def _start(self, case: Case) -> tuple[Index | None, tuple[FloatArray, FloatArray] | None,
                                          tuple[Index, ...]]:
        """The start neighbour's index and fields, and the other neighbours of a secant or
        parallelogram start where the case has them and their fields are at hand
        (``predictors``); where the start neighbour's are not (its answer lost, or a resumed
        study's state without it), the nearest retained case's."""
        index = self.parent[case.number]
        if index is None:
            return None, None, ()
        # its start neighbour, or across geometries Q (its own frictions at the previous
        # geometry), both waited for: flagged not unique one hole position away, the case
        # starts from zero (``predictors.not_unique_beside``)
        beside = {index, *self.extra.get(case.number, ())[:1]} & self.unsettled
        flagged = not_unique_beside(case.index, case.axes, beside) if beside else None
        if flagged is not None:
            log.info("case %d: not unique at the neighbouring hole position %s; started from "
                     "zero", case.number, flagged)
            return None, None, ()
        fields = self._fields(index)
        if fields is None:
            return (*self.state.nearest(case.index), ())
        extra = self.extra.get(case.number, ())
        if retimed_from(index, extra, case.axes) and {index, *extra} & self.unsettled:
            extra = ()  # an answer the problem leaves undetermined: no history to retime
        others = [self._fields(i) for i in extra]
        if extra and all(other is not None for other in others):
            moved = extrapolated_fields(self.grid, case.index, index, fields, extra,
                                        [o for o in others if o is not None], case.axes)
            if moved is not None:
                return index, moved, extra
        return index, fields, ()

    def _fields(self, index: Index) -> tuple[FloatArray, FloatArray] | None:
        """A converged case's interface fields, if still at hand."""
        return self.fields.get(index) or self.state.retained.get(index)

    def _needs(self, number: int, essential: bool = False) -> list[Index]:
        """The cases whose fields case ``number`` starts from (``essential``: but its
        partners across geometries)."""
        extra = () if essential and number in self.across else self.extra.get(number, ())
        return [i for i in (self.parent[number], *extra) if i is not None]

    def _release(self, number: int) -> None:
        """Case ``number`` has started for good: the fields it needed may go."""
        essential = self._needs(number, essential=True)
        for index in self._needs(number):
            if index not in self.children:  # a resumed study's, or a case of another chain
                continue
            self.children[index] -= 1
            if index in essential:
                self.essential[index] -= 1
            if not self.children[index]:
                self.fields.pop(index, None)

    def _stream_case(self, case: Case, start: tuple[Index | None, Any, tuple[Index, ...]] | None,
                     spent: int, spent_s: float) -> StreamCase:
        t0 = time.perf_counter()
        assembly = self.model.assemble(case.mu)
        ops, built = _operators(assembly, self.options)
        start_index, initial, extra = start if start is not None else (None, None, ())
        shape = (assembly.n_steps, ops.points.n_points, 2)
        if initial is not None and any(field.shape != shape for field in initial):
            log.info("%s: its neighbour has other interfaces; started from zero",
                     assembly.label)
            start_index, initial, extra = None, None, ()
        neighbour = (self._fields(start_index) if start_index is not None
                     and not along_geometry(case.index, start_index, case.axes) else None)
        if neighbour is not None and starts.at_limit([assembly], [ops], [neighbour])[0]:
            start_index, initial, extra = None, None, ()
        key = (case.number, spent)
        self.running[key] = (case, start_index, extra, time.perf_counter() - t0, built,
                             spent, spent_s)
        return StreamCase(key, assembly, ops, initial)

    def done(self, key: Hashable, result: SolveResult, wall_s: float) -> None:
        case, start_index, extra, setup_s, built, spent, spent_s = self.running.pop(key)
        reason = starts.set_aside(result, start_index)
        if reason is not None:
            log.info("%s: %s from a warm start; solved again from zero",
                     result.assembly.label, reason)
            self.set_aside[case.number] = reason
            self.again.append((case, result.iterations, wall_s + setup_s))
            return
        self.done_numbers.add(case.number)
        self._release(case.number)  # its neighbours' fields kept until now for the store
        if result.converged and not result.unique:
            self.unsettled.add(case.index)
        if result.converged:
            assert result.interface is not None
            if self.children.get(case.index):
                self.fields[case.index] = (result.interface.displacement_hat,
                                           result.interface.force_hat)
            self.state = _retain(self.state, case, result)
        for dependant in self.dependants.pop(case.number, []):
            self.unmet[dependant.number] -= 1
            if not self.unmet[dependant.number]:
                heapq.heappush(self.ready, (self.priority[dependant.number], dependant.number,
                                            dependant))
        record = case_record(self.grid, case, self.mode, result, spent_s + wall_s + setup_s,
                             setup_s, built, start_index,
                             int(result.timings.get("batch_size", 1)), spent, extra,
                             self.set_aside.pop(case.number, "not unique"))
        self.unsaved.append(record)
        if len(self.unsaved) >= STATE_EVERY or self.finished():
            self.flush()

    def flush(self) -> None:
        """The finished cases not yet handed on go to ``on_records``, with the state."""
        if self.unsaved:
            records, self.unsaved = self.unsaved, []
            self.on_records(records, self._stored_state())

    def _stored_state(self) -> ChainState:
        """The chain's state for the store: its latest converged cases, and those that
        cases still to start from them need (older ones first), so that a resumed chain
        starts every case from its own neighbour, as an uninterrupted one — but for the
        partners across geometries (a geometry's worth at every flush): a resumed case
        without them starts from its neighbour alone."""
        needed = [index for index in self.fields
                  if index not in self.state.retained and self.essential.get(index)]
        if not needed:
            return self.state
        retained = OrderedDict((index, self.fields[index]) for index in needed)
        retained.update(self.state.retained)
        return self.state.keeping(retained, frozenset(self.unsettled))

    def finished(self) -> bool:
        return not self.n_waiting and not self.again and not self.running


def rolls(mode: str, options: LatinOptions, start: str, batch: int) -> bool:
    """Whether a serial chain runs as a rolling batch: multiresolution from the neighbours,
    on NumPy with relaxation (``BatchIterations.join``), in batches of more than one."""
    return (mode != "cold" and start == "neighbour" and options.backend == "numpy"
            and options.acceleration == "relaxation" and batch > 1)


def run_rolling(model: Model, grid: Grid, plan: StudyPlan, chain: tuple[Case, ...],
                mode: str, options: LatinOptions, state: ChainState | None,
                pending: set[int], width: int,
                on_records: Callable[[list[dict[str, Any]], ChainState | None], None]
                ) -> None:
    """The chain's pending cases in one rolling batch of ``width`` (module docstring)."""
    feed = ChainFeed(model, grid, plan, chain, mode, options, state, pending, on_records,
                     width)
    if not feed.n_waiting:
        return
    try:
        solve_latin_stream(feed, options, width)
    finally:  # an interrupted study keeps every case that finished
        feed.flush()
