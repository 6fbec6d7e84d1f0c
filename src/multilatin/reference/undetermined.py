"""What the monolithic reference's answer leaves undetermined: its converged state read as
interface fields ŝ = (Ŵ, F̂) at LATIN's interface points, for the free-motion search of
``decomposition.uniqueness`` (the same rule as LATIN's results).

Where the load uses up the friction along a rigid motion that nothing else holds (B1 at
μ1 + μ2 = 0.3), the discrete problem has many solutions; the semi-smooth Newton method
returns one of them (its Jacobian regularised for floating bodies), as LATIN does. Both now
say so. Ŵ is the trace of the reference's displacements on every interface point; F̂, on the
contact and stop points (the only ones the search reads), is the reference's multiplier of
the pair at that point over the pair's dual-cell length: the force per unit length on that
side, as LATIN's fields are.
"""

from __future__ import annotations

import logging

import numpy as np
from scipy.spatial import cKDTree

from ..decomposition.assembly import Assembly
from ..decomposition.interfaces import InterfacePoints, build_points
from ..decomposition.sliding_extent import LargeSlip, large_slips
from ..decomposition.uniqueness import FreeMotion, free_motions
from ..errors import ModelError
from ..fem.elasticity import FloatArray
from .contact_newton import ContactSet, tangents

log = logging.getLogger(__name__)


def reference_free_motions(assembly: Assembly, displacements: dict[str, FloatArray],
                           contacts: ContactSet, multipliers: FloatArray
                           ) -> tuple[tuple[FreeMotion, ...], tuple[LargeSlip, ...]]:
    """The free rigid motions of the reference's converged state, and its contacts' slips
    beyond the small-sliding range (``sliding_extent``): ``displacements`` per
    substructure (n_steps, n_nodes, 2), ``multipliers`` (n_steps, n_pairs, 2) the normal
    and tangential forces of ``contacts``' pairs on their second side. None are searched
    where LATIN's interface points cannot be built."""
    if contacts.size == 0:
        return (), ()
    try:
        points = build_points(assembly)
    except ModelError as exc:
        log.info("reference: free motions and slips not searched (%s)", exc)
        return (), ()
    n_steps = assembly.n_steps
    w_hat = np.zeros((n_steps, points.n_points, 2))
    for s, sub in enumerate(assembly.substructures):
        lo, hi = points.offsets[s], points.offsets[s + 1]
        u = displacements[sub.name].reshape(n_steps, -1).T  # (2 n_nodes, n_steps)
        w_hat[:, lo:hi] = (points.traces[s] @ u).T.reshape(n_steps, hi - lo, 2)
    on_first = -(multipliers[..., :1] * contacts.normal
                 + multipliers[..., 1:] * tangents(contacts.normal))  # (T, n_pairs, 2)
    density = on_first / contacts.length[:, None]  # per unit length, as LATIN's fields
    f_hat = np.zeros_like(w_hat)
    a, b = points.contact_pairs
    for own, other in ((a, b), (b, a)):
        found = _pairs_at(points, own, contacts, stop=False)
        hit = found >= 0
        f_hat[:, own[hit]] = density[:, found[hit]]
        f_hat[:, other[hit]] = -density[:, found[hit]]
    found = _pairs_at(points, points.stops, contacts, stop=True)
    f_hat[:, points.stops[found >= 0]] = density[:, found[found >= 0]]
    return (tuple(free_motions(assembly, points, w_hat, f_hat)),
            large_slips(assembly, points, w_hat, f_hat))


def _pairs_at(points: InterfacePoints, at: np.ndarray, contacts: ContactSet, *,
              stop: bool) -> np.ndarray:
    """For each interface point of ``at``, the reference pair whose first side is that
    point's side (the same position, a normal the same way; a stop pair where ``stop``),
    else −1."""
    scale = 1e-9 * max(float(np.ptp(points.coords)), 1.0)
    chosen = np.flatnonzero((contacts.second < 0) == stop)
    out = np.full(at.size, -1, dtype=np.int64)
    if not chosen.size or not at.size:
        return out
    tree = cKDTree(contacts.position[chosen])
    for p, near in enumerate(tree.query_ball_point(points.coords[at], scale)):
        for q in near:  # a corner node has one stop pair per normal
            if float(points.normals[at[p]] @ contacts.normal[chosen[q]]) > 0.5:
                out[p] = chosen[q]
                break
    return out
