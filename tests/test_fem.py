"""Q4 and T3 elasticity against exact polynomial solutions and a manufactured solution."""

import numpy as np
import pytest
import scipy.sparse.linalg as spla
from conftest import write_gmsh_mesh

from multilatin.fem.elasticity import (
    PLANE_STRAIN,
    PLANE_STRESS,
    body_force_vector,
    cell_stresses,
    error_norms,
    hooke_matrix,
    stiffness_matrix,
)
from multilatin.fem.mesh import RectMesh


def solve_dirichlet(nodes, cells, hooke, body_force, boundary, value):
    k = stiffness_matrix(nodes, cells, hooke)
    f = body_force_vector(nodes, cells, body_force) if body_force else np.zeros(2 * len(nodes))
    fixed = np.zeros(2 * len(nodes), dtype=bool)
    fixed[np.ravel([2 * boundary, 2 * boundary + 1], order="F")] = True
    u = np.zeros(2 * len(nodes))
    u[fixed] = value(nodes[boundary]).ravel()
    free = ~fixed
    u[free] = spla.spsolve(k[free][:, free].tocsc(), f[free] - k[free][:, fixed] @ u[fixed])
    return u.reshape(-1, 2), k


def distorted_mesh(seed: int = 0):
    mesh = RectMesh(0.0, 1.0, 0.0, 1.0, 4, 4)
    nodes = mesh.nodes.copy()
    rng = np.random.default_rng(seed)
    inner = (nodes[:, 0] > 0) & (nodes[:, 0] < 1) & (nodes[:, 1] > 0) & (nodes[:, 1] < 1)
    nodes[inner] += rng.uniform(-0.08, 0.08, size=(inner.sum(), 2))
    boundary = np.flatnonzero(~inner)
    return nodes, mesh.cells, boundary


def triangles(cells):
    """Each Q4 cell split into two T3 cells along its 0–2 diagonal (counter-clockwise)."""
    return np.vstack([cells[:, [0, 1, 2]], cells[:, [0, 2, 3]]])


@pytest.mark.parametrize("element", ["Q4", "T3"])
@pytest.mark.parametrize("hypothesis", [PLANE_STRESS, PLANE_STRAIN])
def test_patch_test_linear_field_on_distorted_mesh(hypothesis, element):
    """Any linear displacement is reproduced exactly, with exact constant stresses."""
    nodes, cells, boundary = distorted_mesh()
    cells = triangles(cells) if element == "T3" else cells
    hooke = hooke_matrix(2e5, 0.3, hypothesis)
    a = np.array([[1e-3, -2e-3], [3e-3, 0.5e-3]])
    c = np.array([0.1, -0.2])

    def exact(x):
        return x @ a.T + c

    u, k = solve_dirichlet(nodes, cells, hooke, None, boundary, exact)
    np.testing.assert_allclose(u, exact(nodes), rtol=0, atol=1e-12)
    strain = np.array([a[0, 0], a[1, 1], a[0, 1] + a[1, 0]])
    stress = cell_stresses(nodes, cells, hooke, u)
    np.testing.assert_allclose(stress, np.broadcast_to(hooke @ strain, stress.shape), rtol=1e-9)


def test_rigid_body_modes_are_the_kernel():
    mesh = RectMesh(0.0, 2.0, 0.0, 1.0, 3, 2)
    k = stiffness_matrix(mesh.nodes, mesh.cells, hooke_matrix(1.0, 0.25))
    x, y = mesh.nodes.T
    modes = [np.column_stack([np.ones_like(x), 0 * x]), np.column_stack([0 * x, np.ones_like(x)]),
             np.column_stack([-y, x])]
    for mode in modes:
        assert np.abs(k @ mode.ravel()).max() < 1e-12
    eig = np.linalg.eigvalsh(k.toarray())
    assert np.sum(eig < 1e-10 * eig.max()) == 3


def _gmsh_square(path, size: float, element: str):
    """An unstructured gmsh mesh of the unit square (Q4 recombined, or T3) read back as
    nodes and counter-clockwise cells (``multilatin.io.meshfile``)."""
    from multilatin.io.meshfile import read_mesh

    write_gmsh_mesh(path, lambda gmsh: gmsh.model.occ.addRectangle(0.0, 0.0, 0.0, 1.0, 1.0),
                    size, recombine=element == "Q4")
    nodes, cells, _ = read_mesh(path, "test")
    return nodes, cells


@pytest.mark.parametrize("mesh_kind", ["structured", "gmsh"])
@pytest.mark.parametrize("element", ["Q4", "T3"])
def test_convergence_rates_manufactured_solution(element, mesh_kind, tmp_path):
    """Manufactured smooth solution with body force: L2 rate ≈ 2, energy rate ≈ 1, on
    structured meshes and on unstructured gmsh meshes."""
    young, poisson = 1.0, 0.3
    hooke = hooke_matrix(young, poisson, PLANE_STRESS)
    pi = np.pi

    def exact(x):
        return np.stack([np.sin(pi * x[..., 0]) * np.sin(pi * x[..., 1]),
                         x[..., 0] ** 2 * x[..., 1]], axis=-1)

    def grad(x):
        xx, yy = x[..., 0], x[..., 1]
        g = np.empty(x.shape[:-1] + (2, 2))
        g[..., 0, 0] = pi * np.cos(pi * xx) * np.sin(pi * yy)
        g[..., 0, 1] = pi * np.sin(pi * xx) * np.cos(pi * yy)
        g[..., 1, 0] = 2 * xx * yy
        g[..., 1, 1] = xx**2
        return g

    def body_force(x):
        # f = -div σ(u) with plane-stress Hooke, derived by hand
        xx, yy = x[..., 0], x[..., 1]
        c = young / (1 - poisson**2)
        g = (1 - poisson) / 2
        s, co = np.sin, np.cos
        d2u_xx = -pi**2 * s(pi * xx) * s(pi * yy)
        d2u_yy = d2u_xx
        d2u_xy = pi**2 * co(pi * xx) * co(pi * yy)
        d2v_xx, d2v_yy, d2v_xy = 2 * yy, 0 * yy, 2 * xx
        fx = -c * (d2u_xx + poisson * d2v_xy + g * (d2u_yy + d2v_xy))
        fy = -c * (d2v_yy + poisson * d2u_xy + g * (d2v_xx + d2u_xy))
        return np.stack([fx, fy], axis=-1)

    sizes, l2, en = [], [], []
    for n in (4, 8, 16, 32):
        if mesh_kind == "gmsh":
            nodes, cells = _gmsh_square(tmp_path / f"square{n}.msh", 1.0 / n, element)
            on_side = (np.abs(nodes) < 1e-9) | (np.abs(nodes - 1.0) < 1e-9)
            boundary = np.flatnonzero(on_side.any(axis=1))
        else:
            mesh = RectMesh(0.0, 1.0, 0.0, 1.0, n, n)
            nodes = mesh.nodes
            cells = triangles(mesh.cells) if element == "T3" else mesh.cells
            boundary = np.unique(np.concatenate([mesh.side_nodes(s) for s in
                                                 ("bottom", "right", "top", "left")]))
        u, _ = solve_dirichlet(nodes, cells, hooke, body_force, boundary, exact)
        e_l2, e_en = error_norms(nodes, cells, hooke, u, exact, grad)
        sizes.append(1.0 / n)
        l2.append(e_l2)
        en.append(e_en)
    rate_l2 = np.polyfit(np.log(sizes[-3:]), np.log(l2[-3:]), 1)[0]
    rate_en = np.polyfit(np.log(sizes[-3:]), np.log(en[-3:]), 1)[0]
    assert rate_l2 == pytest.approx(2.0, abs=0.15)
    assert rate_en == pytest.approx(1.0, abs=0.1)
