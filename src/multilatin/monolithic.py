"""Monolithic finite-element reference: the whole assembly on the same meshes, without
decomposition, by a direct sparse solve (all load steps as columns).

It shares only the Q4 element kernel with the LATIN solver: nodes of matching substructure
meshes are merged, boundary conditions are applied by elimination and consistent nodal
loads, and reactions come from K u − f.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .assembly import DISPLACEMENT, Assembly
from .errors import ModelError
from .fem.elasticity import FloatArray, IntArray, stiffness_matrix
from .qoi import evaluate_qois
from .result import SolveResult


def merge_nodes(assembly: Assembly) -> tuple[FloatArray, list[IntArray]]:
    """Global node coordinates and, per substructure, the global index of each local node."""
    coords = np.concatenate([s.mesh.nodes for s in assembly.substructures])
    size = float(np.ptp(coords, axis=0).max())
    keys = np.round(coords / (1e-8 * size)).astype(np.int64)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    maps, start = [], 0
    for s in assembly.substructures:
        maps.append(inverse[start:start + s.mesh.n_nodes])
        start += s.mesh.n_nodes
    return coords[first], maps


def solve_monolithic(assembly: Assembly) -> SolveResult:
    """The reference solution of ``assembly`` (perfect interfaces only)."""
    t0 = time.perf_counter()
    for itf in assembly.interfaces:
        if itf.kind not in ("perfect", "boundary"):
            raise ModelError(
                f"interface {itf.name!r}: the monolithic reference handles perfect interfaces "
                f"only, not {itf.kind!r}"
            )
    nodes, maps = merge_nodes(assembly)
    n_dofs = 2 * nodes.shape[0]
    n_steps = assembly.n_steps
    rows, cols, vals = [], [], []
    for sub, gmap in zip(assembly.substructures, maps, strict=True):
        k = stiffness_matrix(sub.mesh.nodes, sub.mesh.cells, sub.material.hooke,
                             sub.material.thickness).tocoo()
        gdof = np.stack([2 * gmap, 2 * gmap + 1], axis=1).ravel()
        rows.append(gdof[k.row])
        cols.append(gdof[k.col])
        vals.append(k.data)
    stiffness = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                              shape=(n_dofs, n_dofs))

    load = np.zeros((n_dofs, n_steps))
    fixed_value = np.full((n_dofs, n_steps), np.nan)
    boundary_dofs: dict[str, set[int]] = {}
    for itf in assembly.interfaces:
        if itf.condition is None:
            continue
        cond = itf.condition
        ref = itf.sides[0]
        sub = assembly.substructures[ref.substructure]
        side = sub.mesh.side_nodes(ref.side)
        gnodes = maps[ref.substructure][side]
        factor = assembly.history.factor(cond.factor)
        # consistent loads of a uniform traction: half of each edge to each of its nodes
        edge_len = np.linalg.norm(np.diff(sub.mesh.nodes[side], axis=0), axis=1)
        nodal_len = np.zeros(side.size)
        nodal_len[:-1] += 0.5 * edge_len
        nodal_len[1:] += 0.5 * edge_len
        nodal_len *= sub.material.thickness
        for comp, kind in enumerate(cond.kinds):
            dofs = 2 * gnodes + comp
            boundary_dofs.setdefault(cond.name, set()).update(dofs.tolist())
            if kind == DISPLACEMENT:
                fixed_value[dofs] = cond.value[comp] * factor[None, :]
            else:
                np.add.at(load, dofs, nodal_len[:, None] * cond.value[comp] * factor[None, :])

    fixed = ~np.isnan(fixed_value[:, 0])
    free = ~fixed
    u = np.zeros((n_dofs, n_steps))
    u[fixed] = fixed_value[fixed]
    k_ff = stiffness[free][:, free].tocsc()
    rhs = load[free] - stiffness[free][:, fixed] @ u[fixed]
    try:
        factor_ff = spla.splu(k_ff)
    except RuntimeError:
        raise ModelError("the assembly is not held against rigid-body motion "
                         "(singular stiffness)") from None
    u[free] = factor_ff.solve(rhs)
    residual = stiffness @ u - load  # reactions: forces the supports exert are −(K u − f)…
    # … the force a boundary exerts on the structure balances the internal forces: K u − f.

    reactions: dict[str, FloatArray] = {}
    for name, dof_set in boundary_dofs.items():
        idx = np.array(sorted(dof_set), dtype=np.int64)
        total = np.zeros((n_steps, 2))
        for comp in range(2):
            sel = idx[idx % 2 == comp]
            total[:, comp] = residual[sel].sum(axis=0) + load[sel].sum(axis=0)
        reactions[name] = total
    displacements = {
        sub.name: np.stack([u[2 * gmap], u[2 * gmap + 1]], axis=-1).transpose(1, 0, 2)
        for sub, gmap in zip(assembly.substructures, maps, strict=True)
    }
    qoi = evaluate_qois(assembly, displacements, reactions)
    wall = time.perf_counter() - t0
    return SolveResult(
        method="monolithic",
        assembly=assembly,
        converged=True,
        iterations=1,
        indicator=0.0,
        history=np.zeros(1),
        timings={"total": wall},
        displacements=displacements,
        reactions=reactions,
        qoi=qoi,
    )
