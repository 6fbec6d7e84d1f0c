"""Monolithic finite-element reference: the whole assembly on the same meshes, without
decomposition.

It shares only the Q4 element kernel with the LATIN solver. Nodes facing each other across
perfect interfaces are merged (one mesh per body); across non-matching ones the mortar
constraint u_slave = P u_master is eliminated (``merge_nodes``); so are prescribed
displacements; uniform tractions give consistent nodal loads. Without contact, one sparse
solve treats all load steps as columns. With contact, the load history is followed step by step by a
semi-smooth Newton method on the Alart–Curnier augmented Lagrangian, node to node
(``multilatin.contact_newton``).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp
import scipy.sparse.csgraph as csgraph
import scipy.sparse.linalg as spla

from ..decomposition.assembly import DISPLACEMENT, Assembly, consistent_densities
from ..decomposition.interfaces import discretise_side, point_normals, slave_side
from ..decomposition.mortar import MortarCoupling, mortar_coupling
from ..decomposition.qoi import ContactPressures, evaluate_qois, per_area
from ..decomposition.result import SolveResult
from ..errors import ModelError, NotConvergedError
from ..fem.elasticity import FloatArray, IntArray
from .contact_newton import contact_set, solve_contact_history, tangents
from .undetermined import reference_free_motions


@dataclass(frozen=True)
class GlobalNodes:
    """The merged mesh's node numbering.

    Nodes facing each other across matching perfect interfaces are one global node. Across
    non-matching ones (mortar, ``decomposition.mortar``) the slave's nodes that do not
    coincide with a master node are *constrained*: u = C u with their rows of C the
    projection P of the master's nodes. A non-matching contact interface gets one virtual
    node per slave node on the master side, constrained the same way, so that contact stays
    node to node (``contact_points``)."""

    count: int  # global nodes, virtual ones included
    maps: list[IntArray]  # per substructure: the global node of each local node
    constraint: sp.csr_matrix  # C (2 count × 2 count), zero columns at constrained dofs
    constrained: npt.NDArray[np.bool_]  # per dof
    # non-matching contact interface → (global nodes of side 0's points, of side 1's
    # points, its coupling)
    contact_points: dict[int, tuple[IntArray, IntArray, MortarCoupling]]


def merge_nodes(assembly: Assembly) -> GlobalNodes:
    """The global numbering of ``assembly``'s nodes and the mortar constraints."""
    offsets = np.cumsum([0] + [s.mesh.n_nodes for s in assembly.substructures])
    n = int(offsets[-1])
    rows, cols = [], []
    projected: list[tuple[IntArray, IntArray, sp.csr_matrix]] = []  # (nodes, masters, P)
    virtual: dict[int, tuple[IntArray, IntArray, MortarCoupling]] = {}  # contact interfaces
    pieces: list[tuple[int, tuple[int | None, int | None]]] = []  # rows in ``projected``
    n_virtual = 0
    for index, itf in enumerate(assembly.interfaces):
        if itf.kind not in ("perfect", "contact") or len(itf.sides) != 2:
            continue
        a, b = itf.sides
        coupling = mortar_coupling(assembly, itf)
        if coupling is None:
            if itf.kind == "perfect":
                rows.append(offsets[a.substructure] + a.nodes(
                    assembly.substructures[a.substructure].mesh))
                cols.append(offsets[b.substructure] + b.nodes(
                    assembly.substructures[b.substructure].mesh))
            continue
        slave = offsets[itf.sides[coupling.slave].substructure] + coupling.slave_nodes
        master = offsets[itf.sides[coupling.master].substructure] + coupling.master_nodes
        projection = coupling.projection
        if itf.kind == "contact":
            n_points = projection.shape[0]
            entries: list[int | None] = [None, None]  # per side: its rows in ``projected``
            if coupling.slave_trace is not None:  # the slave's points on its edges too
                own = n + n_virtual + np.arange(n_points)
                n_virtual += n_points
                projected.append((own, slave, coupling.slave_trace))
                entries[coupling.slave] = len(projected) - 1
                slave = own
            points = n + n_virtual + np.arange(n_points)
            n_virtual += n_points
            projected.append((points, master, projection))
            entries[coupling.master] = len(projected) - 1
            pieces.append((index, (entries[0], entries[1])))
            virtual[index] = ((slave, points, coupling) if coupling.slave == 0
                              else (points, slave, coupling))
            continue
        dense = projection.toarray()
        unit = np.isclose(dense.max(axis=1), 1.0, rtol=0.0, atol=1e-12)
        rows.append(slave[unit])
        cols.append(master[np.argmax(dense[unit], axis=1)])
        if not unit.all():
            projected.append((slave[~unit], master, projection[np.flatnonzero(~unit)]))
    if rows:
        r, c = np.concatenate(rows), np.concatenate(cols)
        graph = sp.csr_matrix((np.ones(r.size), (r, c)), shape=(n, n))
        _, labels = csgraph.connected_components(graph, directed=False)
    else:
        labels = np.arange(n)
    labels = labels.astype(np.int64)
    n_real = int(labels.max()) + 1 if n else 0
    labels = np.concatenate([labels, n_real + np.arange(n_virtual)])
    count = n_real + n_virtual
    _merge_cross_points(assembly, pieces, labels, projected, virtual)
    # C on nodes: identity, but for the constrained ones, whose rows are P on their masters
    keep = np.ones(count, dtype=bool)
    c_rows, c_cols, c_vals = [], [], []
    for nodes, masters, projection in projected:
        coo = projection.tocoo()
        c_rows.append(labels[nodes][coo.row])
        c_cols.append(labels[masters][coo.col])
        c_vals.append(coo.data)
        keep[labels[nodes]] = False
    ids = np.flatnonzero(keep)
    node_map = sp.csr_matrix(
        (np.concatenate([np.ones(ids.size)] + c_vals),
         (np.concatenate([ids] + c_rows), np.concatenate([ids] + c_cols))),
        shape=(count, count))
    for _ in range(8):  # a master constrained in turn (chained non-matching interfaces)
        if not np.asarray(abs(node_map[:, ~keep]).sum()).item():
            break
        node_map = (node_map @ node_map).tocsr()
    else:  # pragma: no cover - needs a cycle of non-matching interfaces
        raise ModelError("mortar interfaces: the constraints between non-matching meshes form "
                         "a cycle")
    constraint = sp.kron(node_map, sp.identity(2), format="csr")
    # the contact points in the global numbering (their nodes were numbered before the
    # nodes of matching perfect interfaces merged)
    contact_points = {index: (labels[first], labels[second], coupling)
                      for index, (first, second, coupling) in virtual.items()}
    return GlobalNodes(count, [labels[offsets[s]:offsets[s + 1]]
                               for s in range(len(assembly.substructures))],
                       constraint, np.repeat(~keep, 2), contact_points)


def _merge_cross_points(assembly: Assembly,
                        pieces: list[tuple[int, tuple[int | None, int | None]]],
                        labels: IntArray,
                        projected: list[tuple[IntArray, IntArray, sp.csr_matrix]],
                        virtual: dict[int, tuple[IntArray, IntArray, MortarCoupling]]) -> None:
    """The pieces of a non-matching contact interface that meet at a cross point (one place
    on the same two bodies, one normal and contact law) are one pair, as LATIN runs them
    (``latin.cross_points``: the pair's law on each side's weighted mean). Per side whose
    members are not one node already, one virtual node: its trace the members' traces (a
    slave's node, a master's projection, a slave's point on its edge) averaged with the
    slave's lengths in each. Where the pieces' slaves lie on different bodies (each the finer
    where its piece ends on nodes of both), both sides are such averages: they were two pairs
    here and one in LATIN, 2.8e-5 to 4.1e-4 apart at η < 1e-11 (session 60,
    ``benchmarks/random_models.py``). In place: the members' points are redirected to the
    first virtual one's (the others' virtual nodes stay unused). ``pieces``: per contact
    interface, the entries of ``projected`` whose rows are its sides' points (None: the
    slave's own nodes)."""
    groups: dict[tuple[Any, ...], list[tuple[int, tuple[int | None, int | None], int,
                                             float]]] = {}
    for index, entries in pieces:
        itf = assembly.interfaces[index]
        coupling = virtual[index][2]
        ref = itf.sides[coupling.slave]
        sub = assembly.substructures[ref.substructure]
        cells = slave_side(sub.mesh.nodes, coupling)
        weights = cells.weights * sub.material.thickness_at(cells.coords)
        # side 0's normal (the slave's, turned where the slave is side 1)
        normals = np.round((1.0 if coupling.slave == 0 else -1.0)
                           * point_normals(sub.mesh, ref.side, cells.nodes, cells.trace), 6) + 0.0
        places = np.round(cells.coords, 9)
        bodies = tuple(assembly.substructures[r.substructure].body for r in itf.sides)
        assert itf.contact is not None
        for i in range(weights.size):
            key = (*bodies, *places[i].tolist(), *normals[i].tolist(), itf.contact.friction,
                   itf.contact.gap)
            groups.setdefault(key, []).append((index, entries, i, float(weights[i])))
    for members in groups.values():
        if len(members) < 2:
            continue
        total = sum(weight for *_, weight in members)
        for side in (0, 1):
            nodes = [int((virtual[index][0] if side == 0 else virtual[index][1])[i])
                     for index, _, i, _ in members]
            if len({int(labels[node]) for node in nodes}) == 1:
                continue  # one node of the merged mesh already (a slave's, on this side)
            target = next(node for (_, entries, _, _), node in zip(members, nodes, strict=True)
                          if entries[side] is not None)
            columns, values = [], []
            for (index, entries, i, weight), node in zip(members, nodes, strict=True):
                entry = entries[side]
                if entry is None:  # the slave's own node
                    columns.append(np.array([node]))
                    values.append(np.array([weight / total]))
                else:  # a virtual node: its row, then no longer read
                    points, master, projection = projected[entry]
                    row = projection[[i]].tocoo()
                    columns.append(master[row.col])
                    values.append(row.data * (weight / total))
                    projection = projection.tolil()
                    projection[i] = 0.0
                    projected[entry] = (points, master, projection.tocsr())
                side_0, side_1, coupling = virtual[index]
                own = (side_0 if side == 0 else side_1).copy()
                own[i] = target
                virtual[index] = ((own, side_1, coupling) if side == 0
                                  else (side_0, own, coupling))
            column = np.concatenate(columns)
            value = np.concatenate(values)
            projected.append((np.array([target]), column,
                              sp.csr_matrix((value, (np.zeros(column.size, dtype=np.int64),
                                                     np.arange(column.size))),
                                            shape=(1, column.size))))


def solve_monolithic(assembly: Assembly) -> SolveResult:
    """The reference solution of ``assembly``."""
    t0 = time.perf_counter()
    if any(itf.kind == "macro" for itf in assembly.interfaces):
        raise ModelError("the monolithic reference has no counterpart of macro-only "
                         "interfaces (paper eq. [20]); use the conforming reference "
                         "(multilatin reference --reference-mesh conforming) or join them by "
                         "mortar (--mortar, Model.with_mortar)")
    nodes = merge_nodes(assembly)
    maps = nodes.maps
    n_dofs = 2 * nodes.count
    n_steps = assembly.n_steps
    rows, cols, vals = [], [], []
    for sub, gmap in zip(assembly.substructures, maps, strict=True):
        k = sub.stiffness().tocoo()
        gdof = np.stack([2 * gmap, 2 * gmap + 1], axis=1).ravel()
        rows.append(gdof[k.row])
        cols.append(gdof[k.col])
        vals.append(k.data)
    stiffness = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                              shape=(n_dofs, n_dofs))
    # the unknowns: every dof but the constrained ones (u = C u, non-matching meshes)
    constraint = nodes.constraint
    stiffness = (constraint.T @ stiffness @ constraint).tocsr()

    load = np.zeros((n_dofs, n_steps))
    fixed_value = np.full((n_dofs, n_steps), np.nan)
    own_load: dict[str, FloatArray] = {}
    # per condition, the dofs it fixes and its dual-cell length there: a dof fixed by two
    # conditions (a corner of two faces) gives each the share of its reaction that its
    # length takes (LATIN's boundary points of a node carry one traction density)
    fixed_of: dict[str, dict[int, float]] = {}
    fixed_length = np.zeros(n_dofs)
    for itf in assembly.interfaces:
        cond = itf.condition
        if cond is None or itf.is_stop:
            continue
        ref = itf.sides[0]
        sub = assembly.substructures[ref.substructure]
        side = ref.nodes(sub.mesh)
        gnodes = maps[ref.substructure][side]
        factor = assembly.history.factor(cond.factor)
        # consistent loads of a uniform traction: half of each edge to each of its nodes
        # dual-cell length × thickness at each node: the consistent load of a uniform traction
        dual_cells = discretise_side(sub.mesh.nodes, side, "nodal", 1.0).weights
        nodal_len = dual_cells * sub.material.thickness_at(sub.mesh.nodes[side])
        mine = own_load.setdefault(cond.name, np.zeros((n_dofs, n_steps)))
        value = cond.values_at(sub.mesh.nodes[side])  # (nodes, 2)
        if cond.pressure:  # traction −p n at each node
            value = -value[:, :1] * point_normals(sub.mesh, ref.side, side)
        if cond.varying is not None:  # the consistent load of a varying traction
            forces = [c for c, kind in enumerate(cond.kinds) if kind != DISPLACEMENT]
            value[:, forces] = consistent_densities(sub.mesh.nodes[side], value)[:, forces]
        for comp, kind in enumerate(cond.kinds):
            dofs = 2 * gnodes + comp
            if kind == DISPLACEMENT:
                fixed_value[dofs] = value[:, comp, None] * factor[None, :]
                # the split by the dual cells' lengths alone: the thickness is one per node,
                # and zero on an axisymmetric part's axis, where a clamped node's reaction
                # was given to no condition (121 N of 100 531 N lost from a clamp's
                # resultant, session 60: a strap pressed on a base, both from r = 0)
                own = fixed_of.setdefault(cond.name, {})
                for dof, length in zip(dofs.tolist(), dual_cells.tolist(), strict=True):
                    own[dof] = own.get(dof, 0.0) + length
                np.add.at(fixed_length, dofs, dual_cells)
            else:
                contribution = (nodal_len * value[:, comp])[:, None] * factor[None, :]
                np.add.at(load, dofs, contribution)
                np.add.at(mine, dofs, contribution)

    for s, gmap in enumerate(maps):  # body forces (paper eq. [1])
        body = assembly.interior_load(s)
        if body is not None:
            np.add.at(load, np.stack([2 * gmap, 2 * gmap + 1], axis=1).ravel(), body.T)
    fixed = ~np.isnan(fixed_value[:, 0]) & ~nodes.constrained
    free = ~fixed & ~nodes.constrained
    load = constraint.T @ load
    u = np.zeros((n_dofs, n_steps))
    u[fixed] = fixed_value[fixed]
    contacts = contact_set(assembly, maps, nodes.contact_points)
    contact_force = np.zeros((n_dofs, n_steps))
    iterations = 1
    if contacts.size == 0:
        k_ff = stiffness[free][:, free].tocsc()
        factor_ff = spla.splu(k_ff)
        if not np.all(np.isfinite(factor_ff.U.diagonal())) or \
                np.abs(factor_ff.U.diagonal()).min() < 1e-12 * np.abs(factor_ff.U.diagonal()).max():
            raise ModelError("the assembly is not held against rigid-body motion "
                             "(singular stiffness)")
        u[free] = factor_ff.solve(load[free] - stiffness[free][:, fixed] @ u[fixed])
        multipliers = np.zeros((n_steps, 0, 2))
    else:
        young = max(s.material.young * (s.material.thickness_at(s.mesh.nodes).mean()
                                        if s.material.radial else s.material.thickness)
                    for s in assembly.substructures)
        u, contact_force, multipliers, iterations = solve_contact_history(
            stiffness, load, u, free, contacts, young, constraint=constraint)

    if not (np.all(np.isfinite(u)) and np.all(np.isfinite(contact_force))):
        raise NotConvergedError("reference: non-finite displacements or forces (overflow or "
                                "NaN): the data's scale is beyond double precision", None)
    reaction_field = stiffness @ u - load - contact_force  # support reactions at fixed dofs
    u = constraint @ u  # every dof, constrained ones included
    reactions: dict[str, FloatArray] = {}
    for name, mine in own_load.items():
        total = mine.T.reshape(n_steps, -1, 2).sum(axis=1)
        own = fixed_of.get(name, {})
        idx = np.array(sorted(own), dtype=np.int64)
        share = np.array([own[dof] for dof in idx.tolist()]) / np.maximum(fixed_length[idx],
                                                                          1e-300)
        for comp in range(2):
            sel = idx % 2 == comp
            total[:, comp] += share[sel] @ reaction_field[idx[sel]]
        reactions[name] = total
    for name in {b for b in contacts.boundary if b is not None}:
        chosen = np.array([b == name for b in contacts.boundary])
        normal, tangent = contacts.normal[chosen], tangents(contacts.normal[chosen])
        lam = multipliers[:, chosen]
        on_body = -(lam[..., :1] * normal + lam[..., 1:] * tangent)
        reactions[name] = on_body.sum(axis=1)
    pair = contacts.second >= 0
    weight = contacts.weight[pair]  # 0 on an axisymmetric part's axis: there the pressure is
    # 0, as LATIN's (it was inf, and a mean contact pressure from the axis too: session 60)
    pressures = ContactPressures(
        bodies=[b for b, p in zip(contacts.bodies, pair, strict=True) if p],
        extents=contacts.extent[pair],
        pressure=per_area(multipliers[:, pair, 0], weight) if multipliers.size
        else np.zeros((n_steps, 0)),
        positions=contacts.position[pair],
        shear=per_area(-multipliers[:, pair, 1], weight) if multipliers.size
        else np.zeros((n_steps, 0)),
    )
    displacements = {
        sub.name: np.stack([u[2 * gmap], u[2 * gmap + 1]], axis=-1).transpose(1, 0, 2)
        for sub, gmap in zip(assembly.substructures, maps, strict=True)
    }
    qoi = evaluate_qois(assembly, displacements, reactions, pressures)
    motions, slips = reference_free_motions(assembly, displacements, contacts, multipliers)
    wall = time.perf_counter() - t0
    return SolveResult(
        method="monolithic",
        assembly=assembly,
        converged=True,
        iterations=iterations,
        indicator=0.0,
        history=np.zeros(1),
        timings={"total": wall},
        displacements=displacements,
        reactions=reactions,
        qoi=qoi,
        contact=pressures if pair.any() else None,
        free_motions=motions,
        large_slips=slips,
    )
