"""A store that always resumes (issue 14, items 2, 4, 5, 6): a study killed anywhere, even
inside a file write, resumes to the answers of an uninterrupted run; leftovers and damaged
files are repaired and said; a second study in the same folder, or the same grid in another
order, is refused."""

from __future__ import annotations

import json
import os
import random
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import multilatin as ml
from multilatin.errors import ModelError
from multilatin.parameters import Grid
from multilatin.study.plan import clear_operator_cache
from multilatin.study.runner import run_study
from multilatin.study.store import FAULT_ENVIRONMENT, FAULT_LOG_ENVIRONMENT, StudyStore, load_study

COMMAND = [sys.executable, "-m", "multilatin.cli", "study", "b1", "--grid", "mu1=0.1,0.3",
           "--grid", "mu2=0,0.2,0.4", "--tol", "1e-5", "--compare", "--no-progress", "--json"]
GRID = Grid({"mu1": [0.1, 0.3], "mu2": [0.0, 0.2, 0.4]})


@pytest.fixture(scope="module")
def b1() -> ml.Model:
    return ml.load_model("b1")


def _comparable(dataset: xr.Dataset) -> xr.Dataset:
    return dataset.drop_vars(["wall_s", "setup_s", "log"]).drop_attrs()


def _journal(folder: Path) -> list[dict[str, object]]:
    lines = (folder / "cases.jsonl").read_text().splitlines()
    return sorted((json.loads(line) for line in lines if line.strip()),
                  key=lambda r: (str(r["mode"]), int(str(r["number"]))))


def _without_times(records: list[dict[str, object]]) -> list[dict[str, object]]:
    # what a run cost (times, memory, whether this process had to build the operators)
    drop = {"wall_s", "setup_s", "elapsed_s", "peak_rss_mb", "log", "operators_built"}
    return [{k: v for k, v in r.items() if k not in drop} for r in records]


def test_a_study_killed_at_every_write_point_resumes_to_the_same_answers(
        tmp_path: Path) -> None:
    """11 SIGKILLs, aimed at each of the store's 11 write points once in a random order
    (before, inside, after every chain-state, journal and study.nc write; where a resumed
    run ends before its point, random points after), each followed by the same command
    again. A killed study that then finishes must hold the records and study.nc of an
    uninterrupted run; the next kills go to a fresh folder, until 11 kills have happened.
    (20 until session 22, which took the CI's longest test from 92 s to about 50.)"""
    straight = tmp_path / "straight"
    subprocess.run([*COMMAND, "--out", str(straight)], capture_output=True, check=True)
    expected_records = _without_times(_journal(straight))
    expected = _comparable(load_study(straight))
    labels = tmp_path / "kills.txt"
    rng = random.Random(14)
    # a run writes per batch: chain state (4 points), journal (3), study.nc (4): 11 points;
    # every one of them is chosen once, then random ones
    choices = rng.sample(range(1, 12), 11)
    kills, campaigns = 0, 0
    while kills < 11:
        folder = tmp_path / f"killed-{campaigns}"
        while True:
            point = choices.pop() if choices else rng.randint(1, 11)
            environment = {**os.environ, FAULT_ENVIRONMENT: str(point),
                           FAULT_LOG_ENVIRONMENT: str(labels)}
            run = subprocess.run([*COMMAND, "--out", str(folder)], capture_output=True,
                                 text=True, env=environment)
            assert run.returncode in (-9, 0), run.stderr
            if run.returncode == 0:
                break  # the study ended before that write point
            kills += 1
        assert len(json.loads(run.stdout)["cases"]) == 6
        assert _without_times(_journal(folder)) == expected_records
        xr.testing.assert_identical(_comparable(load_study(folder)), expected)
        campaigns += 1
    kinds = {label.split(":")[1].strip() for label in labels.read_text().splitlines()}
    assert {"before the write", "inside the write", "written, not yet in place", "in place",
            "before the append", "inside the append", "after the append"} <= kinds


def test_leftovers_and_damaged_files_are_repaired_and_said(b1: ml.Model,
                                                          tmp_path: Path) -> None:
    clear_operator_cache()
    straight = run_study(b1, GRID, out=tmp_path / "straight", progress=False)
    folder = tmp_path / "damaged"
    run_study(b1, GRID, out=folder, progress=False)
    # a chain state cut short while written, an empty one, a garbage one, a cut journal
    # line in the middle, and a damaged study.json
    (folder / "chains" / "multiresolution-0.npz.tmp").write_bytes(b"PK\x03\x04half")
    (folder / "chains" / "multiresolution-0.tmp.npz").write_bytes(b"")
    (folder / "chains" / "multiresolution-0.npz").write_bytes(b"not a zip file")
    lines = (folder / "cases.jsonl").read_text().splitlines()
    lines[2] = lines[2][: len(lines[2]) // 2]
    (folder / "cases.jsonl").write_text("\n".join(lines) + "\n")
    (folder / "study.json").write_text('{"identity": {"model": "b1", ')
    (folder / "study.nc.tmp").write_bytes(b"CDF half")
    (folder / "my-notes.tmp.txt").write_text("the user's own file")  # left alone
    result = run_study(b1, GRID, out=folder, progress=False)
    assert (folder / "my-notes.tmp.txt").read_text() == "the user's own file"
    assert not (folder / "study.nc.tmp").exists()
    repairs = "\n".join(result.repairs)
    assert "removed chains/multiresolution-0.npz.tmp" in repairs
    assert "dropped damaged chain state multiresolution-0.npz" in repairs
    assert "dropped damaged line 3 of cases.jsonl" in repairs
    assert "study.json was damaged" in repairs
    assert sorted(r["number"] for r in result.records) == list(range(6))
    # the damaged line's case was computed again (from zero: its chain state was dropped)
    for got, expected in zip(sorted(result.records, key=lambda r: r["number"]),
                             sorted(straight.records, key=lambda r: r["number"]), strict=True):
        assert got["converged"]
        assert got["qoi"]["R_stop"] == pytest.approx(expected["qoi"]["R_stop"], rel=1e-3,
                                                     abs=1e-2)
    # the folder is sound again: a second resume repairs nothing and computes nothing
    again = run_study(b1, GRID, out=folder, progress=False, on_case=lambda r: pytest.fail())
    assert again.repairs == ()


def test_a_damaged_study_json_with_a_foreign_journal_is_refused(b1: ml.Model,
                                                               tmp_path: Path) -> None:
    run_study(b1, Grid({"mu2": [0.0, 0.1]}), out=tmp_path, progress=False)
    (tmp_path / "study.json").write_text("{")
    with pytest.raises(ModelError, match="study.json is damaged.*do not fit this study"):
        run_study(b1, Grid({"mu2": [0.3, 0.4]}), out=tmp_path, progress=False)


def test_the_same_grid_in_another_order_is_refused_not_transposed(b1: ml.Model,
                                                                  tmp_path: Path) -> None:
    run_study(b1, Grid({"mu1": [0.0, 0.6], "mu2": [0.0, 0.3, 0.6]}), out=tmp_path,
              progress=False)
    before = load_study(tmp_path)
    with pytest.raises(ModelError, match="order mu1, mu2; give them in that order"):
        run_study(b1, Grid({"mu2": [0.0, 0.3, 0.6], "mu1": [0.0, 0.6]}), out=tmp_path,
                  progress=False)
    after = load_study(tmp_path)
    assert after["R_stop"].dims == ("mode", "mu1", "mu2")
    xr.testing.assert_identical(before, after)
    # R_stop(mu1 = 0.6, mu2 = 0) is the 716 N of the paper's figure, not a transposed cell
    assert float(after["R_stop"].sel(mode="multiresolution", mu1=0.6, mu2=0.0)) == (
        pytest.approx(716.2, abs=0.5))


def test_a_second_study_in_the_same_folder_is_refused_with_the_holders_pid(
        tmp_path: Path) -> None:
    holder = subprocess.Popen(
        [sys.executable, "-c",
         "import sys, time; from multilatin.study.store import StudyStore; "
         f"s = StudyStore({str(tmp_path)!r}, {{'model': 'b1'}}); print('held', flush=True); "
         "time.sleep(60)"], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        run = subprocess.run([*COMMAND, "--out", str(tmp_path)], capture_output=True,
                             text=True)
        assert run.returncode == 2
        assert f"another study is running in this folder (PID {holder.pid})" in run.stderr
    finally:
        holder.kill()
        holder.wait()
    # the holder's death releases the lock (SIGKILL included)
    store = StudyStore(tmp_path, {"model": "b1"})
    store.close()


def test_the_lock_is_held_within_one_process_too(b1: ml.Model, tmp_path: Path) -> None:
    store = StudyStore(tmp_path, {"model": "x"})
    try:
        with pytest.raises(ModelError, match=f"PID {os.getpid()}"):
            run_study(b1, Grid({"mu2": [0.0]}), out=tmp_path, progress=False)
    finally:
        store.close()


def test_a_batch_journalled_in_part_resumes_as_it_was(b1: ml.Model, tmp_path: Path) -> None:
    """The old failure: a batch's chain state saved with all its cases but only the first
    journalled; on resume the others were 'recomputed' from their own answers in one
    iteration. Now the state carries the batch's records: they are recovered as they were."""
    clear_operator_cache()
    grid = Grid({"mu1": [0.25, 0.35], "mu2": [0.0, 0.15, 0.3]})
    run_study(b1, grid, out=tmp_path / "a", progress=False)
    folder = tmp_path / "b"
    run_study(b1, grid, out=folder, progress=False)
    lines = (folder / "cases.jsonl").read_text().splitlines()
    (folder / "cases.jsonl").write_text("\n".join(lines[:4]) + "\n")  # the last batch's first
    computed: list[dict[str, object]] = []
    resumed = run_study(b1, grid, out=folder, progress=False, on_case=computed.append)
    assert computed == []
    assert any("recovered 2 case(s)" in repair for repair in resumed.repairs)
    assert _without_times(_journal(folder)) == _without_times(_journal(tmp_path / "a"))


def test_a_case_computed_again_never_starts_from_its_own_answer(b1: ml.Model,
                                                                tmp_path: Path) -> None:
    """Records of an earlier batch lost (damage, not a kill: those are recovered): the chain
    state still holds their converged fields, but each case starts from a neighbour."""
    grid = Grid({"mu1": [0.25, 0.35], "mu2": [0.0, 0.15, 0.3]})
    # line by line: the chain state then holds the last line's records only (a rolling
    # batch of six writes them all with one state, which would recover the lost ones)
    run_study(b1, grid, out=tmp_path, progress=False, rolling=False)
    lines = (tmp_path / "cases.jsonl").read_text().splitlines()
    (tmp_path / "cases.jsonl").write_text("\n".join([lines[0], *lines[3:]]) + "\n")
    computed: list[dict[str, object]] = []
    resumed = run_study(b1, grid, out=tmp_path, progress=False, on_case=computed.append,
                        rolling=False)
    lost = sorted(json.loads(line)["number"] for line in lines[1:3])
    assert sorted(int(str(r["number"])) for r in computed) == lost
    for record in computed:
        own = ", ".join(f"{k}={v:g}" for k, v in dict(record["params"]).items())  # type: ignore[call-overload]
        assert record["start"] != own
        assert int(str(record["iterations"])) > 5
    assert all(r["converged"] for r in resumed.records)
    assert np.isfinite([r["qoi"]["R_stop"] for r in resumed.records]).all()


def test_a_refused_study_leaves_its_folder_unlocked(b1: ml.Model, tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """A study that fails before its first case (here the data-scale check) releases the
    folder: the same process can start a study there again — even while it keeps the
    exception (its traceback holds the failed call's frame, as an interactive session
    does)."""
    from multilatin import limits
    monkeypatch.setattr(limits, "SCALE_RANGE", (1e-120, 1e-3))  # everything "too large"
    with pytest.raises(ModelError, match="double precision") as kept:
        run_study(b1, Grid({"mu2": [0.0]}), out=tmp_path, progress=False)
    monkeypatch.undo()
    assert kept.tb is not None
    result = run_study(b1, Grid({"mu2": [0.0]}), out=tmp_path, progress=False)
    assert result.records[0]["converged"]
