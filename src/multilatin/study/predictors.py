"""Starts beyond the nearest neighbour (issue 16; the paper's §6 starts a case from one
converged neighbour): along a grid line of a parameter that changes the geometry (B3's hole
positions), a case whose start neighbour P is one grid step away, and whose case G one step
further back on the same line has converged too, starts from the secant of the two,

    ŝ = ŝ_P + t (ŝ_P − ŝ_G),   t = (v − v_P) / (v_P − v_G),

in Ŵ and F̂ at every step (v: the parameter's values). Interface fields of nearby hole
positions change smoothly; the fields of nearby friction coefficients do not (contact
statuses change between neighbours: the secant cost 11 % more iterations on the B1 13 × 13
study, session 12), so the rule is for geometric axes only (``Case.axes``;
``start="nearest"`` leaves them out). Measured: docs/performance.md ("Secant starts along
hole positions": B3's 5 × 5 positions 20 % fewer iterations).

The rolling batch takes G where P started from it (so that the start does not depend on
which cases have finished); the line batches and Dask's line tasks where G is among the
converged cases they hold (a task holds its parent line's), else the nearest alone.
"""

from __future__ import annotations

from collections.abc import Collection

from ..fem.elasticity import FloatArray
from ..parameters import Grid

Index = tuple[int, ...]
Fields = tuple[FloatArray, FloatArray]


def secant_partner(index: Index, start: Index | None, axes: Collection[int],
                   shape: tuple[int, ...]) -> Index | None:
    """G = 2 P − C: the grid index one step beyond the start neighbour P on the line from
    case C through P, where C − P is one step along a geometric axis (``axes``) and G lies in
    the grid (``shape``); else None."""
    if start is None:
        return None
    moved = [d for d, (c, p) in enumerate(zip(index, start, strict=True)) if c != p]
    if len(moved) != 1 or moved[0] not in axes:
        return None
    d = moved[0]
    if abs(index[d] - start[d]) != 1:
        return None
    beyond = 2 * start[d] - index[d]
    if not 0 <= beyond < shape[d]:
        return None
    return start[:d] + (beyond,) + start[d + 1:]


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


def start_text(grid: Grid, start: Index | None, partner: Index | None = None) -> str:
    """A record's ``start``: "zero", the neighbour's parameters, and the secant's second
    neighbour where there is one."""
    if start is None:
        return "zero"

    def named(index: Index) -> str:
        return ", ".join(f"{n}={grid[n][i]:g}" for n, i in zip(grid, index, strict=True))

    return named(start) + (f" (secant with {named(partner)})" if partner is not None else "")
