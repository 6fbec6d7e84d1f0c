"""A rolling batch: cases join the running LATIN iteration as soon as they are ready and
leave it as soon as they converge (``solve_latin_stream``; method.md §7).

A batch of cases that start together runs as long as its slowest case, its last iterations
with few cases left, where an iteration costs nearly as much as with many (B1: 1.2 ms for
one case, 6 ms for thirteen). A multiresolution study's cases become ready one by one — a
case as soon as the neighbour it starts from has converged — so a rolling batch keeps
``width`` cases in the iteration all along: each case is iterated, stopped and relaxed
exactly as alone (its own iteration count, ``iteration.BatchIterations``), the batch only
shares the products.
"""

from __future__ import annotations

import logging
import time
from collections import OrderedDict
from collections.abc import Hashable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..decomposition.assembly import Assembly
from ..decomposition.interfaces import InterfacePoints, with_contact_data
from ..decomposition.result import SolveResult
from ..fem.elasticity import FloatArray, IntArray
from ..limits import check_scale
from .batching import same_interfaces
from .body_forces import BodyResponse, body_response, stacked_offsets, with_body_constants
from .engine import one_blas_thread
from .guards import drop_unloaded_starts
from .iteration import BatchIterations
from .local_stage import LocalStage
from .operators import LatinOperators
from .options import LatinOptions
from .solver import _functionals, _recovered, log_result, results_of
from .tracking import QoiFunctionals

__all__ = ["CaseFeed", "StreamCase", "solve_latin_stream"]

log = logging.getLogger(__name__)

#: a rolling batch forgets the cases that left (``BatchIterations.renumber``) once it has
#: held this many times its width: a long stream costs memory and time as its width does
RENUMBER_AFTER = 4
#: the QoI functionals kept for cases still to join, by operators (the latest few)
FUNCTIONALS_KEPT = 8
#: the QoI functionals built so far: by (id of the operators, the QoIs) the operators (so
#: that an id is not reused while kept) and their functionals
_Built = OrderedDict[tuple[int, str], tuple[LatinOperators, QoiFunctionals]]


@dataclass(frozen=True)
class StreamCase:
    """A case ready to join: its key (the feed's own), assembly, operators and start ŝ
    (None: zero)."""

    key: Hashable
    assembly: Assembly
    operators: LatinOperators
    initial: tuple[FloatArray, FloatArray] | None = None


class CaseFeed(Protocol):
    """Where a rolling batch takes its cases from and gives its results to."""

    def take(self, count: int) -> list[StreamCase]:
        """Up to ``count`` cases ready to start now (none: nothing ready yet)."""

    def done(self, key: Hashable, result: SolveResult, wall_s: float) -> None:
        """A case left the batch: its result and its share of the wall time (the batch's
        iterations shared among the cases in them, its setup and post-processing)."""

    def finished(self) -> bool:
        """No case is left to take, now or later."""


@dataclass
class _Member:
    case: StreamCase
    points: InterfacePoints
    wall_s: float
    functional: QoiFunctionals
    body: BodyResponse | None


def solve_latin_stream(feed: CaseFeed, options: LatinOptions, width: int = 16) -> int:
    """Solve the feed's cases in a rolling batch of at most ``width`` (NumPy backend,
    relaxation: the study defaults). Cases of another interface family than the running
    batch's wait until it is empty. Returns the number of batch iterations."""
    if width < 1:
        raise ValueError(f"width: expected at least 1, got {width}")
    batch: BatchIterations | None = None
    members: dict[int, _Member] = {}
    waiting: list[StreamCase] = []  # another interface family: after the running batch
    built: _Built = OrderedDict()
    steps = 0
    # one BLAS thread for the whole stream, as for a batch's iteration and recovery
    # (``solve_latin_batch``); the operators of cases that join are built inside it too
    with one_blas_thread(), np.errstate(over="ignore", invalid="ignore"):
        while True:
            n_active = 0 if batch is None else int(batch.active.size)
            if batch is not None and n_active == 0:
                batch, members = None, {}
            room = width - n_active
            incoming, waiting = waiting[:room], waiting[room:]
            if room > len(incoming):
                incoming += feed.take(room - len(incoming))
            family: LatinOperators | None = (
                batch.ops if batch is not None else
                incoming[0].operators if incoming else None)
            joins = [family is not None and same_interfaces(family, c.operators)
                     for c in incoming]
            waiting = [c for c, j in zip(incoming, joins, strict=True) if not j] + waiting
            joining = [c for c, j in zip(incoming, joins, strict=True) if j]
            if joining:
                batch = _join(batch, members, joining, options, built)
            if batch is None or not batch.active.size:
                if feed.finished() and not waiting:
                    return steps
                raise RuntimeError("a rolling batch ran dry: no case is active or ready")
            t0 = time.perf_counter()
            active = batch.active.copy()
            left = batch.step()
            steps += 1
            share = (time.perf_counter() - t0) / active.size
            for number in active.tolist():
                members[number].wall_s += share
            if left.size:
                t1 = time.perf_counter()
                leaving = [members.pop(number) for number in left.tolist()]
                fields = _recover(batch, leaving, left)
                _leave(batch, leaving, left, fields, time.perf_counter() - t1, options, feed)
                if len(batch.state.histories) > RENUMBER_AFTER * width and batch.active.size:
                    kept = batch.renumber()
                    members = {n: members[int(c)] for n, c in enumerate(kept)}


def _join(batch: BatchIterations | None, members: dict[int, _Member],
          joining: list[StreamCase], options: LatinOptions,
          built: _Built) -> BatchIterations:
    """The cases join ``batch`` (or start one), grouped by their operators; ``built``:
    the QoI functionals built so far, by operators and QoIs."""
    for ops in {id(c.operators): c.operators for c in joining}.values():
        t0 = time.perf_counter()
        group = [c for c in joining if c.operators is ops]
        assemblies = [c.assembly for c in group]
        points = [ops.points if ops.assembly is a else with_contact_data(ops.points, a)
                  for a in assemblies]
        shape = (group[0].assembly.n_steps, ops.points.n_points, 2)
        if any(a.n_steps != shape[0] for a in assemblies) or (
                batch is not None and batch.n_steps != shape[0]):
            raise ValueError("a rolling batch's cases must share the number of load steps")
        w_hat, f_hat = np.zeros((len(group), *shape)), np.zeros((len(group), *shape))
        for i, c in enumerate(group):
            if c.initial is not None:
                w_hat[i], f_hat[i] = c.initial
        bodies = [body_response(ops, assembly) for assembly in assemblies]
        local = LocalStage(assemblies, points, ops.search_direction, macro_only=ops.macro_only,
                           body=stacked_offsets(bodies, shape[0], shape[1]))
        check_scale(assemblies, points[0], ops.search_direction, local)
        drop_unloaded_starts(local, bodies, w_hat, f_hat, [a.label for a in assemblies])
        # built once per operators and set of QoIs: shared functionals are applied to all
        # the cases at once (``NumpyFields.qoi_values``)
        functionals = []
        for assembly, pts in zip(assemblies, points, strict=True):
            key = (id(ops), repr(assembly.qois))
            if key not in built or built[key][0] is not ops:
                built[key] = (ops, _functionals([ops], np.zeros(1, dtype=np.int64),
                                                [assembly], [pts])[0])
                while len(built) > FUNCTIONALS_KEPT:
                    built.popitem(last=False)
            built.move_to_end(key)
            functionals.append(built[key][1])
        functionals = [with_body_constants(functional, body, assembly) for functional, body,
                       assembly in zip(functionals, bodies, assemblies, strict=True)]
        if batch is None:
            batch = BatchIterations(ops, local, options, w_hat, f_hat, None, functionals)
            numbers = batch.active.copy()
        else:
            numbers = batch.join(local, w_hat, f_hat, functionals, ops)
        setup = (time.perf_counter() - t0) / len(group)
        for number, c, pts, functional, body in zip(numbers.tolist(), group, points,
                                                    functionals, bodies, strict=True):
            members[number] = _Member(c, pts, setup, functional, body)
    assert batch is not None
    return batch


def _recover(batch: BatchIterations, leaving: list[_Member], left: IntArray
             ) -> list[dict[str, FloatArray]]:
    """The interior displacements of the cases that left, per operators."""
    if not batch.options.recover_displacements:
        return [{} for _ in leaving]
    distinct = list({id(m.case.operators): m.case.operators for m in leaving}.values())
    geometry = np.array([distinct.index(m.case.operators) for m in leaving])
    return _recovered(batch.state, left.tolist(), distinct, geometry,
                      [m.body for m in leaving], [m.case.assembly for m in leaving])


def _leave(batch: BatchIterations, leaving: list[_Member], left: IntArray,
           fields: list[dict[str, FloatArray]], recovery_s: float, options: LatinOptions,
           feed: CaseFeed) -> None:
    """The cases that left: their results handed to the feed, their exit fields then
    dropped from the batch's state (a long stream holds only its active cases' fields)."""
    t0 = time.perf_counter()
    numbers = left.tolist()
    state = batch.state
    results = results_of(numbers, [m.case.assembly for m in leaving],
                         [m.points for m in leaving], state, fields, options,
                         [m.functional for m in leaving])
    share = (time.perf_counter() - t0 + recovery_s) / len(leaving)
    for number, m, result in zip(numbers, leaving, results, strict=True):
        del state.exits[number]
        width = batch.active.size + len(leaving)
        result.timings.update({"total": m.wall_s + share, "batch_size": float(width)})
        log_result(result, width)
        feed.done(m.case.key, result, m.wall_s + share)
