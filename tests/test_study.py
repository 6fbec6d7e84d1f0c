"""Parametric studies: multiresolution changes no answer, a killed study resumes without
losing or recomputing anything, Dask gives the serial results, bad grids are refused."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import multilatin as ml
from multilatin.errors import ModelError
from multilatin.latin import LatinOptions
from multilatin.parameters import Grid, ParameterSpace
from multilatin.study.chain_state import STORED_CASES, ChainState, nearest_index
from multilatin.study.plan import (
    boustrophedon,
    chain_step_stored,
    clear_operator_cache,
    plan_study,
)
from multilatin.study.runner import run_study
from multilatin.study.store import StudyStore, load_study

MU2_LINE = Grid({"mu1": [0.3], "mu2": [0.0, 0.1, 0.2, 0.3]})


@pytest.fixture(scope="module")
def b1() -> ml.Model:
    return ml.load_model("b1")


def test_grid_parsing_and_sampling(b1: ml.Model) -> None:
    grid = Grid.parse(["mu2=0:0.6:13", "mu1=0.1,0.3", "gap=0.04"])
    assert grid["mu2"][1] == pytest.approx(0.05) and grid["mu2"][-1] == 0.6
    assert grid.shape == (13, 2, 1) and grid.size == 26
    space = ParameterSpace(b1.parameters, {"mu1": (0.0, 0.6), "mu2": (0.0, 0.6)})
    assert space.sample_uniformly(13)["mu1"] == Grid.parse(["mu1=0:0.6:13"])["mu1"]


@pytest.mark.parametrize("items, message", [
    (["mu2=0:0.6:0"], "empty grid"),
    (["mu2="], "empty grid"),
    (["mu2=0:0.6"], "start:stop:count"),
    (["mu2=a,b"], "start:stop:count"),
    (["mu2=0.1", "mu2=0.2"], "given twice"),
    ([], "no parameter"),
])
def test_bad_grids_are_refused(items: list[str], message: str) -> None:
    with pytest.raises(ModelError, match=message):
        Grid.parse(items)


def test_values_out_of_order_are_sorted_and_monotone_ones_kept(
        b1: ml.Model, tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """A case starts from its neighbours along a line and each line is plotted in the
    grid's order: values given out of order would start cases from far-off ones and draw
    zig-zag lines (found by a user-style study, session 53)."""
    with caplog.at_level("WARNING", logger="multilatin.parameters"):
        grid = Grid.parse(["mu2=0.3,0,0.2,0.1", "mu1=0.3"])
    assert grid["mu2"] == (0.0, 0.1, 0.2, 0.3)
    assert "'mu2': values given out of order" in caplog.text and "mu1" not in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING", logger="multilatin.parameters"):
        falling = Grid({"p": [10.0, 5.0, 0.0]})
    assert falling["p"] == (10.0, 5.0, 0.0) and not caplog.text
    shuffled = run_study(b1, grid, out=tmp_path / "shuffled", progress=False)
    given = run_study(b1, MU2_LINE, out=tmp_path / "sorted", progress=False)
    assert [r["iterations"] for r in shuffled.records] == [
        r["iterations"] for r in given.records]
    assert list(shuffled.dataset["mu2"].values) == [0.0, 0.1, 0.2, 0.3]


def test_unknown_or_inadmissible_parameters_fail_before_any_work(b1: ml.Model,
                                                                  tmp_path: Path) -> None:
    with pytest.raises(ModelError, match="unknown parameter"):
        run_study(b1, Grid({"friction": [0.1]}), out=tmp_path / "a", progress=False)
    with pytest.raises(ModelError, match=r"mu2.*-0.1.*outside"):
        run_study(b1, Grid({"mu2": [0.0, -0.1]}), out=tmp_path / "b", progress=False)
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


def test_traversal_visits_neighbours_only() -> None:
    order = list(boustrophedon((3, 4, 2)))
    assert len(set(order)) == 24
    steps = [sum(abs(a - b) for a, b in zip(p, q, strict=True))
             for p, q in zip(order, order[1:], strict=False)]
    assert steps == [1] * 23


def test_plan_puts_no_friction_parameter_in_the_outer_loop(b1: ml.Model) -> None:
    plan = plan_study(b1, Grid({"mu1": [0.1, 0.2], "mu2": [0.0, 0.3]}), chains=2)
    assert plan.geometric == ()
    assert [len(c) for c in plan.chains] == [2, 2]
    assert plan_study(ml.load_model("b0"), Grid({"P": [1.0, 2.0]})).geometric == ()


def test_multiresolution_changes_no_answer(b1: ml.Model, tmp_path: Path) -> None:
    """Converged tightly, warm-started QoIs equal the cold ones (warm starts only change the
    path); fewer iterations in all. (0.3, 0.3) sits at the sliding limit at step 15
    (push 1500 N = 0.6 x 2500 N): flagged not unique, and solved again from zero."""
    options = LatinOptions(tol=1e-7, max_iter=3000)
    clear_operator_cache()
    result = run_study(b1, MU2_LINE, options=options, modes=("multiresolution", "cold"),
                       out=tmp_path, progress=False, batch=1)
    warm, cold = result.mode_records("multiresolution"), result.mode_records("cold")
    assert [r["start"] for r in warm[1:]] == [
        "mu1=0.3, mu2=0", "mu1=0.3, mu2=0.1 (retimed with mu1=0.3, mu2=0)",
        "zero (not unique: the warm start was set aside)"]
    assert [r["unique"] for r in warm] == [True, True, True, False]
    assert [r["unique"] for r in cold] == [True, True, True, False]
    for w, c in zip(warm, cold, strict=True):
        assert w["converged"] and c["converged"]
        assert w["qoi"]["R_stop"] == pytest.approx(c["qoi"]["R_stop"], rel=2e-5, abs=1e-3)
        np.testing.assert_allclose(w["qoi"]["p_B"], c["qoi"]["p_B"], rtol=1e-4)
    # warm starts save iterations where the answer is unique (the set-aside warm attempt of
    # the last case counts in its iterations)
    assert (sum(r["iterations"] for r in warm if r["unique"])
            < sum(r["iterations"] for r in cold if r["unique"]))
    assert [r["operators_built"] for r in warm] == [True, False, False, False]
    gains = result.gains
    assert gains is not None and gains["gain_cases"] == 4
    dataset = load_study(tmp_path)
    assert dataset["R_stop"].dims == ("mode", "mu1", "mu2")
    assert dataset["u_A"].dims == ("mode", "mu1", "mu2", "step")
    assert bool(dataset["finished"].all())


def test_batched_multiresolution_changes_no_answer(b1: ml.Model, tmp_path: Path) -> None:
    """Grid lines solved as batches (``rolling=False``; the rolling batch starts every case
    from the same neighbour, tests/test_rolling.py): the first line case by case from its
    middle case outward, the next line as one batch from the first line's converged cases
    (one grid step away: the waves' rule, ``study.waves.from_the_middle``); tightly
    converged QoIs equal the cold ones. (μ1 + μ2 is kept off the multiples of 0.06, where a
    push step of 150 N x n equals the friction capacity 2500 (μ1 + μ2) and the centre block's
    position at that step is not unique.)"""
    options = LatinOptions(tol=1e-7, max_iter=3000)
    clear_operator_cache()
    grid = Grid({"mu1": [0.25, 0.35], "mu2": [0.0, 0.1, 0.2]})
    result = run_study(b1, grid, options=options, modes=("multiresolution", "cold"),
                       out=tmp_path, progress=False, batch=8, rolling=False)
    warm, cold = result.mode_records("multiresolution"), result.mode_records("cold")
    assert [r["batch"] for r in warm] == [1, 1, 1, 3, 3, 3]
    assert [r["start"] for r in warm] == [  # the first line from its middle case outward
        "mu1=0.25, mu2=0.1", "zero", "mu1=0.25, mu2=0.1",
        "mu1=0.25, mu2=0.2", "mu1=0.25, mu2=0.1", "mu1=0.25, mu2=0"]
    assert [r["params"]["mu2"] for r in warm] == [0.0, 0.1, 0.2, 0.2, 0.1, 0.0]
    assert [r["operators_built"] for r in warm] == [False, True] + [False] * 4
    assert all(r["batch"] == 1 for r in cold)
    for w in warm:
        c = next(r for r in cold if r["params"] == w["params"])
        assert w["converged"] and c["converged"]
        assert w["qoi"]["R_stop"] == pytest.approx(c["qoi"]["R_stop"], rel=2e-5, abs=1e-3)
        np.testing.assert_allclose(w["qoi"]["u_A"], c["qoi"]["u_A"], rtol=1e-4, atol=1e-7)
    assert result.elapsed_s["multiresolution"] > 0
    assert sum(r["wall_s"] for r in warm) <= result.elapsed_s["multiresolution"]


def test_a_case_that_does_not_converge_is_recorded_and_the_study_goes_on(
        b1: ml.Model, tmp_path: Path) -> None:
    with pytest.warns(RuntimeWarning, match="4 of 4 case.s. did not converge"):
        result = run_study(b1, MU2_LINE, options=LatinOptions(max_iter=5), out=tmp_path,
                           progress=False)
    assert len(result.records) == 4
    assert not any(r["converged"] for r in result.records)
    assert all("NOT CONVERGED" in r["log"] for r in result.records)
    dataset = load_study(tmp_path)
    assert not bool(dataset["converged"].any())
    assert bool(dataset["R_stop"].isnull().all())  # no answer: masked


def test_another_study_in_the_same_folder_is_refused(b1: ml.Model, tmp_path: Path) -> None:
    run_study(b1, Grid({"mu2": [0.0]}), out=tmp_path, progress=False)
    with pytest.raises(ModelError, match="different study.*grid"):
        run_study(b1, Grid({"mu2": [0.1]}), out=tmp_path, progress=False)
    # other solver options: the message names each one, with both values
    with pytest.raises(ModelError, match=r"options\.settled_steps \(0\.0 here, 0\.01 in the "
                       r"folder\)"):
        run_study(b1, Grid({"mu2": [0.0]}), out=tmp_path, progress=False,
                  options=LatinOptions(qoi_rtol=1e-3, settled_steps=0.0))


def test_a_study_of_an_edited_mesh_file_is_not_resumed(tmp_path: Path) -> None:
    """A mesh file is part of the model: resumed after the mesh was edited (one node moved
    by 1e-4 mm), a study used to keep its finished cases, solved on the old mesh, beside
    new ones (session 44)."""
    from importlib import resources

    models = resources.files("multilatin") / "models"
    for name in ("lug.toml", "lug_plate.msh", "lug_pin.msh"):
        (tmp_path / name).write_bytes((models / name).read_bytes())
    grid = Grid({"mu": [0.2]})
    out = tmp_path / "study"
    run_study(ml.load_model(tmp_path / "lug.toml"), grid, out=out, progress=False)
    run_study(ml.load_model(tmp_path / "lug.toml"), grid, out=out, progress=False)  # resumes
    pin = tmp_path / "lug_pin.msh"
    lines = pin.read_text().split("\n")
    at = lines.index("$Nodes") + 4  # the first node block's first coordinates
    x, rest = lines[at].split(" ", 1)
    lines[at] = f"{float(x) + 1e-4!r} {rest}"
    pin.write_text("\n".join(lines))
    with pytest.raises(ModelError, match=r"differs in the contents of the mesh file\(s\) "
                       r"lug_pin\.msh"):
        run_study(ml.load_model(tmp_path / "lug.toml"), grid, out=out, progress=False)


def _comparable(dataset: xr.Dataset) -> xr.Dataset:
    return dataset.drop_vars(["wall_s", "setup_s", "log"]).drop_attrs()


def test_a_killed_study_resumes_without_loss_or_recomputation(tmp_path: Path) -> None:
    """A real SIGKILL mid-study; the same command again finishes it. Nothing finished is
    recomputed (the first run's records are kept as they were), and the store equals an
    uninterrupted run's."""
    command = [sys.executable, "-m", "multilatin.cli", "study", "b1", "--grid", "mu1=0.3",
               "--grid", "mu2=0:0.6:9", "--tol", "1e-6", "--no-progress", "--json",
               "--batch", "1"]
    killed = tmp_path / "killed"
    process = subprocess.Popen([*command, "--out", str(killed)], stdout=subprocess.DEVNULL,
                               stderr=subprocess.DEVNULL)
    journal = killed / "cases.jsonl"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if journal.exists() and journal.read_text().count("\n") >= 3:
            break
        time.sleep(0.01)
    os.kill(process.pid, signal.SIGKILL)
    process.wait()
    before = [json.loads(line) for line in journal.read_text().splitlines() if line.strip()]
    assert 3 <= len(before) < 9, "the study was not interrupted mid-run"

    resumed = subprocess.run([*command, "--out", str(killed)], capture_output=True, text=True,
                             check=True)
    after = [json.loads(line) for line in journal.read_text().splitlines() if line.strip()]
    numbers = [r["number"] for r in after]
    assert sorted(numbers) == list(range(9))  # each case once: none lost, none twice
    assert after[:len(before)] == before  # finished cases kept as they were
    assert len(json.loads(resumed.stdout)["cases"]) == 9

    straight = tmp_path / "straight"
    subprocess.run([*command, "--out", str(straight)], capture_output=True, check=True)
    xr.testing.assert_identical(_comparable(load_study(killed)),
                                _comparable(load_study(straight)))


def test_journal_lines_lost_after_a_batch_are_recovered_from_its_chain_state(
        b1: ml.Model, tmp_path: Path) -> None:
    """A batched study whose journal lost its last records (a crash after the chain state
    of the batch was written): the same study again recovers them from the state, equal to
    the originals, and computes nothing."""
    grid = Grid({"mu1": [0.25, 0.35], "mu2": [0.0, 0.15, 0.3, 0.45]})
    options = LatinOptions(tol=1e-6)
    run_study(b1, grid, options=options, out=tmp_path, progress=False, batch=4)
    journal = tmp_path / "cases.jsonl"
    lines = journal.read_text().splitlines()
    assert len(lines) == 8
    journal.write_text("\n".join(lines[:5]) + "\n")
    computed: list[dict[str, object]] = []
    result = run_study(b1, grid, options=options, out=tmp_path, progress=False, batch=4,
                       on_case=computed.append)
    assert computed == []
    after = [json.loads(line) for line in journal.read_text().splitlines()]
    assert sorted(after, key=lambda r: r["number"]) == sorted(
        (json.loads(line) for line in lines), key=lambda r: r["number"])
    assert any("recovered 3 case(s)" in repair for repair in result.repairs)
    assert all(r["converged"] for r in result.records)


def test_a_chain_state_is_stored_bounded(tmp_path: Path) -> None:
    """A torch wavefront retains two batches' worth of cases (GBs at B3's scale): the store,
    and a Dask chain's client, get the most recent ``STORED_CASES`` alone, with their flags;
    the chain itself goes on with the whole state."""
    state = ChainState(300)
    for i in range(150):
        state = state.added((i, 0), (np.full((1, 2, 2), float(i)), np.zeros((1, 2, 2))),
                            unsettled=i in (20, 140))
    kept = state.stored()
    latest = [(i, 0) for i in range(150 - STORED_CASES, 150)]
    assert list(kept.retained) == latest and kept.unsettled == frozenset({(140, 0)})
    assert len(state.retained) == 150 and state.stored(300) is state
    record = {"mode": "multiresolution", "number": 0, "chain": 0}
    records, shipped = chain_step_stored(([record], state))
    assert records == [record] and shipped is not None and list(shipped.retained) == latest
    store = StudyStore(tmp_path, {"model": "test"})
    try:
        store.add_batch([record], state)
        resumed = store.chain_state("multiresolution", 0)
    finally:
        store.close()
    assert resumed is not None and list(resumed.retained) == latest
    assert resumed.unsettled == frozenset({(140, 0)})
    assert float(resumed.retained[latest[0]][0][0, 0, 0]) == latest[0][0]


def test_a_chain_state_takes_a_batch_as_its_cases_one_by_one() -> None:
    """``added_all`` (a batch's converged cases at once, one copy of the state) keeps what
    ``added`` case by case keeps: the latest ``capacity`` cases, in order, with their flags;
    the nearest retained case one grid step away found by lookup, ties to the latest."""
    cases = [((i % 4, i // 4), (np.full((1, 1, 2), float(i)), np.zeros((1, 1, 2))), i % 3 == 0)
             for i in range(12)]
    start = ChainState(7).added((9, 9), cases[0][1], True)
    one_by_one = start
    for index, fields, flag in cases:
        one_by_one = one_by_one.added(index, fields, flag)
    together = start.added_all(cases)
    assert list(together.retained) == list(one_by_one.retained) == [c[0] for c in cases[5:]]
    assert together.unsettled == one_by_one.unsettled == {(2, 1), (1, 2)}
    for index in [(i, j) for i in range(-1, 5) for j in range(-1, 4)]:  # as the scan finds
        assert together.nearest(index)[0] == nearest_index(list(together.retained), index)[0]
    assert together.nearest((2, 2))[0] == (3, 2)  # of (1, 2), (3, 2), (2, 1): the latest


def test_dask_cluster_gives_the_serial_results(b1: ml.Model, tmp_path: Path) -> None:
    pytest.importorskip("dask.distributed")
    grid = Grid({"mu1": [0.1, 0.3], "mu2": [0.0, 0.2, 0.4]})
    serial = run_study(b1, grid, chains=2, out=tmp_path / "serial", progress=False)
    distributed = run_study(b1, grid, chains=2, workers=2, schedule="chains",
                            out=tmp_path / "dask", progress=False)
    # the same iterations and statuses; the same numbers but for rounding: Dask's workers
    # run BLAS on one thread (its nanny sets OMP_NUM_THREADS=1), this process on every
    # core, and OpenBLAS's dense products may round differently with another thread count.
    # An error estimate is a difference of nearly equal iterates: rounding weighs more there
    left, right = _comparable(serial.dataset), _comparable(distributed.dataset)
    assert sorted(left.data_vars) == sorted(right.data_vars)
    for name in left.data_vars:
        if str(name).endswith("_err"):  # within 1e-8 of the QoI's own scale
            scale = float(np.nanmax(np.abs(left[str(name)[:-4]].values)))
            xr.testing.assert_allclose(left[name], right[name], rtol=1e-6, atol=1e-8 * scale)
        elif left[name].dtype.kind == "f":
            xr.testing.assert_allclose(left[name], right[name], rtol=1e-9, atol=1e-12)
        else:
            xr.testing.assert_identical(left[name], right[name])
    assert len({r["chain"] for r in distributed.records}) == 2


def _device_share() -> str | None:
    return os.environ.get("MULTILATIN_DEVICE_SHARE")


def test_a_local_clusters_workers_size_their_batches_to_their_share() -> None:
    """A local cluster's workers share one machine (and GPU): each is told their number
    (``MULTILATIN_DEVICE_SHARE``, which ``limits.batch_memory`` divides the memory by), so
    that workers starting their batches at once do not each take the whole device."""
    pytest.importorskip("dask.distributed")
    from dask.distributed import Client

    from multilatin.study.cluster import local_cluster

    environment = dict(os.environ)  # Dask's nanny writes its workers' into this process's
    cluster = local_cluster(2)
    client = Client(cluster)
    try:
        assert set(client.run(_device_share).values()) == {"2"}
    finally:
        client.close()
        cluster.close()
        os.environ.clear()
        os.environ.update(environment)


def test_a_script_without_a_main_guard_is_told_why_its_workers_did_not_start(
        tmp_path: Path) -> None:
    """A script that starts a study with workers at import time: each worker process
    imports it again and fails; Dask says only "Nanny failed to start", the study says
    what to do (session 42)."""
    pytest.importorskip("dask.distributed")
    script = tmp_path / "study.py"
    script.write_text("import multilatin as ml\n"
                      "ml.run_study(ml.load_model('b0'), ml.Grid({'P': [1.0]}), workers=1,\n"
                      "             progress=False)\n")
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                          timeout=240, cwd=tmp_path)
    assert done.returncode != 0
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("RuntimeError: workers: a local Dask cluster of 1 process")
    assert "if __name__ == '__main__':" in last


def test_each_geometry_is_built_once_in_a_serial_study(tmp_path: Path) -> None:
    """A study whose batches hold lines of hole positions (b3: xc innermost of the geometric
    parameters, frictions outside) meets every geometry again at each line: each one's
    operators are built once (``plan._operators`` keeps ``_OPERATOR_CACHE_SIZE`` of them;
    with 2 kept, a 3-position line rebuilt 2 of them at every line)."""
    clear_operator_cache()
    result = run_study(ml.load_model("b3"), Grid.parse(["xc=23:25:3", "mu1=0:0.6:3", "rc=3"]),
                       options=LatinOptions(qoi_rtol=1e-2), out=tmp_path, progress=False)
    records = result.records
    assert len(records) == 9 and all(r["converged"] for r in records)
    assert sum(bool(r["operators_built"]) for r in records) == 3


def test_a_default_start_chosen_for_a_gpu_says_so(
        b1: ml.Model, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        caplog: pytest.LogCaptureFixture) -> None:
    """Where a study's start is the device's default (``study.defaults``), the log says
    which it is and over how many geometries (a GPU stood in for: the choice itself is
    ``study_defaults``', tested in test_torch_backend.py)."""
    from multilatin.study import runner

    monkeypatch.setattr(runner, "on_gpu", lambda options: True)
    with caplog.at_level("INFO", logger="multilatin.study.runner"):
        run_study(b1, Grid.parse(["mu1=0.1:0.2:2"]), out=tmp_path, progress=False)
    assert "2 cases over 1 geometries: start 'neighbour' (study.defaults)" in caplog.text
    caplog.clear()
    with caplog.at_level("INFO", logger="multilatin.study.runner"):
        run_study(b1, Grid.parse(["mu1=0.1:0.2:2"]), out=tmp_path / "zero", progress=False,
                  start="zero")
    assert "study.defaults" not in caplog.text
