"""``[[holes]]`` of a model file: geometric details by level set, placed in the substructure
that contains them (paper §5, §7.2–7.3).

A hole must lie strictly inside one substructure (as in the paper); a parameter set that
moves or grows it across a substructure boundary is refused with an error that names the
parameter values. A circle of radius 0 is no hole.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Callable, Collection, Mapping, Sequence
from typing import Any

import numpy as np

from ..errors import ModelError
from ..fem.levelset import Circle, LevelSet, Slot, Union
from ..fem.mesh import UnstructuredMesh
from .assembly import Substructure

HOLE_FIELDS = {"name", "substructure", "body", "shape", "centre", "radius", "start", "end"}
SHAPES = ("circle", "slot")


def parameters_named(table: Mapping[str, Any], mu: Mapping[str, float]) -> str:
    """``" (parameters xc = 25, rc = 3)"``: the parameters that the fields of ``table`` (a
    hole's, a boundary condition's) read, for messages."""
    used = sorted({name for value in table.values()
                   for name in re.findall(r"[A-Za-z_]\w*", str(value)) if name in mu})
    if not used:
        return ""
    return " (parameters " + ", ".join(f"{name} = {mu[name]:g}" for name in used) + ")"


def _point(table: Mapping[str, Any], key: str, where: str,
           num: Callable[[Any, str], float]) -> tuple[float, float]:
    value = table.get(key)
    if not isinstance(value, list) or len(value) != 2:
        raise ModelError(f"{where}.{key}: expected a list of two values, got {value!r}")
    return num(value[0], f"{where}.{key}"), num(value[1], f"{where}.{key}")


def _shape(table: Mapping[str, Any], where: str, num: Callable[[Any, str], float],
           params: str) -> tuple[Circle | Slot | None, tuple[float, float]]:
    """The level set (None for a zero radius) and the point that places it."""
    shape = table.get("shape", "circle")
    if shape not in SHAPES:
        raise ModelError(f"{where}.shape: unknown shape {shape!r} (known: {', '.join(SHAPES)})")
    if "radius" not in table:
        raise ModelError(f"{where}: missing field 'radius'")
    radius = num(table["radius"], f"{where}.radius")
    if radius < 0.0:
        raise ModelError(f"{where}.radius: a hole radius must be >= 0, got {radius:g}{params}")
    if shape == "circle":
        centre = _point(table, "centre", where, num)
        return (Circle(centre, radius) if radius > 0.0 else None), centre
    start, end = _point(table, "start", where, num), _point(table, "end", where, num)
    middle = (0.5 * (start[0] + end[0]), 0.5 * (start[1] + end[1]))
    return (Slot(start, end, radius) if radius > 0.0 else None), middle


def _owner(table: Mapping[str, Any], where: str, subs: Sequence[Substructure],
           place: tuple[float, float], params: str, replaced: Collection[str] = ()) -> int:
    """Index of the substructure that holds the hole. replaced: bodies whose split the
    caller chose (``--split``, the conforming reference's one substructure per body): a
    substructure of the file's split of such a body is gone, and the hole is placed in the
    body by its position instead."""
    body = table.get("body")
    if "substructure" in table:
        name = str(table["substructure"])
        index = next((i for i, s in enumerate(subs) if s.name == name), None)
        if index is None and name.partition("[")[0] not in replaced:
            raise ModelError(f"{where}.substructure: no substructure named {name!r}")
        if index is not None:
            if not (subs[index].mesh.contains(place, tol=0.0)
                    and subs[index].mesh.holds(place)):
                raise ModelError(f"{where}: the hole at {list(place)} lies outside "
                                 f"substructure {name!r} {_box(subs[index])}{params}"
                                 + _void_note(subs[index], place))
            return index
        body = name.partition("[")[0]
    if body is not None and not any(s.body == body for s in subs):
        raise ModelError(f"{where}.body: no body named {body!r}")
    # the substructure whose cells hold the centre (a mesh file's extent may hold another
    # part: a pin in a lug's bore)
    for i, sub in enumerate(subs):
        if (body is None or sub.body == body) and sub.mesh.contains(place, tol=0.0) \
                and sub.mesh.holds(place):
            return i
    scope = f"body {body!r}" if body is not None else "the assembly"
    extents = [sub for sub in subs if (body is None or sub.body == body)
               and sub.mesh.contains(place, tol=0.0)]
    raise ModelError(f"{where}: the hole at {list(place)} lies outside {scope}{params}"
                     + (_void_note(extents[0], place) if extents else ""))


def _void_note(sub: Substructure, place: tuple[float, float]) -> str:
    """For a centre in a mesh file's extent but in none of its cells, say so."""
    return "" if sub.mesh.holds(place) else (
        f" (it lies in the extent of {sub.name!r} but in none of its cells: a hole of its "
        "mesh)")


def _box(sub: Substructure) -> str:
    m = sub.mesh
    return f"[{m.x0:g}, {m.x1:g}] x [{m.y0:g}, {m.y1:g}]"


def place_holes(tables: Sequence[Mapping[str, Any]], subs: list[Substructure],
                mu: Mapping[str, float],
                num: Callable[[Any, str], float],
                check_keys: Callable[[Mapping[str, Any], set[str], str], None],
                replaced: Collection[str] = ()) -> list[Substructure]:
    """The substructures with their holes (several holes in one substructure: their union);
    replaced: the bodies whose split the caller chose (``_owner``)."""
    holes: dict[int, list[LevelSet]] = {}
    single: dict[int, Substructure] = {}  # a substructure with its one hole, cut cells cached
    for h, table in enumerate(tables):
        where = f"holes[{h}]"
        if not isinstance(table, Mapping):
            raise ModelError(f"{where}: expected a table")
        check_keys(table, HOLE_FIELDS, where)
        where = f"holes[{h}] ({str(table.get('name', f'hole{h}'))!r})"
        params = parameters_named(table, mu)
        level_set, place = _shape(table, where, num, params)
        index = _owner(table, where, subs, place, params, replaced)
        if level_set is None:
            continue
        sub = subs[index]
        holed = dataclasses.replace(sub, hole=level_set)
        assert holed.cut is not None
        if not np.any(holed.cut.material_fraction > 0.0):
            raise ModelError(f"{where}: the hole leaves substructure {sub.name!r} {_box(sub)} "
                             f"with no material{params}")
        x0, x1, y0, y1 = level_set.bounding_box()
        margin = 1e-9 * max(sub.mesh.x1 - sub.mesh.x0, sub.mesh.y1 - sub.mesh.y0)
        if not (sub.mesh.x0 + margin < x0 and x1 < sub.mesh.x1 - margin
                and sub.mesh.y0 + margin < y0 and y1 < sub.mesh.y1 - margin):
            raise ModelError(
                f"{where}: the hole crosses the boundary of substructure {sub.name!r} "
                f"{_box(sub)} (hole extent [{x0:g}, {x1:g}] x [{y0:g}, {y1:g}]){params}; a hole "
                "must lie strictly inside one substructure")
        if isinstance(sub.mesh, UnstructuredMesh):  # its own boundary: curved faces, holes
            edges = sub.mesh.nodes[sub.mesh.boundary_edges]  # (e, 2, 2)
            middle = 0.5 * (edges[:, 0] + edges[:, 1])
            half = 0.5 * np.linalg.norm(edges[:, 1] - edges[:, 0], axis=1)
            near = np.flatnonzero(level_set(middle) <= half * (1.0 + 1e-12))
            along = np.linspace(0.0, 1.0, 33)[None, :, None]
            samples = edges[near, :1] + along * (edges[near, 1:] - edges[near, :1])
            if near.size and np.any(level_set(samples) <= 0.0):
                raise ModelError(
                    f"{where}: the hole meets the boundary of substructure {sub.name!r}'s "
                    f"mesh (read from a file){params}; a hole must lie strictly inside the "
                    "material")
        holes.setdefault(index, []).append(level_set)
        single[index] = holed
    out = list(subs)
    for index, parts in holes.items():
        sub = (single[index] if len(parts) == 1
               else dataclasses.replace(subs[index], hole=Union(tuple(parts))))
        cut = sub.cut
        assert cut is not None
        boundary = np.concatenate([sub.mesh.side_nodes(s) for s in
                                   ("bottom", "right", "top", "left")])
        if not cut.active_nodes[boundary].all():
            raise ModelError(f"holes: the holes leave no material at the boundary of "
                             f"substructure {sub.name!r} {_box(sub)}")
        out[index] = sub
    return out
