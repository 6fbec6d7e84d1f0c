"""``[history]``, ``[[boundary]]``, ``[[body_force]]`` and ``[[temperature]]`` of a
model file: the load history, the boundary conditions (prescribed displacements, forces,
rigid stops), the forces per unit volume and the temperature changes."""

from __future__ import annotations

from collections.abc import Callable, Collection, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...decomposition.assembly import (
    DISPLACEMENT,
    FORCE,
    STOP,
    BodyForce,
    BoundaryCondition,
    History,
    Interface,
    SideRef,
    Substructure,
    TemperatureChange,
)
from ...errors import ModelError
from ...fem.elasticity import FloatArray
from ...fem.mesh import SIDES, normal_axis
from ..expressions import MAX_EXPRESSION_LENGTH, evaluate, names_in
from .checks import SectionReader, check_keys, load_factor, named_tables, pair, require


class LoadingSections(SectionReader):
    """Load history and boundary conditions."""

    def history(self) -> History:
        table = dict(self.data.get("history", {}))
        check_keys(table, {"factors"}, "history")
        factors_raw = dict(table.get("factors", {}))
        if "history" in self.data and not factors_raw:
            raise ModelError("history.factors: a load history with no steps (no load factors)")
        factors: dict[str, np.ndarray] = {}
        n_steps = None
        for fname, values in factors_raw.items():
            where = f"history.factors.{fname}"
            if not isinstance(values, list) or not values:
                raise ModelError(f"{where}: a load history with no steps (got {values!r})")
            arr = np.array([self.num(v, f"{where}[{t}]") for t, v in enumerate(values)])
            if n_steps is not None and arr.size != n_steps:
                raise ModelError(
                    f"{where}: {arr.size} steps, but other load factors have {n_steps}"
                )
            n_steps = arr.size
            factors[fname] = arr
        return History(factors, n_steps or 1)

    def boundaries(
        self,
        subs: list[Substructure],
        bodies: dict[str, tuple[float, ...]],
        history: History,
        used: dict[tuple[int, str], list[tuple[float, float] | None]],
    ) -> list[Interface]:
        out: list[Interface] = []
        names: set[str] = set()
        for b, table in enumerate(self.data.get("boundary", [])):
            where = f"boundary[{b}]"
            check_keys(table, {"name", "face", "substructure", "side", "type", "value",
                                "components", "factor", "friction", "gap", "segment"}, where)
            name = str(table.get("name", f"boundary{b}"))
            where = f"boundary[{b}] ({name!r})"
            if name in names:
                raise ModelError(f"{where}.name: boundary {name!r} is defined twice")
            names.add(name)
            kind = require(table, "type", where)
            refs = self._select_sides(table, where, subs, bodies, set(self.split))
            if "segment" in table:
                refs = self._segment(table, where, subs, refs)
            if kind in (STOP, "wall") and any(ref.side not in SIDES for ref in refs):
                raise ModelError(f"{where}.type: a named group of edges takes displacement, "
                                 f"force or mixed conditions, not {kind!r}")
            law = None
            if {"friction", "gap"} & set(table) and kind != STOP:
                raise ModelError(f"{where}: friction and gap apply to type = 'stop' only")
            if kind == STOP and {"value", "factor"} & set(table):
                field = sorted({"value", "factor"} & set(table))[0]
                raise ModelError(f"{where}.{field}: a stop takes no {field} (its obstacle "
                                 "is fixed, `gap` away)")
            if "components" in table and kind != "mixed":
                raise ModelError(f"{where}.components: components apply to type = 'mixed' "
                                 f"only, got type = {kind!r}")
            pressure = kind == "pressure"
            if pressure:  # normal traction -p n: one value
                kinds: tuple[str, ...] = (FORCE, FORCE)
                table = {**table, "value": [table.get("value", 0.0), 0.0]}
                if isinstance(table["value"][0], list):
                    raise ModelError(f"{where}.value: a pressure is one number or expression")
            elif kind in (DISPLACEMENT, FORCE):
                kinds = (kind, kind)
            elif kind == "mixed":
                kinds = tuple(pair(require(table, "components", where), f"{where}.components"))
                for k in kinds:
                    if k not in (DISPLACEMENT, FORCE):
                        raise ModelError(
                            f"{where}.components: each component is 'displacement' or 'force', "
                            f"got {k!r}"
                        )
            elif kind == "wall":
                # smooth wall: normal displacement prescribed, tangential force zero
                axis = normal_axis(refs[0].side) if refs else 0
                kinds = (DISPLACEMENT, FORCE) if axis == 0 else (FORCE, DISPLACEMENT)
                table = {**table, "value": table.get("value", [0.0, 0.0])}
            elif kind == STOP:
                kinds = (STOP, STOP)
                law = self.contact_law(table, where)
                table = {**table, "value": [0.0, 0.0]}
            else:
                raise ModelError(
                    f"{where}.type: unknown boundary type {kind!r} "
                    "(known: displacement, force, pressure, mixed, wall, stop)"
                )
            (vx, vy), varying, factor = self._values(table, where, history)
            condition = BoundaryCondition(name, (kinds[0], kinds[1]), (vx, vy), factor,
                                          pressure, varying)
            if varying is not None:  # evaluated at every node of the face, errors now
                for ref in refs:
                    sub = subs[ref.substructure]
                    condition.values_at(sub.mesh.nodes[ref.nodes(sub.mesh)])
            if not refs:
                raise ModelError(f"{where}.face: no substructure side lies on {table['face']!r}")
            for ref in refs:
                key = (ref.substructure, ref.side)
                _check_free(subs[ref.substructure], ref, used.get(key, []), where)
                used.setdefault(key, []).append(ref.segment)
                out.append(Interface(f"{name}@{subs[ref.substructure].name}", "boundary",
                                     (ref,), condition, law))
        return out

    def body_forces(self, subs: list[Substructure], history: History) -> list[BodyForce]:
        """``[[body_force]]``: forces per unit volume on bodies (gravity, a spinning
        part's inertia), uniform or expressions of x and y, each with its load factor."""
        out: list[BodyForce] = []
        for table, name, where, bodies in _on_bodies(self.data, "body_force", subs):
            value, varying, factor = self._values(table, where, history)
            out.append(BodyForce(name, value, bodies, factor, varying))
            _evaluated(out[-1], varying, subs)
        return out

    def temperatures(self, subs: list[Substructure], history: History
                     ) -> list[TemperatureChange]:
        """``[[temperature]]``: temperature changes ΔT from the stress-free state on
        bodies, uniform or expressions of x and y, each with its load factor; a body
        without thermal expansion (``alpha``) is refused: the change would do nothing."""
        out: list[TemperatureChange] = []
        for table, name, where, bodies in _on_bodies(self.data, "temperature", subs):
            raw = require(table, "value", where)
            if isinstance(raw, list):
                raise ModelError(f"{where}.value: a temperature change is one number or "
                                 f"expression (K), got {raw!r}")
            (value, _), varying, factor = self._values({**table, "value": [raw, 0.0]}, where,
                                                       history)
            out.append(TemperatureChange(name, value, bodies, factor, varying))
            for sub in subs:
                if out[-1].acts_on(sub) and sub.material.expansion == 0.0:
                    raise ModelError(
                        f"{where}.bodies: body {sub.body!r} has no thermal expansion (its "
                        f"material's alpha is 0): give the material an alpha, or name the "
                        f"bodies the change acts on")
            _evaluated(out[-1], varying, subs)
        return out

    def _values(self, table: Mapping[str, Any], where: str, history: History
                ) -> tuple[tuple[float, float], CoordinateValues | None, str | None]:
        """A table's ``value`` pair (uniform, or varying with x and y) and its load
        ``factor``, checked against the history's factors."""
        raw = pair(require(table, "value", where), f"{where}.value")
        varying = CoordinateValues.of(raw, self.lookup, f"{where}.value")
        vx, vy = (varying.uniform if varying is not None else
                  (self.num(v, f"{where}.value") for v in raw))
        return (vx, vy), varying, load_factor(table, where, history.factors)

    def _segment(self, table: Mapping[str, Any], where: str, subs: list[Substructure],
                 refs: list[SideRef]) -> list[SideRef]:
        """The parts of the face's sides that ``segment`` = [start, end] spans (a range of
        the coordinate along the face); its ends must be nodes of the meshes."""
        if any(ref.side not in SIDES for ref in refs):
            raise ModelError(f"{where}.segment: a segment applies to a side (bottom, right, "
                             "top, left), not to a named group of edges")
        start, end = (self.num(v, f"{where}.segment")
                      for v in pair(table["segment"], f"{where}.segment"))
        if not start < end:
            raise ModelError(f"{where}.segment: expected [start, end] with start < end, got "
                             f"[{start:g}, {end:g}]")
        lines = [subs[ref.substructure].mesh.side_line(ref.side) for ref in refs]
        low, high = min(line[2] for line in lines), max(line[3] for line in lines)
        tolerance = 1e-9 * (high - low)
        if start < low - tolerance or end > high + tolerance:
            raise ModelError(f"{where}.segment: [{start:g}, {end:g}] reaches past the face, "
                             f"which spans [{low:g}, {high:g}]")
        out = []
        for ref, (axis, _, lo, hi) in zip(refs, lines, strict=True):
            a, b = max(lo, start), min(hi, end)
            if b - a <= tolerance:
                continue
            mesh = subs[ref.substructure].mesh
            along = mesh.nodes[mesh.side_nodes(ref.side), 1 - axis]
            for value in (a, b):
                if np.abs(along - value).min() > tolerance:
                    below, above = along[along < value].max(), along[along > value].min()
                    raise ModelError(
                        f"{where}.segment: {value:g} is not a node of side {ref.side!r} of "
                        f"{subs[ref.substructure].name!r} (its nearest nodes are at "
                        f"{below:.12g} and {above:.12g}); a segment starts and ends on nodes")
            whole = a - lo <= tolerance and hi - b <= tolerance
            out.append(SideRef(ref.substructure, ref.side, None if whole else (a, b)))
        return out

    @staticmethod
    def _select_sides(
        table: Mapping[str, Any], where: str, subs: list[Substructure],
        bodies: dict[str, tuple[float, ...]], replaced: Collection[str] = (),
    ) -> list[SideRef]:
        if "face" in table:
            body, _, side = str(table["face"]).partition(".")
            if body not in bodies:
                raise ModelError(f"{where}.face: no body named {body!r} in {table['face']!r}")
            if side not in SIDES:
                return _named_groups(subs, side, f"{where}.face", lambda s: s.body == body,
                                     f"body {body!r}")
            x0, x1, y0, y1 = bodies[body]
            level = {"left": x0, "right": x1, "bottom": y0, "top": y1}[side]
            return [
                SideRef(i, side) for i, s in enumerate(subs)
                if s.body == body and abs(s.mesh.side_line(side)[1] - level) <= 1e-9 * (
                    1.0 + abs(level))
            ]
        sub_name = require(table, "substructure", where)
        side = require(table, "side", where)
        if side not in SIDES:
            return _named_groups(subs, str(side), f"{where}.side",
                                 lambda s: s.name == sub_name, f"substructure {sub_name!r}")
        for i, s in enumerate(subs):
            if s.name == sub_name:
                return [SideRef(i, side)]
        body = str(sub_name).partition("[")[0]
        if body in replaced:
            raise ModelError(
                f"{where}.substructure: {sub_name!r} is not a substructure once body "
                f"{body!r} is split otherwise than in the file (--split, or the conforming "
                "reference's one substructure per body); name a face of the body, or use "
                "the reference on the same meshes (mesh = 'same')")
        raise ModelError(f"{where}.substructure: no substructure named {sub_name!r}")



def _on_bodies(data: Mapping[str, Any], section: str, subs: list[Substructure]
               ) -> Iterator[tuple[Mapping[str, Any], str, str, tuple[str, ...]]]:
    """The tables of an array ``[[section]]`` of loads on bodies (``name``, ``bodies``,
    ``value``, ``factor``; ``checks.named_tables``) with their bodies, checked."""
    known = list(dict.fromkeys(sub.body for sub in subs))
    for table, name, where in named_tables(data, section, {"name", "bodies", "value",
                                                           "factor"}):
        yield table, name, where, _bodies(table, where, known)


def _evaluated(load: BodyForce | TemperatureChange, varying: CoordinateValues | None,
               subs: list[Substructure]) -> None:
    """A value varying with x and y evaluated at every node it acts on: errors now."""
    for sub in subs:
        if varying is not None and load.acts_on(sub):
            load.values_at(sub.mesh.nodes)


def _bodies(table: Mapping[str, Any], where: str, known: list[str]) -> tuple[str, ...]:
    """A table's ``bodies`` (one name or a list; none: every body), each one checked."""
    bodies = table.get("bodies", [])
    if isinstance(bodies, str):
        bodies = [bodies]
    if not isinstance(bodies, list) or not all(isinstance(x, str) for x in bodies):
        raise ModelError(f"{where}.bodies: expected a list of body names, got {bodies!r}")
    for body in bodies:
        if body not in known:
            raise ModelError(f"{where}.bodies: no body named {body!r} (bodies: "
                             f"{', '.join(known)})")
    return tuple(bodies)


def _check_free(sub: Substructure, ref: SideRef, taken: list[tuple[float, float] | None],
                where: str) -> None:
    """A boundary condition's side (or segment) must not overlap what interfaces or other
    conditions took of it; the error names the parts that are still free."""
    if not taken:
        return
    if ref.side not in SIDES:
        raise ModelError(f"{where}: group {ref.side!r} of {sub.name!r} already belongs to an "
                         "interface or another boundary condition")
    _, _, lo, hi = sub.mesh.side_line(ref.side)
    tolerance = 1e-9 * (hi - lo)
    start, end = ref.segment or (lo, hi)
    spans = sorted(segment or (lo, hi) for segment in taken)
    if all(min(end, b) - max(start, a) <= tolerance for a, b in spans):
        return
    free, at = [], lo
    for a, b in spans:
        if a - at > tolerance:
            free.append(f"[{at:g}, {a:g}]")
        at = max(at, b)
    if hi - at > tolerance:
        free.append(f"[{at:g}, {hi:g}]")
    taken_text = ", ".join(f"[{a:g}, {b:g}]" for a, b in spans)
    what = ("choose a segment within one" if ref.segment is not None else
            "give segment = [start, end] to load one")
    hint = f"; its free parts are {' and '.join(free)}: {what}" if free else ""
    raise ModelError(f"{where}: side {ref.side!r} of {sub.name!r} already belongs to an "
                     f"interface or another boundary condition over {taken_text}{hint}")


def _named_groups(subs: list[Substructure], group: str, where: str,
                  chosen: Callable[[Substructure], bool], owner: str) -> list[SideRef]:
    """The faces named ``group`` (a mesh file's physical group of boundary edges) of the
    chosen substructures; an error naming the sides and groups there are when none is."""
    refs = [SideRef(i, group) for i, s in enumerate(subs)
            if chosen(s) and group in getattr(s.mesh, "groups", {})]
    if not refs:
        groups = sorted({g for s in subs if chosen(s) for g in getattr(s.mesh, "groups", {})})
        raise ModelError(f"{where}: {owner} has no side or group named {group!r} (sides: "
                         f"{', '.join(SIDES)}; groups of its mesh files: "
                         f"{', '.join(groups) or 'none'})")
    for ref in refs:
        try:
            subs[ref.substructure].mesh.side_nodes(group)
        except ValueError as exc:
            raise ModelError(f"{where}: {exc}") from None
    return refs


#: the names of a point's coordinates in a boundary value's expression
COORDINATES = ("x", "y")


@dataclass(frozen=True)
class CoordinateValues:
    """A boundary condition's values that vary along its face: per component the text of
    an expression of the point's coordinates ``x`` and ``y`` and of the parameters (None
    where the component's value is uniform, ``uniform`` then), evaluated point by point."""

    expressions: tuple[str | None, str | None]
    uniform: tuple[float, float]
    parameters: tuple[tuple[str, float], ...]
    where: str

    @staticmethod
    def of(raw: Sequence[Any], lookup: Mapping[str, float], where: str
           ) -> CoordinateValues | None:
        """The varying values of a ``value`` pair (None where neither component names x
        or y); a parameter named x or y would shadow the coordinate: refused."""
        texts = [v if isinstance(v, str) and len(v) <= MAX_EXPRESSION_LENGTH
                 and set(COORDINATES) & _names(v) else None for v in raw]
        if texts == [None, None]:
            return None
        clash = sorted(set(COORDINATES) & set(lookup))
        if clash:
            raise ModelError(f"{where}: {raw!r} names the coordinate {clash[0]!r}, which is "
                             f"also a parameter's name: rename the parameter")
        uniform = tuple(0.0 if text is not None else evaluate(v, lookup, where)
                        for v, text in zip(raw, texts, strict=True))
        return CoordinateValues((texts[0], texts[1]), (uniform[0], uniform[1]),
                                tuple(sorted(lookup.items())), where)

    def __call__(self, points: FloatArray) -> FloatArray:
        out = np.tile(np.asarray(self.uniform, dtype=np.float64), (len(points), 1))
        parameters = dict(self.parameters)
        for c, text in enumerate(self.expressions):
            if text is not None:
                out[:, c] = [evaluate(text, {**parameters, "x": px, "y": py},
                                      f"{self.where} at ({px:g}, {py:g})")
                             for px, py in np.asarray(points, dtype=np.float64).tolist()]
        return out


def _names(text: str) -> set[str]:
    """The names an expression reads (none where it does not parse: ``evaluate`` says
    why)."""
    try:
        return names_in(text)
    except (SyntaxError, RecursionError, MemoryError):
        return set()
