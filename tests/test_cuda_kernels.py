"""The CUDA contact kernels of the torch backend (``latin.cuda_local``) give the NumPy local
stage's answers: run by Numba's CUDA simulator on the CPU (a subprocess: the simulator is
chosen when Numba is imported), on random fields that open, close, stick and slip, with
stops, held nodes and held corners (b1, b1-9, b3); on a GPU they are checked again at their
first call against the torch operations (``TorchLocalStage.use_kernels``)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("torch", reason="the torch backend needs the extra 'gpu'")
pytest.importorskip("numba", reason="the kernels need the extra 'fast'")

CHECK = """
import numpy as np, torch
from conftest import local_stage_input
from multilatin.latin.torch_local import TorchLocalStage

for name in ("b1", "b1-9", "b3"):
    _, _, _, stage, w, f = local_stage_input(name, 5)
    expected = stage(w, f)
    device_stage = TorchLocalStage(stage, torch, torch.device("cpu"))
    device_stage.use_kernels(stage)
    device_stage(torch.as_tensor(w), torch.as_tensor(f))  # checked against the operations
    assert device_stage.contact_kernels is not None, name
    for cases in (np.arange(w.shape[0]), np.array([3, 1])):
        if cases.size < w.shape[0]:  # cases leave: the subset keeps its cases' data
            device_stage.subset(cases)
        got = device_stage(torch.as_tensor(w[cases]), torch.as_tensor(f[cases]))
        for e, g in zip(expected, got, strict=True):
            e = e[cases]
            np.testing.assert_allclose(g.numpy(), e, rtol=1e-12, atol=1e-12 * np.abs(e).max())
    stops = stage.stops.size
    held = int((stage.held_side >= 0).sum())
    print(name, "pairs", stage.contact_pairs[0].size, "stops", stops, "held", held,
          "corners", stage.corner.size)
"""


def test_the_contact_kernels_equal_the_numpy_local_stage() -> None:
    tests = Path(__file__).parent
    env = {**os.environ, "NUMBA_ENABLE_CUDASIM": "1",
           "PYTHONPATH": os.pathsep.join([str(tests), os.environ.get("PYTHONPATH", "")])}
    run = subprocess.run([sys.executable, "-c", CHECK], env=env, capture_output=True,
                         text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    lines = run.stdout.split("\n")
    # the cases cover stops, held nodes and held corners
    assert any("stops 0" not in line and line.startswith("b") for line in lines), run.stdout
    assert any("held 0" not in line and line.startswith("b") for line in lines), run.stdout
    assert any("corners 0" not in line and line.startswith("b") for line in lines), run.stdout
