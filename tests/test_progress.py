"""What a user sees while a study runs: progress as log lines when stderr is no terminal,
and Dask's INFO chatter only with -v."""

from __future__ import annotations

import logging
import subprocess
import sys
from pathlib import Path

import pytest

import multilatin as ml
from multilatin.study import runner


def test_progress_reaches_the_log_when_stderr_is_no_terminal(
        tmp_path: Path, caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(runner, "PROGRESS_INTERVAL_S", 0.0)  # a line per finished batch
    monkeypatch.setattr(sys.stderr, "isatty", lambda: False)
    grid = ml.Grid({"mu1": [0.3], "mu2": [0.0, 0.2, 0.4]})
    with caplog.at_level(logging.INFO, logger="multilatin.progress"):
        ml.run_study(ml.load_model("b1"), grid, out=tmp_path, batch=1, progress=True)
    lines = [r.getMessage() for r in caplog.records if r.name == "multilatin.progress"]
    assert len(lines) >= 3
    assert lines[0].startswith("b1 multiresolution: 1/3 cases")
    assert lines[-1].startswith("b1 multiresolution: 3/3 cases") and "0 s left" in lines[-1]


def test_dask_stays_quiet_without_verbose(tmp_path: Path) -> None:
    pytest.importorskip("distributed")
    command = [sys.executable, "-m", "multilatin.cli", "study", "b1", "--grid", "mu1=0.3",
               "--grid", "mu2=0,0.3", "--workers", "1", "--out", str(tmp_path / "quiet")]
    quiet = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert quiet.returncode == 0, quiet.stderr
    assert "distributed" not in quiet.stderr
    assert "multilatin.progress" in quiet.stderr  # the progress line, without -v
    command[-1] = str(tmp_path / "verbose")
    loud = subprocess.run([*command, "-v"], capture_output=True, text=True, timeout=300)
    assert loud.returncode == 0 and "distributed" in loud.stderr
