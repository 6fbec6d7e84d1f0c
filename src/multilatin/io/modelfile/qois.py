"""``[[qoi]]`` of a model file: the quantities of interest a solve reports."""

from __future__ import annotations

import numpy as np

from ...decomposition.assembly import History, QuantityOfInterest, Substructure
from ...errors import ModelError
from .checks import SectionReader, check_keys, pair, require, unit_text


class QoiSections(SectionReader):
    """Quantities of interest."""

    def qois(self, subs: list[Substructure], boundary_names: set[str],
             history: History) -> list[QuantityOfInterest]:
        out = []
        for q, table in enumerate(self.data.get("qoi", [])):
            where = f"qoi[{q}]"
            check_keys(table, {"name", "type", "point", "component", "boundary", "scale",
                                "step", "between", "segment", "unit"}, where)
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
            if comp not in ("x", "y"):
                raise ModelError(f"{where}.component: expected 'x' or 'y', got {comp!r}")
            if kind == "displacement":
                px, py = (self.num(v, f"{where}.point")
                          for v in pair(require(table, "point", where), f"{where}.point"))
                if not any(s.mesh.contains((px, py)) for s in subs):
                    raise ModelError(f"{where}.point: {[px, py]} lies in no substructure")
                if any(s.hole is not None and s.mesh.contains((px, py))
                       and float(s.hole(np.array([px, py]))) < 0.0 for s in subs):
                    raise ModelError(f"{where}.point: {[px, py]} lies in a hole")
                out.append(QuantityOfInterest(name, kind, "xy".index(comp), (px, py), None, scale,
                                              step, unit=unit))
            elif kind == "reaction":
                bname = require(table, "boundary", where)
                if bname not in boundary_names:
                    raise ModelError(f"{where}.boundary: no boundary named {bname!r}")
                out.append(QuantityOfInterest(name, kind, "xy".index(comp), None, bname, scale,
                                              step, unit=unit))
            else:
                raise ModelError(f"{where}.type: unknown kind {kind!r} "
                                 "(known: displacement, reaction, contact_pressure)")
        return out

