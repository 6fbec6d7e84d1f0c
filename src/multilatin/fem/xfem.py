"""Q4 operators on a mesh with a level-set hole (paper §5.1): material cells with the usual
Gauss rule, cut cells with their own rule on the material part, void cells dropped, and the
unknowns of nodes whose support is entirely void removed.

Removed unknowns keep their place in the numbering (so traces, outputs and operator reuse see
one numbering per mesh) but are decoupled: their rows and columns hold the identity, and
with a zero right-hand side they are zero; the result is the operator restricted to the active
unknowns.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp

from .elasticity import FloatArray, Quadrature, error_norms, stiffness_matrix
from .levelset import CutCells
from .mesh import RectMesh, UnstructuredMesh


def inactive_dofs(cut: CutCells | None) -> np.ndarray:
    """Interleaved dofs of the nodes whose support is entirely void."""
    if cut is None:
        return np.zeros(0, dtype=np.int64)
    nodes = cut.inactive_nodes
    return np.stack([2 * nodes, 2 * nodes + 1], axis=1).ravel()


def xfem_stiffness(mesh: RectMesh | UnstructuredMesh, hooke: FloatArray, thickness: float,
                   cut: CutCells | None) -> sp.csr_matrix:
    """K = Σ_material ∫ Bᵀ D B + Σ_cut ∫_(material part) Bᵀ D B, identity on removed dofs."""
    if cut is None:
        return stiffness_matrix(mesh.nodes, mesh.cells, hooke, thickness)
    stiffness = stiffness_matrix(mesh.nodes, mesh.cells[cut.material], hooke, thickness)
    if cut.cut.size:
        stiffness = stiffness + stiffness_matrix(mesh.nodes, mesh.cells[cut.cut], hooke,
                                                 thickness, cut.cut_quadrature)
    removed = inactive_dofs(cut)
    pin = np.zeros(2 * mesh.n_nodes)
    pin[removed] = 1.0
    return (stiffness + sp.diags(pin)).tocsr()


def xfem_error_norms(
    mesh: RectMesh, cut: CutCells, hooke: FloatArray, displacement: FloatArray,
    exact: Callable[[FloatArray], FloatArray],
    exact_gradient: Callable[[FloatArray], FloatArray],
    thickness: float = 1.0,
) -> tuple[float, float]:
    """L2 and energy norms of the error over the material part only."""
    parts = [error_norms(mesh.nodes, mesh.cells[cut.material], hooke, displacement, exact,
                         exact_gradient, thickness, Quadrature.gauss(4))]
    if cut.cut.size:
        parts.append(error_norms(mesh.nodes, mesh.cells[cut.cut], hooke, displacement, exact,
                                 exact_gradient, thickness, cut.cut_quadrature))
    l2 = float(np.sqrt(sum(p[0] ** 2 for p in parts)))
    energy = float(np.sqrt(sum(p[1] ** 2 for p in parts)))
    return l2, energy
