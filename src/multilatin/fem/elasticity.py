"""2D linear elasticity with bilinear quadrangles (Q4), vectorised over elements and
quadrature points (paper eq. [1]–[3]).

Degrees of freedom are interleaved: dof ``2 i + c`` is component ``c`` of node ``i``.
Strains and stresses use Voigt notation ``(xx, yy, xy)`` with engineering shear strain;
axisymmetric ones (x = r, y = z) add the hoop component: ``(rr, zz, rz, θθ)``, its Hooke
operator 4 × 4 (which is how the functions here tell it), integrals over the whole
revolution (2π r in place of the thickness).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
import scipy.sparse as sp

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.int64]

PLANE_STRESS = "plane_stress"
PLANE_STRAIN = "plane_strain"
AXISYMMETRIC = "axisymmetric"
HYPOTHESES = (PLANE_STRESS, PLANE_STRAIN, AXISYMMETRIC)


def hooke_matrix(young: float, poisson: float, hypothesis: str = PLANE_STRESS) -> FloatArray:
    """Hooke's operator D (eq. [3]) in Voigt notation for plane stress or plane strain."""
    if hypothesis == PLANE_STRESS:
        c = young / (1.0 - poisson**2)
        return c * np.array(
            [[1.0, poisson, 0.0], [poisson, 1.0, 0.0], [0.0, 0.0, (1.0 - poisson) / 2.0]]
        )
    if hypothesis == PLANE_STRAIN:
        c = young / ((1.0 + poisson) * (1.0 - 2.0 * poisson))
        return c * np.array(
            [
                [1.0 - poisson, poisson, 0.0],
                [poisson, 1.0 - poisson, 0.0],
                [0.0, 0.0, (1.0 - 2.0 * poisson) / 2.0],
            ]
        )
    if hypothesis == AXISYMMETRIC:  # (rr, zz, rz, θθ)
        c = young / ((1.0 + poisson) * (1.0 - 2.0 * poisson))
        return c * np.array([[1.0 - poisson, poisson, 0.0, poisson],
                             [poisson, 1.0 - poisson, 0.0, poisson],
                             [0.0, 0.0, (1.0 - 2.0 * poisson) / 2.0, 0.0],
                             [poisson, poisson, 0.0, 1.0 - poisson]])
    raise ValueError(f"hypothesis must be one of {HYPOTHESES}, not {hypothesis!r}")


@dataclass(frozen=True)
class Quadrature:
    """Quadrature points in the reference square ``[-1, 1]²``.

    ``points`` has shape ``(n_cells or 1, n_qp, 2)`` and ``weights`` ``(n_cells or 1, n_qp)``;
    a leading dimension of 1 means the same rule for every cell. Cut cells (X-FEM) get a rule
    of their own; a zero weight switches a point off.
    """

    points: FloatArray
    weights: FloatArray

    @staticmethod
    def gauss(order: int = 2) -> Quadrature:
        x, w = np.polynomial.legendre.leggauss(order)
        gx, gy = np.meshgrid(x, x)
        points = np.column_stack([gx.ravel(), gy.ravel()])[None]
        weights = np.outer(w, w).ravel()[None]
        return Quadrature(points, weights)

    @staticmethod
    def triangle(degree: int = 1) -> Quadrature:
        """Rules on the reference triangle (0, 0), (1, 0), (0, 1), exact to degree 1, 2 or 4
        (the centroid; three interior points; Dunavant's six points, also for any higher
        ``degree`` asked)."""
        if degree <= 1:
            points, weights = np.array([[1 / 3, 1 / 3]]), np.array([0.5])
        elif degree == 2:
            points = np.array([[1 / 6, 1 / 6], [2 / 3, 1 / 6], [1 / 6, 2 / 3]])
            weights = np.full(3, 1 / 6)
        else:
            a, b = 0.445948490915965, 0.091576213509771
            wa, wb = 0.223381589678011 / 2, 0.109951743655322 / 2
            points = np.array([[a, a], [1 - 2 * a, a], [a, 1 - 2 * a],
                               [b, b], [1 - 2 * b, b], [b, 1 - 2 * b]])
            weights = np.array([wa, wa, wa, wb, wb, wb])
        return Quadrature(points[None], weights[None])

    @staticmethod
    def for_cells(n_nodes: int, degree: int) -> Quadrature:
        """A rule exact to ``degree`` (at least) on the element with ``n_nodes`` (Q4, T3)."""
        if n_nodes == 3:
            return Quadrature.triangle(degree)
        return Quadrature.gauss(max(1, (degree + 2) // 2))


def shape_functions(ref_points: FloatArray, n_nodes: int = 4
                    ) -> tuple[FloatArray, FloatArray]:
    """Q4 (``n_nodes`` 4, reference square) or T3 (3, reference triangle) shape functions and
    their reference gradients at ``ref_points`` (..., 2).

    Returns ``N`` (..., n_nodes) and ``dN`` (..., n_nodes, 2).
    """
    if n_nodes == 3:
        xi, eta = ref_points[..., 0], ref_points[..., 1]
        n = np.stack([1.0 - xi - eta, xi, eta], axis=-1)
        dn = np.broadcast_to(np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]]),
                             ref_points.shape[:-1] + (3, 2))
        return n, np.array(dn)
    xi = ref_points[..., 0]
    eta = ref_points[..., 1]
    sx = np.array([-1.0, 1.0, 1.0, -1.0])
    sy = np.array([-1.0, -1.0, 1.0, 1.0])
    n = 0.25 * (1.0 + xi[..., None] * sx) * (1.0 + eta[..., None] * sy)
    dn_dxi = 0.25 * sx * (1.0 + eta[..., None] * sy)
    dn_deta = 0.25 * sy * (1.0 + xi[..., None] * sx)
    return n, np.stack([dn_dxi, dn_deta], axis=-1)


def physical_gradients(
    cell_coords: FloatArray, quadrature: Quadrature
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Shape functions ``N`` (c, q, a), physical gradients (c, q, a, 2) and ``w·det J`` (c, q)
    for cells of ``a`` nodes (4: Q4, 3: T3)."""
    n, dn = shape_functions(quadrature.points, cell_coords.shape[1])
    n = np.broadcast_to(n, (cell_coords.shape[0],) + n.shape[1:])
    # batched 2 × a by a × 2 products (matmul broadcasts a shared rule over the cells;
    # einsum on broadcast views took 4 ms for B3's 32 cut cells of 192 points)
    jac = np.swapaxes(dn, -1, -2) @ cell_coords[:, None]  # (c, q, d, e): d x_e / d xi_d
    det = jac[..., 0, 0] * jac[..., 1, 1] - jac[..., 0, 1] * jac[..., 1, 0]
    if np.any(det <= 0.0):
        raise ValueError("an element is degenerate or inverted (det J <= 0)")
    inv_t = np.empty_like(jac)  # (J⁻¹)ᵀ
    inv_t[..., 0, 0] = jac[..., 1, 1]
    inv_t[..., 0, 1] = -jac[..., 1, 0]
    inv_t[..., 1, 0] = -jac[..., 0, 1]
    inv_t[..., 1, 1] = jac[..., 0, 0]
    inv_t /= det[..., None, None]
    grad = dn @ inv_t  # dN/dx = J⁻¹ dN/dξ, (c, q, a, 2)
    return n, grad, det * quadrature.weights


def strain_matrices(grad: FloatArray) -> FloatArray:
    """Strain-displacement matrices B (c, q, 3, 2a) for interleaved element dofs."""
    b = np.zeros(grad.shape[:2] + (3, 2 * grad.shape[2]))
    b[..., 0, 0::2] = grad[..., 0]
    b[..., 1, 1::2] = grad[..., 1]
    b[..., 2, 0::2] = grad[..., 1]
    b[..., 2, 1::2] = grad[..., 0]
    return b


def strains_and_weights(cell_coords: FloatArray, quadrature: Quadrature, radial: bool,
                        thickness: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Shape functions (c, q, a), B (c, q, 3, 2a) — (c, q, 4, 2a) where ``radial``, its
    last row the hoop strain u_r / r — and the integration weights (c, q): w·det J times
    the thickness, or times 2π r (axisymmetric: the whole revolution)."""
    n, grad, wdet = physical_gradients(cell_coords, quadrature)
    b = strain_matrices(grad)
    if not radial:
        return n, b, thickness * wdet
    r = np.einsum("cqa,ca->cq", n, cell_coords[..., 0])
    hoop = np.zeros(b.shape[:2] + (1, b.shape[3]))
    on_axis = r[..., None] <= 1e-12 * np.abs(cell_coords[..., 0]).max()
    # u_r / r, and on the axis (a point asked there; no quadrature point lies on it) its
    # limit ∂u_r/∂r, u_r being zero there
    hoop[..., 0, 0::2] = np.where(on_axis, grad[..., 0],
                                  n / np.where(on_axis, 1.0, r[..., None]))
    return n, np.concatenate([b, hoop], axis=2), 2.0 * np.pi * r * wdet


def element_dofs(cells: IntArray) -> IntArray:
    """Interleaved dofs (c, 2a) of each cell of ``a`` nodes."""
    return np.stack([2 * cells, 2 * cells + 1], axis=-1).reshape(cells.shape[0], -1)


def stiffness_matrix(
    nodes: FloatArray,
    cells: IntArray,
    hooke: FloatArray,
    thickness: float = 1.0,
    quadrature: Quadrature | None = None,
) -> sp.csr_matrix:
    """Global stiffness K = Σ_e ∫ Bᵀ D B t dΩ (eq. [2]–[3]), assembled without element loops."""
    return assemble_cells(element_stiffness(nodes, cells, hooke, thickness, quadrature),
                          cells, nodes.shape[0])


def element_stiffness(
    nodes: FloatArray,
    cells: IntArray,
    hooke: FloatArray,
    thickness: float = 1.0,
    quadrature: Quadrature | None = None,
) -> FloatArray:
    """Element stiffnesses ∫_e Bᵀ D B t dΩ, (c, 2a, 2a) on interleaved element dofs (2π r
    for t with a 4 × 4 ``hooke``: axisymmetric)."""
    quadrature = quadrature or Quadrature.for_cells(cells.shape[1], 2)
    _, b, weight = strains_and_weights(nodes[cells], quadrature, hooke.shape[0] == 4,
                                       thickness)
    return np.asarray(np.einsum("cqji,jk,cqkl,cq->cil", b, hooke, b, weight, optimize=True),
                      dtype=np.float64)


def assemble_cells(element_matrices: FloatArray, cells: IntArray, n_nodes: int
                   ) -> sp.csr_matrix:
    """Σ_e of element matrices (c, 2a, 2a) on interleaved dofs, as a (2 n_nodes)² CSR."""
    dofs = element_dofs(cells)
    per_cell = dofs.shape[1]
    rows = np.repeat(dofs, per_cell, axis=1).ravel()
    cols = np.tile(dofs, (1, per_cell)).ravel()
    n = 2 * n_nodes
    return sp.csr_matrix((element_matrices.ravel(), (rows, cols)), shape=(n, n))


def body_force_vector(
    nodes: FloatArray,
    cells: IntArray,
    force: Callable[[FloatArray], FloatArray],
    thickness: float = 1.0,
    quadrature: Quadrature | None = None,
) -> FloatArray:
    """Load vector ∫ N f t dΩ of a body force density ``force(x) -> (..., 2)``."""
    quadrature = quadrature or Quadrature.for_cells(cells.shape[1], 4)
    n, _, wdet = physical_gradients(nodes[cells], quadrature)
    return _load_vector(n, force(np.einsum("cqa,cad->cqd", n, nodes[cells])), wdet, cells,
                        thickness, nodes.shape[0])


def interpolated_load_vector(nodes: FloatArray, cells: IntArray, nodal_force: FloatArray,
                             thickness: float = 1.0, quadrature: Quadrature | None = None,
                             radial: bool = False) -> FloatArray:
    """Load vector ∫ N f_h t dΩ of the body force density interpolated from its values at
    the nodes, f_h = Σ_a N_a f_a (``nodal_force`` (n_nodes, 2)): exact for a density
    linear in x and y (gravity, a spinning part's ρ ω² r), and one evaluation per node
    instead of per quadrature point. ``quadrature``: per-cell rules too (a cut cell's).
    ``radial``: axisymmetric (2π r for the thickness)."""
    quadrature = quadrature or Quadrature.for_cells(cells.shape[1], 4)
    n, _, weight = strains_and_weights(nodes[cells], quadrature, radial, thickness)
    return _load_vector(n, np.einsum("cqa,cad->cqd", n, nodal_force[cells]), weight, cells,
                        1.0, nodes.shape[0])


def _load_vector(n: FloatArray, force: FloatArray, wdet: FloatArray, cells: IntArray,
                 thickness: float, n_nodes: int) -> FloatArray:
    """Σ_cells ∫ N f t dΩ from shape functions (c, q, a), the force at the quadrature
    points (c, q, 2) and w·det J (c, q), interleaved (2 n_nodes,)."""
    fe = thickness * np.einsum("cqa,cqd,cq->cad", n, force, wdet)
    out = np.zeros(2 * n_nodes)
    np.add.at(out, element_dofs(cells).ravel(), fe.reshape(-1))
    return out


def cell_strains(nodes: FloatArray, cells: IntArray, displacement: FloatArray,
                 radial: bool = False) -> FloatArray:
    """Strain (xx, yy, engineering γ_xy; and θθ where ``radial``) at each cell centre, for
    displacements (..., n_nodes, 2). Returns an array (..., n_cells, 3 or 4)."""
    centre = (Quadrature.triangle(1) if cells.shape[1] == 3 else
              Quadrature(np.zeros((1, 1, 2)), np.full((1, 1), 4.0)))
    b = strains_and_weights(nodes[cells], centre, radial, 1.0)[1][:, 0]  # (c, 3 or 4, 2a)
    ue = displacement[..., cells, :].reshape(displacement.shape[:-2] + (cells.shape[0], -1))
    return np.asarray(np.einsum("cjk,...ck->...cj", b, ue), dtype=np.float64)


def cell_stresses(
    nodes: FloatArray,
    cells: IntArray,
    hooke: FloatArray,
    displacement: FloatArray,
) -> FloatArray:
    """Stress (xx, yy, xy) at each cell centre, for displacements (..., n_nodes, 2).

    Returns an array (..., n_cells, 3).
    """
    strain = cell_strains(nodes, cells, displacement, hooke.shape[0] == 4)
    return np.asarray(np.einsum("ij,...cj->...ci", hooke, strain), dtype=np.float64)


def point_stress_matrix(cell_coords: FloatArray, ref: FloatArray, hooke: FloatArray
                        ) -> FloatArray:
    """D B at reference point ``ref`` (2,) of one cell (``cell_coords`` (a, 2)): the stress
    (xx, yy, xy; θθ axisymmetric) there is this (3 or 4, 2a) matrix times the cell's
    interleaved displacements."""
    point = Quadrature(np.asarray(ref, dtype=np.float64).reshape(1, 1, 2), np.ones((1, 1)))
    b = strains_and_weights(np.asarray(cell_coords)[None], point, hooke.shape[0] == 4, 1.0)[1]
    return np.asarray(hooke @ b[0, 0], dtype=np.float64)


def thermal_strain(expansion: float, poisson: float, hypothesis: str) -> FloatArray:
    """The in-plane strain (xx, yy, γ_xy) a unit temperature change gives a free part: α
    (1, 1, 0) in plane stress, (1 + ν) α (1, 1, 0) in plane strain (the part's ε_zz = 0
    keeps σ_zz = ν (σ_xx + σ_yy) − E α ΔT, ``von_mises``'s ``out_of_plane``); α (1, 1, 0,
    1) axisymmetric (rr, zz, rz, θθ)."""
    if hypothesis == AXISYMMETRIC:
        return np.array([expansion, expansion, 0.0, expansion])
    scale = (1.0 + poisson) if hypothesis == PLANE_STRAIN else 1.0
    return np.array([scale * expansion, scale * expansion, 0.0])


def initial_strain_load(nodes: FloatArray, cells: IntArray, hooke: FloatArray,
                        strain: FloatArray, nodal_scale: FloatArray, thickness: float = 1.0,
                        quadrature: Quadrature | None = None) -> FloatArray:
    """Load vector ∫ Bᵀ D ε₀ t dΩ of the initial strain ε₀ = ``strain`` (3,) times a
    scale interpolated from its nodal values (``nodal_scale`` (n_nodes,): a temperature
    change), interleaved (2 n_nodes,): exact for a scale linear in x and y."""
    quadrature = quadrature or Quadrature.for_cells(cells.shape[1], 2)
    n, b, weight = strains_and_weights(nodes[cells], quadrature, hooke.shape[0] == 4,
                                       thickness)
    at_points = np.einsum("cqa,ca->cq", n, nodal_scale[cells])
    fe = np.einsum("cqjk,j,cq,cq->ck", b, hooke @ strain, at_points, weight)
    out = np.zeros(2 * nodes.shape[0])
    np.add.at(out, element_dofs(cells).ravel(), fe.reshape(-1))
    return out


def von_mises(stress: FloatArray, poisson: float, hypothesis: str,
              out_of_plane: FloatArray | None = None) -> FloatArray:
    """Von Mises equivalent stress from (..., 3) in-plane stresses; in plane strain σ_zz =
    ν (σ_xx + σ_yy) + ``out_of_plane`` (− E α ΔT under a temperature change); axisymmetric
    (..., 4), the hoop stress the third normal one."""
    sxx, syy, sxy = stress[..., 0], stress[..., 1], stress[..., 2]
    szz = poisson * (sxx + syy) if hypothesis == PLANE_STRAIN else np.zeros_like(sxx)
    if hypothesis == AXISYMMETRIC:
        szz = stress[..., 3]
    if hypothesis == PLANE_STRAIN and out_of_plane is not None:
        szz = szz + out_of_plane
    return np.asarray(
        np.sqrt(0.5 * ((sxx - syy) ** 2 + (syy - szz) ** 2 + (szz - sxx) ** 2) + 3.0 * sxy**2)
    )


def interpolate(
    nodes: FloatArray, cells: IntArray, displacement: FloatArray, cell: int, ref: FloatArray
) -> FloatArray:
    """Displacement (..., 2) at reference point ``ref`` of ``cell``."""
    n, _ = shape_functions(ref[None], cells.shape[1])
    return np.asarray(np.einsum("a,...ad->...d", n[0], displacement[..., cells[cell], :]),
                      dtype=np.float64)


def error_norms(
    nodes: FloatArray,
    cells: IntArray,
    hooke: FloatArray,
    displacement: FloatArray,
    exact: Callable[[FloatArray], FloatArray],
    exact_gradient: Callable[[FloatArray], FloatArray],
    thickness: float = 1.0,
    quadrature: Quadrature | None = None,
) -> tuple[float, float]:
    """L2 and energy norms of the error of a finite-element displacement (n_nodes, 2).

    ``exact(x) -> (..., 2)`` and ``exact_gradient(x) -> (..., 2, 2)`` with
    ``grad[..., i, j] = d u_i / d x_j``.
    """
    quadrature = quadrature or Quadrature.for_cells(cells.shape[1], 6)
    n, grad, wdet = physical_gradients(nodes[cells], quadrature)
    x = np.einsum("cqa,cad->cqd", n, nodes[cells])
    ue = displacement[cells]  # (c, a, 2)
    uh = np.einsum("cqa,cad->cqd", n, ue)
    gh = np.einsum("cqaj,cai->cqij", grad, ue)
    du = uh - exact(x)
    dg = gh - exact_gradient(x)
    strain = np.stack([dg[..., 0, 0], dg[..., 1, 1], dg[..., 0, 1] + dg[..., 1, 0]], axis=-1)
    l2 = np.sqrt(thickness * np.einsum("cqd,cqd,cq->", du, du, wdet))
    energy = np.sqrt(thickness * np.einsum("cqi,ij,cqj,cq->", strain, hooke, strain, wdet))
    return float(l2), float(energy)
