"""Work on a torch device captured once as a CUDA graph and replayed (issue 19): one
launch per iteration instead of one per operation, which bound a GPU iteration (profiled on
an H200: B1's 169 cases, 6 303 kernels per iteration, the device busy 12.5 ms of 62); and
``load_torch``, PyTorch checked for a device."""

from __future__ import annotations

import gc
import importlib
import logging
from typing import Any

from ..errors import ModelError

log = logging.getLogger(__name__)

Tensor = Any  # torch.Tensor (PyTorch is optional)

#: the extra that installs PyTorch
INSTALL_HINT = "pip install 'multilatin[gpu]'"


def load_torch(device: str) -> Any:
    """PyTorch, checked for ``device``; a ``ModelError`` naming the option otherwise."""
    try:
        torch = importlib.import_module("torch")
    except ImportError:
        raise ModelError(f"backend: 'torch' needs PyTorch, which is not installed "
                         f"({INSTALL_HINT})") from None
    if device.startswith("cuda"):
        if not torch.cuda.is_available():
            raise ModelError(f"device: {device!r} asked for, but PyTorch sees no CUDA GPU "
                             f"(torch {torch.__version__}; use device 'cpu')")
        index = int(device.split(":")[1]) if ":" in device else 0
        if index >= torch.cuda.device_count():
            raise ModelError(f"device: {device!r} asked for, but PyTorch sees "
                             f"{torch.cuda.device_count()} GPU(s)")
    return torch


class DeviceGraph:
    """``compute`` (a function of tensors only, returning tensors) captured once per shape
    of its inputs as one CUDA graph and replayed: its inputs are copied into the graph's
    own buffers and its outputs copied out. Everything else it reads (operators, the local
    stage's per-case data, a batch's rows) must stay as it was at the capture: ``reset``
    when it changes. Where a capture fails, it says so and the caller goes on eagerly
    (None). ``eager``: no capture, ``compute`` called as it is (on a CPU, where tests run
    the callers' bookkeeping)."""

    def __init__(self, torch: Any, compute: Any, eager: bool = False) -> None:
        self.torch, self.compute, self.eager = torch, compute, eager
        self.graph: Any = None
        self.inputs: tuple[Tensor, ...] = ()
        self.outputs: tuple[Tensor, ...] = ()

    def reset(self) -> None:
        self.graph, self.inputs, self.outputs = None, (), ()

    def __call__(self, inputs: tuple[Tensor, ...]) -> tuple[Tensor, ...] | None:
        if self.eager:
            return tuple(self.compute(*inputs))
        if self.graph is None or any(x.shape != y.shape for x, y in
                                     zip(inputs, self.inputs, strict=True)):
            if not self._capture(inputs):
                return None
        for buffer, x in zip(self.inputs, inputs, strict=True):
            buffer.copy_(x)
        self.graph.replay()
        return tuple(x.clone() for x in self.outputs)

    def _capture(self, inputs: tuple[Tensor, ...]) -> bool:  # pragma: no cover - a GPU's
        torch = self.torch
        self.reset()  # the previous width's graph and buffers go first (its memory pool)
        self.inputs = tuple(x.clone() for x in inputs)
        try:
            stream = torch.cuda.Stream()
            stream.wait_stream(torch.cuda.current_stream())
            with torch.cuda.stream(stream):  # a warm-up outside the capture
                self.compute(*self.inputs)
            torch.cuda.current_stream().wait_stream(stream)
            graph = torch.cuda.CUDAGraph()
            # no garbage collection inside the capture (``torch.cuda.graph`` collects just
            # before): B1's wavefront on an H100 (session 40) logged 7 × "operation not
            # permitted when stream is capturing (function reset)", most likely an earlier
            # batch's engine (a cycle through its graphs' bound methods) collected during a
            # capture, its graph reset there; not yet rerun on a GPU with this
            collecting = gc.isenabled()
            gc.disable()
            try:
                with torch.cuda.graph(graph):
                    self.outputs = tuple(self.compute(*self.inputs))
            finally:
                if collecting:
                    gc.enable()
        except Exception as exc:  # noqa: BLE001
            log.warning("%s could not be captured as a CUDA graph (%s); it runs operation "
                        "by operation", getattr(self.compute, "__name__", "the work"), exc)
            torch.cuda.synchronize()
            self.reset()
            return False
        self.graph = graph
        return True
