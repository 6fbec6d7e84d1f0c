"""Starts beyond the nearest neighbour (issue 16; the paper's §6 starts a case from one
converged neighbour), along parameters that change the geometry (B3's hole positions):

- secant: a case whose start neighbour P is one grid step away, and whose case G one step
  further back on the same line has converged too, starts from

      ŝ = ŝ_P + t (ŝ_P − ŝ_G),   t = (v − v_P) / (v_P − v_G),

  in Ŵ and F̂ at every step (v: the parameter's values);
- parallelogram: a case C started from P across lines, where the case Q beside C on its own
  line and P both started from the same case R, starts from ŝ_P + ŝ_Q − ŝ_R;
- parallelogram across geometries (studies over hole positions and frictions): a case C
  started from P along a friction axis, where Q = C and R = P at the previous geometry came
  earlier in the traversal, starts from ŝ_P + ŝ_Q − ŝ_R.

Interface fields of nearby hole positions change smoothly; the fields of nearby friction
coefficients do not (contact statuses change between neighbours: the secant cost 11 % more
iterations on the B1 13 × 13 study, session 12), so the rules are for geometric axes only
(``Case.axes``; ``start="nearest"`` leaves them out). Measured: docs/performance.md
("Secant and parallelogram starts along hole positions": B3's 5 × 5 positions 32 % fewer
iterations, B3's xc × 13 × 4 frictions 37 % fewer).

The rolling batch takes G where P started from it, and the parallelogram where R started P
and Q, waiting for Q (so that no start depends on which cases have finished); the line
batches and Dask's line tasks take the secant where G is among the converged cases they
hold, else a parallelogram whose Q and R they hold (``held_square``; a task holds its
parent line's cases and its partner lines', ``waves.partner_lines``: the line one step
beyond the parent, or the two lines beside it and the parent across a geometric axis;
never the task's own line, whose cases are solved together), else the nearest alone.
"""

from __future__ import annotations

from collections.abc import Collection, Iterator, Mapping, Sequence

from ..decomposition.assembly import Assembly
from ..decomposition.interfaces import InterfacePoints, with_contact_data
from ..decomposition.uniqueness import RESERVE_TOL, FreeMotion, limit_motions_batch
from ..fem.elasticity import FloatArray
from ..parameters import Grid
from .retiming import retimed_fields

Index = tuple[int, ...]
Fields = tuple[FloatArray, FloatArray]


def _step_axis(index: Index, start: Index | None) -> int | None:
    """The axis along which ``index`` is one grid step from ``start``; None otherwise."""
    if start is None:
        return None
    moved = [d for d, (c, p) in enumerate(zip(index, start, strict=True)) if c != p]
    if len(moved) != 1 or abs(index[moved[0]] - start[moved[0]]) != 1:
        return None
    return moved[0]


def _beyond(index: Index, start: Index | None, shape: tuple[int, ...]
            ) -> tuple[int, Index] | None:
    """(d, G = 2 P − C): the axis d along which case C is one grid step from its start
    neighbour P, and the grid index one step beyond P on that line, where it lies in the
    grid (``shape``); else None."""
    d = _step_axis(index, start)
    if d is None:
        return None
    assert start is not None
    beyond = 2 * start[d] - index[d]
    if not 0 <= beyond < shape[d]:
        return None
    return d, start[:d] + (beyond,) + start[d + 1:]


def secant_partner(index: Index, start: Index | None, axes: Collection[int],
                   shape: tuple[int, ...]) -> Index | None:
    """G = 2 P − C: the grid index one step beyond the start neighbour P on the line from
    case C through P, where C − P is one step along a geometric axis (``axes``) and G lies in
    the grid (``shape``); else None."""
    found = _beyond(index, start, shape)
    return found[1] if found is not None and found[0] in axes else None


def retimed_partner(index: Index, start: Index | None, axes: Collection[int],
                    shape: tuple[int, ...]) -> Index | None:
    """G = 2 P − C as ``secant_partner``, where C − P is one step along an axis that does
    *not* change the geometry (not in ``axes``: a friction line): the other neighbour of a
    retimed start (``retiming``); else None."""
    found = _beyond(index, start, shape)
    return found[1] if found is not None and found[0] not in axes else None


def secant_fields(grid: Grid, index: Index, start: Index, fields: Fields, partner: Index,
                  partner_fields: Fields) -> Fields | None:
    """The secant start ŝ_P + t (ŝ_P − ŝ_G) of case ``index`` (module docstring); None when
    the two neighbours' fields differ in shape (interfaces discretised otherwise)."""
    if any(a.shape != b.shape for a, b in zip(fields, partner_fields, strict=True)):
        return None
    (d,) = [d for d, (p, g) in enumerate(zip(start, partner, strict=True)) if p != g]
    values = grid[list(grid)[d]]
    t = (values[index[d]] - values[start[d]]) / (values[start[d]] - values[partner[d]])
    return (fields[0] + t * (fields[0] - partner_fields[0]),
            fields[1] + t * (fields[1] - partner_fields[1]))


def parallelogram_partners(index: Index, start: Index | None, axes: Collection[int],
                           shape: tuple[int, ...], parent: Mapping[Index, Index | None]
                           ) -> tuple[Index, Index] | None:
    """(Q, R) of a parallelogram start ŝ_P + ŝ_Q − ŝ_R for case C from its start neighbour
    P one step along a geometric axis: Q = C − σ e_b and R = P − σ e_b on another geometric
    axis b, where R is the case both P and Q started from (``parent``: each case's start
    neighbour by grid index) — B3's 5 × 5 study: the cases of the lines next to the middle
    one. None where there is no such pair."""
    a = _step_axis(index, start)
    if a is None or a not in axes:
        return None
    assert start is not None
    for b in sorted(axes):
        if b == a:
            continue
        for sigma in (1, -1):
            if not 0 <= index[b] - sigma < shape[b]:
                continue
            q = index[:b] + (index[b] - sigma,) + index[b + 1:]
            r = start[:b] + (start[b] - sigma,) + start[b + 1:]
            if parent.get(start) == r and parent.get(q) == r:
                return q, r
    return None


def across_geometries(index: Index, start: Index | None, axes: Collection[int],
                      number: Mapping[Index, int]) -> tuple[Index, Index] | None:
    """(Q, R) of a parallelogram start across geometries, ŝ_P + ŝ_Q − ŝ_R, for case C
    started from P one step along an axis that does *not* change the geometry (a friction):
    Q = C − σ e_b and R = P − σ e_b one step back along a geometric axis b (the same
    frictions at the previous geometry), both earlier than C in the traversal (``number``:
    each case's place in it; so no case waits for a later one). Measured:
    ``benchmarks/geometry_neighbours.py`` (B3: 12–14 iterations a case instead of 25–50)."""
    a = _step_axis(index, start)
    if a is None or a in axes or index not in number:
        return None
    assert start is not None
    for b in sorted(axes):
        for sigma in (1, -1):
            q = index[:b] + (index[b] - sigma,) + index[b + 1:]
            r = start[:b] + (start[b] - sigma,) + start[b + 1:]
            if (q in number and r in number and number[q] < number[index]
                    and number[r] < number[index]):
                return q, r
    return None


def beside(index: Index, start: Index, a: int, axes: Collection[int]
           ) -> Iterator[tuple[Index, Index]]:
    """The (Q, R) = (C − σ e_b, P − σ e_b) beside case C = ``index`` and P = ``start`` (one
    step apart along axis ``a``), for every other axis b and σ = ±1, one of a and b
    geometric (``axes``): the other corners of a parallelogram start."""
    for b in range(len(index)):
        if b == a or (a not in axes and b not in axes):
            continue
        for sigma in (1, -1):
            yield (index[:b] + (index[b] - sigma,) + index[b + 1:],
                   start[:b] + (start[b] - sigma,) + start[b + 1:])


def held_square(index: Index, start: Index | None, axes: Collection[int],
                held: Collection[Index]) -> tuple[Index, Index] | None:
    """(Q, R) of a parallelogram start ŝ_P + ŝ_Q − ŝ_R for case C from its start neighbour
    P one step away, among the converged cases ``held`` (the line batches' and Dask's line
    tasks' rule: which cases a task holds is fixed by the task graph,
    ``waves.partner_lines``): the first pair ``beside`` C and P that ``held`` has. None
    where there is none."""
    a = _step_axis(index, start)
    if a is None or start is None:
        return None
    return next(((q, r) for q, r in beside(index, start, a, axes) if q in held and r in held),
                None)


def not_unique_beside(index: Index, axes: Collection[int], unsettled: Collection[Index]
                      ) -> Index | None:
    """A case flagged not unique at the same frictions one hole position away from case
    ``index`` (one step along a geometric axis, ``axes``), among ``unsettled``; None if
    none. The case is then most likely not unique too (the friction limit is the load's, not
    the hole's: B3's studies flag the same friction pairs at every position), so it starts
    from zero rather than from a warm attempt that would be set aside
    (``starts.set_aside``; docs/performance.md, session 26)."""
    for other in sorted(unsettled):
        d = _step_axis(index, other)
        if d is not None and d in axes:
            return other
    return None


def along_geometry(index: Index, start: Index, axes: Collection[int]) -> bool:
    """Whether ``index`` differs from ``start`` along geometric axes only (``Case.axes``):
    the same friction coefficients and gaps, so ``at_friction_limit`` would read the
    start's state with its own coefficients — where ``not_unique_beside`` already tells."""
    return all(d in axes for d, (a, b) in enumerate(zip(index, start, strict=True)) if a != b)


def at_friction_limit(assemblies: Sequence[Assembly], points: Sequence[InterfacePoints],
                      neighbours: Sequence[Fields]) -> list[FreeMotion | None]:
    """Per case, a free motion that makes it most likely not unique, read from its start
    neighbour's converged fields (``neighbours``) with the case's own friction coefficients
    and gaps (``points``: the case's geometry): a rigid motion of that state, reaching the
    last step, whose friction reserve under the case's coefficients is within
    ``RESERVE_TOL`` of zero either way — the load sits at the case's friction limit; None
    if there is none.

    Such a case starts from zero: its warm attempt would be set aside (``starts.set_aside``;
    the main job: 512 of the study's 5 404 iterations). A neighbour on the sticking side
    predicts it (B1: the reserve 1e-10 to 1e-5 at every such pair), one on the sliding side
    does not (its body rests on a stop); a wrong guess costs a solve from zero, never an
    answer that depends on the path (docs/performance.md, session 30)."""
    case_points = [with_contact_data(pts, assembly) for pts, assembly
                   in zip(points, assemblies, strict=True)]
    found = limit_motions_batch(assemblies, case_points, [w for w, _ in neighbours],
                                [f for _, f in neighbours], RESERVE_TOL)
    return [next((motion for motion in motions if motion.reaches_last_step), None)
            for motions in found]


def retimed_from(start: Index, extra: tuple[Index, ...], axes: Collection[int]) -> bool:
    """Whether the start from ``start`` with ``extra`` is a retimed one (``retiming``): one
    other neighbour, one step along a non-geometric axis (not in ``axes``)."""
    return len(extra) == 1 and _step_axis(start, extra[0]) not in axes


def extrapolated_fields(grid: Grid, index: Index, start: Index, fields: Fields,
                        extra: tuple[Index, ...], extra_fields: Sequence[Fields],
                        axes: Collection[int] = ()) -> Fields | None:
    """The secant start (``extra`` = (G,), along a geometric axis: ``axes``), the retimed
    start (``extra`` = (G,) along another axis, ``retiming``) or the parallelogram start
    ŝ_P + ŝ_Q − ŝ_R (``extra`` = (Q, R)); None when the neighbours' fields differ in shape
    (or a single load step leaves nothing to retime)."""
    if retimed_from(start, extra, axes):
        return retimed_fields(fields, extra_fields[0])
    if len(extra) == 1:
        return secant_fields(grid, index, start, fields, extra[0], extra_fields[0])
    if any(a.shape != b.shape for other in extra_fields
           for a, b in zip(fields, other, strict=True)):
        return None
    q, r = extra_fields
    return (fields[0] + q[0] - r[0], fields[1] + q[1] - r[1])


def start_text(grid: Grid, start: Index | None, extra: tuple[Index, ...] = (),
               axes: Collection[int] = ()) -> str:
    """A record's ``start``: "zero", the neighbour's parameters, and the other neighbours of
    a secant (along a geometric axis, ``axes``), retimed or parallelogram start where there
    are."""
    if start is None:
        return "zero"

    def named(index: Index) -> str:
        return ", ".join(f"{n}={grid[n][i]:g}" for n, i in zip(grid, index, strict=True))

    if len(extra) == 1:
        kind = "retimed" if retimed_from(start, extra, axes) else "secant"
        return f"{named(start)} ({kind} with {named(extra[0])})"
    if len(extra) == 2:
        return f"{named(start)} (parallelogram with {named(extra[0])}; {named(extra[1])})"
    return named(start)
