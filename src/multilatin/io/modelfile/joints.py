"""``[[interfaces]]`` of a model file: perfect and contact interfaces between
substructures, declared or found where sides face each other."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ...decomposition.assembly import ContactLaw, Interface, SideRef, Substructure
from ...decomposition.mortar import face_distances
from ...errors import ModelError
from ...fem.mesh import SIDES
from .checks import OPPOSITE, SectionReader, check_keys, pair, require

#: an interface found where sides face each other, without its contact law: name, kind,
#: its two sides and the declaration whose law it takes (None: a perfect interface)
Joint = tuple[str, str, SideRef, SideRef, "frozenset[str] | None"]
#: a declared interface: kind, contact law, where declared, reach
Declaration = tuple[str, "ContactLaw | None", str, float]
#: geometries whose interfaces a model keeps found (``InterfaceSections._found``)
INTERFACE_CACHE_SIZE = 8


class InterfaceSections(SectionReader):
    """Interfaces between substructures."""

    def interfaces(self, subs: list[Substructure]) -> list[Interface]:
        declared: dict[frozenset[str], Declaration] = {}
        by_faces: list[Interface] = []  # between named groups of edges (mesh files)
        for d, table in enumerate(self.data.get("interfaces", [])):
            where = f"interfaces[{d}]"
            check_keys(table, {"between", "type", "friction", "gap", "reach"}, where)
            a, b = pair(require(table, "between", where), f"{where}.between")
            kind = table.get("type", "perfect")
            if kind not in ("perfect", "contact", "macro"):
                raise ModelError(f"{where}.type: unknown interface type {kind!r} "
                                 "(known: perfect, contact, macro)")
            if kind != "contact" and ({"friction", "gap", "reach"} & set(table)):
                raise ModelError(f"{where}: friction, gap and reach apply to type = 'contact' "
                                 "only")
            reach = table.get("reach", 0.0)
            if isinstance(reach, bool) or not isinstance(reach, (int, float)) \
                    or not 0.0 <= reach < math.inf:
                raise ModelError(f"{where}.reach: expected a distance >= 0, got {reach!r}")
            if "." in a or "." in b:
                by_faces.append(self._between_faces(table, where, subs, a, b, kind))
                continue
            known = {s.name for s in subs} | {s.body for s in subs}
            if self.split and not {a, b} <= known:
                continue  # names substructures that a caller's split has replaced
            for end in (a, b):
                if end not in known:
                    raise ModelError(f"{where}.between: no body or substructure named {end!r}")
            if a == b:
                raise ModelError(f"{where}.between: an interface joins two different parts, "
                                 f"got {a!r} twice")
            law = self.contact_law(table, where) if kind == "contact" else None
            declared[frozenset((a, b))] = (kind, law, where, float(reach))
        found, used_declarations = self._found(subs, declared)
        for key, (_, _, where, _) in declared.items():
            if key not in used_declarations:
                a, b = sorted(key)
                raise ModelError(
                    f"{where}.between: {a!r} and {b!r} do not face each other (they share no side)"
                )
        return found + by_faces

    def _found(self, subs: list[Substructure], declared: dict[frozenset[str], Declaration]
               ) -> tuple[list[Interface], set[frozenset[str]]]:
        """The interfaces where sides face each other, and the declarations they used.
        Kept between builds (the model's ``cache``) for substructures of the same
        ``Substructure.description`` (name, body, mesh, material; a hole lies strictly inside
        its substructure and changes no face) and the same declared kinds and reaches: a
        study over frictions, gaps or hole positions finds its interfaces once, and each
        case only puts its contact laws on them."""
        shape = frozenset((key, kind, reach) for key, (kind, _, _, reach) in declared.items())
        kept = getattr(self.cache, "interfaces", None)
        found = None
        if kept is not None:
            with self.cache.lock:  # type: ignore[union-attr]
                faces = tuple(sub.description for sub in subs)
                for n, (known_faces, known_shape, joints, used) in enumerate(kept):
                    if known_shape == shape and known_faces == faces:
                        kept.insert(0, kept.pop(n))
                        found = joints, used
                        break
        if found is None:
            found = self._joints(subs, declared)
            if kept is not None:
                with self.cache.lock:  # type: ignore[union-attr]
                    kept.insert(0, (tuple(sub.description for sub in subs), shape, *found))
                    del kept[INTERFACE_CACHE_SIZE:]
        joints, used = found
        return [Interface(name, kind, (ref_a, ref_b),
                          contact=declared[key][1] if key is not None else None)
                for name, kind, ref_a, ref_b, key in joints], set(used)

    def _joints(self, subs: list[Substructure], declared: dict[frozenset[str], Declaration]
                ) -> tuple[list[Joint], set[frozenset[str]]]:
        """``_found``'s interfaces without their contact laws: (name, kind, sides, the
        declaration whose law applies)."""
        scale = 1e-9 * max(max(s.mesh.x1 - s.mesh.x0, s.mesh.y1 - s.mesh.y0) for s in subs)
        joints: list[Joint] = []
        used: set[frozenset[str]] = set()
        for i, j, side in _facing_sides(subs, scale):
            other = OPPOSITE[side]
            axis, _, lo, hi = subs[i].mesh.side_line(side)
            _, _, lo_b, hi_b = subs[j].mesh.side_line(other)
            a, b = subs[i], subs[j]
            where = f"interface between {a.name!r} ({side} side) and {b.name!r} ({other} side)"
            start, end = max(lo, lo_b), min(hi, hi_b)  # the part both sides share
            ref_a = SideRef(i, side, None if abs(start - lo) + abs(end - hi) <= 2 * scale
                            else (start, end))
            ref_b = SideRef(j, other, None if abs(start - lo_b) + abs(end - hi_b)
                            <= 2 * scale else (start, end))
            kind, law_key, reach = "perfect", None, 0.0
            # the most specific declaration wins: body-body, then with one name, then names
            for key in (frozenset((a.body, b.body)), frozenset((a.name, b.body)),
                        frozenset((a.body, b.name)), frozenset((a.name, b.name))):
                if key in declared:
                    kind, _, _, reach = declared[key]
                    law_key = key
                    used.add(key)
            if reach > 0.0:  # a curved face: the shared part is where the faces' nodes are
                ref_a, ref_b, start, end = _curved_faces(a, b, side, other, reach, where,
                                                         (i, j))
            na, nb = ref_a.nodes(a.mesh), ref_b.nodes(b.mesh)
            covers = []  # the sides with nodes where the shared part begins and ends
            for mesh, nodes in ((a.mesh, na), (b.mesh, nb)):
                ends = mesh.nodes[nodes[[0, -1]], 1 - axis] if nodes.size else np.zeros(2)
                covers.append(nodes.size >= 2 and np.abs(ends - [start, end]).max() <= scale)
            if not any(covers) and kind != "contact":  # a contact piece: points of its own
                raise ModelError(
                    f"{where}: the shared part [{start:g}, {end:g}] along "
                    f"{'yx'[axis]} does not start and end on nodes of {a.name!r} or of "
                    f"{b.name!r}; place nodes of one of the meshes where the interface "
                    "ends")
            if (ref_a.segment is not None or ref_b.segment is not None) and kind == "macro":
                raise ModelError(f"{where}: a macro interface must be a whole side of both "
                                 "substructures")
            # non-matching perfect and contact interfaces are joined by mortar projection
            # (``decomposition.mortar``); macro ones transmit macro quantities only
            joints.append((f"{a.name}|{b.name}", kind, ref_a, ref_b, law_key))
        return joints, used

    def _between_faces(self, table: Any, where: str, subs: list[Substructure], a: str, b: str,
                       kind: str) -> Interface:
        """A perfect or contact interface between two named groups of boundary edges
        (``body.group`` or ``substructure.group``): curved faces, joined node to node where
        their nodes match and by mortar projection where they do not."""
        if kind == "macro":
            raise ModelError(f"{where}.type: an interface between named faces is perfect or "
                             "contact, not macro")
        if "reach" in table:
            raise ModelError(f"{where}.reach: applies to a curved face facing a side, not "
                             "to two named faces")
        refs = []
        for end in (a, b):
            owner, _, group = end.partition(".")
            chosen = [i for i, s in enumerate(subs) if owner in (s.name, s.body)
                      and group in getattr(s.mesh, "groups", {})]
            if len(chosen) != 1:
                groups = sorted({f"{s.name}.{g}" for s in subs if owner in (s.name, s.body)
                                 for g in getattr(s.mesh, "groups", {})})
                raise ModelError(f"{where}.between: {end!r} names no group of edges of a "
                                 f"mesh file (groups there: {', '.join(groups) or 'none'})")
            try:
                subs[chosen[0]].mesh.side_nodes(group)
            except ValueError as exc:
                raise ModelError(f"{where}.between: {exc}") from None
            refs.append(SideRef(chosen[0], group))
        if refs[0].substructure == refs[1].substructure:
            raise ModelError(f"{where}.between: an interface joins two different parts, got "
                             f"{a!r} and {b!r} of one substructure")
        law = self.contact_law(table, where) if kind == "contact" else None
        interface = Interface(f"{a}|{b}", kind, (refs[0], refs[1]), contact=law)
        # named faces are taken to touch (no gap from their geometry): refuse faces apart
        # by more than a quarter of an element, beyond the chords' own sag
        try:
            distance, edge = face_distances(subs, interface)
        except ModelError as exc:
            raise ModelError(f"{where}.between: {exc}") from None
        apart = np.flatnonzero(distance > 0.25 * edge)
        if apart.size:
            worst = int(apart[np.argmax(distance[apart])])
            raise ModelError(
                f"{where}.between: {a!r} and {b!r} do not touch: {apart.size} node(s) "
                f"{distance[worst]:.3g} apart at most (elements of {edge[worst]:.3g} there); "
                "named faces in an interface must touch (a clearance between them is not "
                "modelled)")
        return interface



def _curved_faces(a: Substructure, b: Substructure, side: str, other: str, reach: float,
                  where: str, indices: tuple[int, int]) -> tuple[SideRef, SideRef, float, float]:
    """The sides of a contact interface declared with ``reach`` (a curved face near a
    straight side: its boundary nodes within ``reach``, each with its own initial gap) and
    the part of them both span."""
    axis = a.mesh.side_line(side)[0]
    spans = []
    for sub, name in ((a, side), (b, other)):
        try:
            nodes = sub.mesh.side_nodes(name, reach)
        except ValueError as exc:
            raise ModelError(f"{where}: {exc}") from None
        spans.append((float(sub.mesh.nodes[nodes[0], 1 - axis]),
                      float(sub.mesh.nodes[nodes[-1], 1 - axis])))
    start, end = max(s[0] for s in spans), min(s[1] for s in spans)
    if end <= start:
        raise ModelError(f"{where}: the faces within reach = {reach:g} do not overlap")
    refs = tuple(SideRef(index, name, None if abs(span[0] - start) + abs(span[1] - end)
                         <= 1e-9 * (end - start) else (start, end), reach)
                 for index, name, span in zip(indices, (side, other), spans, strict=True))
    return refs[0], refs[1], start, end


def _facing_sides(subs: list[Substructure], scale: float) -> list[tuple[int, int, str]]:
    """(i, j, side) for the sides of substructure i < j's that face side ``OPPOSITE[side]``
    of substructure j (the same line, to ``scale``) over more than ``scale``: where
    interfaces may be, in the order of the pairs and then of ``SIDES``; all pairs compared
    at once (a Python loop over pairs was most of a B3 case's assembly)."""
    lines = np.array([[s.mesh.side_line(side) for side in SIDES] for s in subs], dtype=float)
    opposite = [SIDES.index(OPPOSITE[side]) for side in SIDES]
    own, facing = lines[:, None, :, :], lines[None, :, opposite, :]  # (i, j, side, line)
    same_line = np.abs(own[..., 1] - facing[..., 1]) <= scale
    shared = (np.minimum(own[..., 3], facing[..., 3])
              - np.maximum(own[..., 2], facing[..., 2])) > scale  # more than a corner
    pairs = np.triu(np.ones((len(subs), len(subs)), dtype=bool), k=1)[:, :, None]
    i, j, side = np.nonzero(same_line & shared & pairs)
    return [(int(a), int(b), SIDES[c]) for a, b, c in zip(i, j, side, strict=True)]
