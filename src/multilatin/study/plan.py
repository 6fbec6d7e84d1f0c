"""Parametric studies with multiresolution (paper §6, figure 9; method.md §6).

A study is a tensor grid of parameter sets. Its cases are traversed so that consecutive
cases are neighbours (a boustrophedon over the grid, the parameters that change an operator —
the geometry — outermost, as in the paper's figure 9), split into independent *chains*. In
``multiresolution`` mode every case of a chain starts from the converged interface fields of
the nearest already-converged case of its chain, beginning with a linear stage, and reuses
the operators as long as the geometry does not change; in ``cold`` mode every case is a
standalone computation (its own operators, started from zero).
"""

from __future__ import annotations

import logging
import time
from collections import OrderedDict
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..decomposition.result import SolveResult
from ..errors import ModelError
from ..fem.elasticity import FloatArray
from ..kept import Kept
from ..latin import LatinOptions, solve_latin, solve_latin_batch
from ..latin.operators import LatinOperators
from ..latin.signatures import operator_signature
from ..model import Model
from ..parameters import Grid, Mu
from . import starts
from .chain_state import ChainState
from .predictors import along_geometry
from .records import case_record

log = logging.getLogger(__name__)

MODES = ("multiresolution", "cold")
#: how the multiresolution mode starts a case: from its nearest converged neighbour, and
#: along geometric axes from neighbours extrapolated (``predictors``), along the others
#: from the neighbour's history retimed (``retiming``); from the
#: nearest alone (the paper's §6); or from zero with the cases in wide batches — every case
#: of a geometry, sharing the operators (NumPy), or consecutive cases of several geometries
#: (torch) — for a GPU, where a wide batch costs little more than a narrow one
START_FROM = ("neighbour", "nearest", "zero")
#: how a Dask run shares out multiresolution work (``run_study(schedule=...)``,
#: ``study.waves``)
SCHEDULES = ("waves", "chains")


@dataclass(frozen=True)
class Case:
    """One computation of a study: its place in the traversal and its parameters."""

    number: int  # position in the traversal (0-based)
    index: tuple[int, ...]  # grid index, in the grid's parameter order
    mu: Mu
    chain: int
    #: the grid's dimensions that change the geometry: extrapolated starts along them
    #: (``predictors``: secant, parallelogram)
    axes: tuple[int, ...] = ()
    #: retimed starts along the other axes (``retiming``; not with ``start="nearest"``)
    retime: bool = False


@dataclass(frozen=True)
class StudyPlan:
    """The cases of a study in traversal order, split into independent chains."""

    grid: Grid
    chains: tuple[tuple[Case, ...], ...]
    geometric: tuple[str, ...]  # grid parameters that change an operator (outer loops)
    #: the innermost traversal dimension: the grid lines that multiresolution batches
    #: (geometric on the NumPy backend only; None on torch when it changes an operator)
    inner: int | None = None

    def batches(self, chain: tuple[Case, ...], size: int, by: str = "line"
                ) -> list[tuple[Case, ...]]:
        """Consecutive cases of ``chain`` in pieces of at most ``size`` that keep together
        (``by``): ``"line"``, a line of the grid along the innermost dimension (``inner``:
        the cases a batched multiresolution step solves together);
        ``"geometry"``, every case of a geometry (a study from zero on the NumPy backend,
        ``START_FROM``); ``"any"``, whatever their geometry (the same on the torch backend,
        which batches several geometries)."""
        if by not in ("line", "geometry", "any"):
            raise ValueError(f"by: expected 'line', 'geometry' or 'any', got {by!r}")
        out: list[list[Case]] = []
        previous_line = None
        geometric = [d for d, name in enumerate(self.grid) if name in self.geometric]
        for case in chain:
            if by == "any":
                line: tuple[int, ...] | None = ()
            elif by == "geometry":
                line = tuple(case.index[d] for d in geometric)
            else:
                line = (None if self.inner is None else
                        tuple(i for d, i in enumerate(case.index) if d != self.inner))
            if out and line is not None and line == previous_line and len(out[-1]) < size:
                out[-1].append(case)
            else:
                out.append([case])
            previous_line = line
        return [tuple(batch) for batch in out]

    def wavefront(self, chain: tuple[Case, ...], size: int) -> list[tuple[Case, ...]]:
        """The k-th grid line of every geometry of ``chain`` together, for k = 0, 1, …, in
        pieces of at most ``size``: each case's neighbour one step away in its geometry's
        line k − 1 is solved in an earlier batch (multiresolution on the torch backend,
        which batches several geometries: B3's 125 hole geometries × a line of 13)."""
        geometric = [d for d, name in enumerate(self.grid) if name in self.geometric]
        seen: dict[tuple[int, ...], int] = {}
        waves: dict[int, list[Case]] = {}
        for line in self.batches(chain, len(chain)):
            key = tuple(line[0].index[d] for d in geometric)
            k = seen.get(key, 0)
            seen[key] = k + 1
            waves.setdefault(k, []).extend(line)
        return [tuple(wave[i:i + size]) for k in sorted(waves) for wave in [waves[k]]
                for i in range(0, len(wave), size)]

    def geometry_waves(self, chain: tuple[Case, ...]) -> list[tuple[Case, ...]]:
        """The geometries of ``chain`` in waves outward from its middle one: its cases first
        (from zero), then every geometry one step (along one geometric parameter) from a
        geometry of the wave before, all its cases in one batch, each starting from the
        same other parameters' case there (torch multiresolution: B3's 125 hole
        geometries in 7 waves of up to 36 × 169 cases, where ``wavefront`` takes 13 of
        1 625). A wave is one batch, however wide: the device chunks it by its memory.
        None for a chain of one geometry (``wavefront``'s lines then)."""
        geometric = [d for d, name in enumerate(self.grid) if name in self.geometric]
        by_geometry: dict[tuple[int, ...], list[Case]] = {}
        for case in chain:
            by_geometry.setdefault(tuple(case.index[d] for d in geometric), []).append(case)
        if len(by_geometry) < 2:
            return []
        keys = list(by_geometry)

        def steps(a: tuple[int, ...], b: tuple[int, ...]) -> int:
            return sum(abs(x - y) for x, y in zip(a, b, strict=True))

        root = min(keys, key=lambda k: sum(steps(k, other) for other in keys))
        level, frontier = {root: 0}, [root]
        while frontier:  # breadth first over geometries one step apart
            depth = level[frontier[0]] + 1
            frontier = [k for k in keys if k not in level
                        and any(steps(k, f) == 1 for f in frontier)]
            level.update(dict.fromkeys(frontier, depth))
        last = max(level.values())
        for k in keys:  # not reached one step at a time: a wave of its own, at the end
            level.setdefault(k, last + 1)
        waves: dict[int, list[Case]] = {}
        for k in keys:
            waves.setdefault(level[k], []).extend(by_geometry[k])
        return [tuple(waves[n]) for n in sorted(waves)]

    @property
    def cases(self) -> list[Case]:
        return [case for chain in self.chains for case in chain]

    @property
    def size(self) -> int:
        return sum(len(chain) for chain in self.chains)


def boustrophedon(shape: tuple[int, ...]) -> Iterator[tuple[int, ...]]:
    """Every index of ``shape``, consecutive ones differing by one step in one dimension
    (the first dimension outermost)."""
    if not shape:
        yield ()
        return
    inner = list(boustrophedon(shape[1:]))
    for i in range(shape[0]):
        for rest in inner if i % 2 == 0 else reversed(inner):
            yield (i, *rest)


def geometric_parameters(model: Model, grid: Grid, options: LatinOptions) -> list[str]:
    """The grid's parameters with several values that change an operator (a geometry), in
    the grid's order, found by assembling a case one step along each; the grid validated
    against the model first."""
    grid.validate(model.parameters)
    names = list(grid)
    base = operator_signature(_assemble(model, grid, (0,) * len(names)), options)
    return [name for d, name in enumerate(names) if len(grid[name]) > 1 and
            operator_signature(_assemble(model, grid, tuple(int(e == d) for e in
                                                            range(len(names)))),
                               options) != base]


def plan_study(model: Model, grid: Grid, options: LatinOptions | None = None,
               chains: int = 1, extrapolate: bool = True) -> StudyPlan:
    """Validate the grid against the model (names, ranges, geometry of every distinct
    geometric parameter set) and order its cases; nothing is computed here.
    ``extrapolate``: cases may start from neighbours extrapolated along geometric axes
    (``Case.axes``, ``predictors``) and retimed along the others (``Case.retime``,
    ``retiming``); False: from the nearest alone."""
    options = options or LatinOptions()
    if chains < 1:
        raise ModelError(f"chains: must be >= 1, got {chains}")
    names = list(grid)
    geometric = geometric_parameters(model, grid, options)
    # every geometry of the study is built once now, so that a bad one fails before any work
    geometric_dims = [names.index(name) for name in geometric]
    for sub_index in np.ndindex(*[len(grid[name]) for name in geometric]):
        index = [0] * len(names)
        for d, i in zip(geometric_dims, sub_index, strict=True):
            index[d] = i
        _assemble(model, grid, tuple(index))
    # single values change nothing in the traversal: outermost, so that the innermost
    # dimension (the grid lines that multiresolution batches) is one with several values
    rest = [d for d in range(len(names)) if d not in geometric_dims]
    order = (geometric_dims + [d for d in rest if len(grid[names[d]]) == 1]
             + [d for d in rest if len(grid[names[d]]) > 1])
    shape = tuple(len(grid[names[d]]) for d in order)
    ordered = []
    for traversal_index in boustrophedon(shape):
        index = [0] * len(names)
        for d, i in zip(order, traversal_index, strict=True):
            index[d] = i
        ordered.append(tuple(index))
    n_chains = min(chains, len(ordered))
    bounds = np.linspace(0, len(ordered), n_chains + 1).round().astype(int)
    chain_cases = tuple(
        tuple(Case(number, ordered[number], grid.mu(ordered[number], model.parameters), c,
                   tuple(sorted(geometric_dims)) if extrapolate else (), extrapolate)
              for number in range(bounds[c], bounds[c + 1]))
        for c in range(n_chains))
    # the grid lines that multiresolution batches: along the innermost dimension; a
    # geometric one only on NumPy, whose batches take several geometries sharing their
    # interfaces (a hole moved inside a substructure; others are solved apart) but keep the
    # lines (torch's wavefront needs a line of one geometry)
    several = [d for d in order if len(grid[names[d]]) > 1]
    inner = (several[-1] if several and (several[-1] not in geometric_dims
                                         or options.backend == "numpy") else None)
    return StudyPlan(grid, chain_cases, tuple(geometric), inner)


def _assemble(model: Model, grid: Grid, index: tuple[int, ...]) -> Any:
    mu = grid.mu(index, model.parameters)
    try:
        return model.assemble(mu)
    except ModelError as error:
        params = ", ".join(f"{k}={v:g}" for k, v in mu.items())
        raise ModelError(f"parameter set ({params}): {error}") from None


# operators of the latest geometries met by this process (a worker keeps its own); lines
# of hole positions meet theirs again at every line (2 kept: 36 builds instead of 5 on B3's
# 5 positions × 52 frictions, 1.1–1.4 s of ~27 s); b3's take ~5 MB a geometry
_OPERATORS: OrderedDict[str, LatinOperators] = OrderedDict()
_OPERATOR_CACHE_SIZE = 8


def clear_operator_cache() -> None:
    """Forget the operators this process keeps between cases (and studies), and what
    their builds share (``Kept``: meshes' arrays, element stiffnesses, orderings)."""
    _OPERATORS.clear()
    Kept.clear_all()


def _operators(assembly: Any, options: LatinOptions) -> tuple[LatinOperators, bool]:
    """Cached operators for this geometry; True when they had to be built."""
    signature = operator_signature(assembly, options)
    if signature in _OPERATORS:
        _OPERATORS.move_to_end(signature)
        return _OPERATORS[signature], False
    # a new geometry: substructures unchanged since the latest operators are reused
    latest = next(reversed(_OPERATORS.values())) if _OPERATORS else None
    ops = LatinOperators(assembly, options, reuse=latest)
    _OPERATORS[signature] = ops
    while len(_OPERATORS) > _OPERATOR_CACHE_SIZE:
        _OPERATORS.popitem(last=False)
    return ops, True


def run_case(model: Model, grid: Grid, case: Case, mode: str, options: LatinOptions,
             state: ChainState | None) -> tuple[dict[str, Any], ChainState | None]:
    """Solve one case; returns its record and the chain's state for the next case."""
    t0 = time.perf_counter()
    assembly = model.assemble(case.mu)
    extra: tuple[tuple[int, ...], ...]
    if mode == "cold":
        ops, built = LatinOperators(assembly, options), True
        start_index, initial, extra = None, None, ()
    else:
        ops, built = _operators(assembly, options)
        state = state if state is not None else ChainState(_retained_capacity(grid))
        start_index, initial, extra = starts.case_start(grid, state, case, assembly, ops)
    setup_s = time.perf_counter() - t0
    result = solve_latin(assembly, options, operators=ops, initial=initial, check=False)
    [(result, spent, reason)] = starts.path_independent([assembly], options, [ops], [result],
                                                        [start_index])
    wall_s = time.perf_counter() - t0
    if mode != "cold" and result.converged and state is not None:
        state = _retain(state, case, result)
    return case_record(grid, case, mode, result, wall_s, setup_s, built, start_index, 1,
                       spent, extra, reason), state


def run_batch(model: Model, grid: Grid, cases: tuple[Case, ...], mode: str,
              options: LatinOptions, state: ChainState | None, start: str = "neighbour"
              ) -> tuple[list[dict[str, Any]], ChainState | None]:
    """Solve cases together (``solve_latin_batch``), each started from its converged
    neighbour one grid step away (multiresolution: a grid line from the previous line). On
    the NumPy backend a batch is a grid line (``StudyPlan.inner``: of one geometry, or of
    hole positions along a geometric innermost parameter); where some case has no such neighbour
    (the first line of a chain), and in cold mode, the cases are solved one by one, each
    from the previous. On the torch backend a batch may hold lines of several geometries
    (``StudyPlan.wavefront``), a case without a converged neighbour starting from zero. A
    batch's wall time is shared among its cases in proportion to their iterations
    (``record["batch"]`` gives the batch's size). ``start="zero"`` (multiresolution mode):
    every case of the batch starts from zero."""
    if mode != "cold" and start == "zero":
        records, _ = _solve_together(model, grid, cases, mode, options, None)
        return records, state
    if mode != "cold":
        state = state if state is not None else ChainState(_retained_capacity(grid))
    on_device = options.backend == "torch" and mode != "cold"
    if not on_device and (mode == "cold" or len(cases) == 1 or not all(
            _has_neighbour(state, case) for case in cases)):
        records = []
        for case in cases:
            record, after = run_case(model, grid, case, mode, options, state)
            state = after if after is not None else state
            records.append(record)
        return records, state
    assert state is not None
    if state.capacity < 2 * len(cases):  # a wavefront keeps the previous lines of all
        state = state.keeping(state.retained, capacity=2 * len(cases))  # its geometries
    return _solve_together(model, grid, cases, mode, options, state)


def _solve_together(model: Model, grid: Grid, cases: tuple[Case, ...], mode: str,
                    options: LatinOptions, state: ChainState | None
                    ) -> tuple[list[dict[str, Any]], ChainState | None]:
    """Cases solved as one batch with their geometries' operators, each from its nearest
    converged neighbour in ``state`` (None: all from zero, ``START_FROM``), the converged
    ones retained; non-unique warm-started answers solved again from zero."""
    t0 = time.perf_counter()
    assemblies = [model.assemble(case.mu) for case in cases]
    per_case, first_built = [], []
    for assembly in assemblies:
        ops, built = _operators(assembly, options)
        per_case.append(ops)
        first_built.append(built)
    chosen = [starts.case_start(grid, state, case, assembly, ops, limit=False)
              if state is not None else starts.FROM_ZERO
              for case, assembly, ops in zip(cases, assemblies, per_case, strict=True)]
    warm = [(n, index) for n, (index, _, _) in enumerate(chosen) if index is not None
            and not along_geometry(cases[n].index, index, cases[n].axes)]
    if warm and state is not None:  # the friction limit from the neighbours' states at once
        limited = starts.at_limit([assemblies[n] for n, _ in warm],
                                  [per_case[n] for n, _ in warm],
                                  [state.retained[index] for _, index in warm])
        for (n, _), zero in zip(warm, limited, strict=True):
            chosen[n] = starts.FROM_ZERO if zero else chosen[n]
    setup_s = time.perf_counter() - t0
    results = solve_latin_batch(assemblies, options, operators=per_case,
                                initial=[fields for _, fields, _ in chosen], check=False)
    kept = starts.path_independent(assemblies, options, per_case, results,
                                   [start_index for start_index, _, _ in chosen])
    wall_s = time.perf_counter() - t0
    total_iterations = sum(r.iterations + spent for r, spent, _ in kept)
    records = []
    for case, (result, spent, reason), (start_index, _, extra), built in zip(
            cases, kept, chosen, first_built, strict=True):
        share = (result.iterations + spent) / total_iterations
        records.append(case_record(grid, case, mode, result, share * wall_s, share * setup_s,
                                    built, start_index, len(cases), spent, extra, reason))
    if state is not None:  # the converged ones, retained in one copy of the state
        state = state.added_all([_retained(case, result) for case, (result, _, _) in
                                 zip(cases, kept, strict=True) if result.converged])
    return records, state


def _has_neighbour(state: ChainState | None, case: Case) -> bool:
    """A converged case one grid step from ``case`` is retained."""
    distance = state.distance(case.index) if state is not None else None
    return distance is not None and distance <= 1


def _retained(case: Case, result: SolveResult
              ) -> tuple[tuple[int, ...], tuple[FloatArray, FloatArray], bool]:
    """What a chain's state keeps of a converged case: its ŝ, flagged when not unique."""
    assert result.interface is not None
    return (case.index, (result.interface.displacement_hat, result.interface.force_hat),
            not result.unique)


def _retain(state: ChainState, case: Case, result: SolveResult) -> ChainState:
    return state.added_all([_retained(case, result)])


def _retained_capacity(grid: Grid) -> int:
    """Enough converged neighbours to find one a single grid step away after a failure."""
    inner = max(grid.shape) if len(grid) else 1
    return int(min(2 * inner + 1, 64))


def run_chain_step(model: Model, grid: Grid, cases: tuple[Case, ...], mode: str,
                   options: LatinOptions,
                   previous: tuple[list[dict[str, Any]], ChainState | None] | ChainState | None,
                   start: str = "neighbour") -> tuple[list[dict[str, Any]], ChainState | None]:
    """A task of a distributed chain, one batch of cases: ``previous`` is the previous
    task's output (or a resumed state, or None at the start of a chain)."""
    state = previous[1] if isinstance(previous, tuple) else previous
    return run_batch(model, grid, cases, mode, options, state, start)


def chain_step_stored(output: tuple[list[dict[str, Any]], ChainState | None]
                      ) -> tuple[list[dict[str, Any]], ChainState | None]:
    """A chain task's records and the state its store keeps (``ChainState.stored``): run
    beside the task on its worker, so that only this much travels to the client."""
    records, state = output
    return records, state.stored() if state is not None else None
