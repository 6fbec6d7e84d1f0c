"""The condensed interface operator C_E = T S_E⁻¹ Tᵀ M0 from the Schur complement of a
factorisation with the trace's unknowns last (``multilatin.latin.condensation``), against
the same operator from dense linear algebra."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

import multilatin as ml
from multilatin.latin import LatinOperators
from multilatin.latin.condensation import SCHUR_MIN_DOFS, ReorderedFactor, condense


def _substructures(name: str) -> list[tuple[sp.csc_matrix, sp.csr_matrix, np.ndarray]]:
    """Every substructure's S_E (with the default search direction), trace and M0."""
    assembly = ml.load_model(name).assemble()
    ops = LatinOperators(assembly, ml.LatinOptions())
    out = []
    for s, sub in enumerate(assembly.substructures):
        lo, hi = ops.flat_ranges[s]
        trace = ops.points.traces[s].tocsr()
        k = ops.search_direction.reshape(-1)[lo:hi]
        operator = (sub.stiffness() + trace.T @ sp.diags(ops.m0[lo:hi] * k) @ trace).tocsc()
        out.append((operator, trace, ops.m0[lo:hi]))
    return out


@pytest.mark.parametrize("name", ["b1", "b3", "lug", "b2"])
def test_the_schur_complement_gives_the_condensed_operator(name: str) -> None:
    """Both ways, on a model's first six substructures (rectangles, a holed one, gmsh
    meshes joined by mortar projection): C_E within 1e-12 of T S⁻¹ Tᵀ M0 computed densely, and the
    factorisation solves S x = b."""
    rng = np.random.default_rng(0)
    for operator, trace, m0 in _substructures(name)[:6]:
        dense = operator.toarray()
        exact = trace @ np.linalg.solve(dense, (trace.T @ sp.diags(m0)).toarray())
        for schur in (True, False):
            factor, condensed, _ = condense(operator, trace, m0, schur=schur)
            assert np.abs(condensed - exact).max() <= 1e-12 * np.abs(exact).max()
            rhs = rng.standard_normal((operator.shape[0], 3))
            solution = factor.solve(rhs)
            assert np.abs(dense @ solution - rhs).max() <= 1e-10 * np.abs(rhs).max()
            if schur:
                assert isinstance(factor, ReorderedFactor)


def test_large_substructures_take_the_schur_complement_and_recover_alike() -> None:
    """B1's substructures (1 250 unknowns) are condensed through the Schur complement; their
    interior displacements by solves (a few columns) equal those by the dense S⁻¹ Tᵀ M0
    built once enough columns were asked for."""
    assembly = ml.load_model("b1").assemble()
    ops = LatinOperators(assembly, ml.LatinOptions())
    block = ops.substructure_operators[0]
    assert assembly.substructures[0].stiffness().shape[0] >= SCHUR_MIN_DOFS
    assert isinstance(block.factor, ReorderedFactor) and block.recovery is None
    assert block.trace_rhs is not None
    width = block.trace_rhs.shape[1]
    columns = np.random.default_rng(1).standard_normal((width, width))
    by_solves = block.interior(columns[: width // 2])
    assert "recovery" not in block._built
    both = block.interior(columns)  # now past the columns a dense S⁻¹ Tᵀ M0 takes
    assert "recovery" in block._built
    assert np.abs(both[: width // 2] - by_solves).max() <= 1e-12 * np.abs(by_solves).max()


def test_every_hole_position_of_a_mesh_shares_one_interior_ordering() -> None:
    """A holed substructure ordered on its uncut mesh's pattern (``stiffness_pattern``): C_E
    within 1e-12 of the dense one at three hole positions (one through nodes), and the
    interior's ordering is computed once for all three."""
    from multilatin.latin import condensation

    model = ml.load_model("b3")
    condensation._ORDERINGS.clear()
    orderings = []
    for xc, yc in ((24.0, 74.0), (26.0, 77.0), (25.0, 75.0)):
        assembly = model.assemble({"xc": xc, "yc": yc})
        ops = LatinOperators(assembly, ml.LatinOptions())
        s = next(i for i, sub in enumerate(assembly.substructures) if sub.hole is not None)
        sub = assembly.substructures[s]
        lo, hi = ops.flat_ranges[s]
        trace = ops.points.traces[s].tocsr()
        m0 = ops.m0[lo:hi]
        k = ops.search_direction.reshape(-1)[lo:hi]
        operator = (sub.stiffness() + trace.T @ sp.diags(m0 * k) @ trace).tocsc()
        pattern = sub.stiffness_pattern()
        assert pattern is not None and pattern.nnz > sub.stiffness().nnz  # void cells in it
        factor, condensed, _ = condense(operator, trace, m0, schur=True, pattern=pattern)
        assert isinstance(factor, ReorderedFactor)
        dense = operator.toarray()
        exact = trace @ np.linalg.solve(dense, (trace.T @ sp.diags(m0)).toarray())
        assert np.abs(condensed - exact).max() <= 1e-12 * np.abs(exact).max()
        orderings.append(factor.order)
    assert len(condensation._ORDERINGS) == 1  # b3's unholed substructures differ in size
    assert all(np.array_equal(o, orderings[0]) for o in orderings)
