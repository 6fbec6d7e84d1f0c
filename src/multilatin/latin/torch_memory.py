"""How many cases a PyTorch batch may hold (``cases_per_chunk``): the fields' footprint
per case against the free memory of the device, or the CPU's limit."""

from __future__ import annotations

from ..errors import ModelError
from ..limits import batch_memory, memory_limit
from .torch_graph import load_torch

__all__ = ["FIELDS_PER_CASE", "MEMORY_SHARE", "cases_per_chunk"]

#: field-sized arrays (n_steps × n_points × 2 doubles) alive at once per case of a batch: s,
#: ŝ, the new s, the linear stage's right-hand side and products, the macro correction, the
#: local stage's temporaries, host copies; measured 20.6 on the CPU build (peak RSS growth,
#: 400 b3 cases) and 31.8 on an H100 with the CUDA graphs' memory pools (B3's batches of 4 225
#: cases: 29.4 GiB), with a margin, + 2 for the jumps' fourth mark (session 34, unmeasured)
FIELDS_PER_CASE = 36
#: share of the free device memory a batch may take
MEMORY_SHARE = 0.7


def cases_per_chunk(n_steps: int, n_points: int, device: str) -> int:
    """How many cases of this shape a batch may hold on ``device``: the free memory (CUDA's
    own count on a GPU; the limit of ``multilatin.limits`` on the CPU), at most this
    process's share where several share it and ``MULTILATIN_MAX_MEMORY_GB`` where set
    (``limits.batch_memory``), over the fields' footprint. A ``ModelError`` when not even
    one case fits."""
    torch = load_torch(device)
    if device.startswith("cuda"):
        free, total = torch.cuda.mem_get_info(torch.device(device))
        free, source = batch_memory(free, total, f"{free / 2**30:.1f} GiB free on {device}")
    else:
        limit, source = memory_limit()
        free, source = batch_memory(limit, limit, source)
    per_case = FIELDS_PER_CASE * n_steps * n_points * 2 * 8
    fits = int(MEMORY_SHARE * free // per_case)
    if fits < 1:
        raise ModelError(f"device: one case needs about {per_case / 2**20:.0f} MiB of "
                         f"fields, more than {MEMORY_SHARE:.0%} of what is left ({source})")
    return fits
