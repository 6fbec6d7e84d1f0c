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

from ..kept import Kept
from .elasticity import (
    FloatArray,
    Quadrature,
    assemble_cells,
    element_stiffness,
    error_norms,
    initial_strain_load,
    interpolated_load_vector,
    stiffness_matrix,
)
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
    material = _cell_stiffness(mesh, hooke, thickness)[cut.material]
    stiffness = assemble_cells(material, mesh.cells[cut.material], mesh.n_nodes)
    if cut.cut.size:
        stiffness = stiffness + stiffness_matrix(mesh.nodes, mesh.cells[cut.cut], hooke,
                                                 thickness, cut.cut_quadrature)
    removed = inactive_dofs(cut)
    pin = np.zeros(2 * mesh.n_nodes)
    pin[removed] = 1.0
    return (stiffness + sp.diags(pin)).tocsr()


def xfem_load_vector(mesh: RectMesh | UnstructuredMesh, nodal_force: FloatArray,
                     thickness: float, cut: CutCells | None, radial: bool = False
                     ) -> FloatArray:
    """∫ N f_h t dΩ over the material only (``interpolated_load_vector``; 2π r for t where
    ``radial``): material cells with the usual rule, cut cells on their material part, void
    cells not at all (zero on the removed dofs, as their rows of ``xfem_stiffness`` ask)."""
    if cut is None:
        return interpolated_load_vector(mesh.nodes, mesh.cells, nodal_force, thickness,
                                        radial=radial)
    load = interpolated_load_vector(mesh.nodes, mesh.cells[cut.material], nodal_force,
                                    thickness, radial=radial)
    if cut.cut.size:
        load += interpolated_load_vector(mesh.nodes, mesh.cells[cut.cut], nodal_force,
                                         thickness, cut.cut_quadrature, radial)
    return load


def xfem_initial_strain_load(mesh: RectMesh | UnstructuredMesh, hooke: FloatArray,
                             strain: FloatArray, nodal_scale: FloatArray, thickness: float,
                             cut: CutCells | None) -> FloatArray:
    """∫ Bᵀ D ε₀ t dΩ over the material only (``initial_strain_load``), as
    ``xfem_load_vector`` integrates a body force."""
    if cut is None:
        return initial_strain_load(mesh.nodes, mesh.cells, hooke, strain, nodal_scale,
                                   thickness)
    load = initial_strain_load(mesh.nodes, mesh.cells[cut.material], hooke, strain,
                               nodal_scale, thickness)
    if cut.cut.size:
        load += initial_strain_load(mesh.nodes, mesh.cells[cut.cut], hooke, strain,
                                    nodal_scale, thickness, cut.cut_quadrature)
    return load


#: element stiffnesses of whole meshes with the usual rule, by mesh, material and thickness:
#: a hole moving inside a substructure changes its cut and void cells only, so a study over
#: hole positions integrates the others once (B3: 501 of 533 cells)
_CELL_STIFFNESS: Kept[tuple[str, bytes, float], FloatArray] = Kept(8)
#: meshes of more cells are integrated each time (their element stiffnesses: 512 B a cell)
_CELL_STIFFNESS_MAX_CELLS = 20_000
_PATTERNS: Kept[str, sp.csr_matrix] = Kept(8)


def _cell_stiffness(mesh: RectMesh | UnstructuredMesh, hooke: FloatArray,
                    thickness: float) -> FloatArray:
    """Every cell's element stiffness (c, 8, 8) with the usual Gauss rule, kept per mesh
    (``repr`` names a structured mesh by its box and divisions, a mesh of its own by a digest
    of its nodes and cells)."""

    def integrate() -> FloatArray:
        out = element_stiffness(mesh.nodes, mesh.cells, hooke, thickness)
        out.setflags(write=False)
        return out

    if mesh.n_cells > _CELL_STIFFNESS_MAX_CELLS:
        return integrate()
    key = (repr(mesh), np.ascontiguousarray(hooke).tobytes(), float(thickness))
    return _CELL_STIFFNESS.get(key, integrate)


def mesh_pattern(mesh: RectMesh | UnstructuredMesh) -> sp.csr_matrix:
    """The nonzero pattern (ones) of the stiffness of every cell of ``mesh``: it contains the
    pattern of the mesh with any hole, kept per mesh as ``_cell_stiffness`` is."""

    def pattern() -> sp.csr_matrix:
        ones = np.ones((mesh.n_cells, 2 * mesh.cells.shape[1], 2 * mesh.cells.shape[1]))
        return assemble_cells(ones, mesh.cells, mesh.n_nodes)

    return _PATTERNS.get(repr(mesh), pattern)


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
