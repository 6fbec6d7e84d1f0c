"""One parameter set through every section of a model file into an ``Assembly``."""

from __future__ import annotations

from ...decomposition.assembly import DISPLACEMENT, STOP, Assembly, Interface, Substructure
from ...errors import ModelError
from .bodies import BodySections
from .joints import InterfaceSections
from .loading import LoadingSections
from .qois import QoiSections


class Builder(BodySections, InterfaceSections, LoadingSections, QoiSections):
    """Evaluates a model table with one parameter set into an ``Assembly``."""

    def assembly(self, name: str) -> Assembly:
        subs, bodies = self.substructures()
        interfaces = self.interfaces(subs)
        used = {(ref.substructure, ref.side) for itf in interfaces for ref in itf.sides}
        history = self.history()
        boundaries = self.boundaries(subs, bodies, history, used)
        _check_held(subs, interfaces, boundaries)
        qois = self.qois(subs, {itf.condition.name for itf in boundaries if itf.condition},
                         history)
        return Assembly(name, tuple(subs), tuple(interfaces + boundaries), history, tuple(qois),
                        self.mu)


def _check_held(subs: list[Substructure], interfaces: list[Interface],
                boundaries: list[Interface]) -> None:
    """Every group of substructures joined by interfaces must touch something that can hold
    it: a prescribed displacement component or a rigid stop (a body held by friction on a
    stop alone is accepted; whether the load finds an equilibrium is the solve's to say)."""
    group = list(range(len(subs)))

    def root(i: int) -> int:
        while group[i] != i:
            group[i] = group[group[i]]
            i = group[i]
        return i

    for itf in interfaces:
        if len(itf.sides) == 2:
            a, b = (root(ref.substructure) for ref in itf.sides)
            group[a] = b
    held = {root(itf.sides[0].substructure) for itf in boundaries
            if itf.condition is not None
            and (DISPLACEMENT in itf.condition.kinds or itf.condition.kinds[0] == STOP)}
    free = sorted({subs[i].body for i in range(len(subs)) if root(i) not in held})
    if free:
        raise ModelError(
            f"boundary: nothing holds {', '.join(repr(b) for b in free)}: no prescribed "
            "displacement and no rigid stop on it or on a body it touches; it can move as a "
            "rigid body")
