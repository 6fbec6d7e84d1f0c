"""Where a multiresolution case starts, and when it starts again: the start neighbour's
fields (or an extrapolation from several, ``predictors``), zero where the case is most
likely not unique (``at_limit``: a neighbour's state read with the case's friction
coefficients, or a flag one hole position away), and a warm-started answer that the
discrete problem does not determine, or whose failure the start may have caused, solved
again from zero (``path_independent``), so that no study's answer depends on its order."""

from __future__ import annotations

import logging
import re
from collections.abc import Sequence
from typing import TYPE_CHECKING

from ..decomposition.assembly import Assembly
from ..decomposition.result import SolveResult
from ..fem.elasticity import FloatArray
from ..latin import LatinOptions, solve_latin_batch
from ..latin.guards import START_FAILURES
from ..latin.operators import LatinOperators
from ..parameters import Grid
from .predictors import (
    along_geometry,
    at_friction_limit,
    extrapolated_fields,
    held_square,
    not_unique_beside,
    retimed_partner,
    secant_partner,
)

if TYPE_CHECKING:
    from .chain_state import ChainState
    from .plan import Case

log = logging.getLogger(__name__)

Index = tuple[int, ...]
Fields = tuple[FloatArray, FloatArray]
#: a case's start: its start neighbour (None: from zero), the fields it starts from, the
#: other neighbours of an extrapolated start
Start = tuple[Index | None, Fields | None, tuple[Index, ...]]
FROM_ZERO: Start = (None, None, ())


def case_start(grid: Grid, state: ChainState, case: Case, assembly: Assembly,
               ops: LatinOperators, limit: bool = True) -> Start:
    """The nearest converged neighbour's index and interface fields to start ``case`` from,
    and the other neighbours of an extrapolated start (``predictors``: a secant along a
    geometric axis, where the case one step further back on the line is retained, else a
    parallelogram whose other two corners are, ``held_square``; else, along another axis,
    a retimed start where that case is retained, came first and both are unique,
    ``retiming``; else none); from zero when
    its interfaces are discretised otherwise (a geometric parameter that moves a part across
    a substructure's boundary) or when it is most likely not unique (``at_limit``;
    ``limit=False``: the caller checks that, for a batch of cases at once; not asked along
    geometric axes, ``along_geometry``)."""
    flagged = not_unique_beside(case.index, case.axes, state.unsettled)
    if flagged is not None:
        log.info("%s: not unique at the neighbouring hole position %s; started from zero",
                 assembly.label, flagged)
        return FROM_ZERO
    start_index, initial = state.nearest(case.index)
    shape = (assembly.n_steps, ops.points.n_points, 2)
    if initial is not None and any(field.shape != shape for field in initial):
        log.info("%s: its nearest converged neighbour has other interfaces; started from "
                 "zero", assembly.label)
        return FROM_ZERO
    if start_index is None or initial is None:
        return start_index, initial, ()
    if (limit and not along_geometry(case.index, start_index, case.axes)
            and at_limit([assembly], [ops], [initial])[0]):
        return FROM_ZERO
    partner = secant_partner(case.index, start_index, case.axes, grid.shape)
    if partner in state.retained:
        assert partner is not None
        secant = extrapolated_fields(grid, case.index, start_index, initial, (partner,),
                                     [state.retained[partner]], case.axes)
        if secant is not None:
            return start_index, secant, (partner,)
    square = held_square(case.index, start_index, case.axes, state.retained)
    if square is not None:
        fields = extrapolated_fields(grid, case.index, start_index, initial, square,
                                     [state.retained[i] for i in square])
        if fields is not None:
            return start_index, fields, square
    # along a friction line: the start neighbour's history retimed (``retiming``), where
    # the case one step further back came before it (as the rolling batch asks: P started
    # from G) and both are unique
    partner = (retimed_partner(case.index, start_index, case.axes, grid.shape)
               if case.retime else None)
    if (partner is not None and partner in state.retained
            and not {start_index, partner} & state.unsettled
            and list(state.retained).index(partner) < list(state.retained).index(start_index)):
        retimed = extrapolated_fields(grid, case.index, start_index, initial, (partner,),
                                      [state.retained[partner]], case.axes)
        if retimed is not None:
            return start_index, retimed, (partner,)
    return start_index, initial, ()


def at_limit(assemblies: Sequence[Assembly], operators: Sequence[LatinOperators],
             neighbours: Sequence[Fields]) -> list[bool]:
    """Per case: most likely not unique, read from its start neighbour's converged fields
    (``predictors.at_friction_limit``, the cases of one geometry together); such a case
    starts from zero, as its warm attempt would be set aside (``set_aside``)."""
    motions = at_friction_limit(assemblies, [ops.points for ops in operators], neighbours)
    for assembly, motion in zip(assemblies, motions, strict=True):
        if motion is not None:
            log.info("%s: at the friction limit from its neighbour's state (%s); started "
                     "from zero", assembly.label, motion.describe())
    return [motion is not None for motion in motions]


def set_aside(result: SolveResult, start_index: Index | None) -> str | None:
    """Why a warm-started answer is set aside and the case solved again from zero (None:
    kept). One the discrete problem does not determine (``multilatin.uniqueness``): a warm
    start would pick the solution nearest its neighbour's, and the study's answer would
    depend on its order. One whose failure the start may have caused
    (``latin.guards.START_FAILURES``: its fields vanished, as a warm start at zero load's
    do, blew up or overflowed): a cold solve may converge. Not one at the cap, or without
    an equilibrium: no start changes those, and a second solve would double their cost."""
    if start_index is None:
        return None
    if not result.converged:
        if not result.failure.startswith(START_FAILURES):
            return None
        return "not converged, " + re.split(r"[:;(]", result.failure, maxsplit=1)[0].strip()
    return None if result.unique else "not unique"


def path_independent(assemblies: Sequence[Assembly], options: LatinOptions,
                     operators: Sequence[LatinOperators], results: Sequence[SolveResult],
                     start_indices: Sequence[Index | None]
                     ) -> list[tuple[SolveResult, int, str]]:
    """Warm-started cases whose answer is set aside (``set_aside``: not determined by the
    discrete problem, or not converged) are solved again from zero with the same operators
    (all of them as one batch), so that no study's answer depends on the order of its grid.
    Returns per case the result kept, the iterations spent on the warm attempt (0 when it
    is kept) and why it was set aside ("" when kept)."""
    reasons = [set_aside(result, start) for result, start in
               zip(results, start_indices, strict=True)]
    kept = [(result, 0, "") for result in results]
    again = [n for n, reason in enumerate(reasons) if reason is not None]
    if not again:
        return kept
    for n in again:
        log.info("%s: %s from a warm start; solved again from zero", assemblies[n].label,
                 reasons[n])
    cold = solve_latin_batch([assemblies[n] for n in again], options,
                             operators=[operators[n] for n in again], check=False)
    for n, result in zip(again, cold, strict=True):
        kept[n] = (result, results[n].iterations, str(reasons[n]))
    return kept
