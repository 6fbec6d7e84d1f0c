"""The LATIN micro-macro solver against the monolithic solution on the same mesh."""

import numpy as np
import pytest

import multilatin as ml

TIGHT = ml.LatinOptions(tol=1e-10, max_iter=5000)


@pytest.fixture(scope="module")
def b0_reference(b0):
    return b0.reference().qoi["v_tip"]


@pytest.mark.parametrize("split", [(10, 1), (5, 1), (4, 2), (20, 2)])
def test_b0_latin_equals_monolithic(b0, b0_reference, split):
    result = b0.solve(options=TIGHT, split={"beam": split})
    assert result.converged
    assert len(result.assembly.substructures) == split[0] * split[1]
    assert result.qoi["v_tip"] == pytest.approx(b0_reference, rel=1e-6)


def test_b0_monolithic_is_close_to_beam_theory(b0, b0_reference):
    """Independent order-of-magnitude check: Timoshenko |v_tip| = 2.016 mm (benchmarks.md);
    Q4 on 8 elements through the depth is slightly stiffer, and converges towards the 2D
    value under refinement."""
    coarse = -b0_reference
    fine = -b0.reference(refine=4).qoi["v_tip"]
    assert 1.95 < coarse < fine < 2.03
    assert abs(fine - 2.016) < abs(coarse - 2.016)


@pytest.mark.parametrize("kappa", [0.1, 0.5, 2.0])
def test_b0_answer_does_not_depend_on_search_direction(b0, b0_reference, kappa):
    result = b0.solve(options=ml.LatinOptions(kappa=kappa, tol=1e-10, max_iter=5000))
    assert result.qoi["v_tip"] == pytest.approx(b0_reference, rel=1e-6)
    assert result.qoi["R_clamp"] == pytest.approx(100.0, rel=1e-6)


def test_b0_fields_equal_monolithic_everywhere(b0):
    latin = b0.solve(options=TIGHT)
    reference = b0.reference()
    scale = max(np.abs(u).max() for u in reference.displacements.values())
    for name, u in reference.displacements.items():
        np.testing.assert_allclose(latin.displacements[name], u, atol=1e-7 * scale)


def test_uniform_tension_is_exact_through_the_decomposition():
    """Constant-stress patch test across a 3 x 2 split with mixed (roller) conditions:
    u_x = σ x / E, u_y = -ν σ y / E exactly."""
    model = ml.Model(ml.ModelSpec.from_string(
        """
        [materials.m]
        E = 1000.0
        nu = 0.25
        [[bodies]]
        name = "plate"
        x = [0.0, 3.0]
        y = [0.0, 2.0]
        elements = [6, 4]
        split = [3, 2]
        material = "m"
        [[boundary]]
        name = "left"
        face = "plate.left"
        type = "mixed"
        components = ["displacement", "force"]
        value = [0.0, 0.0]
        [[boundary]]
        name = "bottom"
        face = "plate.bottom"
        type = "mixed"
        components = ["force", "displacement"]
        value = [0.0, 0.0]
        [[boundary]]
        name = "right"
        face = "plate.right"
        type = "force"
        value = [5.0, 0.0]
        """, name="tension"))
    result = model.solve(options=TIGHT)
    for sub in result.assembly.substructures:
        x, y = sub.mesh.nodes.T
        exact = np.column_stack([5.0 * x / 1000.0, -0.25 * 5.0 * y / 1000.0])
        np.testing.assert_allclose(result.displacements[sub.name][0], exact, atol=1e-9)
    assert result.reactions["left"][0, 0] == pytest.approx(-10.0, rel=1e-8)


def test_relaxation_is_required(b0):
    """method.md §4: without relaxation the statically determined tip cluster gives an
    eigenvalue −1 and η stalls; with ω = 0.8 it converges."""
    plain = b0.solve(options=ml.LatinOptions(relaxation=1.0, max_iter=400), check=False)
    assert not plain.converged
    assert plain.history[-50:].min() > 1e-4
    relaxed = b0.solve(options=ml.LatinOptions(relaxation=0.8, max_iter=400))
    assert relaxed.converged


def iterations(model, n_sub, macro, max_iter=1000):
    opts = ml.LatinOptions(tol=1e-5, macro=macro, max_iter=max_iter)
    return model.solve(options=opts, split={"beam": (n_sub, 1)}, check=False)


def test_macro_problem_makes_iterations_scalable(b0):
    """With the macro problem the iteration count stays nearly flat as B0 is split into
    5, 10, 20, 40 substructures; without it, no split gets near (> 10 times as many)."""
    with_macro = [iterations(b0, n, True) for n in (5, 10, 20, 40)]
    counts = [r.iterations for r in with_macro]
    assert all(r.converged for r in with_macro)
    assert max(counts) <= 1.5 * min(counts)
    for n, count in zip((5, 10, 20, 40), counts, strict=True):
        plain = iterations(b0, n, False, max_iter=10 * count)
        assert not plain.converged
        assert plain.indicator > 10 * 1e-5


def test_not_converged_is_an_error(b0):
    with pytest.raises(ml.NotConvergedError) as info:
        b0.solve(options=ml.LatinOptions(max_iter=3))
    assert info.value.result.converged is False
    assert info.value.result.iterations == 3


def test_loads_as_columns_scale_linearly():
    """Load steps are columns of one right-hand side: a two-step history with factors 1 and
    3 gives exactly three times the first step's answer at the second."""
    spec = ml.ModelSpec.from_dict({
        "materials": {"s": {"E": 2e5, "nu": 0.3}},
        "bodies": [{"name": "beam", "x": [0, 200], "y": [0, 20], "elements": [40, 4],
                    "split": [5, 1], "material": "s"}],
        "history": {"factors": {"load": [1.0, 3.0]}},
        "boundary": [
            {"name": "clamp", "face": "beam.left", "type": "displacement", "value": [0, 0]},
            {"name": "tip", "face": "beam.right", "type": "force", "value": [0, -5],
             "factor": "load"},
        ],
        "qoi": [{"name": "v", "type": "displacement", "point": [200, 10], "component": "y"}],
    })
    result = ml.Model(spec).solve(options=TIGHT)
    v = result.qoi["v"]
    assert v[1] == pytest.approx(3 * v[0], rel=1e-8)
    assert v[0] == pytest.approx(ml.Model(spec).reference().qoi["v"][0], rel=1e-6)


def test_observer_sees_every_iteration_without_changing_it(b0):
    """The diagnostic hook (``benchmarks/tail_modes.py``) is called once per iteration with
    s = (W, F), the last of which is the result's s, and observing does not change the run."""
    assembly = b0.assemble()
    seen: list[tuple[int, np.ndarray, np.ndarray]] = []

    def record(iteration, active, w, f):
        assert active.tolist() == [0]
        seen.append((iteration, w.copy(), f.copy()))

    observed = ml.solve_latin(assembly, observer=record)
    plain = ml.solve_latin(assembly)
    assert [s[0] for s in seen] == list(range(1, observed.iterations + 1))
    np.testing.assert_array_equal(observed.history, plain.history)
    np.testing.assert_array_equal(seen[-1][1][0], observed.interface.displacement)
    np.testing.assert_array_equal(seen[-1][2][0], observed.interface.force)


@pytest.mark.parametrize("name", ["b1", "lug"])
def test_the_dense_recovery_equals_the_factorisation(name):
    """Interior displacements from S⁻¹ Tᵀ M0 dense (``SubstructureOperators.recovery``)
    equal those of solves with the factorisation, on many columns at once."""
    import dataclasses

    from multilatin.latin import LatinOperators
    from multilatin.model import load_model

    assembly = load_model(name).assemble()
    ops = LatinOperators(assembly, ml.LatinOptions())
    blocks = ops.substructure_operators
    assert all(b.dense_recovery() is not None for b in blocks)
    rng = np.random.default_rng(2)
    shape = (7, ops.points.n_points, 2)
    w, f = 1e-3 * rng.normal(size=shape), 10.0 * rng.normal(size=shape)
    ops.substructure_operators = [dataclasses.replace(b, recovery=b.dense_recovery())
                                  for b in blocks]
    dense = ops.recover(w, f)
    ops.substructure_operators = [dataclasses.replace(b, recovery=None) for b in blocks]
    factored = ops.recover(w, f)  # 7 columns: fewer than a dense S⁻¹ Tᵀ M0 takes
    assert all("recovery" not in b._built for b in ops.substructure_operators)
    for sub in assembly.substructures:
        assert dense[sub.name].shape == (7, sub.mesh.n_nodes, 2)
        np.testing.assert_allclose(dense[sub.name], factored[sub.name], rtol=1e-10,
                                   atol=1e-10 * np.abs(factored[sub.name]).max())
