"""Multiresolution on many workers without cold chains: grid lines as a task graph (issue 16).

Cutting the traversal into ``workers`` contiguous chains (``schedule="chains"``) starts
every chain from zero and breaks the line-after-line batches: on B1's 13 × 13 grid the
multiresolution iterations grow from 8 570 (one chain) to 11 065 (16 chains), on a B3 study
of 845 cases from 66 150 to 74 692 (``benchmarks/dask_waves.py``). Here (``"waves"``) a
study keeps one chain and its grid lines become the tasks of a graph. The first line is the
one nearest the middle of the grid, solved case after case from its middle case outward
(the study's only start from zero; on several workers its two halves side by side); every
other line starts from a *parent* line one grid
step nearer the first — in the same geometry where there is one — so that every case has
a converged neighbour one step away, as in a serial study, and the graph is only as deep as
the grid's half-widths. Lines at the same depth run side by side. Each line is cut into
pieces of its inner parameter's range (batches of ``solve_latin_batch``), as many as keep
the workers busy at its depth; a piece waits only for the pieces of its parent line that
hold its neighbours, so that the lines run as a pipeline. Which neighbour a case starts
from does not depend on the number of workers, and a serial study over two or more
parameters, all geometric or none, starts its cases by the same rule
(``from_the_middle``: its rolling batch, ``study.rolling``, or these tasks one after the
other, ``run_line_tasks``). Along hole positions a task also waits for the *partner* lines
of its cases' extrapolated starts (``partner_lines``, ``predictors``), each nearer the first
line than its own: the graph is no deeper.

Cold mode has no dependencies: each piece is a task of its own.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Callable, Collection
from dataclasses import dataclass
from typing import Any

from ..latin import LatinOptions
from ..model import Model
from ..parameters import Grid
from .chain_state import ChainState
from .plan import Case, StudyPlan, _retained_capacity, run_batch
from .predictors import beside
from .store import StudyStore

__all__ = ["LineGraph", "LineTask", "from_the_middle", "line_graph", "line_tasks",
           "run_line_tasks", "run_line_task", "submit_line_tasks"]


@dataclass(frozen=True)
class LineTask:
    """Cases of one grid line (or a piece of it) solved together, and the earlier tasks
    whose converged cases they start from (``parents``: indices into the task list)."""

    cases: tuple[Case, ...]
    parents: tuple[int, ...]
    depth: int
    #: earlier tasks holding the other neighbours of its cases' extrapolated starts
    #: (``partner_lines``): a secant's or a parallelogram's; none with ``start="nearest"``
    partners: tuple[int, ...] = ()


@dataclass(frozen=True)
class LineGraph:
    """A chain's grid lines (``StudyPlan.batches(..., "line")``) as a tree: the ``root``
    line nearest the middle of the grid, and every other line's ``parent``, a line one grid
    step nearer the root (along the innermost outer parameter where there is one: a line of
    the same geometry rather than a neighbouring geometry's); ``order``: breadth first from
    the root, ``depth``: grid steps from it."""

    lines: list[tuple[Case, ...]]
    root: int
    order: list[int]
    depth: dict[int, int]
    parent: dict[int, int | None]
    inner: int | None
    #: per line, its index in the grid's other dimensions (``dims``, in the grid's order)
    keys: list[tuple[int, ...]]
    dims: tuple[int, ...]
    number_of: dict[tuple[int, ...], int]  # per key, its line

    def along(self, case: Case) -> int:
        """The case's index along the lines."""
        return case.index[self.inner] if self.inner is not None else 0


def line_graph(plan: StudyPlan, chain: tuple[Case, ...]) -> LineGraph:
    """The chain's lines as a tree (``LineGraph``)."""
    lines = plan.batches(chain, len(chain), "line")
    inner = plan.inner

    def outer(case: Case) -> tuple[int, ...]:
        return tuple(i for d, i in enumerate(case.index) if d != inner)

    keys = [outer(line[0]) for line in lines]
    number_of = {key: n for n, key in enumerate(keys)}
    middle = [(min(column) + max(column)) / 2 for column in zip(*keys, strict=True)]
    root = min(range(len(lines)), key=lambda n: (
        sum(abs(k - m) for k, m in zip(keys[n], middle, strict=True)), n))
    # breadth first from the first line: depth = grid steps from it (a chain's lines are
    # consecutive in the traversal, each one step from the one before: all are reached)
    def neighbours(n: int) -> list[int]:  # the innermost outer parameter's first
        out = []
        for d in reversed(range(len(keys[n]))):
            for step in (-1, 1):
                m = number_of.get(keys[n][:d] + (keys[n][d] + step,) + keys[n][d + 1:])
                if m is not None:
                    out.append(m)
        return out

    depth_of = {root: 0}
    order, frontier = [root], [root]
    while frontier:
        following = []
        for n in frontier:
            for m in neighbours(n):
                if m not in depth_of:
                    depth_of[m] = depth_of[n] + 1
                    following.append(m)
        order += following
        frontier = following
    parent_line: dict[int, int | None] = {root: None}
    for n in order[1:]:
        parent_line[n] = next(m for m in neighbours(n) if depth_of[m] == depth_of[n] - 1)
    dims = tuple(d for d in range(len(chain[0].index)) if d != inner)
    return LineGraph(lines, root, order, depth_of, parent_line, inner, keys, dims, number_of)


def partner_lines(graph: LineGraph, n: int, axes: Collection[int], retime: bool = False
                  ) -> tuple[int, ...]:
    """The lines holding the other neighbours of line ``n``'s extrapolated starts
    (``predictors``), each nearer the root than ``n`` (so it is solved earlier, and no
    task waits longer than its depth): where ``n``'s parent line is one step along a
    geometric axis (``axes``: grid dimensions) and the line one step further is nearer the
    root, that line (secant); else two lines Q, R beside ``n`` and its parent one step back
    along another outer axis, one of the two axes geometric (parallelogram: across
    geometries, or across hole-position lines); else, along a non-geometric axis and with
    ``retime``, the line one step beyond its parent (a retimed start, ``retiming``); else
    none. Parallelograms of two non-geometric axes are left out as the rolling batch leaves
    them (session 12, ``predictors``)."""
    parent = graph.parent[n]
    if parent is None or not (axes or retime):
        return ()
    key, parent_key = graph.keys[n], graph.keys[parent]
    moved = [i for i, (k, p) in enumerate(zip(key, parent_key, strict=True)) if k != p]
    if len(moved) != 1:
        return ()
    (a,) = moved

    def earlier(k: tuple[int, ...]) -> int | None:
        m = graph.number_of.get(k)
        return m if m is not None and graph.depth[m] < graph.depth[n] else None

    geometric = [i for i, d in enumerate(graph.dims) if d in axes]  # positions in a key
    beyond = earlier(tuple(2 * p - k for k, p in zip(key, parent_key, strict=True)))
    if a in geometric and beyond is not None:
        return (beyond,)
    for q_key, r_key in beside(key, parent_key, a, geometric):
        q, r = earlier(q_key), earlier(r_key)
        if q is not None and r is not None:
            return (q, r)
    if retime and a not in geometric and beyond is not None and graph.parent[parent] == beyond:
        return (beyond,)
    return ()


def line_tasks(plan: StudyPlan, chain: tuple[Case, ...], workers: int, batch: int
               ) -> list[LineTask]:
    """The chain's grid lines as a task graph (module docstring), every task after its
    parents; pieces of at most ``batch`` cases."""
    graph = line_graph(plan, chain)
    lines, order, depth_of, parent_line = graph.lines, graph.order, graph.depth, graph.parent
    along = graph.along
    load: dict[int, int] = {}  # cases per depth
    for n, depth in depth_of.items():
        load[depth] = load.get(depth, 0) + len(lines[n])
    tasks: list[LineTask] = []
    tasks_of_line: dict[int, dict[int, int]] = {}
    held: dict[int, list[set[int]]] = {}  # per line, the inner values of each piece
    for n in order:
        line, parent, depth = lines[n], parent_line[n], depth_of[n]
        extrapolated = partner_lines(graph, n, line[0].axes, line[0].retime)
        values = sorted({along(case) for case in line})
        n_pieces = min(len(values), max(math.ceil(len(values) / batch),
                                        math.ceil(max(workers, 1) * len(values)
                                                  / max(load[depth], 1))))
        if parent is None and workers > 1 and len(values) > 2:
            # the middle case alone, then both halves side by side, each a chain of pieces
            c, k = len(values) // 2, max(1, (n_pieces - 1) // 2)
            cuts = ([round(i * c / k) for i in range(k)] + [c, c + 1]
                    + [c + 1 + round(i * (len(values) - c - 1) / k) for i in range(1, k + 1)])
            bounds = sorted(set(cuts))
        else:
            bounds = [round(i * len(values) / n_pieces) for i in range(n_pieces + 1)]
        n_pieces = len(bounds) - 1
        ranges = [set(values[bounds[r]:bounds[r + 1]]) for r in range(n_pieces)]
        pieces = [[case for case in line if along(case) in ranges[r]] for r in range(n_pieces)]
        tasks_of_line[n] = {}
        held[n] = ranges
        sequence: list[tuple[int, tuple[int, ...]]]
        if parent is not None:  # the parent line's pieces that hold the same inner values
            sequence = [(r, tuple(tasks_of_line[parent][q] for q, other in
                                  enumerate(held[parent]) if other & ranges[r]))
                        for r in range(n_pieces)]
        else:  # the middle piece from zero, then outward: each piece from the one before
            centre = values[len(values) // 2]
            mid = next(r for r in range(n_pieces) if centre in ranges[r])
            first: tuple[int, ...] = ()
            sequence = [(mid, first)]
            sequence += [(r, (r - 1,)) for r in range(mid + 1, n_pieces)]
            sequence += [(r, (r + 1,)) for r in range(mid - 1, -1, -1)]
        for r, after in sequence:
            if parent is not None:  # solved together: any order
                piece = pieces[r]
            elif r == mid:  # from its middle case outward, each case next to one solved
                piece = sorted(pieces[r], key=lambda c: (abs(along(c) - centre), along(c)))
            else:  # each case next to the one before, the first next to the piece before
                piece = sorted(pieces[r], key=along, reverse=r < mid)
            parents = after if parent is not None else tuple(tasks_of_line[n][a] for a in after)
            partners = tuple(tasks_of_line[m][q] for m in extrapolated
                             for q, other in enumerate(held[m]) if other & ranges[r])
            tasks_of_line[n][r] = len(tasks)
            tasks.append(LineTask(tuple(piece), parents, depth, partners))
    return tasks


def run_line_task(model: Model, grid: Grid, cases: tuple[Case, ...], mode: str,
                  options: LatinOptions,
                  parents: list[tuple[list[dict[str, Any]], ChainState | None]],
                  resumed: ChainState | None, start: str = "neighbour",
                  partners: list[tuple[list[dict[str, Any]], ChainState | None]] | None = None
                  ) -> tuple[list[dict[str, Any]], ChainState | None]:
    """A task of the graph: its cases solved together (``run_batch``), started from the
    converged cases its parent tasks retained (and a resumed study's saved state), and
    extrapolated with its partner tasks' (``LineTask.partners``)."""
    if mode == "cold":
        return run_batch(model, grid, cases, mode, options, None, start)
    retained: OrderedDict[tuple[int, ...], Any] = OrderedDict()
    unsettled: set[tuple[int, ...]] = set()
    # the parents' last: a case's start neighbour is the latest of the nearest
    outputs = [output[1] for output in (partners or [])] + [output[1] for output in parents]
    for state in [resumed, *outputs]:
        if state is not None:
            retained.update(state.retained)
            unsettled |= state.unsettled
    # only what the cases may start from travels on: the converged cases up to NEAR grid
    # steps away (one step: the parent line; two: a fallback next to a failed neighbour)
    near = OrderedDict((index, fields) for index, fields in retained.items()
                       if any(sum(abs(a - b) for a, b in zip(index, case.index, strict=True))
                              <= NEAR for case in cases))
    capacity = max(_retained_capacity(grid), len(near) + len(cases))
    records, state = run_batch(model, grid, cases, mode, options,
                               ChainState().keeping(near, frozenset(unsettled), capacity),
                               start)
    if state is None:
        return records, state
    # what the task hands on: its own converged cases, the ones its children start from
    # (a child's cases are one step from them; its parents' cases are two or more steps
    # away). Dask keeps a task's output until its children are done, and a wave's frontier
    # holds hundreds of lines: with the parents' cases as well, the outputs held on a
    # worker grew to ~1.4 GB on the 21 125-case B3 study
    own = {case.index for case in cases}
    kept = OrderedDict((index, fields) for index, fields in state.retained.items()
                       if index in own)
    return records, state.keeping(kept)


def from_the_middle(plan: StudyPlan) -> bool:
    """Whether a serial multiresolution study starts its cases by the waves' rule (its
    middle line from its middle case outward, every other line from its parent line; the
    chain of starts half as deep as from a corner): studies over two or more parameters,
    in one chain, that are all geometric (B3's hole positions: every case has operators of
    its own) or none is. A line alone goes from its first value onward (the paper's table
    1), or in the rolling batch from several seeds (``rolling.seeded_line_starts``);
    studies over geometries and other parameters in the traversal's order (each
    geometry's operators built once, its cases together); several chains as Dask's
    ``"chains"`` schedule runs them."""
    varying = [name for name in plan.grid if len(plan.grid[name]) > 1]
    one_kind = not plan.geometric or set(varying) <= set(plan.geometric)
    return one_kind and len(varying) >= 2 and len(plan.chains) == 1


def run_line_tasks(model: Model, grid: Grid, plan: StudyPlan, chain: tuple[Case, ...],
                   mode: str, options: LatinOptions, pending: set[int], batch: int,
                   resumed: ChainState | None, start: str,
                   on_records: Callable[[list[dict[str, Any]], ChainState | None], None]
                   ) -> None:
    """The chain's line tasks (``line_tasks`` for one worker) one after the other in this
    process: the same starts as Dask's waves. A task's converged cases are kept, and
    stored with the chain's state, until the tasks that start from them have run."""
    tasks = line_tasks(plan, chain, 1, batch)
    children = [0] * len(tasks)
    for task in tasks:
        for p in task.parents + task.partners:
            children[p] += 1
    outputs: dict[int, tuple[list[dict[str, Any]], ChainState | None]] = {}
    for number, task in enumerate(tasks):
        cases = tuple(c for c in task.cases if c.number in pending)
        if cases:
            parents = [outputs[p] for p in task.parents if p in outputs]
            partners = [outputs[p] for p in task.partners if p in outputs]
            records, state = run_line_task(model, grid, cases, mode, options, parents,
                                           resumed, start, partners)
        for p in task.parents + task.partners:
            children[p] -= 1
            if not children[p]:
                outputs.pop(p, None)
        if not cases:
            continue
        if children[number]:
            outputs[number] = ([], state)
        stored = state
        if state is not None:  # with the cases that tasks still to run start from
            kept: OrderedDict[tuple[int, ...], Any] = OrderedDict()
            flags = set(state.unsettled)
            for _, output in outputs.values():
                kept.update(output.retained if output is not None else {})
                flags |= output.unsettled if output is not None else set()
            kept.update(state.retained)
            stored = state.keeping(kept, frozenset(flags))
        on_records(records, stored)


#: grid steps from a task's cases within which its parents' converged cases are kept
NEAR = 2


def submit_line_tasks(client: Any, model_future: Any, grid: Grid, plan: StudyPlan, mode: str,
                      options: LatinOptions, store: StudyStore, batch: int, workers: int,
                      start: str) -> list[Any]:
    """Submit every chain's pending tasks to the Dask ``client``, each with its parents'
    futures (Dask passes their outputs); finished cases are left out. A task whose parents
    all finished in an earlier run starts from the chain's saved state."""
    futures = []
    for chain_number, chain in enumerate(plan.chains):
        resumed = store.chain_state(mode, chain_number) if mode != "cold" else None
        resumed_future = client.scatter(resumed) if resumed is not None else None
        submitted: dict[int, Any] = {}
        for number, task in enumerate(line_tasks(plan, chain, workers, batch)):
            pending = tuple(c for c in task.cases if not store.finished(mode, c.number))
            if not pending:
                continue
            parents = ([submitted[p] for p in task.parents if p in submitted]
                       if mode != "cold" else [])  # cold cases start from zero: no waiting
            partners = ([submitted[p] for p in task.partners if p in submitted]
                        if mode != "cold" else [])
            submitted[number] = client.submit(
                run_line_task, model_future, grid, pending, mode, options, parents,
                resumed_future, start, partners, pure=False,
                key=f"{mode}-line-{pending[0].number}-{id(store)}")
            futures.append(submitted[number])
    return futures
