"""Points in parts of a model file: where a point QoI reads (``[[qoi]]``) and where a
point load acts (``[[point_load]]``), with the part that holds it."""

from __future__ import annotations

import numpy as np

from ...decomposition.assembly import History, Interface, PointLoad, Substructure
from ...decomposition.qoi import part_holding
from ...errors import ModelError
from .checks import SectionReader, load_factor, named_tables, pair, require


class PointSections(SectionReader):
    """Points in parts, and the point loads."""

    def point_in_part(self, table: dict[str, object], where: str, subs: list[Substructure],
                      interfaces: list[Interface]
                      ) -> tuple[tuple[float, float], str | None, str | None, int]:
        """A table's ``point`` and the part it names (``body`` / ``substructure``, each
        None when not given; ``_chosen_part``), checked: in a substructure's cells, not in
        a hole; and the substructure that reads or takes it (the first that holds it among
        the named part's)."""
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
        s = part_holding(subs, (px, py), sub_name, body)
        assert s is not None
        return (px, py), body, sub_name, s

    def point_loads(self, subs: list[Substructure], history: History,
                    interfaces: list[Interface]) -> list[PointLoad]:
        """``[[point_load]]``: a force (N: through the whole thickness) at a point, on the
        part that holds it (``body`` / ``substructure`` where parts that are not joined by
        a perfect interface share it), multiplied at each step by its load factor."""
        out: list[PointLoad] = []
        for table, name, where in named_tables(self.data, "point_load", {
                "name", "point", "value", "factor", "body", "substructure"}):
            point, _, _, s = self.point_in_part(dict(table), where, subs, interfaces)
            fx, fy = (self.num(v, f"{where}.value")
                      for v in pair(require(table, "value", where), f"{where}.value"))
            out.append(PointLoad(name, point, (fx, fy), subs[s].name,
                                 load_factor(table, where, history.factors)))
        return out


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
