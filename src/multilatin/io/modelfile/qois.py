"""``[[qoi]]`` of a model file: the quantities of interest a solve reports."""

from __future__ import annotations

from ...decomposition.assembly import History, Interface, QuantityOfInterest, Substructure
from ...decomposition.qoi import STRESS_COMPONENTS
from ...errors import ModelError
from .checks import RESERVED_NAMES, check_keys, pair, require, unit_text
from .points import PointSections


class QoiSections(PointSections):
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
            _check_fields(table, kind, where)
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
                point, body, sub_name, s = self.point_in_part(table, where, subs, interfaces)
                if comp == "tt" and not subs[s].material.radial:
                    raise ModelError(f"{where}.component: 'tt' (the hoop stress) needs an "
                                     "axisymmetric part")
                out.append(QuantityOfInterest(name, kind, components.index(comp), point,
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



#: the fields each kind of QoI reads besides name, type, scale, step and unit
KIND_FIELDS = {"displacement": {"point", "component", "body", "substructure"},
               "stress": {"point", "component", "body", "substructure"},
               "reaction": {"boundary", "component"},
               "contact_pressure": {"between", "segment"}}


def _check_fields(table: dict[str, object], kind: object, where: str) -> None:
    """A field another kind of QoI reads is refused, not ignored (a reaction given a
    ``point`` is still the whole boundary's resultant)."""
    if not isinstance(kind, str) or kind not in KIND_FIELDS:
        return  # an unknown kind: refused below, with the known ones
    foreign = sorted(set(table) - KIND_FIELDS[kind]
                     - {"name", "type", "scale", "step", "unit"})
    if foreign:
        raise ModelError(f"{where}.{foreign[0]}: a {kind} QoI takes no {foreign[0]} (it reads "
                         f"{', '.join(sorted(KIND_FIELDS[kind]))})")


def _check_names(qois: list[QuantityOfInterest], parameters: set[str]) -> None:
    """A QoI's name labels its values in the results, study.nc and table.csv: two QoIs of one
    name (the second replaced the first), or a QoI named as a parameter, a study variable
    (its values written as ``converged`` or ``iterations``) or another QoI's error estimate
    (``<name>_err``) or determined flag (``<name>_determined``) would mix them up."""
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
        for suffix, what in (("_err", "error estimate"), ("_determined", "determined flag")):
            base = name.removesuffix(suffix)
            if name.endswith(suffix) and base in names:
                raise ModelError(f"{where}: {name!r} is the name of {base!r}'s {what} in "
                                 "the study's outputs: choose another")
