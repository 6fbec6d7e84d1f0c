"""Settled leading steps (``LatinOptions.settled_steps``, ``engine.NumpyFields.settle``): a
load step's fields depend on the earlier steps' alone, so once a case's first steps have
settled the iteration goes on over the later ones only. The local stage started from a
settled step's ŝ is the full pass; the linear stage on the live rows is the full one's rows;
solves with and without it agree within their tolerance, on fewer step-iterations."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import multilatin as ml
from multilatin.decomposition.interfaces import with_contact_data
from multilatin.errors import ModelError
from multilatin.latin import LatinOperators, LatinOptions, kernels, solve_latin
from multilatin.latin.engine import NumpyFields
from multilatin.latin.local_stage import LocalStage
from multilatin.latin.two_scale import keep_settled

pytestmark = pytest.mark.skipif(kernels.coupled_contact is None, reason="Numba not installed")


def _random_fields(name: str, micro_stiffening: float
                   ) -> tuple[LatinOperators, LocalStage, np.ndarray, np.ndarray]:
    """Two cases' random s = (W, F) that open, close, stick and slip (``test_two_scale``)."""
    model = ml.load_model(name)
    assemblies = [model.assemble({"mu1": 0.2, "mu2": 0.1}),
                  model.assemble({"mu1": 0.4, "mu2": 0.0})]
    ops = LatinOperators(assemblies[0], LatinOptions(micro_stiffening=micro_stiffening))
    points = [ops.points, with_contact_data(ops.points, assemblies[1])]
    local = LocalStage(assemblies, points, ops.search_direction, macro_only=ops.macro_only)
    rng = np.random.default_rng(3)
    shape = (2, assemblies[0].n_steps, ops.points.n_points, 2)
    w = np.abs(ops.points.coords).max() * 1e-4 * rng.normal(size=shape)
    return ops, local, w, 20.0 * rng.normal(size=shape)


@pytest.mark.parametrize("name", ["b1", "b1-9", "b3"])
def test_the_local_stage_from_settled_steps_is_the_full_pass(name: str) -> None:
    """Diagonal H (one pass): started at each case's ``first`` step from the ŝ of the steps
    before — the history Coulomb's law, the stops and the held corners carry — the local
    stage gives the full pass's ŝ exactly, and computes nothing before ``first``. The pairs
    and the stop points of a cross point (b1-9, b3, ``cross_points``) restart from their mean
    Ŵ, the merged pair's or stop's history to rounding: their points to 1e-12."""
    ops, local, w, f = _random_fields(name, micro_stiffening=1.0)
    full_w, full_f = local(w, f)
    assert np.abs(full_f[:, :, local.contact_pairs[0]]).max() > 0
    for first in ([0, 7], [4, 12], [14, 1]):
        first_steps = np.array(first, dtype=np.int64)
        w_hat, f_hat = local.without_contact(w, f, first_steps)
        settled_rows = np.arange(w.shape[1])[None, :] < first_steps[:, None]
        w_hat[settled_rows], f_hat[settled_rows] = np.nan, np.nan  # never read
        for c, t0 in enumerate(first):
            if t0:  # the history: the last settled step's ŝ
                w_hat[c, t0 - 1], f_hat[c, t0 - 1] = full_w[c, t0 - 1], full_f[c, t0 - 1]
        local.contact_stage(w, f, w_hat, f_hat, first_steps)
        grouped = np.zeros(w.shape[2], dtype=bool)
        for points, _, _ in local.groups.sides:
            grouped[points.ravel()] = True
        for c, t0 in enumerate(first):
            for got, full in ((w_hat, full_w), (f_hat, full_f)):
                np.testing.assert_array_equal(got[c, t0:, ~grouped], full[c, t0:, ~grouped])
                np.testing.assert_allclose(got[c, t0:, grouped], full[c, t0:, grouped],
                                           rtol=1e-12, atol=1e-12 * np.abs(full).max())
            assert np.isnan(w_hat[c, :max(t0 - 1, 0)]).all()


def test_keep_settled_copies_the_rows_before_first() -> None:
    into = (np.zeros((2, 4, 3)),)
    keep_settled(np.array([1, 3]), into, (np.ones((2, 4, 3)),))
    assert into[0][:, :, 0].tolist() == [[1, 0, 0, 0], [1, 1, 1, 0]]


@pytest.mark.parametrize("micro_stiffening", [4.0, 1.0])
def test_the_live_linear_stage_is_the_full_one_on_its_rows(micro_stiffening: float) -> None:
    """``NumpyFields`` with settled leading steps runs the linear stage (and its relaxation)
    on the other rows alone; there they equal the full stage's, the settled rows keep s —
    also for a batch of two hole positions (the geometries' columns remapped)."""
    model = ml.load_model("b3")
    options = LatinOptions(micro_stiffening=micro_stiffening)
    assemblies = [model.assemble({"xc": 25.0}), model.assemble({"xc": 26.0})]
    operators = [LatinOperators(a, options) for a in assemblies]
    ops = operators[0]
    local = LocalStage(assemblies, [ops.points, with_contact_data(ops.points, assemblies[1])],
                       ops.search_direction, macro_only=ops.macro_only)
    rng = np.random.default_rng(5)
    shape = (2, assemblies[0].n_steps, ops.points.n_points, 2)
    fields = [rng.normal(size=shape) for _ in range(4)]
    relaxation = np.array([0.9, 0.7])

    def engine() -> NumpyFields:
        out = NumpyFields(ops, local, options, fields[0].copy(), fields[1].copy(), None, None,
                          (operators, np.array([0, 1])))
        out.w, out.f = fields[2].copy(), fields[3].copy()
        return out

    full, live = engine(), engine()
    full.linear_stage(relaxation)
    live.first = np.array([3, 9])
    live.linear_stage(relaxation)
    for c, t0 in enumerate(live.first):
        for got, expected, before in ((live.w, full.w, fields[2]), (live.f, full.f, fields[3])):
            np.testing.assert_allclose(got[c, t0:], expected[c, t0:], rtol=1e-12,
                                       atol=1e-12 * np.abs(expected).max())
            np.testing.assert_array_equal(got[c, :t0], before[c, :t0])


def test_the_indicator_gives_each_steps_gap() -> None:
    ops, local, w, f = _random_fields("b1", micro_stiffening=4.0)
    engine = NumpyFields(ops, local, LatinOptions(), *local(w, f), None, None)
    engine.w, engine.f = w, f
    gap, _ = engine.indicator()
    np.testing.assert_allclose(np.sqrt(engine.step_gaps.sum(axis=1)), gap, rtol=1e-12)
    np.testing.assert_allclose(engine.step_gaps[0, 5], engine.displacement_weight @ np.square(
        w[0, 5] - engine.w_hat[0, 5]).ravel() + engine.force_weight @ np.square(
        f[0, 5] - engine.f_hat[0, 5]).ravel(), rtol=1e-12)


@pytest.mark.parametrize("name, params, start", [
    ("b1", {"mu1": 0.1, "mu2": 0.3}, {"mu1": 0.15, "mu2": 0.3}),
    ("b1-9", {"mu1": 0.1, "mu2": 0.3}, {"mu1": 0.15, "mu2": 0.3}),
    ("b3", {"mu1": 0.1, "mu2": 0.3}, {"mu1": 0.15, "mu2": 0.3}),
])
def test_a_warm_solve_settles_its_first_steps_and_keeps_its_answer(
        name: str, params: dict[str, float], start: dict[str, float]) -> None:
    """From a neighbour's converged fields the first steps settle early: the iteration runs
    over fewer steps, to the same answer within the tolerance, against a tight solve."""
    model = ml.load_model(name)
    options = LatinOptions(qoi_rtol=1e-3)
    assembly = model.assemble(params)
    ops = LatinOperators(assembly, options)
    neighbour = solve_latin(model.assemble(start), options, operators=ops)
    assert neighbour.interface is not None
    initial = (neighbour.interface.displacement_hat, neighbour.interface.force_hat)
    tight = solve_latin(assembly, LatinOptions(tol=1e-10), operators=ops)
    results = {}
    for factor in (0.0, LatinOptions().settled_steps):
        chosen = dataclasses.replace(options, settled_steps=factor)
        rows = [0, 0]
        original = NumpyFields.linear_stage

        def counted(engine: NumpyFields, relaxation: np.ndarray, rows: list[int] = rows,
                    original: object = original) -> None:
            rows[0] += int((engine.w_hat.shape[1] - engine.first).sum())
            rows[1] += engine.w_hat.shape[1] * engine.first.size
            original(engine, relaxation)  # type: ignore[operator]

        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(NumpyFields, "linear_stage", counted)
            result = solve_latin(assembly, chosen, operators=ops, initial=initial)
        results[factor] = (result, rows[0] / rows[1])
    off, on = results[0.0], results[LatinOptions().settled_steps]
    assert off[1] == 1.0 and on[1] < 0.9  # steps settled
    for result, _ in (off, on):
        for name_q, value in tight.qoi.items():
            got, expected = np.asarray(result.qoi[name_q]), np.asarray(value)
            scale = max(np.abs(expected).max(), 1e-12)
            assert np.abs(got - expected).max() <= 1e-3 * scale, name_q
    assert abs(on[0].iterations - off[0].iterations) <= 2
    # a settled step's estimate is the one it had when it settled, not the zero its frozen
    # values would read: it still bounds the error it keeps
    settled = int(on[0].timings["settled_steps"])
    assert settled > 0 and off[0].timings["settled_steps"] == 0
    for name_q, value in tight.qoi.items():
        if np.ndim(value) == 0:
            continue  # R_stop: the last step, never settled
        estimate = np.asarray(on[0].qoi_error[name_q], dtype=float)[:settled]
        true = np.abs(np.asarray(on[0].qoi[name_q]) - np.asarray(value))[:settled]
        assert np.all(estimate > 0.0), name_q
        above = true > 1e-6 * np.abs(value).max()  # benchmarks/qoi_error.py's floor
        assert np.all(estimate[above] >= true[above]), name_q


def test_settled_steps_are_a_checked_option() -> None:
    with pytest.raises(ModelError, match="settled_steps"):
        LatinOptions(settled_steps=1.5)
    with pytest.raises(ModelError, match="settled_steps"):
        LatinOptions(settled_steps=-0.1)
