"""Monolithic finite-element reference: the whole assembly on the same meshes, without
decomposition.

It shares only the Q4 element kernel with the LATIN solver. Nodes facing each other across
perfect interfaces are merged (one mesh per body); prescribed displacements are eliminated;
uniform tractions give consistent nodal loads. Without contact, one sparse solve treats all
load steps as columns. With contact, the load history is followed step by step by a
semi-smooth Newton method on the Alart–Curnier augmented Lagrangian, node to node
(``multilatin.contact_newton``).
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.csgraph as csgraph
import scipy.sparse.linalg as spla

from ..decomposition.assembly import DISPLACEMENT, Assembly
from ..decomposition.interfaces import discretise_side
from ..decomposition.qoi import ContactPressures, evaluate_qois
from ..decomposition.result import SolveResult
from ..errors import ModelError, NotConvergedError
from ..fem.elasticity import FloatArray, IntArray
from .contact_newton import contact_set, solve_contact_history, tangents


def merge_nodes(assembly: Assembly) -> tuple[int, list[IntArray]]:
    """Number of global nodes and, per substructure, the global index of each local node;
    nodes facing each other across perfect interfaces are the same global node."""
    offsets = np.cumsum([0] + [s.mesh.n_nodes for s in assembly.substructures])
    rows, cols = [], []
    for itf in assembly.interfaces:
        if itf.kind != "perfect":
            continue
        a, b = itf.sides
        mesh_a = assembly.substructures[a.substructure].mesh
        mesh_b = assembly.substructures[b.substructure].mesh
        rows.append(offsets[a.substructure] + a.nodes(mesh_a))
        cols.append(offsets[b.substructure] + b.nodes(mesh_b))
    n = int(offsets[-1])
    if rows:
        r, c = np.concatenate(rows), np.concatenate(cols)
        graph = sp.csr_matrix((np.ones(r.size), (r, c)), shape=(n, n))
        _, labels = csgraph.connected_components(graph, directed=False)
    else:
        labels = np.arange(n)
    labels = labels.astype(np.int64)
    return int(labels.max()) + 1, [labels[offsets[s]:offsets[s + 1]]
                                   for s in range(len(assembly.substructures))]


def solve_monolithic(assembly: Assembly) -> SolveResult:
    """The reference solution of ``assembly``."""
    t0 = time.perf_counter()
    if any(itf.kind == "macro" for itf in assembly.interfaces):
        raise ModelError("the monolithic reference needs matching meshes, and this assembly "
                         "has macro-only interfaces; use the conforming reference "
                         "(multilatin reference --reference-mesh conforming)")
    n_nodes, maps = merge_nodes(assembly)
    n_dofs = 2 * n_nodes
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

    load = np.zeros((n_dofs, n_steps))
    fixed_value = np.full((n_dofs, n_steps), np.nan)
    own_load: dict[str, FloatArray] = {}
    fixed_of: dict[str, set[int]] = {}
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
        nodal_len = discretise_side(sub.mesh.nodes, side, "nodal", sub.material.thickness).weights
        mine = own_load.setdefault(cond.name, np.zeros((n_dofs, n_steps)))
        for comp, kind in enumerate(cond.kinds):
            dofs = 2 * gnodes + comp
            if kind == DISPLACEMENT:
                fixed_value[dofs] = cond.value[comp] * factor[None, :]
                fixed_of.setdefault(cond.name, set()).update(dofs.tolist())
            else:
                contribution = nodal_len[:, None] * cond.value[comp] * factor[None, :]
                np.add.at(load, dofs, contribution)
                np.add.at(mine, dofs, contribution)

    fixed = ~np.isnan(fixed_value[:, 0])
    free = ~fixed
    u = np.zeros((n_dofs, n_steps))
    u[fixed] = fixed_value[fixed]
    contacts = contact_set(assembly, maps)
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
        young = max(s.material.young * s.material.thickness for s in assembly.substructures)
        u, contact_force, multipliers, iterations = solve_contact_history(
            stiffness, load, u, free, contacts, young)

    if not (np.all(np.isfinite(u)) and np.all(np.isfinite(contact_force))):
        raise NotConvergedError("reference: non-finite displacements or forces (overflow or "
                                "NaN): the data's scale is beyond double precision", None)
    reaction_field = stiffness @ u - load - contact_force  # support reactions at fixed dofs
    reactions: dict[str, FloatArray] = {}
    for name, mine in own_load.items():
        total = mine.T.reshape(n_steps, -1, 2).sum(axis=1)
        idx = np.array(sorted(fixed_of.get(name, set())), dtype=np.int64)
        for comp in range(2):
            sel = idx[idx % 2 == comp]
            total[:, comp] += reaction_field[sel].sum(axis=0)
        reactions[name] = total
    for name in {b for b in contacts.boundary if b is not None}:
        chosen = np.array([b == name for b in contacts.boundary])
        normal, tangent = contacts.normal[chosen], tangents(contacts.normal[chosen])
        lam = multipliers[:, chosen]
        on_body = -(lam[..., :1] * normal + lam[..., 1:] * tangent)
        reactions[name] = on_body.sum(axis=1)
    pair = contacts.second >= 0
    pressures = ContactPressures(
        bodies=[b for b, p in zip(contacts.bodies, pair, strict=True) if p],
        extents=contacts.extent[pair],
        pressure=multipliers[:, pair, 0] / contacts.weight[pair] if multipliers.size
        else np.zeros((n_steps, 0)),
    )
    displacements = {
        sub.name: np.stack([u[2 * gmap], u[2 * gmap + 1]], axis=-1).transpose(1, 0, 2)
        for sub, gmap in zip(assembly.substructures, maps, strict=True)
    }
    qoi = evaluate_qois(assembly, displacements, reactions, pressures)
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
    )
