"""Quantities of interest from displacement fields and boundary reactions."""

from __future__ import annotations

from collections.abc import Mapping

from .assembly import Assembly
from .fem.elasticity import FloatArray, interpolate


def evaluate_qois(
    assembly: Assembly,
    displacements: Mapping[str, FloatArray],
    reactions: Mapping[str, FloatArray],
) -> dict[str, float | list[float]]:
    """Each QoI as a number (one load step) or a list over the load steps."""
    out: dict[str, float | list[float]] = {}
    for q in assembly.qois:
        if q.kind == "displacement":
            assert q.point is not None
            sub = next(s for s in assembly.substructures if s.mesh.contains(q.point))
            cell, ref = sub.mesh.locate(q.point)
            values = interpolate(sub.mesh.nodes, sub.mesh.cells, displacements[sub.name],
                                 cell, ref)[:, q.component]
        elif q.kind == "reaction":
            assert q.boundary is not None
            values = reactions[q.boundary][:, q.component]
        else:  # pragma: no cover - rejected when the model is read
            raise ValueError(q.kind)
        values = q.scale * values
        out[q.name] = float(values[0]) if values.size == 1 else [float(v) for v in values]
    return out
