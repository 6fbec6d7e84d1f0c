"""What a model defines, in words, for ``multilatin show``: its contacts, its boundary
conditions (the sides, or parts of sides, they act on), its body forces, temperature
changes and point loads, and what each quantity of interest reads."""

from __future__ import annotations

import numpy as np

from ..decomposition.assembly import DISPLACEMENT, Assembly, Interface, QuantityOfInterest
from ..decomposition.qoi import STRESS_COMPONENTS, point_substructure

__all__ = ["body_force_lines", "boundary_lines", "contact_lines", "point_load_lines",
           "qoi_reads", "temperature_lines"]


def _where(assembly: Assembly, interfaces: list[Interface]) -> str:
    """The sides a condition acts on: ``sub.side``, with the segment where it is part of
    one (``[a, b]`` along the side)."""
    parts = []
    for itf in interfaces:
        for ref in itf.sides:
            part = f"{assembly.substructures[ref.substructure].name}.{ref.side}"
            if ref.segment is not None:
                part += f" [{ref.segment[0]:g}, {ref.segment[1]:g}]"
            parts.append(part)
    return ", ".join(parts)


def contact_lines(assembly: Assembly) -> list[str]:
    """One line per pair of bodies in contact: its friction and initial gap (negative: an
    interference), and how many interfaces the substructures cut it into."""
    by_bodies: dict[tuple[str, ...], list[Interface]] = {}
    for itf in assembly.interfaces:
        if itf.kind == "contact" and itf.contact is not None:
            bodies = tuple(assembly.substructures[ref.substructure].body for ref in itf.sides)
            by_bodies.setdefault(bodies, []).append(itf)
    lines = []
    for bodies, interfaces in by_bodies.items():
        laws = sorted({(i.contact.friction, i.contact.gap) for i in interfaces
                       if i.contact is not None})
        law = "; ".join(f"friction {friction:g}, "
                        + (f"gap {gap:g}" if gap >= 0.0 else
                           f"gap {gap:g} (an interference of {-gap:g})")
                        for friction, gap in laws)
        pieces = f" ({len(interfaces)} interfaces)" if len(interfaces) > 1 else ""
        lines.append(f"{'|'.join(bodies)}: {law}{pieces}")
    return lines


def boundary_lines(assembly: Assembly) -> list[str]:
    """One line per boundary condition: its kind and values (per component), the load
    factor that multiplies them, and where it acts."""
    by_name: dict[str, list[Interface]] = {}
    for itf in assembly.interfaces:
        if itf.condition is not None:
            by_name.setdefault(itf.condition.name, []).append(itf)
    lines = []
    for name, interfaces in by_name.items():
        condition, law = interfaces[0].condition, interfaces[0].contact
        assert condition is not None
        texts = getattr(condition.varying, "expressions", None)  # expressions of x and y
        shown = tuple(text if texts is not None and text is not None else f"{value:g}"
                      for text, value in zip(texts or (None, None), condition.value,
                                             strict=True))
        if law is not None:
            what = f"rigid stop, gap {law.gap:g}, friction {law.friction:g}"
        else:
            values = shown
            if condition.pressure:
                what = f"pressure {values[0]}"
            elif condition.kinds[0] == condition.kinds[1]:
                noun = "displacement" if condition.kinds[0] == DISPLACEMENT else "traction"
                what = f"{noun} ({values[0]}, {values[1]})"
            else:
                what = ", ".join(
                    f"{axis} {'displacement' if kind == DISPLACEMENT else 'traction'} {value}"
                    for axis, kind, value in zip("xy", condition.kinds, values, strict=True))
        factor = f" × factor {condition.factor!r}" if condition.factor else ""
        lines.append(f"{name}: {what}{factor} on {_where(assembly, interfaces)}")
    return lines


def body_force_lines(assembly: Assembly) -> list[str]:
    """One line per body force: its value per unit volume (expressions of x and y as
    written), the load factor, the bodies it acts on and its resultant on them at a unit
    factor (over the material: holes left out)."""
    lines = []
    for force in assembly.body_forces:
        texts = getattr(force.varying, "expressions", None) or (None, None)
        shown = ", ".join(text if text is not None else f"{value:g}"
                          for text, value in zip(texts, force.value, strict=True))
        total = sum((force.unit_load(sub).reshape(-1, 2).sum(axis=0)
                     for sub in assembly.substructures if force.acts_on(sub)), np.zeros(2))
        bodies = ", ".join(force.bodies) if force.bodies else "every body"
        factor = f" × factor {force.factor!r}" if force.factor else ""
        lines.append(f"{force.name}: ({shown}) per unit volume{factor} on {bodies}; "
                     f"resultant ({total[0]:.6g}, {total[1]:.6g})")
    return lines


def temperature_lines(assembly: Assembly) -> list[str]:
    """One line per temperature change: its value (an expression of x and y as written),
    the load factor and the bodies it acts on."""
    lines = []
    for change in assembly.temperatures:
        texts = getattr(change.varying, "expressions", None)
        shown = texts[0] if texts is not None and texts[0] is not None else f"{change.value:g}"
        bodies = ", ".join(change.bodies) if change.bodies else "every body"
        factor = f" × factor {change.factor!r}" if change.factor else ""
        lines.append(f"{change.name}: ΔT = {shown}{factor} on {bodies}")
    return lines


def point_load_lines(assembly: Assembly) -> list[str]:
    """One line per point load: its force, the load factor, the point and the part."""
    return [f"{load.name}: ({load.value[0]:g}, {load.value[1]:g})"
            + (f" × factor {load.factor!r}" if load.factor else "")
            + f" at ({load.point[0]:g}, {load.point[1]:g}) of {load.substructure}"
            for load in assembly.point_loads]


def qoi_reads(assembly: Assembly, q: QuantityOfInterest) -> str:
    """What a QoI reads, in words: the part a point is read in (``point_substructure``),
    the boundary, or the contact and its segment; its scale and step."""
    if q.kind == "displacement":
        assert q.point is not None
        sub = assembly.substructures[point_substructure(assembly.substructures, q)]
        what = (f"{'xy'[q.component]} displacement at ({q.point[0]:g}, {q.point[1]:g}) of "
                f"{sub.name}" + (f" (body {sub.body})" if sub.body != sub.name else ""))
    elif q.kind == "stress":
        assert q.point is not None
        sub = assembly.substructures[point_substructure(assembly.substructures, q)]
        what = (f"stress {STRESS_COMPONENTS[q.component]} at ({q.point[0]:g}, "
                f"{q.point[1]:g}) of {sub.name}"
                + (f" (body {sub.body})" if sub.body != sub.name else ""))
    elif q.kind == "reaction":
        what = f"{'xy'[q.component]} resultant of boundary {q.boundary!r} on the structure"
    else:
        assert q.bodies is not None and q.segment is not None
        what = (f"mean contact pressure between {q.bodies[0]} and {q.bodies[1]} over "
                f"[{q.segment[0]:g}, {q.segment[1]:g}]")
    return (what + (f", times {q.scale:g}" if q.scale != 1.0 else "")
            + (f", at step {q.step}" if q.step is not None else ", per load step"
               if assembly.n_steps > 1 else ""))
