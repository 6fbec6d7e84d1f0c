"""How far a study's multiresolution answers lie from its cold ones, where both modes ran
(``--compare``): per QoI the largest difference over the values both modes converged to and
the discrete problem determines, relative to max(|cold|, ``QOI_FLOOR`` of the QoI's largest
|cold| over the grid) — the scale the QoI rule's bound uses (``latin.iteration``). Each
mode within ``qoi_rtol`` of the tight answer puts the two within twice that; a difference
beyond it says a warm start led somewhere a cold solve does not (sessions 51–52 found two
such cases this way, by hand)."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..latin.iteration import QOI_FLOOR

__all__ = ["mode_agreement"]


def _values(record: dict[str, Any], name: str) -> tuple[np.ndarray, np.ndarray]:
    """A record's QoI values (one per load step, or one) and where they are determined."""
    value = np.atleast_1d(np.asarray(record["qoi"][name], dtype=np.float64))
    flags = record.get("qoi_determined", {}).get(name, True)
    determined = np.broadcast_to(np.atleast_1d(np.asarray(flags, dtype=bool)), value.shape)
    return value, determined & np.isfinite(value)


def mode_agreement(warm: list[dict[str, Any]], cold: list[dict[str, Any]]
                   ) -> dict[str, float]:
    """Per QoI: the largest relative difference between the multiresolution records
    ``warm`` and the ``cold`` ones of the same cases (matched by number), over the cases
    converged in both and the values both determine; NaN where none is."""
    by_number = {r["number"]: r for r in cold}
    pairs = [(r, by_number[r["number"]]) for r in warm
             if r["number"] in by_number and r["converged"] and by_number[r["number"]]["converged"]]
    if not pairs:
        return {}
    out: dict[str, float] = {}
    for name in pairs[0][1]["qoi"]:
        read = [(_values(w, name), _values(c, name)) for w, c in pairs]
        largest = max(float(np.abs(c[dw & dc]).max(initial=0.0))
                      for (_, dw), (c, dc) in read)
        worst = float("nan")
        for (w, dw), (c, dc) in read:
            both = dw & dc
            if not both.any():
                continue
            scale = np.maximum(np.abs(c[both]), QOI_FLOOR * largest)
            gap = np.abs(w[both] - c[both])
            relative = np.divide(gap, scale, out=np.where(gap > 0, np.inf, 0.0), where=scale > 0)
            worst = float(np.nanmax([worst, relative.max()]))
        out[name] = worst
    return out
