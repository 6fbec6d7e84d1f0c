"""A study's batch and start where the user gives none: measured choices per device
(docs/gpu.md for the GPU's)."""

from __future__ import annotations

import math

from ..latin import LatinOptions
from ..model import Model
from ..parameters import Grid
from .plan import geometric_parameters

#: a study's default batch from zero on a GPU: 25 B3 geometries × 169 frictions, one fifth
#: of the 21 125-case study, 15 GiB of an H200 (docs/gpu.md)
GPU_BATCH = 4225
#: batches per process where several share a GPU (``workers``): the 21 125-case study on 8
#: processes in batches of 529, 56 s on an H100 (each batch a task; 58–61 s as chains)
#: against 105 s in one (docs/gpu.md, session 29)
GPU_BATCHES_PER_WORKER = 5


def on_gpu(options: LatinOptions) -> bool:
    """The torch backend on a CUDA device."""
    return options.backend == "torch" and options.device.startswith("cuda")


def study_defaults(options: LatinOptions, batch: int | None, start: str | None,
                   workers: int = 0, n_cases: int = 0, geometries: int = 1
                   ) -> tuple[int, str]:
    """``run_study``'s batch and start where not given. On a GPU (the torch backend on a
    CUDA device), a study of at least ``GPU_BATCH`` cases on several processes sharing it
    (``workers``), each with at least two geometries (``geometries``), runs from the
    neighbour in geometry waves (``StudyPlan.geometry_waves``: the 21 125-case B3 study on
    8 processes of an H100 in 51–57 s against 59 s from zero, 47 % fewer iterations; on 6,
    46 s against 58–60 s; docs/gpu.md, session 40); other studies — smaller ones, whose
    batches leave the device waiting on launches rather than on arithmetic, and one process
    (geometry waves not measured there) — every case from zero in batches of ``GPU_BATCH``
    (B1's 13 × 13 grid in 0.83–1.22 s, 4 to 7 × faster than the lines' wavefront), with
    ``workers`` processes ``GPU_BATCHES_PER_WORKER`` batches each of the ``n_cases``.
    Elsewhere from the neighbour, 16."""
    gpu = on_gpu(options)
    if start is None:
        waves = n_cases >= GPU_BATCH and workers >= 2 and geometries >= 2 * workers
        start = "zero" if gpu and not waves else "neighbour"
    if batch is None:  # (a given 0 stays, for run_study's error)
        batch = GPU_BATCH if gpu and start == "zero" else 16
        if gpu and start == "zero" and workers > 1:
            batch = min(batch, max(1, math.ceil(n_cases / (GPU_BATCHES_PER_WORKER * workers))))
    return batch, start


def count_geometries(model: Model, grid: Grid, options: LatinOptions) -> int:
    """How many geometries (operators) the grid's cases take."""
    return math.prod(len(grid[name]) for name in geometric_parameters(model, grid, options))
