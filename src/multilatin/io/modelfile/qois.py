"""``[[qoi]]`` of a model file: the quantities of interest a solve reports."""

from __future__ import annotations

import numpy as np

from ...decomposition.assembly import History, Interface, QuantityOfInterest, Substructure
from ...decomposition.qoi import STRESS_COMPONENTS
from ...errors import ModelError
from .checks import RESERVED_NAMES, SectionReader, check_keys, pair, require, unit_text


class QoiSections(SectionReader):
    """Quantities of interest."""

    def qois(self, subs: list[Substructure], boundary_names: set[str],
             history: History, interfaces: list[Interface]) -> list[QuantityOfInterest]:
        out = []
        for q, table in enumerate(self.data.get("qoi", [])):
            where = f"qoi[{q}]"
            check_keys(table, {"name", "type", "point", "component", "boundary", "scale",
                                "step", "between", "segment", "unit", "body", "substructure"},
                       where)
            name = str(require(table, "name", where))
            where = f"qoi[{q}] ({name!r})"
            unit = unit_text(table.get("unit", ""), f"{where}.unit")
            scale = self.num(table.get("scale", 1.0), f"{where}.scale")
            step = table.get("step")
            if step is not None:
                if isinstance(step, bool) or not isinstance(step, int) \
                        or not 1 <= step <= history.n_steps:
                    raise ModelError(f"{where}.step: expected a step in 1..{history.n_steps}, "
                                     f"got {step!r}")
            kind = require(table, "type", where)
            if kind == "contact_pressure":
                a, b = (str(v) for v in pair(require(table, "between", where),
                                              f"{where}.between"))
                bodies = {s.body for s in subs}
                for end in (a, b):
                    if end not in bodies:
                        raise ModelError(f"{where}.between: no body named {end!r}")
                lo, hi = (self.num(v, f"{where}.segment")
                          for v in pair(require(table, "segment", where), f"{where}.segment"))
                if not hi > lo:
                    raise ModelError(f"{where}.segment: expected [start, end] with end > start, "
                                     f"got {[lo, hi]}")
                out.append(QuantityOfInterest(name, kind, 0, scale=scale, step=step,
                                              bodies=(a, b), segment=(lo, hi), unit=unit))
                continue
            comp = require(table, "component", where)
            components = STRESS_COMPONENTS if kind == "stress" else ("x", "y")
            if comp not in components:
                raise ModelError(f"{where}.component: expected "
                                 f"{' or '.join(map(repr, components))}"
                                 + (" (a stress QoI's component)" if kind == "stress" else "")
                                 + f", got {comp!r}")
            if kind in ("displacement", "stress"):
                px, py = (self.num(v, f"{where}.point")
                          for v in pair(require(table, "point", where), f"{where}.point"))
                holding = [s for s, sub in enumerate(subs) if sub.mesh.holds((px, py))]
                if not holding:
                    raise ModelError(f"{where}.point: {[px, py]} lies in no substructure"
                                     + _extent_note(subs, (px, py)))
                if any(sub.hole is not None and float(sub.hole(np.array([px, py]))) < 0.0
                       for sub in (subs[s] for s in holding)):
                    raise ModelError(f"{where}.point: {[px, py]} lies in a hole")
                body, sub_name = _chosen_part(table, subs, holding, (px, py), interfaces, where)
                out.append(QuantityOfInterest(name, kind, components.index(comp), (px, py),
                                              None, scale, step, unit=unit, body=body,
                                              substructure=sub_name))
            elif kind == "reaction":
                bname = require(table, "boundary", where)
                if bname not in boundary_names:
                    raise ModelError(f"{where}.boundary: no boundary named {bname!r}")
                out.append(QuantityOfInterest(name, kind, "xy".index(comp), None, bname, scale,
                                              step, unit=unit))
            else:
                raise ModelError(f"{where}.type: unknown kind {kind!r} "
                                 "(known: displacement, stress, reaction, contact_pressure)")
        _check_names(out, set(self.data.get("parameters", {})))
        return out



def _check_names(qois: list[QuantityOfInterest], parameters: set[str]) -> None:
    """A QoI's name labels its values in the results, study.nc and table.csv: two QoIs of one
    name (the second replaced the first), or a QoI named as a parameter, a study variable
    (its values written as ``converged`` or ``iterations``) or another QoI's error estimate
    (``<name>_err``) would mix them up."""
    names = [q.name for q in qois]
    for i, name in enumerate(names):
        where = f"qoi[{i}] ({name!r}).name"
        if not name:
            raise ModelError(f"{where}: a name must not be empty")
        if name in names[:i]:
            raise ModelError(f"{where}: {name!r} names qoi[{names.index(name)}] too")
        if name in parameters:
            raise ModelError(f"{where}: {name!r} is a parameter's name")
        if name in RESERVED_NAMES:
            raise ModelError(f"{where}: {name!r} is a name the study's outputs use "
                             f"({', '.join(RESERVED_NAMES)}): choose another")
        if name.endswith("_err") and name[:-4] in names:
            raise ModelError(f"{where}: {name!r} is the name of {name[:-4]!r}'s error "
                             "estimate in the study's outputs: choose another")


def _extent_note(subs: list[Substructure], point: tuple[float, float]) -> str:
    """For a point in a mesh file's extent but in none of its cells, say so."""
    extents = [sub.name for sub in subs if sub.mesh.contains(point)]
    return (f" (it lies in the extent of {', '.join(map(repr, extents))} but in none of "
            "its cells: a hole of the mesh, or outside a curved boundary)" if extents else "")


def _chosen_part(table: dict[str, object], subs: list[Substructure], holding: list[int],
                 point: tuple[float, float], interfaces: list[Interface], where: str
                 ) -> tuple[str | None, str | None]:
    """A displacement QoI's ``body`` / ``substructure`` (each None when not given), checked:
    the named part holds the point, and the point is not shared by parts that are not joined
    by a perfect interface (a contact that slides or opens, a macro-only interface: their
    sides' displacements differ there) unless one part is named."""
    body = table.get("body")
    sub_name = table.get("substructure")
    if body is not None and sub_name is not None:
        raise ModelError(f"{where}: give body or substructure, not both")
    chosen = holding
    for key, value in (("body", body), ("substructure", sub_name)):
        if value is None:
            continue
        of = [sub.body if key == "body" else sub.name for sub in subs]
        if not isinstance(value, str) or value not in of:
            raise ModelError(f"{where}.{key}: no {key} named {value!r}")
        chosen = [s for s in holding if of[s] == value]
        if not chosen:
            here = sorted({of[s] for s in holding})
            raise ModelError(f"{where}.{key}: the point {list(point)} does not lie in "
                             f"{value!r} (it lies in {', '.join(map(repr, here))})")
    if len(chosen) > 1:
        parent = {s: s for s in chosen}

        def root(s: int) -> int:
            while parent[s] != s:
                s = parent[s]
            return s

        for itf in interfaces:
            if itf.kind == "perfect" and len(itf.sides) == 2:
                a, b = (ref.substructure for ref in itf.sides)
                if a in parent and b in parent:
                    parent[root(a)] = root(b)
        if len({root(s) for s in chosen}) > 1:
            names = sorted({subs[s].name for s in chosen})
            bodies = sorted({subs[s].body for s in chosen})
            hint = (f"add body = {bodies[0]!r} (or {', '.join(map(repr, bodies[1:]))})"
                    if len(bodies) > 1 else
                    f"add substructure = {names[0]!r} (or {', '.join(map(repr, names[1:]))})")
            raise ModelError(
                f"{where}.point: {list(point)} lies on {', '.join(map(repr, names))}, which "
                "are not joined by a perfect interface there (a contact, a macro-only "
                f"interface or no interface: their displacements may differ): {hint}")
    return (str(body) if body is not None else None,
            str(sub_name) if sub_name is not None else None)
