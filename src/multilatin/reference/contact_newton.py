"""Reference solver for frictional contact: a semi-smooth Newton method on the Alart–Curnier
augmented Lagrangian, node to node, incremental over the load history.

An algorithm independent of LATIN (no decomposition, no search directions): per step,
unknowns are the free displacements u and, per contact pair, the normal and tangential
forces λ = (λ_N, λ_T) that the first body exerts on the second. With [u] = u₂ − u₁,
g = j + n·[u] (gap) and s = t·([u] − [u]ᵗ⁻¹) (slip increment):

    K u = f + Gᵀ λ
    λ_N = max(0, λ_N − r g)                                  (unilateral contact)
    λ_T = proj_[−μ λ̄_N, μ λ̄_N](λ_T − r s),  λ̄_N = max(0, λ_N − r g)   (Coulomb)

The generalised Jacobian is exact on each active set but for two tiny regularisations, of
the Jacobian only (the residual, hence the converged equations, stay exact): floating bodies
(B1's centre block at μ = 0 during the preload) and redundant constraints (a corner node
against a stop and sticking on a face held by a wall: unique displacements, indeterminate
multipliers). A pair whose two nodes have their tangential displacement held (a fixed dof,
or a closed stop on that node, which it was on at the previous step already) keeps its
previous tangential force, limited to the cone: the
friction there is statically indeterminate, and this is the rule of the LATIN local stage
(``latin.LocalStage``) and the limit of any tangential compliance — unless its prescribed
holders moved since the last step (against each other, or one against a closed stop): the
pair slides, by Coulomb's law. A stop pair whose node is held tangentially (a fixed dof that did
not move, or another closed stop on that node, on it at the previous step) keeps its
previous force the same way.
Steps are damped by backtracking on the residual norm (full semi-smooth steps can cycle
between active sets); a load step they do not solve is reached in parts (``CONTINUATION``),
each the same step's equations at a share of its load increment, slips still counted from
the step before, and then with a smaller augmentation (``AUGMENTATIONS``).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..decomposition.assembly import Assembly
from ..decomposition.interfaces import discretise_side, point_normals, slave_side
from ..decomposition.mortar import MortarCoupling, facing_positions, touching_by_declaration
from ..errors import NotConvergedError
from ..fem.elasticity import FloatArray, IntArray

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ContactSet:
    """Node-to-node contact pairs of the merged mesh. For a rigid stop ``second`` is −1.

    ``normal`` points out of the first body; ``length`` is the dual-cell length, ``weight``
    that × the contact's thickness (the thinner side's: the face that touches), the area a
    pressure is read on;
    ``extent`` the dual cell along the interface (for mean pressures); ``bodies`` and
    ``boundary`` name what each pair belongs to.
    """

    first: IntArray
    second: IntArray
    normal: FloatArray
    friction: FloatArray
    gap: FloatArray
    weight: FloatArray
    length: FloatArray
    extent: FloatArray
    position: FloatArray  # (n, 2) where the first side's node is (the slave's, when mortar)
    bodies: list[frozenset[str]]
    boundary: list[str | None]

    @property
    def size(self) -> int:
        return int(self.first.size)


#: the equilibrium residual is asked no smaller than this many times the rounding of K u
#: (machine epsilon × max |K| |u|): a prescribed displacement far larger than the
#: deformation (a foundation moved by 100 mm under a block deforming by 1e-3 mm) puts that
#: rounding (~4e-9 N) above tol × the largest load (1e-9 N), and Newton could never
#: converge (docs/correctness.md, session 41)
ROUNDING = 100.0
#: halvings of a Newton step before it is taken whole (``solve_contact_history``)
BACKTRACKS = 12
#: a step whose Newton iterations fail is reached in so many equal parts, in turn
CONTINUATION = (4, 16)
#: and then all again with the augmentation r this share of E (it changes no equation)
AUGMENTATIONS = np.array([1.0, 0.1])


def contact_set(assembly: Assembly, maps: list[IntArray],
                mortar_points: dict[int, tuple[IntArray, IntArray, MortarCoupling]] | None = None
                ) -> ContactSet:
    """Contact pairs; a node pair met on two substructure sides of one normal (a cross
    point) is one pair with the weights added (a node on two stops of other normals, a block
    in a rigid corner, is two). ``mortar_points``: for a contact interface between
    non-matching meshes, the global nodes of its pairs (``monolithic.merge_nodes``: the
    slave's nodes and virtual nodes where the master's projected trace is)."""
    records: dict[tuple[int, int], list[list[Any]]] = {}
    for index, itf in enumerate(assembly.interfaces):
        if itf.contact is None:
            continue
        ref = itf.sides[0]
        sub = assembly.substructures[ref.substructure]
        first, second, coupling = (mortar_points or {}).get(index, (None, None, None))
        if coupling is None:
            nodes = ref.nodes(sub.mesh)
            cells = discretise_side(sub.mesh.nodes, nodes, "nodal", 1.0)
        else:  # the slave side's points
            slave_sub = assembly.substructures[itf.sides[coupling.slave].substructure]
            cells = slave_side(slave_sub.mesh.nodes, coupling)
            nodes = np.arange(cells.weights.size)  # one per point
        length = cells.weights
        lo, hi = cells.extents[:, 0], cells.extents[:, 1]
        position = cells.coords
        # the thinner side's thickness, or 2π r axisymmetric, at each point
        thickness = np.min([assembly.substructures[r.substructure].material.thickness_at(
            position) for r in itf.sides], axis=0)
        bodies = frozenset(assembly.substructures[r.substructure].body for r in itf.sides)
        boundary = None
        normal = (point_normals(sub.mesh, ref.side, nodes) if coupling is None
                  else point_normals(sub.mesh, ref.side, cells.nodes, cells.trace)
                  if coupling.slave == 0
                  else point_normals(sub.mesh, ref.side, coupling.master_nodes,
                                     coupling.projection))
        offset = np.zeros(nodes.size)  # initial distance of a curved face (SideRef.reach)
        if len(itf.sides) == 2 and not touching_by_declaration(itf):
            at = facing_positions(assembly.substructures, itf, coupling)
            offset = np.einsum("pi,pi->p", at[1] - at[0], normal)
            offset[np.abs(offset) <= 1e-12 * max(float(np.ptp(sub.mesh.nodes)), 1.0)] = 0.0
        if coupling is not None:  # merge_nodes gave the slave's and the virtual nodes
            assert first is not None and second is not None
        elif len(itf.sides) == 2:
            first = maps[ref.substructure][nodes]
            other = itf.sides[1]
            second = maps[other.substructure][
                other.nodes(assembly.substructures[other.substructure].mesh)]
        else:
            first = maps[ref.substructure][nodes]
            second = np.full(nodes.size, -1)
            assert itf.condition is not None
            boundary = itf.condition.name
        for p in range(nodes.size):
            # pieces of one face meet at a cross point with (about) one normal: one pair;
            # two stops (or contacts) of other normals at one node, a block in a rigid
            # corner, are two
            same = records.setdefault((int(first[p]), int(second[p])), [])
            rec = next((r for r in same if float(np.dot(r[0], normal[p])) > 0.5), None)
            if rec is not None:
                rec[4] += length[p] * thickness[p]
                rec[8] += length[p]
                rec[5] = (min(rec[5][0], lo[p]), max(rec[5][1], hi[p]))
            else:
                same.append([normal[p], itf.contact.friction, itf.contact.gap + offset[p],
                             bodies, length[p] * thickness[p], (lo[p], hi[p]), boundary,
                             position[p], length[p]])
    keys = [key for key, same in records.items() for _ in same]
    vals = [rec for same in records.values() for rec in same]
    return ContactSet(
        first=np.array([k[0] for k in keys], dtype=np.int64),
        second=np.array([k[1] for k in keys], dtype=np.int64),
        normal=np.array([v[0] for v in vals]).reshape(-1, 2),
        friction=np.array([v[1] for v in vals], dtype=float),
        gap=np.array([v[2] for v in vals], dtype=float),
        weight=np.array([v[4] for v in vals], dtype=float),
        length=np.array([v[8] for v in vals], dtype=float),
        extent=np.array([v[5] for v in vals], dtype=float).reshape(-1, 2),
        position=np.array([v[7] for v in vals], dtype=float).reshape(-1, 2),
        bodies=[v[3] for v in vals],
        boundary=[v[6] for v in vals],
    )


def _stops_by_axis(contacts: ContactSet) -> dict[tuple[int, int], int]:
    """(node, the axis of its stop pair's normal) -> the stop pair: what it holds."""
    return {(int(contacts.first[q]), int(np.argmax(np.abs(contacts.normal[q])))): int(q)
            for q in np.flatnonzero(contacts.second < 0)}


def _held_corners(contacts: ContactSet, free: npt.NDArray[np.bool_]) -> tuple[IntArray, IntArray]:
    """Pairs between two bodies whose nodes both have the tangential displacement held, by a
    fixed dof or by a stop pair on that node (index in the pairs, −1 for a fixed dof)."""
    tangential = np.argmax(np.abs(tangents(contacts.normal)), axis=1)
    stop_of = _stops_by_axis(contacts)
    corner, corner_stops = [], []
    for j in np.flatnonzero(contacts.second >= 0):
        component = int(tangential[j])
        holders = []
        for node in (int(contacts.first[j]), int(contacts.second[j])):
            if not free[2 * node + component]:
                holders.append(-1)
            elif (node, component) in stop_of:
                holders.append(stop_of[(node, component)])
        if len(holders) == 2:
            corner.append(j)
            corner_stops.append(holders)
    return (np.array(corner, dtype=np.int64),
            np.array(corner_stops, dtype=np.int64).reshape(-1, 2))


def _moving_corners(contacts: ContactSet, corner: IntArray, corner_stops: IntArray,
                    u_fixed: FloatArray, step: int) -> npt.NDArray[np.bool_]:
    """Per held corner: whether its fixed holders moved against each other along the
    contact at ``step`` (or one of them, the other side held by a stop):
    ``latin.held_stops.moving_corners``, the same rule."""
    moving = np.zeros(corner.size, dtype=bool)
    tangential = np.argmax(np.abs(tangents(contacts.normal[corner])), axis=1)
    for q, j in enumerate(corner.tolist()):
        moves = []
        for h, node in enumerate((contacts.first[j], contacts.second[j])):
            dof = 2 * int(node) + int(tangential[q])
            if corner_stops[q, h] < 0:  # a fixed dof (else a stop, which holds still)
                before = u_fixed[dof, step - 1] if step else 0.0
                moves.append(u_fixed[dof, step] - before)
        moving[q] = (moves[1] - moves[0] != 0.0) if len(moves) == 2 else (
            len(moves) == 1 and moves[0] != 0.0)
    return moving


def _held_stops(contacts: ContactSet, free: npt.NDArray[np.bool_]
                ) -> tuple[IntArray, IntArray]:
    """Stop pairs whose node has its tangential displacement held, by a fixed dof (−1) or
    by another stop pair on that node (its index): ``held_nodes.held_stops``, the same
    rule (axis-aligned stops only)."""
    tangential = np.argmax(np.abs(tangents(contacts.normal)), axis=1)
    stops = np.flatnonzero(contacts.second < 0)
    stop_of = _stops_by_axis(contacts)
    pairs, holders = [], []
    for q in stops:
        node, component = int(contacts.first[q]), int(tangential[q])
        if abs(contacts.normal[q, component]) > 1e-12:
            continue
        if not free[2 * node + component]:
            pairs.append(int(q))
            holders.append(-1)
        elif (node, component) in stop_of:
            pairs.append(int(q))
            holders.append(stop_of[(node, component)])
    return np.array(pairs, dtype=np.int64), np.array(holders, dtype=np.int64)


def tangents(normal: FloatArray) -> FloatArray:
    """t = n rotated by +90°: the tangential direction of each contact pair."""
    return np.column_stack([-normal[:, 1], normal[:, 0]])


def _jump_operator(contacts: ContactSet, n_dofs: int) -> sp.csr_matrix:
    """G (2 n_pairs × n_dofs): rows n·[u] and t·[u] of each pair."""
    n = contacts.normal
    t = tangents(n)
    rows, cols, vals = [], [], []
    for row_dir, direction in ((0, n), (1, t)):
        for comp in range(2):
            pair_rows = 2 * np.arange(contacts.size) + row_dir
            rows.append(pair_rows)
            cols.append(2 * contacts.first + comp)
            vals.append(-direction[:, comp])
            has_second = contacts.second >= 0
            rows.append(pair_rows[has_second])
            cols.append(2 * contacts.second[has_second] + comp)
            vals.append(direction[has_second, comp])
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(2 * contacts.size, n_dofs))


def solve_contact_history(
    stiffness: sp.csr_matrix,
    load: FloatArray,
    u_fixed: FloatArray,
    free: npt.NDArray[np.bool_],
    contacts: ContactSet,
    young: float,
    tol: float = 1e-10,
    max_newton: int = 60,
    constraint: sp.csr_matrix | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray, int]:
    """Displacements (n_dofs, n_steps), contact nodal forces, multipliers (n_steps, pairs, 2)
    and the total number of Newton iterations. ``constraint``: C of the dofs constrained by
    non-matching interfaces (``monolithic.merge_nodes``): the unknowns are then u with
    every dof = C u, ``stiffness`` and ``load`` already reduced (Cᵀ K C, Cᵀ f)."""
    n_dofs, n_steps = load.shape
    jump = _jump_operator(contacts, n_dofs)
    movable = free.copy()  # for the held-corner rule: constrained dofs are not held
    if constraint is not None:
        movable |= np.asarray(abs(constraint).sum(axis=0)).ravel() == 0.0
        jump = (jump @ constraint).tocsr()
    jump_free = jump[:, free].tocsr()
    k_ff = stiffness[free][:, free].tocsr()
    k_fc = stiffness[free][:, ~free].tocsr()
    n_free = int(free.sum())
    n_pairs = contacts.size
    r = young  # augmentation parameter, a stiffness per unit thickness
    mu = contacts.friction
    jacobian_uu = k_ff + sp.diags(1e-10 * k_ff.diagonal())  # floating bodies
    g_n, g_t = jump_free[0::2], jump_free[1::2]  # n·[u] and t·[u] rows
    minus_g_n_t, minus_g_t_t = -g_n.T, -g_t.T
    zero = sp.csr_matrix((n_pairs, n_pairs))
    jump_on_fixed = jump[:, ~free]
    scale_force = max(float(np.abs(load).max()), 1.0)
    gap_tol = 1e3 * tol * scale_force / r  # on gaps and slips (mm); forces: tol * scale_force
    abs_ff, abs_fc = abs(k_ff), abs(k_fc)  # for the rounding of K u (``ROUNDING``)

    u = u_fixed.copy()
    multipliers = np.zeros((n_steps, n_pairs, 2))
    contact_force = np.zeros((n_dofs, n_steps))
    lam = np.zeros(2 * n_pairs)
    u_free = np.zeros(n_free)
    jump_prev = np.zeros(n_pairs)  # tangential jump t·[u] at the previous step
    on_stop = contacts.gap <= 0.0  # a pair closed at the previous step (at rest: u = 0)
    carried = np.zeros(n_pairs, dtype=bool)  # a pair's force at the previous step > 0
    corner, corner_stops = _held_corners(contacts, movable)
    corner_stop = np.maximum(corner_stops, 0)  # an index where a corner has no stop
    held_stop, stop_holder = _held_stops(contacts, movable)
    lam_t_prev = np.zeros(n_pairs)  # tangential multipliers at the previous step
    total_iterations = 0

    def residuals(u_free: FloatArray, lam: FloatArray, rhs: FloatArray, jump_fixed: FloatArray,
                  jump_prev: FloatArray, lam_t_prev: FloatArray, kink_active: bool
                  ) -> tuple[FloatArray, Any]:
        """Equilibrium and Alart–Curnier residuals at (u, λ), with the active sets."""
        jumps = jump_free @ u_free + jump_fixed
        gap = contacts.gap + jumps[0::2]
        slip = jumps[1::2] - jump_prev
        lam_n, lam_t = lam[0::2], lam[1::2]
        normal_trial = lam_n - r * gap
        # the kink λ_N − r g = 0 (a closed contact at rest) counts as inactive, or as active
        # and, with no friction bound yet, sticking where a step is solved again
        # (``kink_active``); the residuals are the same there
        active = (normal_trial >= 0.0) if kink_active else (normal_trial > 0.0)
        bound = mu * np.where(active, normal_trial, 0.0)
        tangent_trial = lam_t - r * slip
        stick = active & ((bound > 0.0) | kink_active) & (np.abs(tangent_trial) <= bound)
        if corner.size:
            # friction first (``latin.held_stops.open_arrivals``): a corner's stop that
            # carried nothing at the step before is open while the corner sticks with its
            # node not beyond the stop
            quiet = ((corner_stops >= 0) & ~carried[corner_stop] & stick[corner][:, None]
                     & (gap[corner_stop] >= -gap_tol))
            active[corner_stop[quiet]] = False
            stick &= active
        slip_mask = active & ~stick
        sign = np.sign(tangent_trial)
        if corner.size or held_stop.size:
            # held corner with its stops closed, stop held at its node (its holder a
            # prescribed displacement that did not move, or a closed stop): the previous
            # friction force, limited to the cone (the rule of the LATIN local stage; it
            # is indeterminate there)
            held = np.zeros(n_pairs, dtype=bool)
            # a stop holds where its node was on it at the previous step already (a
            # node that reaches it slid along the contact: ``held_stops.ATTACHED``)
            held[corner] = np.all((corner_stops < 0)
                                  | (active & on_stop & carried)[corner_stop], axis=1)
            held[corner] &= ~corner_moving
            holder = np.maximum(stop_holder, 0)
            held[held_stop] = np.where(stop_holder < 0, slip[held_stop] == 0.0,
                                       active[holder] & on_stop[holder])
            held &= active
            clipped = held & (np.abs(lam_t_prev) > bound)
            stick = stick & ~held
            slip_mask = (slip_mask & ~held) | clipped
            sign = np.where(held, np.sign(lam_t_prev), sign)
            frozen = held & ~clipped
        else:
            frozen = np.zeros(n_pairs, dtype=bool)
        c_n = np.where(active, r * gap, lam_n)
        c_t = np.where(stick, r * slip, np.where(slip_mask, lam_t - bound * sign, lam_t))
        c_t = np.where(frozen, lam_t - lam_t_prev, c_t)
        res_eq = k_ff @ u_free - rhs - jump_free.T @ lam
        return np.r_[res_eq, c_n, c_t], (active, stick, slip_mask, sign)

    def merit(residual: FloatArray, force_tol: float) -> float:
        """Largest residual relative to its tolerance (converged when < 1); ``force_tol``
        the equilibrium's."""
        size_eq = np.abs(residual[:n_free]).max() / force_tol if n_free else 0.0
        size_c = (np.abs(residual[n_free:]).max() / (r * gap_tol)) if n_pairs else 0.0
        return float(max(size_eq, size_c))

    def newton_iterations(u_free: FloatArray, lam: FloatArray, rhs: FloatArray,
                          jump_fixed: FloatArray, force_tol: float, kink_active: bool
                          ) -> tuple[bool, FloatArray, FloatArray, int]:
        """Damped semi-smooth Newton iterations of one step from (u, λ): whether they
        converged, (u, λ) and the index of the last iteration."""
        def evaluate(u_free: FloatArray, lam: FloatArray) -> tuple[FloatArray, Any]:
            return residuals(u_free, lam, rhs, jump_fixed, jump_prev, lam_t_prev, kink_active)

        residual, sets = evaluate(u_free, lam)
        for newton in range(max_newton):
            if newton > 0 and merit(residual, force_tol) < 1.0:
                return True, u_free, lam, newton
            active, stick, slip_mask, sign = sets
            # generalised Jacobian, rows: equilibrium, C_N, C_T
            dn_du = sp.diags(np.where(active, r, 0.0)) @ g_n
            # −δ on the diagonal of active constraint rows (Jacobian only): redundant
            # constraints (a corner against a stop and a sticking face) keep it regular
            dn_dln = sp.diags(np.where(active, -1e-10, 1.0))
            dt_du = (sp.diags(np.where(stick, r, 0.0)) @ g_t
                     + sp.diags(np.where(slip_mask, mu * sign * r, 0.0)) @ g_n)
            dt_dln = sp.diags(np.where(slip_mask, -mu * sign, 0.0))
            dt_dlt = sp.diags(np.where(stick, -1e-10, 1.0))
            jacobian = sp.bmat([
                [jacobian_uu, minus_g_n_t, minus_g_t_t],
                [dn_du, dn_dln, zero],
                [dt_du, dt_dln, dt_dlt],
            ], format="csc")
            delta = spla.splu(jacobian).solve(-residual)
            delta_lam = np.empty(2 * n_pairs)
            delta_lam[0::2] = delta[n_free:n_free + n_pairs]
            delta_lam[1::2] = delta[n_free + n_pairs:]
            # backtracking on the residual's norm: the full semi-smooth step can cycle
            # between active sets (seen on B1 when the stop closes under friction)
            current = float(np.linalg.norm(residual))
            step_length = 1.0
            for _ in range(BACKTRACKS):
                trial_u = u_free + step_length * delta[:n_free]
                trial_lam = lam + step_length * delta_lam
                trial_residual, trial_sets = evaluate(trial_u, trial_lam)
                if np.linalg.norm(trial_residual) < (1.0 - 1e-4 * step_length) * current:
                    break
                step_length *= 0.5
            else:
                # no decrease down to 2⁻¹¹: a point of nearly no pressure flipping
                # between stick and slip at each tiny step (a holed block at μ = 100 on
                # a conforming mesh, 60 such steps); the full step leaves that cycle
                trial_u, trial_lam = u_free + delta[:n_free], lam + delta_lam
                trial_residual, trial_sets = evaluate(trial_u, trial_lam)
            u_free, lam, residual, sets = trial_u, trial_lam, trial_residual, trial_sets
        return False, u_free, lam, max_newton - 1

    for step in range(n_steps):
        corner_moving = _moving_corners(contacts, corner, corner_stops, u_fixed, step)
        rhs = load[free, step] - k_fc @ u_fixed[~free, step]
        jump_fixed = jump_on_fixed @ u_fixed[~free, step]
        # tol × the largest load, or the rounding of K u where that is larger
        force_tol = max(tol * scale_force, ROUNDING * np.finfo(np.float64).eps * float(
            np.max(abs_ff @ np.abs(u_free) + abs_fc @ np.abs(u_fixed[~free, step]),
                   initial=0.0)))
        # a step whose Newton iterations do not converge is solved again from its start
        # with the kink of the normal law taken as active, a pair there sticking: a body
        # held by its contact alone (a plate pressed on a wider base, nothing else holding
        # it sideways) floated in the Jacobian of its first iteration, whose step was ~1e10
        # too long, and the steps cycled (session 46; docs/correctness.md); other models
        # fail the other way. Then by continuation: the step's load and prescribed motion
        # reached in equal parts, each part solved from the one before, the slips still
        # counted from the step before (``jump_prev``, ``lam_t_prev``): the parts are the
        # same discrete step, reached from closer starts (a block held sideways by friction
        # alone, on a plate pushed under it, cycled between slip sets). Then all of it again
        # with a smaller augmentation r, which changes no equation (session 62)
        start = (u_free, lam)
        before = ((load[free, step - 1] - k_fc @ u_fixed[~free, step - 1],
                   jump_on_fixed @ u_fixed[~free, step - 1]) if step
                  else (np.zeros_like(rhs), np.zeros_like(jump_fixed)))
        for r in AUGMENTATIONS * young:
            for parts in (1, *CONTINUATION):
                u_free, lam = start
                for part in range(1, parts + 1):
                    share = part / parts  # the last part: the step itself, exactly
                    part_rhs, part_jump = ((rhs, jump_fixed) if part == parts else
                                           (before[0] + share * (rhs - before[0]),
                                            before[1] + share * (jump_fixed - before[1])))
                    for kink_active in (False, True):
                        converged, u_part, lam_part, newton = newton_iterations(
                            u_free, lam, part_rhs, part_jump, force_tol, kink_active)
                        total_iterations += newton + 1
                        if converged:
                            break
                    if not converged:
                        break
                    u_free, lam = u_part, lam_part
                if converged:
                    break
            if converged:
                if parts > 1 or r != young:
                    log.debug("contact step %d: reached in %d part(s), r = %g E", step + 1,
                              parts, r / young)
                break
        if not converged:
            raise NotConvergedError(
                f"contact reference: semi-smooth Newton did not converge at load step "
                f"{step + 1} within {max_newton} iterations", None)
        u[free, step] = u_free
        multipliers[step, :, 0] = lam[0::2]
        multipliers[step, :, 1] = lam[1::2]
        lam_t_prev = lam[1::2].copy()
        contact_force[:, step] = jump.T @ lam
        jumps = jump @ u[:, step]
        jump_prev = jumps[1::2]
        on_stop = contacts.gap + jumps[0::2] <= gap_tol
        carried = lam[0::2] > tol * scale_force
        log.debug("contact step %d: %d Newton iterations", step + 1, newton)
    return u, contact_force, multipliers, total_iterations
