"""One parameter set through every section of a model file into an ``Assembly``."""

from __future__ import annotations

from ...decomposition.assembly import DISPLACEMENT, Assembly
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
        if not any(DISPLACEMENT in itf.condition.kinds for itf in boundaries if itf.condition):
            raise ModelError(
                "boundary: no displacement is prescribed anywhere; the assembly can move as a "
                "rigid body"
            )
        qois = self.qois(subs, {itf.condition.name for itf in boundaries if itf.condition},
                         history)
        return Assembly(name, tuple(subs), tuple(interfaces + boundaries), history, tuple(qois),
                        self.mu)
