"""Level-set holes on a fixed mesh (paper §5): cut-cell quadrature and the Kirsch plate."""

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from multilatin.fem.elasticity import PLANE_STRESS, hooke_matrix
from multilatin.fem.levelset import Circle, Slot, Union, cut_cells
from multilatin.fem.mesh import RectMesh
from multilatin.fem.xfem import xfem_error_norms, xfem_stiffness


def material_area(mesh, cut):
    return float(cut.material_fraction.sum() * mesh.hx * mesh.hy)


def quadrature_area(mesh, cut):
    """The area integrated by the rules themselves (not by the stored fractions)."""
    cell = mesh.hx * mesh.hy
    return float(cut.material.size * cell + cut.cut_quadrature.weights.sum() * cell / 4.0)


def test_area_of_a_holed_square_converges_at_second_order():
    hole = Circle((1.3, 1.45), 0.5)
    exact = 9.0 - np.pi * 0.25
    errors = []
    for n in (10, 20, 40, 80):
        mesh = RectMesh(0.0, 3.0, 0.0, 3.0, n, n)
        cut = cut_cells(mesh, hole)
        assert quadrature_area(mesh, cut) == pytest.approx(material_area(mesh, cut), abs=1e-12)
        errors.append(abs(material_area(mesh, cut) - exact))
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    print("area error", errors, "rates", rates)
    assert errors[-1] < 1e-4
    assert np.all(rates > 1.8)


def test_straight_cut_is_integrated_exactly():
    """A half-plane cut: exact area, and a stiffness that does not depend on the number of
    sub-triangles (the degree-2 rule integrates the Q4 integrand exactly on polygons)."""

    def half_plane(x):
        return 0.6 * x[..., 0] + 0.8 * x[..., 1] - 1.37

    mesh = RectMesh(0.0, 3.0, 0.0, 3.0, 7, 7)
    x_axis, y_axis = 1.37 / 0.6, 1.37 / 0.8
    hooke = hooke_matrix(1.0, 0.3, PLANE_STRESS)
    stiffness = []
    for subdivisions in (1, 3, 8):
        cut = cut_cells(mesh, half_plane, subdivisions)
        assert material_area(mesh, cut) == pytest.approx(9.0 - 0.5 * x_axis * y_axis, rel=1e-13)
        stiffness.append(xfem_stiffness(mesh, hooke, 1.0, cut).toarray())
    scale = np.abs(stiffness[0]).max()
    np.testing.assert_allclose(stiffness[1], stiffness[0], atol=1e-12 * scale)
    np.testing.assert_allclose(stiffness[2], stiffness[0], atol=1e-12 * scale)


def test_classification_finds_a_hole_smaller_than_a_cell():
    mesh = RectMesh(0.0, 1.0, 0.0, 1.0, 2, 2)
    cut = cut_cells(mesh, Circle((0.25, 0.25), 0.1), subdivisions=8)
    assert cut.cut.tolist() == [0]
    assert material_area(mesh, cut) == pytest.approx(1.0 - np.pi * 0.01, rel=2e-2)


def test_union_and_slot_level_sets():
    mesh = RectMesh(0.0, 4.0, 0.0, 2.0, 80, 40)
    holes = Union((Circle((1.0, 1.0), 0.4), Slot((2.2, 1.0), (3.2, 1.0), 0.3)))
    cut = cut_cells(mesh, holes)
    exact = 8.0 - np.pi * 0.16 - (np.pi * 0.09 + 1.0 * 0.6)
    assert material_area(mesh, cut) == pytest.approx(exact, rel=1e-3)
    assert cut.void.size > 0 and not cut.active_nodes.all()


def test_nodes_with_void_support_are_removed_and_decoupled():
    mesh = RectMesh(0.0, 3.0, 0.0, 3.0, 30, 30)
    cut = cut_cells(mesh, Circle((1.5, 1.5), 0.5))
    stiffness = xfem_stiffness(mesh, hooke_matrix(1.0, 0.0), 1.0, cut).tocsr()
    removed = 2 * cut.inactive_nodes
    assert removed.size > 0
    row = stiffness[removed[0]].toarray().ravel()
    assert row[removed[0]] == 1.0 and np.count_nonzero(row) == 1
    centre = int(np.argmin(np.linalg.norm(mesh.nodes - 1.5, axis=1)))
    assert centre in cut.inactive_nodes


def kirsch(young, poisson, traction, radius):
    """Infinite plate with a circular hole of ``radius`` at the origin under remote uniaxial
    tension ``traction`` along x, plane stress: displacement and stress (Kirsch)."""
    shear = young / (2.0 * (1.0 + poisson))
    kappa = (3.0 - poisson) / (1.0 + poisson)

    def displacement(x):
        r = np.hypot(x[..., 0], x[..., 1])
        t = np.arctan2(x[..., 1], x[..., 0])
        a = radius
        c = traction * a / (8.0 * shear)
        ux = c * (r / a * (kappa + 1.0) * np.cos(t)
                  + 2.0 * a / r * ((1.0 + kappa) * np.cos(t) + np.cos(3 * t))
                  - 2.0 * a**3 / r**3 * np.cos(3 * t))
        uy = c * (r / a * (kappa - 3.0) * np.sin(t)
                  + 2.0 * a / r * ((1.0 - kappa) * np.sin(t) + np.sin(3 * t))
                  - 2.0 * a**3 / r**3 * np.sin(3 * t))
        return np.stack([ux, uy], axis=-1)

    def stress(x):
        r = np.hypot(x[..., 0], x[..., 1])
        t = np.arctan2(x[..., 1], x[..., 0])
        q2, q4 = (radius / r) ** 2, (radius / r) ** 4
        sxx = 1.0 - q2 * (1.5 * np.cos(2 * t) + np.cos(4 * t)) + 1.5 * q4 * np.cos(4 * t)
        syy = -q2 * (0.5 * np.cos(2 * t) - np.cos(4 * t)) - 1.5 * q4 * np.cos(4 * t)
        sxy = -q2 * (0.5 * np.sin(2 * t) + np.sin(4 * t)) + 1.5 * q4 * np.sin(4 * t)
        return traction * np.stack([sxx, syy, sxy], axis=-1)

    def gradient(x, step=1e-6):
        grad = np.empty(x.shape[:-1] + (2, 2))
        for j in range(2):
            dx = np.zeros(2)
            dx[j] = step
            grad[..., :, j] = (displacement(x + dx) - displacement(x - dx)) / (2 * step)
        return grad

    return displacement, gradient, stress


def test_kirsch_reference_is_consistent():
    """The displacement formula, differentiated and passed through Hooke's law, gives the
    Kirsch stresses, traction-free on the hole and the remote tension far away."""
    young, poisson = 1000.0, 0.3
    displacement, gradient, stress = kirsch(young, poisson, 1.0, 0.5)
    rng = np.random.default_rng(1)
    x = rng.uniform(-3, 3, size=(50, 2))
    x = x[np.hypot(x[:, 0], x[:, 1]) > 0.6]
    g = gradient(x)
    strain = np.stack([g[:, 0, 0], g[:, 1, 1], g[:, 0, 1] + g[:, 1, 0]], axis=-1)
    np.testing.assert_allclose(strain @ hooke_matrix(young, poisson).T, stress(x), atol=1e-6)
    t = np.linspace(0, 2 * np.pi, 13)
    on_hole = 0.5 * np.stack([np.cos(t), np.sin(t)], axis=-1)
    s = stress(on_hole)
    traction = np.stack([s[:, 0] * np.cos(t) + s[:, 2] * np.sin(t),
                         s[:, 2] * np.cos(t) + s[:, 1] * np.sin(t)], axis=-1)
    np.testing.assert_allclose(traction, 0.0, atol=1e-12)


def solve_kirsch(n, radius=0.5, half_width=2.0, young=1000.0, poisson=0.3):
    mesh = RectMesh(-half_width, half_width, -half_width, half_width, n, n)
    hooke = hooke_matrix(young, poisson)
    cut = cut_cells(mesh, Circle((0.0, 0.0), radius))
    displacement, gradient, _ = kirsch(young, poisson, 1.0, radius)
    stiffness = xfem_stiffness(mesh, hooke, 1.0, cut)
    boundary = np.unique(np.concatenate([mesh.side_nodes(s) for s in
                                         ("bottom", "right", "top", "left")]))
    fixed = np.zeros(2 * mesh.n_nodes, dtype=bool)
    fixed[np.ravel([2 * boundary, 2 * boundary + 1], order="F")] = True
    u = np.zeros(2 * mesh.n_nodes)
    u[fixed] = displacement(mesh.nodes[boundary]).ravel()
    free = ~fixed
    u[free] = spla.spsolve(stiffness[free][:, free].tocsc(),
                           -stiffness[free][:, fixed] @ u[fixed])
    u = u.reshape(-1, 2)
    return xfem_error_norms(mesh, cut, hooke, u, displacement, gradient)


def test_kirsch_plate_converges_at_optimal_rates():
    """X-FEM (no remeshing) on a hole that cuts cells arbitrarily: L2 error O(h²), energy
    error O(h), the rates of Q4 on a conforming mesh."""
    sizes = (12, 24, 48, 96)
    errors = np.array([solve_kirsch(n) for n in sizes])
    rates = np.log2(errors[:-1] / errors[1:])
    # the cut pattern changes with refinement, so successive rates scatter: fit the slope
    slope = np.polyfit(np.log(1.0 / np.array(sizes)), np.log(errors), 1)[0]  # error ~ h^slope
    print("Kirsch errors (L2, energy)", errors.tolist(), "rates", rates.tolist(), slope)
    assert slope[0] > 1.85 and slope[1] > 0.9, slope
    assert np.all(rates[:, 0] > 1.7) and np.all(rates[:, 1] > 0.8), rates


def test_element_stiffnesses_kept_per_mesh_give_the_integrated_stiffness():
    """``xfem_stiffness`` takes the material cells' element stiffnesses from the mesh's kept
    ones: equal (1e-12) to integrating those cells and the cut ones anew, for two holes in
    the same mesh (the second one a hit of the cache), and the cut cells' quadrature has no
    more points than the fullest cell has of positive weight (they sum to its material
    area)."""
    import scipy.sparse as sp

    from multilatin.fem import xfem
    from multilatin.fem.elasticity import stiffness_matrix
    from multilatin.fem.xfem import inactive_dofs

    mesh = RectMesh(0.0, 10.0, 0.0, 10.0, 10, 10)
    hooke = hooke_matrix(2e5, 0.3)
    xfem._CELL_STIFFNESS.clear()
    for centre in ((5.0, 5.0), (4.3, 6.1)):
        cut = cut_cells(mesh, Circle(centre, 2.2))
        weights = cut.cut_quadrature.weights
        assert cut.cut.size and np.all(weights >= 0.0)
        assert np.any(np.all(weights > 0.0, axis=1))  # as many columns as the fullest cell
        # the reference square's area is 4: each cut cell's weights sum to 4 × its fraction
        assert np.allclose(weights.sum(axis=1), 4.0 * cut.material_fraction[cut.cut],
                           rtol=1e-12)
        kept = xfem_stiffness(mesh, hooke, 1.0, cut)
        anew = (stiffness_matrix(mesh.nodes, mesh.cells[cut.material], hooke)
                + stiffness_matrix(mesh.nodes, mesh.cells[cut.cut], hooke, 1.0,
                                   cut.cut_quadrature)
                + sp.diags(np.isin(np.arange(2 * mesh.n_nodes), inactive_dofs(cut)) * 1.0))
        assert abs(kept - anew).max() <= 1e-12 * abs(anew).max()
    assert len(xfem._CELL_STIFFNESS) == 1


def test_forgetting_the_operators_forgets_what_their_builds_share():
    """``clear_operator_cache`` (benchmarks run studies as fresh processes do) empties every
    ``Kept`` map: the element stiffnesses kept per mesh among them."""
    from multilatin.fem import xfem
    from multilatin.kept import Kept
    from multilatin.study.plan import clear_operator_cache

    mesh = RectMesh(0.0, 10.0, 0.0, 10.0, 10, 10)
    xfem_stiffness(mesh, hooke_matrix(2e5, 0.3), 1.0, cut_cells(mesh, Circle((5.0, 5.0), 2.2)))
    mine: Kept[str, int] = Kept(2)
    mine.get("a", lambda: 1)
    assert len(xfem._CELL_STIFFNESS) and len(mine)
    clear_operator_cache()
    assert len(xfem._CELL_STIFFNESS) == 0 and len(mine) == 0
