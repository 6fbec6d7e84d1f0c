"""The PyTorch backend (issue 19) gives the NumPy backend's answers: same iterations, same
fields to rounding, on the CPU here; on a GPU with ``MULTILATIN_TEST_DEVICE=cuda``
(``benchmarks/gpu.py`` measures it there)."""

from __future__ import annotations

import os
import re
from collections.abc import Callable
from importlib.resources import files
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import warm_b1_4_batch

import multilatin as ml
from multilatin.errors import ModelError
from multilatin.latin import LatinOptions, solve_latin, solve_latin_batch

torch = pytest.importorskip("torch", reason="the torch backend needs the extra 'gpu'")

#: the torch backend iterates every load step every iteration (``settled_steps`` is the
#: NumPy backend's): the NumPy side of each comparison does too, the same algorithm
EVERY_STEP = LatinOptions(settled_steps=0.0)
TIGHT = LatinOptions(tol=1e-9, max_iter=3000, settled_steps=0.0)
#: where the torch side runs: PyTorch's CPU build in CI, ``cuda`` on a GPU machine
DEVICE = os.environ.get("MULTILATIN_TEST_DEVICE", "cpu")


def _relative(expected: object, got: object) -> float:
    e, g = np.asarray(expected, dtype=float), np.asarray(got, dtype=float)
    return float(np.max(np.abs(e - g)) / max(np.max(np.abs(e)), 1e-300))


@pytest.mark.parametrize("name", ["b1", "b1-9", "b3"])
def test_the_local_stage_equals_the_numpy_one(
        name: str, random_local_stage_input: Callable[[str, int], tuple[Any, ...]]) -> None:
    """On random fields that open, close, stick and slip, at stops, held nodes and corners."""
    from multilatin.latin.torch_local import TorchLocalStage

    _, _, _, stage, w, f = random_local_stage_input(name, 5)
    expected = stage(w, f)
    device_stage = TorchLocalStage(stage, torch, torch.device(DEVICE))
    got = [g.cpu().numpy() for g in device_stage(torch.as_tensor(w, device=DEVICE),
                                                 torch.as_tensor(f, device=DEVICE))]
    for e, g in zip(expected, got, strict=True):
        np.testing.assert_allclose(g, e, rtol=1e-12, atol=1e-12 * np.abs(e).max())
    assert np.abs(got[1][:, :, stage.contact_pairs[0]]).max() > 0
    # cases leave: the subset keeps its cases' data
    keep = np.array([3, 1])
    device_stage.subset(keep)
    part = device_stage(torch.as_tensor(w[keep], device=DEVICE),
                        torch.as_tensor(f[keep], device=DEVICE))
    np.testing.assert_allclose(part[1].cpu().numpy(), expected[1][keep], rtol=1e-12,
                               atol=1e-12 * np.abs(expected[1]).max())


@pytest.mark.parametrize(("name", "mu"), [("b1", {"mu1": 0.3, "mu2": 0.15}),
                                          ("b3", {"mu1": 0.35, "mu2": 0.25, "rc": 3.0}),
                                          ("b0", {})])
def test_a_tight_solve_equals_the_numpy_one(name: str, mu: dict[str, float]) -> None:
    """To 1e-9 relative at tight tolerance, iterations within ±2 (they are equal here)."""
    assembly = ml.load_model(name).assemble(mu)
    reference = solve_latin(assembly, TIGHT)
    got = solve_latin(assembly, TIGHT.__class__(**{**TIGHT.__dict__, "backend": "torch",
                                                       "device": DEVICE}))
    assert abs(got.iterations - reference.iterations) <= 2
    for qoi, value in reference.qoi.items():
        assert _relative(value, got.qoi[qoi]) < 1e-9, qoi
    assert reference.interface is not None and got.interface is not None
    assert _relative(reference.interface.force_hat, got.interface.force_hat) < 1e-9
    for body, u in reference.displacements.items():
        assert _relative(u, got.displacements[body]) < 1e-9


@pytest.mark.parametrize(("acceleration", "padded"), [("relaxation", False), ("anderson", False),
                                                     ("rre", False), ("relaxation", True),
                                                     ("rre", True), ("relaxation", 0.25)])
def test_a_warm_batch_equals_the_numpy_one(acceleration: str, padded: bool | float,
                                          monkeypatch: pytest.MonkeyPatch) -> None:
    """Cold and warm starts mixed in one batch, cases leaving at different iterations, the
    QoI stopping rule on (η alone with Anderson or RRE, which give no QoI estimates),
    relaxation, Anderson mixing or RRE: the same stops and answers. ``padded``: the rows of
    the cases that left stay in the batch until at most half (or the fraction given) are
    active (as on a GPU, where the local stage is one CUDA graph per width; no graph on the
    CPU)."""
    from multilatin.latin import torch_engine

    if padded is not True and padded:
        monkeypatch.setattr(torch_engine, "COMPACT_BELOW", padded)
    if padded:  # and the whole iteration as one function, as the graph a GPU replays
        monkeypatch.setattr(torch_engine, "PADDED_DEVICES", ("cuda", "cpu"))
        monkeypatch.setattr(torch_engine, "FUSED_DEVICES", ("cuda", "cpu"))
        fused: list[int] = []
        monkeypatch.setattr(torch_engine.TorchFields, "_iteration", _counted(
            torch_engine.TorchFields._iteration, fused))
    options = LatinOptions(qoi_rtol=1e-3 if acceleration == "relaxation" else None,
                           acceleration=acceleration, anderson_depth=5, settled_steps=0.0)
    assemblies, ops, starts = warm_b1_4_batch(options)
    reference = solve_latin_batch(assemblies, options, operators=ops, initial=starts)
    from dataclasses import replace

    got = solve_latin_batch(assemblies, replace(options, backend="torch", device=DEVICE), operators=ops,
                            initial=starts)
    assert len({r.iterations for r in reference}) > 2  # padded: kept rows, then compacted
    if padded:  # every iteration after the first as one (RRE's steps shift the fields)
        assert len(fused) > max(r.iterations for r in got) // 2
        # the widths the rows took: 4 until at most 2 (or 1) are active, then compacted
        assert sorted(set(fused), reverse=True) == ([4, 2, 1] if padded is True else [4, 1])
    for one, other in zip(reference, got, strict=True):
        assert abs(one.iterations - other.iterations) <= 2
        assert one.stopped_on_qoi == other.stopped_on_qoi
        # Anderson's least squares on top of the coupled local stage's inner passes carry
        # the backends' rounding further (5.6e-8 measured; η < 1e-6 leaves ~1e-6); where
        # that moves a stop by an iteration, the answers differ by what η < 1e-6 leaves:
        # R_stop within 1.8e-5 relative on B1 (docs/tolerance.md; u_A 1.8e-6 seen here)
        limit = (1e-9 if acceleration != "anderson" else
                 1e-6 if one.iterations == other.iterations else 2e-5)
        assert _relative(one.qoi["R_stop"], other.qoi["R_stop"]) < limit
        assert _relative(one.qoi["u_A"], other.qoi["u_A"]) < limit


@pytest.mark.parametrize("padded", [False, True])
def test_sliding_jumps_on_the_device_equal_the_numpy_ones(
        padded: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    """B1 at κ = 1, (μ1, μ2) = (0, 0.05): the centre block crawls toward the stop and only
    the sliding extrapolation's jump lets it converge before the drift check (200
    iterations; ``test_sliding``). Its marks and test stay on the torch device: the same
    jump, iterations and answer as NumPy's, beside a case that does not crawl."""
    from dataclasses import replace

    from multilatin.latin import torch_engine

    if padded:
        monkeypatch.setattr(torch_engine, "PADDED_DEVICES", ("cuda", "cpu"))
        monkeypatch.setattr(torch_engine, "FUSED_DEVICES", ("cuda", "cpu"))
    model, options = ml.load_model("b1"), LatinOptions(kappa=1.0)
    batch = [model.assemble({"mu1": 0.0, "mu2": 0.05}), model.assemble({"mu1": 0.3,
                                                                        "mu2": 0.0})]
    reference = solve_latin_batch(batch, options)
    got = solve_latin_batch(batch, replace(options, backend="torch", device=DEVICE))
    assert reference[0].iterations < 200
    if not padded:  # without the jump: not converged (stopped on its drift)
        assert not solve_latin_batch(batch[:1], replace(options, extrapolate_sliding=False,
                                                        backend="torch", device=DEVICE),
                                     check=False)[0].converged
    for one, other in zip(reference, got, strict=True):
        assert other.converged and one.iterations == other.iterations
        assert _relative(one.qoi["R_stop"], other.qoi["R_stop"]) < 1e-9


def test_a_two_mode_jump_on_the_device_equals_the_numpy_one(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The sliding block at κ = 0.1 converges through a two-mode jump (``latin.sliding``,
    session 34: fewer iterations than with one mode): the torch backend's marks and fit
    give the same jump, iterations and answer as NumPy's."""
    from dataclasses import replace

    from multilatin.latin import sliding

    assembly, options = ml.load_model("slide").assemble(), LatinOptions(kappa=0.1)
    reference = solve_latin_batch([assembly], options)[0]
    got = solve_latin_batch([assembly], replace(options, backend="torch", device=DEVICE))[0]
    assert got.converged and got.iterations == reference.iterations
    assert np.max(np.abs(np.asarray(got.qoi["R_push"]) - np.asarray(reference.qoi["R_push"]))
                  ) < 1e-9 * np.max(np.abs(np.asarray(reference.qoi["R_push"])))
    monkeypatch.setattr(sliding, "MODES", 1)
    assert solve_latin_batch([assembly], options)[0].iterations > got.iterations


def test_a_small_study_equals_the_numpy_one(tmp_path: object) -> None:
    """The same strategy on both backends (every case from zero in one batch: on torch,
    multiresolution solves a grid's first lines from zero instead of case after case, see
    the wavefront test): the same iterations and answers."""

    model = ml.load_model("b1")
    grid = ml.Grid({"mu1": [0.1, 0.3], "mu2": [0.0, 0.2]})
    options = LatinOptions(tol=1e-8, settled_steps=0.0)
    reference, got = _on_both_backends(model, grid, options, batch=4, start="zero")
    ref = reference.dataset["R_stop"].values
    np.testing.assert_allclose(got.dataset["R_stop"].values, ref, rtol=1e-9)
    iterations = {r["number"]: r["iterations"] for r in reference.records}
    for record in got.records:
        assert abs(record["iterations"] - iterations[record["number"]]) <= 2


def test_a_study_on_a_gpu_starts_from_zero_or_in_geometry_waves() -> None:
    """Measured on GPUs (docs/gpu.md): a study too small to keep the device busy goes from
    zero in wide batches (4 to 7 × faster than the lines' wavefront), a wide one over many
    geometries on several processes in geometry waves (the 21 125-case B3 study on 8
    processes of an H100: 51–57 s against 59 s); one process, not measured in waves, from
    zero; given values and other devices keep theirs."""
    from multilatin.study.defaults import GPU_BATCH, count_geometries, study_defaults

    gpu = LatinOptions(backend="torch", device="cuda:0")
    assert study_defaults(gpu, None, None) == (GPU_BATCH, "zero")
    assert study_defaults(gpu, 13, None) == (13, "zero")
    assert study_defaults(gpu, None, "neighbour") == (16, "neighbour")
    # processes sharing the GPU: GPU_BATCHES_PER_WORKER batches each, none above GPU_BATCH
    assert study_defaults(gpu, None, None, 8, 21125) == (529, "zero")
    assert study_defaults(gpu, None, None, 2, 10**6) == (GPU_BATCH, "zero")
    assert study_defaults(gpu, None, None, 8, 3) == (1, "zero")
    # wide, on several processes, two geometries or more each: geometry waves
    assert study_defaults(gpu, None, None, 8, 21125, 125) == (16, "neighbour")
    assert study_defaults(gpu, None, None, 2, 21125, 4) == (16, "neighbour")
    assert study_defaults(gpu, None, None, 8, 21125, 15)[1] == "zero"  # < 2 per process
    assert study_defaults(gpu, None, None, 8, GPU_BATCH - 1, 125)[1] == "zero"  # narrow
    assert study_defaults(gpu, None, None, 0, 21125, 125)[1] == "zero"  # one process
    assert study_defaults(gpu, None, "zero", 8, 21125, 125) == (529, "zero")
    for options in (LatinOptions(backend="torch"), LatinOptions()):
        assert study_defaults(options, None, None) == (16, "neighbour")
        assert study_defaults(options, None, None, 0, 21125, 125) == (16, "neighbour")
    # the geometries a grid's cases take: hole positions and radii, not frictions
    b3 = ml.load_model("b3")
    grid = ml.Grid.parse(["mu1=0:0.6:13", "xc=23:27:5", "yc=73:77:2", "rc=3"])
    assert count_geometries(b3, grid, gpu) == 10
    assert count_geometries(b3, ml.Grid.parse(["mu1=0:0.6:13"]), gpu) == 1


def test_options_say_what_is_wrong() -> None:

    assembly = ml.load_model("b1").assemble()
    if not torch.cuda.is_available():
        with pytest.raises(ModelError, match="device: 'cuda' asked for, but PyTorch sees no"):
            solve_latin(assembly, LatinOptions(backend="torch", device="cuda"))
    with pytest.raises(ModelError, match="device: the numpy backend works on the CPU only"):
        LatinOptions(device="cuda")
    with pytest.raises(ModelError, match="backend: expected one of"):
        LatinOptions(backend="jax")


def test_several_geometries_in_one_batch_give_each_geometrys_answers() -> None:
    """Hole positions and radii of B3 as one torch batch: the holed substructure's operators
    per geometry, the others shared; the NumPy answers case by case."""
    b3 = ml.load_model("b3")
    mus = [{"rc": 2.0, "mu1": 0.3}, {"rc": 4.0, "mu1": 0.35, "mu2": 0.25},
           {"rc": 2.0, "xc": 24.0, "mu1": 0.1, "mu2": 0.3}]
    assemblies = [b3.assemble(mu) for mu in mus]
    got = solve_latin_batch(assemblies, LatinOptions(backend="torch", device=DEVICE))
    assert got[0].timings["batch_size"] == 3  # one batch
    for assembly, result in zip(assemblies, got, strict=True):
        alone = solve_latin(assembly, EVERY_STEP)
        assert abs(result.iterations - alone.iterations) <= 2
        for qoi, value in alone.qoi.items():
            assert _relative(value, result.qoi[qoi]) < 1e-9, qoi
        for body, u in alone.displacements.items():
            assert _relative(u, result.displacements[body]) < 1e-9


def test_a_study_from_zero_batches_geometries_on_torch(tmp_path: object) -> None:
    """``start="zero"``: NumPy batches each geometry, torch all of them; same answers."""

    model = ml.load_model("b3")
    grid = ml.Grid({"xc": [23.0, 26.0], "mu1": [0.1, 0.3]})
    options = EVERY_STEP  # the same stops on both backends: equal to rounding anyway
    reference, got = _on_both_backends(model, grid, options, batch=8, start="zero")
    assert {r["batch"] for r in reference.records} == {2}
    assert {r["batch"] for r in got.records} == {4}
    assert {r["start"] for r in got.records} == {"zero"}
    np.testing.assert_allclose(got.dataset["R_stop"].values,
                               reference.dataset["R_stop"].values, rtol=1e-9)


def test_the_fused_local_stage_gives_the_numpy_answers(tmp_path: Path) -> None:
    """``fuse=True`` (torch.compile) on a 2-step variant of ``slide`` (a short history keeps
    the compilation to about half a minute): three frictions in one batch, leaving it at
    different iterations (a batch of one included), equal to the NumPy solves."""
    from dataclasses import replace

    text = (files("multilatin") / "models" / "slide.toml").read_text()
    text = text.replace("press = [0.5, 1, 1, 1, 1, 1, 1, 1, 1, 1]", "press = [0.5, 1]")
    text = re.sub(r"push = \[0, 0, [^\]]*\]", "push = [0, 0.004]", text)
    (tmp_path / "slide2.toml").write_text(text)
    model = ml.load_model(tmp_path / "slide2.toml")
    assemblies = [model.assemble({"mu": mu}) for mu in (0.1, 0.2, 0.3)]
    assert assemblies[0].n_steps == 2
    # the diagonal direction: with the two-scale one (the default) the three frictions
    # converge together (84 iterations), and cases leaving the batch is what this checks
    options = LatinOptions(tol=1e-8, micro_stiffening=1.0)
    reference = solve_latin_batch(assemblies, options)
    got = solve_latin_batch(assemblies, replace(options, backend="torch", device=DEVICE,
                                                     fuse=True))
    assert len({r.iterations for r in reference}) == 3
    for one, other in zip(reference, got, strict=True):
        assert abs(one.iterations - other.iterations) <= 2
        assert _relative(one.qoi["R_push"], other.qoi["R_push"]) < 1e-9
    with pytest.raises(ModelError, match="fuse: compiles the torch backend"):
        LatinOptions(fuse=True)


def test_a_batch_larger_than_the_memory_is_solved_in_chunks(
        monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    """The memory limit (on the CPU, ``MULTILATIN_MAX_MEMORY_GB``; on a GPU, the free device
    memory) splits a batch into chunks with the same answers; not even one case fitting is
    an error naming the device, never an out-of-memory crash."""
    from dataclasses import replace

    from multilatin.latin.torch_memory import FIELDS_PER_CASE, MEMORY_SHARE, cases_per_chunk

    model = ml.load_model("b1")
    assemblies = [model.assemble({"mu1": mu}) for mu in (0.1, 0.2, 0.3)]
    options = LatinOptions(backend="torch", device=DEVICE, tol=1e-4)  # equal stops: any tol
    whole = solve_latin_batch(assemblies, options)
    per_case = FIELDS_PER_CASE * assemblies[0].n_steps * whole[0].interface.coords.shape[0] * 16
    monkeypatch.setenv("MULTILATIN_MAX_MEMORY_GB", str(1.5 * per_case / MEMORY_SHARE / 1e9))
    with caplog.at_level("INFO", logger="multilatin.latin.solver"):
        chunked = solve_latin_batch(assemblies, options)
    assert "batch of 3 cases solved in chunks of 1" in caplog.text
    for one, other in zip(whole, chunked, strict=True):
        assert one.iterations == other.iterations
        assert other.timings["batch_size"] == 1
        # rounding: products over 3 cases or 1, which the coupled local stage's inner
        # iteration carries along (2e-10 and 3e-9 measured in two runs; η < 3e-6 leaves
        # R_stop ~1e-6 off the fixed point)
        assert _relative(one.qoi["R_stop"], other.qoi["R_stop"]) < 1e-7
    monkeypatch.setenv("MULTILATIN_MAX_MEMORY_GB", str(0.5 * per_case / MEMORY_SHARE / 1e9))
    with pytest.raises(ModelError, match="device: one case needs about"):
        solve_latin_batch(assemblies, replace(options, max_iter=5))
    # processes sharing the memory (a local Dask cluster's workers) take a share each
    n_points = whole[0].interface.coords.shape[0]
    monkeypatch.setenv("MULTILATIN_MAX_MEMORY_GB", str(4.5 * per_case / MEMORY_SHARE / 1e9))
    assert cases_per_chunk(assemblies[0].n_steps, n_points, DEVICE) == 4
    monkeypatch.setenv("MULTILATIN_DEVICE_SHARE", "3")
    assert cases_per_chunk(assemblies[0].n_steps, n_points, DEVICE) == 1
    monkeypatch.setenv("MULTILATIN_DEVICE_SHARE", "none")
    with pytest.raises(ModelError, match="MULTILATIN_DEVICE_SHARE: expected a number"):
        cases_per_chunk(assemblies[0].n_steps, n_points, DEVICE)


def test_a_batch_the_device_runs_out_of_memory_for_is_solved_again_in_halves(
        monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture) -> None:
    """Where the device runs out of memory after all (other processes sharing it: 8 under
    CUDA's MPS filled an H100, session 40), the batch is solved again in halves with the
    same answers; where not even one case fits, an error naming the device, never an
    out-of-memory crash. The device's error is raised here for batches over 2 cases."""
    from multilatin.latin import solver

    model = ml.load_model("b1")
    assemblies = [model.assemble({"mu1": mu}) for mu in (0.1, 0.2, 0.3, 0.4, 0.5)]
    options = LatinOptions(backend="torch", device=DEVICE, tol=1e-4)
    whole = solve_latin_batch(assemblies, options)
    iterate, widths = solver.iterate, []

    def full_above(limit: int) -> Callable[..., Any]:
        def iterate_or_fill(*args: Any) -> Any:
            widths.append(args[3].shape[0])
            if args[3].shape[0] > limit:
                raise torch.OutOfMemoryError("CUDA out of memory. Tried to allocate 198 MiB")
            return iterate(*args)
        return iterate_or_fill

    monkeypatch.setattr(solver, "iterate", full_above(2))
    with caplog.at_level("WARNING", logger="multilatin.latin.solver"):
        halves = solve_latin_batch(assemblies, options)
    assert widths == [5, 3, 2, 1, 2]  # 5 → 3 + 2, 3 → 2 + 1
    assert ("ran out of memory for a batch of 5 cases (CUDA out of memory); solving it "
            "again as batches of 3") in caplog.text
    for one, other in zip(whole, halves, strict=True):
        assert one.iterations == other.iterations
        assert _relative(one.qoi["R_stop"], other.qoi["R_stop"]) < 1e-7  # as in chunks
    monkeypatch.setattr(solver, "iterate", full_above(0))
    with pytest.raises(ModelError, match="device: one case does not fit in the memory left "
                                         f"on '{DEVICE}' \\(CUDA out of memory\\)"):
        solve_latin_batch(assemblies[:2], options)


def test_multiresolution_on_torch_runs_geometry_waves(tmp_path: Path) -> None:
    """``start="neighbour"`` on torch: the geometries in waves (``StudyPlan.geometry_waves``),
    the first geometry's cases from zero in one batch, then the other's, each warm-started
    from the same frictions one hole position away; the answers those of the NumPy study
    (its lines one geometry at a time) to the tolerance. (Nearest starts: with the
    default ones a case beside a position flagged not unique starts from zero,
    ``predictors.not_unique_beside``, tested in test_predictors.py.)"""

    model = ml.load_model("b3")
    grid = ml.Grid({"xc": [23.0, 26.0], "mu1": [0.1, 0.3], "mu2": [0.0, 0.2]})
    options = LatinOptions()  # the default η: R_stop within 0.1 % (docs/tolerance.md)
    reference, got = _on_both_backends(model, grid, options, start="nearest")
    assert {r["batch"] for r in got.records} == {4}  # 2 geometries, 2 × 2 frictions each
    for record in got.records:  # the second batch from the first, one hole position away
        if not record["start"].startswith("zero"):
            start = dict(item.split("=") for item in record["start"].split(", "))
            moved = [name for name, value in start.items()
                     if grid[name].index(float(value)) != grid[name].index(record["params"][name])]
            assert moved == ["xc"] and record["params"]["xc"] == 26.0, record["start"]
    # the first batch (the first geometry) from zero, and (26, 0.1, 0.2) of the second:
    # beside (23, 0.1, 0.2), at the friction limit (μ1 + μ2 = 0.3) and flagged not unique
    # (``predictors.not_unique_beside``)
    zero = {(r["params"]["xc"], r["params"]["mu1"], r["params"]["mu2"]): r["unique"]
            for r in got.records if r["start"] == "zero"}
    assert len(zero) == 5 and zero[(26.0, 0.1, 0.2)] is False
    np.testing.assert_allclose(got.dataset["R_stop"].values,
                               reference.dataset["R_stop"].values, rtol=2e-3)


def test_geometry_waves_on_dask_chains_each_start_once_from_zero(tmp_path: Path) -> None:
    """Torch multiresolution on two Dask processes (``schedule="chains"``): each chain's
    geometry waves start from zero once, at the chain's middle geometry, every other case
    one hole position away in its chain; the answers those of the serial study to the
    tolerance; the chains' states, kept whole on their workers, reach the store as their
    latest cases alone (``ChainState.stored``)."""
    pytest.importorskip("dask.distributed")
    model = ml.load_model("b3")
    grid = ml.Grid({"mu1": [0.1, 0.4], "mu2": [0.1, 0.4], "xc": [24.0, 25.0, 26.0],
                    "yc": [74.0, 76.0], "rc": [3.0]})
    options = LatinOptions(qoi_rtol=1e-3, backend="torch", device=DEVICE)
    serial = ml.run_study(model, grid, options=options, out=tmp_path / "serial",
                          progress=False)
    chains = ml.run_study(model, grid, options=options, out=tmp_path / "dask", workers=2,
                          progress=False)
    for result, n_chains in ((serial, 1), (chains, 2)):
        zero = [r for r in result.records if r["start"] == "zero"]
        geometries = {(r["params"]["xc"], r["params"]["yc"]) for r in zero}
        assert len(geometries) == n_chains and len(zero) == 4 * n_chains
        for record in result.records:
            if record["start"] != "zero":  # "<neighbour> (parallelogram with …)" or alone
                neighbour = record["start"].split(" (")[0]
                start = dict(item.split("=") for item in neighbour.split(", "))
                moved = [name for name in ("xc", "yc")
                         if float(start[name]) != record["params"][name]]
                assert len(moved) == 1 and all(float(start[name]) == record["params"][name]
                                               for name in ("mu1", "mu2")), record["start"]
    np.testing.assert_allclose(chains.dataset["R_stop"].values,
                               serial.dataset["R_stop"].values, rtol=2e-3)
    assert len(list((tmp_path / "dask" / "chains").glob("*.npz"))) == 2


def _on_both_backends(model: ml.Model, grid: ml.Grid, options: LatinOptions, **kwargs: Any
                      ) -> tuple[ml.StudyResult, ml.StudyResult]:
    """The same study on the NumPy and the torch backend (each in a folder of its own)."""
    from dataclasses import replace

    on_numpy, on_torch = (ml.run_study(model, grid, options=replace(options, backend=backend,
                                                                   device=device),
                                       progress=False, **kwargs)
                          for backend, device in (("numpy", "cpu"), ("torch", DEVICE)))
    return on_numpy, on_torch


def _counted(function: Any, calls: list[int]) -> Any:
    """``function`` (a method of an engine) recording each call's batch width."""
    def counted(*args: Any) -> Any:
        calls.append(args[0].w.shape[0])
        return function(*args)
    return counted
