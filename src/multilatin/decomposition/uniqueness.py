"""Where the discrete problem does not determine the answer: free rigid motions at the
friction limit.

A converged state is one solution of the incremental contact problem; it is the only one
unless some rigid motion of a group of substructures changes no force. That happens when
the load uses up the friction capacity along a motion that nothing else holds: every closed
contact point lets it slide (no motion along its normal), no prescribed displacement
component moves, and the friction forces already oppose it at their limit μ|N| (B1 at
μ1 + μ2 = 0.3, step 10: the push 15 MPa × 50 mm = 750 N equals the capacity
0.3 × 2500 N, and the centre block's position between its place at step 9 and the stop is
free). Where the motion slides along points with friction, the later steps inherit that
position (Coulomb's law acts on increments), so they are not determined either: two
correct solvers, or one solver started from two places, may return different answers,
1.2 % apart on that B1 case.

``free_motions`` finds such motions in a converged state: for every load step and every
*cluster* (substructures joined by perfect or macro-only interfaces, which move together),
the rigid motions (two translations, one rotation; axisymmetric, the axial translation
alone) that the pressed contacts (no motion
along their normal) and the prescribed displacements allow, that push into no contact
touching with zero force, and whose friction reserve — the share of the friction capacity
along the motion not yet used — is below ``reserve_tol``. A point slipping during the step
keeps its force (at the limit) for a small motion either way; a point at rest only for a
motion against its force. Clusters joined through contact interfaces are searched together
too (``rigid_clusters.contact_unions``: a stack of blocks sliding as one while friction
holds them to each other, which no cluster alone shows; until session 51 such a case went
unflagged, and a warm start returned 2.3 times the cold answer's slide), up to
``MAX_UNIONS`` unions; motions in which a union's clusters move differently (slipping on
each other too) are not searched.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..fem.elasticity import FloatArray
from .assembly import Assembly
from .interfaces import InterfacePoints
from .rigid_clusters import Cluster, free_clusters

#: a free motion is reported when less than this share of the friction capacity along it is
#: left (the load is within 0.1 % of the sliding limit)
RESERVE_TOL = 1e-3
#: a normal force below this share of the case's largest interface force presses nothing:
#: LATIN leaves ~3e-5 of it at a stop's corner point that the exact answer does not press
#: (a strap free to leave its stop was reported unique at 1e-9; session 61,
#: ``tests/test_uniqueness.py``)
PRESSED = 1e-4
#: cases whose fields ``limit_motions_batch`` stacks at once
LIMIT_CASES = 256


@dataclass(frozen=True)
class FreeMotion:
    """A rigid motion of ``bodies`` at ``step`` (1-based) that changes no force: velocity
    (vx, vy) + ω × (x − centre), with ``reserve`` the unused share of friction along it.
    ``reaches_last_step``: the last step's answer depends on it (it is the last step, or
    friction carries the position into the later steps). ``friction_holds``: friction
    resists the motion at all (false where its contacts are open or frictionless).
    ``carried_on``: there are later steps and friction carries the position into them."""

    step: int
    bodies: tuple[str, ...]
    velocity: tuple[float, float]
    rotation: float
    centre: tuple[float, float]
    reserve: float
    reaches_last_step: bool
    friction_holds: bool = True
    carried_on: bool = False

    def describe(self, steps: Sequence[int] = ()) -> str:
        """One line; ``steps``: the steps of one motion named together (a motion that
        does not reach the last step, found at several), in place of its own."""
        what = (f"translation ({self.velocity[0]:+.3g}, {self.velocity[1]:+.3g})"
                if abs(self.rotation) < 1e-9 else
                f"rotation about ({self.centre[0]:.4g}, {self.centre[1]:.4g})")
        why = (f"the friction along it used to {100 * (1 - self.reserve):.2f} % of its "
               "capacity" if self.friction_holds else
               "nothing resists it (no pressed contact with friction along it)")
        at = f"step(s) {', '.join(map(str, steps))}" if steps else f"step {self.step}"
        whose = "those steps'" if steps else "this step's"
        later = (", nor are the answers of the later steps that friction builds on it"
                 if self.carried_on else "")
        return (f"{at}: {'+'.join(self.bodies)} is free to move ({what}), {why}"
                + ("; its position along it is not determined by the discrete problem "
                   f"(this step's forces are){later}" if self.reaches_last_step else
                   f"; only {whose} displacements are undetermined"))


def free_motions(assembly: Assembly, points: InterfacePoints, displacement_hat: FloatArray,
                 force_hat: FloatArray, reserve_tol: float = RESERVE_TOL) -> list[FreeMotion]:
    """The free rigid motions of a converged state ŝ = (Ŵ, F̂), shapes ``(n_steps,
    n_points, 2)`` (see the module's docstring). Vectorised over the load steps: per cluster,
    the constraints' Gram matrix on the three rigid modes for every step at once, its null
    space by a batched eigendecomposition."""
    return free_motions_batch([assembly], [points], [displacement_hat], [force_hat],
                              reserve_tol)[0]


def free_motions_batch(assemblies: Sequence[Assembly], points: Sequence[InterfacePoints],
                       displacement_hats: Sequence[FloatArray], force_hats: Sequence[FloatArray],
                       reserve_tol: float = RESERVE_TOL) -> list[list[FreeMotion]]:
    """``free_motions`` of several converged states, computed together for the cases that
    share their clusters (one geometry: a batch's cases), vectorised over cases and steps."""
    return _by_geometry(assemblies, points, displacement_hats, force_hats,
                        lambda clusters, pts, w, f: _motions_of(clusters, pts, w, f,
                                                                reserve_tol))


def _by_geometry(assemblies: Sequence[Assembly], points: Sequence[InterfacePoints],
                 displacement_hats: Sequence[FloatArray], force_hats: Sequence[FloatArray],
                 motions_of: Callable[[list[Cluster], list[InterfacePoints],
                                       list[FloatArray], list[FloatArray]],
                                      list[list[FreeMotion]]],
                 chunk: int | None = None) -> list[list[FreeMotion]]:
    """Per case, ``motions_of`` its fields, for the cases that share their clusters (one
    geometry) together, ``chunk`` of them at a time (None: all); motions by step."""
    out: list[list[FreeMotion]] = [[] for _ in assemblies]
    groups: dict[int, tuple[list[Cluster], list[int]]] = {}
    for c, (assembly, pts) in enumerate(zip(assemblies, points, strict=True)):
        clusters = free_clusters(assembly, pts)
        groups.setdefault(id(clusters), (clusters, []))[1].append(c)
    for clusters, members in groups.values():
        size = chunk or len(members)
        for start in range(0, len(members), size):
            part = members[start:start + size]
            found = motions_of(clusters, [points[c] for c in part],
                               [displacement_hats[c] for c in part],
                               [force_hats[c] for c in part])
            for c, motions in zip(part, found, strict=True):
                out[c] = sorted(motions, key=lambda motion: motion.step)
    return out


@dataclass(frozen=True)
class ClusterState:
    """What both readings of a cluster take from cases' states ŝ (C cases, T steps, its
    n points): μ per point, forces F̂, their normal part N, and where the contacts are
    pushed (N < 0), shut (opening within ``near``) and slipping during the step."""

    friction: FloatArray  # (C, n)
    force: FloatArray  # (C, T, n, 2)
    normal_force: FloatArray  # (C, T, n)
    pushed: np.ndarray  # (C, T, n)
    shut: np.ndarray
    moving: np.ndarray


def _scales(displacement_hats: Sequence[FloatArray], force_hats: Sequence[FloatArray]
            ) -> tuple[FloatArray, FloatArray]:
    """Per case, the largest |F̂| and 1e-4 × the largest |Ŵ| (1 where zero), shapes (C, 1,
    1): a force below the first's ``PRESSED`` is none, a gap or slip within the second is
    shut."""
    force_scale = np.array([_largest(force) or 1.0 for force in force_hats])
    near = 1e-4 * np.array([_largest(w) or 1.0 for w in displacement_hats])
    return force_scale[:, None, None], near[:, None, None]


def _cluster_state(cluster: Cluster, points: Sequence[InterfacePoints],
                   displacement_hats: Sequence[FloatArray], force_hats: Sequence[FloatArray],
                   scales: tuple[FloatArray, FloatArray]) -> ClusterState:
    """``ClusterState`` of ``cluster`` in these cases (``scales``: ``_scales`` of their
    fields); only the cluster's points of the fields are gathered (on b3 108 of 955:
    stacking whole fields was most of the time). A study reads one case at a time, on
    arrays of a few hundred entries: each NumPy call's overhead is most of the cost."""
    force_scale, near = scales
    p, normal = cluster.p, cluster.normal
    contact_rows, stop_rows = cluster.rows
    friction = _stacked([np.concatenate([pts.contact_friction[contact_rows],
                                         pts.stop_friction[stop_rows]]) for pts in points])
    gap = _stacked([np.concatenate([pts.contact_gap[contact_rows], pts.stop_gap[stop_rows]])
                    for pts in points])
    force = _stacked([np.take(f, p, axis=1) for f in force_hats])  # (C, T, n, 2)
    normal_force = _along(force, normal)
    # [Ŵ] = Ŵ_partner − Ŵ_own (a stop's side is fixed): opening and slip increments
    jump = _stacked([np.take(w, cluster.partner_or_own, axis=1) for w in displacement_hats])
    jump[:, :, cluster.at_stop] = 0.0
    jump -= _stacked([np.take(w, p, axis=1) for w in displacement_hats])
    opening = _along(jump, normal)  # less the gap
    increment = jump.copy()
    increment[:, 1:] -= jump[:, :-1]
    normal_increment = opening.copy()
    normal_increment[:, 1:] -= opening[:, :-1]
    # |slip|² = |increment|² − (increment · n)², n a unit normal
    slip_squared = (np.einsum("ctnd,ctnd->ctn", increment, increment)
                    - normal_increment * normal_increment)
    return ClusterState(friction, force, normal_force, normal_force < -PRESSED * force_scale,
                         gap[:, None, :] + opening <= near, slip_squared > near * near)


def _along(vectors: FloatArray, normal: FloatArray) -> FloatArray:
    """x · n per point, ``vectors`` (…, n, 2) and ``normal`` (n, 2) (an einsum's overhead
    is most of its cost on arrays this small)."""
    return vectors[..., 0] * normal[:, 0] + vectors[..., 1] * normal[:, 1]


def _stacked(per_case: list[FloatArray]) -> FloatArray:
    """The cases' arrays stacked along a new first axis (one case: a view of it)."""
    return per_case[0][None] if len(per_case) == 1 else np.stack(per_case)


def _free_directions(cluster: Cluster, pressed: np.ndarray
                     ) -> tuple[FloatArray, np.ndarray]:
    """The rigid modes' directions per case and step (``vectors``, (C, T, 3, 3)) and which
    of them the ``pressed`` points (no motion along their normal) and the prescribed
    displacements leave free (``free``, (C, T, 3))."""
    along = cluster.along_normal  # Σ_pressed a aᵀ, as one product over the points
    outer = (along[:, :, None] * along[:, None, :]).reshape(-1, 9)
    gram = cluster.held + (pressed.astype(float) @ outer).reshape(*pressed.shape[:2], 3, 3)
    values, vectors = np.linalg.eigh(gram)  # ascending
    return vectors, values <= 1e-10 * np.maximum(values[..., -1:], 1e-300)


def _motions_of(clusters: list[Cluster], points: Sequence[InterfacePoints],
                displacement_hats: Sequence[FloatArray], force_hats: Sequence[FloatArray],
                reserve_tol: float) -> list[list[FreeMotion]]:
    """``free_motions_batch`` for cases of the same ``clusters`` (fields (n_steps,
    n_points, 2) each)."""
    n_cases, n_steps = len(force_hats), force_hats[0].shape[0]
    out: list[list[FreeMotion]] = [[] for _ in range(n_cases)]
    scales = _scales(displacement_hats, force_hats)
    for cluster in clusters:
        normal, modes = cluster.normal, cluster.modes
        state = _cluster_state(cluster, points, displacement_hats, force_hats, scales)
        friction, force, normal_force = state.friction, state.force, state.normal_force
        moving, pressed = state.moving, state.pushed  # pressed: no motion along n
        touching = ~pressed & state.shut  # may only separate
        vectors, free = _free_directions(cluster, pressed)
        if not free.any():
            continue
        tangential_force = force - normal_force[..., None] * normal
        limit = friction[:, None, :] * np.abs(normal_force)  # (C, T, n): μ|N|
        # every free direction of every case and step at once, each with both signs (the
        # motion −v: the velocities, their normal parts and frictions' work change sign)
        cases, steps, columns = np.nonzero(free)
        directions = vectors[cases, steps, :, columns]  # (P, 3)
        velocity = np.einsum("nck,pk->pnc", modes, directions)  # (P, n, 2)
        into = _along(velocity, normal)  # along n: into the partner
        carried = _carried(velocity, into, normal, friction[cases])
        near = touching[cases, steps]
        *reserves, capacity = _friction_reserve(
            velocity, into, normal, tangential_force[cases, steps], limit[cases, steps],
            moving[cases, steps], cluster.weights)
        admissible = [(~np.any(near & (sign * into > 1e-9), axis=1)
                       & (reserve <= reserve_tol), reserve)
                      for sign, reserve in zip((1.0, -1.0), reserves, strict=True)]
        centre = (float(cluster.centre[0]), float(cluster.centre[1]))
        for i, (c, t) in enumerate(zip(cases.tolist(), steps.tolist(), strict=True)):
            for sign, (free_along, reserve) in zip((1.0, -1.0), admissible, strict=True):
                if free_along[i]:  # one sign of a direction is enough to say it is free
                    mode = sign * directions[i]
                    out[c].append(FreeMotion(t + 1, cluster.bodies,
                                             (float(mode[0]), float(mode[1])),
                                             float(mode[2] / cluster.size), centre,
                                             max(float(reserve[i]), 0.0),
                                             t + 1 == n_steps or bool(carried[i]),
                                             bool(capacity[i] > 0.0),
                                             t + 1 < n_steps and bool(carried[i])))
                    break
    return out


def _largest(x: FloatArray) -> float:
    """max |x| without an array of |x|."""
    return float(max(x.max(), -x.min())) if x.size else 0.0


def _friction_reserve(velocity: FloatArray, into: FloatArray, normal: FloatArray,
                      tangential_force: FloatArray, limit: FloatArray, moving: np.ndarray,
                      weights: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Per motion p (``velocity`` (P, n, 2) at the n points, ``into`` its normal part, and
    the forces, limits and slips of its step, (P, n, …)): the share of the friction
    capacity along it not yet used, 0 when the motion changes no friction force — for the
    motion and for its opposite —, and the capacity itself. A point slipping during the
    step (``moving``) keeps its force for a small motion either way if its force is at the
    limit; a point at rest keeps it only for a motion against its force, at the limit."""
    slide = velocity - into[..., None] * normal
    speed = np.hypot(slide[..., 0], slide[..., 1])
    slipping = np.hypot(tangential_force[..., 0], tangential_force[..., 1]) * speed
    against = -np.einsum("pnc,pnc->pn", tangential_force, slide)  # μ|N| speed at the limit
    capacity = (limit * speed) @ weights
    positive = capacity > 0
    divisor = np.where(positive, capacity, 1.0)
    forward, backward = (
        np.where(positive, (capacity - np.where(moving, slipping, sign * against) @ weights)
                 / divisor, 0.0)
        for sign in (1.0, -1.0))
    return forward, backward, capacity


def _carried(velocity: FloatArray, into: FloatArray, normal: FloatArray,
             friction: FloatArray) -> np.ndarray:
    """Per motion p (``velocity`` (P, n, 2) at the cluster's n points, ``into`` its normal
    part, ``friction`` (P, n) their μ): friction carries its position into the later steps
    — it slides along a point with friction, whose later slip increments start from it.
    A motion along the normals only (a body lifted off its frictional contacts) is not
    carried: contact and stops read the current gap, not its history (session 50)."""
    slide = velocity - into[..., None] * normal
    return np.asarray(np.any((np.hypot(slide[..., 0], slide[..., 1]) > 1e-9) & (friction > 0), axis=1))


def limit_motions_batch(assemblies: Sequence[Assembly], points: Sequence[InterfacePoints],
                        displacement_hats: Sequence[FloatArray],
                        force_hats: Sequence[FloatArray], reserve_tol: float = RESERVE_TOL
                        ) -> list[list[FreeMotion]]:
    """Per case, the rigid motions that a converged state ŝ = (Ŵ, F̂) of *another* case
    (a study's neighbour) puts at the friction limit of ``points``' coefficients: a case
    there is most likely not unique (``study.predictors.at_friction_limit``).

    As ``free_motions``, but the stops yield: a motion may push into a stop, whose force
    then counts in the load along it. The load along a rigid motion v is what the contact
    forces hold, P·v = −Σ w F·v (the cluster in equilibrium), its capacity Σ w μ|N| |v_t|
    with ``points``' μ; the reserve (capacity − P·v) / capacity. On a sliding neighbour
    whose body rests on the stop (B1 at μ1 + μ2 = 0.25, step 10: 750 N held by 625 N of
    friction and 125 N of the stop) read with μ1 + μ2 = 0.3, the reserve is zero, as on
    a sticking one (0.35: 750 N held by friction alone). Not where the body already
    rested on a stop (or another contact) along the motion at the step before: it then
    reaches the limit on the stop, its answer unique (B1 (0.45, 0.15) at step 15, on the
    stop since step 13). A motion with no capacity at all — the cluster pressed on
    frictionless contacts — is free where the load along it is within ``reserve_tol`` of
    the forces' own Σ w |F| |v| (session 52: B1 without its wall at μ2 = 0, the top block;
    before, its cases' warm attempts were set aside, 1 075 of the 13 × 13 study's 13 806
    iterations). ``reserve`` is signed here."""
    return _by_geometry(assemblies, points, displacement_hats, force_hats,
                        lambda clusters, pts, w, f: _limit_motions_of(clusters, pts, w, f,
                                                                      reserve_tol),
                        LIMIT_CASES)  # bounds the stacked fields


def _limit_motions_of(clusters: list[Cluster], points: Sequence[InterfacePoints],
                      displacement_hats: Sequence[FloatArray],
                      force_hats: Sequence[FloatArray], reserve_tol: float
                      ) -> list[list[FreeMotion]]:
    """``limit_motions_batch`` for cases of the same ``clusters``, vectorised over the
    cases, their steps and free directions."""
    n_cases, n_steps = len(force_hats), force_hats[0].shape[0]
    out: list[list[FreeMotion]] = [[] for _ in range(n_cases)]
    scales = _scales(displacement_hats, force_hats)
    for cluster in clusters:
        normal, modes = cluster.normal, cluster.modes
        between = ~cluster.at_stop  # contact points between bodies (not stops)
        state = _cluster_state(cluster, points, displacement_hats, force_hats, scales)
        friction, force, normal_force = state.friction, state.force, state.normal_force
        moving = state.moving
        closed = state.pushed | state.shut  # (C, T, n)
        pressed = state.pushed & between
        touching = ~pressed & state.shut & between
        vectors, free = _free_directions(cluster, pressed)
        limit = friction[:, None, :] * np.abs(normal_force)  # (C, T, n)
        # every free direction of every case and step, with both signs (the motion −v:
        # its velocities and the load along it change sign, its capacity does not)
        all_cases, all_steps, columns = np.nonzero(free)
        directions = vectors[all_cases, all_steps, :, columns]  # (P, 3)
        velocity = np.einsum("nck,pk->pnc", modes, directions)
        along_n = _along(velocity, normal)
        slide = velocity - along_n[..., None] * normal
        carried = _carried(velocity, along_n, normal, friction[all_cases])
        all_holding = limit[all_cases, all_steps] * np.hypot(slide[..., 0], slide[..., 1])
        capacity = all_holding @ cluster.weights
        along_load = -np.einsum("pnc,pnc,n->p", force[all_cases, all_steps], velocity,
                                cluster.weights)
        # no capacity at all, the cluster pressed on frictionless contacts: free where the
        # load along the motion is nil beside the forces' own size along it (a state with
        # no force tells nothing: a neighbour nothing loads)
        gross = np.einsum("pn,pn,n->p", np.linalg.norm(force[all_cases, all_steps], axis=-1),
                          np.linalg.norm(velocity, axis=-1), cluster.weights)
        unresisted = ((capacity <= 0.0) & np.any(pressed[all_cases, all_steps], axis=1)
                      & (np.abs(along_load) <= reserve_tol * gross))
        for sign in (1.0, -1.0):
            load = sign * along_load
            reserve = (capacity - load) / np.where(capacity > 0.0, capacity, 1.0)
            near_limit = np.flatnonzero(((capacity > 0.0) & (load > 0.0)
                                         & (np.abs(reserve) <= reserve_tol))
                                        | (unresisted & (sign > 0.0)))
            if not near_limit.size:
                continue
            cases, steps = all_cases[near_limit], all_steps[near_limit]
            modes_p = sign * directions[near_limit]
            into, holding = sign * along_n[near_limit] > 1e-9, all_holding[near_limit]
            before = np.maximum(steps - 1, 0)
            # not into a touching contact; not along a body that rested on a stop (or a
            # contact) the step before; on a stop only where it slid there
            blocked = (np.any(touching[cases, steps] & into, axis=1)
                       | ((steps > 0) & np.any(closed[cases, before] & into, axis=1))
                       | (np.any(closed[cases, steps] & ~between & into, axis=1)
                          & ~np.all(moving[cases, steps] | (holding <= 0.0) | ~between,
                                    axis=1)))
            reserve = reserve[near_limit]
            for n in np.flatnonzero(~blocked):
                c, t, mode = int(cases[n]), int(steps[n]), modes_p[n]
                if any(m.step == t + 1 and m.bodies == cluster.bodies for m in out[c]):
                    continue  # one sign of one direction per step is enough
                out[c].append(FreeMotion(
                    t + 1, cluster.bodies, (float(mode[0]), float(mode[1])),
                    float(mode[2] / cluster.size),
                    (float(cluster.centre[0]), float(cluster.centre[1])),
                    float(reserve[n]), t + 1 == n_steps or bool(carried[near_limit[n]]),
                    carried_on=t + 1 < n_steps and bool(carried[near_limit[n]])))
    return out
