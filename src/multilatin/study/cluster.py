"""The processes a study computes in: the compiled kernels loaded before a mode's clock
starts, and a local Dask cluster whose workers load them beside the first task."""

from __future__ import annotations

import logging
import time
from dataclasses import replace
from typing import Any

from ..latin import LatinOptions, kernels, solve_latin
from ..limits import DEVICE_SHARE_ENVIRONMENT
from ..model import Model
from .plan import Case

log = logging.getLogger(__name__)


def load_kernels(model: Model, case: Case, options: LatinOptions) -> None:
    """Compile the Numba kernels, or load them from Numba's cache, on two iterations of the
    study's first case, before any mode's clock starts: the first study after installing
    would otherwise charge the compilation (about 1.5 s, once per installation) to the mode
    that runs first, and ``--compare`` would compare unequal things. (Dask workers do it in
    their own processes: ``warm_workers``.)"""
    if kernels.relax is None:
        return
    t0 = time.perf_counter()
    solver_log = logging.getLogger("multilatin.latin")
    level = solver_log.level
    solver_log.setLevel(max(logging.WARNING, solver_log.getEffectiveLevel()))
    try:  # its "not converged after 2 iterations" is no news to the user
        solve_latin(model.assemble(case.mu), replace(options, max_iter=2), check=False)
    finally:
        solver_log.setLevel(level)
    log.info("compiled kernels ready in %.2f s", time.perf_counter() - t0)


def warm_workers(client: Any, model_future: Any, case: Case, options: LatinOptions,
                 tag: str) -> list[Any]:
    """Every worker loads the compiled kernels as soon as the study starts (one task pinned
    to each, before its others), beside the first task — the waves' middle line on one
    worker — rather than at its own first task, on the waves' critical path (measured on 16
    workers: the first case done 3.9–4.5 s after the start; docs/performance.md). The
    futures are the caller's to keep until the study ends."""
    return [client.submit(_warm_worker, model_future, case, options, workers=[address],
                          allow_other_workers=False, pure=False, priority=10,
                          key=f"warm-up-{address}-{tag}")
            for address in worker_addresses(client)]


def worker_addresses(client: Any) -> list[str]:
    """Every worker of the client's cluster: Dask's ``scheduler_info`` listed only 5 by
    default from mid-2025 (dask/distributed#9045) until #9308 (2026)."""
    try:
        info = client.scheduler_info(n_workers=-1)
    except TypeError:  # older Dask: no such argument, every worker listed
        info = client.scheduler_info()
    return list(info["workers"])


def _warm_worker(model: Model, case: Case, options: LatinOptions) -> None:
    """``load_kernels`` on a worker; a failure there is the study's own tasks' to report."""
    try:
        load_kernels(model, case, options)
    except Exception:  # noqa: BLE001
        log.debug("a worker's warm-up failed", exc_info=True)


def local_cluster(workers: int) -> Any:
    """A local Dask cluster of ``workers`` one-thread processes. Dask starts its workers with
    MALLOC_TRIM_THRESHOLD_ set, which turns off glibc's dynamic mmap threshold: every field
    array of an iteration is then mmapped and unmapped again (measured: the system time
    equal to the computing time, no gain from the second worker). The workers here keep
    glibc's default, and ``MULTILATIN_DEVICE_SHARE`` set to their number (a torch batch
    sizes its fields to its share of the device, ``limits.batch_memory``); Dask's INFO
    chatter only with -v."""
    import dask
    from dask.distributed import LocalCluster

    environ = {name: value for name, value in
               dask.config.get("distributed.nanny.pre-spawn-environ", {}).items()
               if name != "MALLOC_TRIM_THRESHOLD_"}
    # the workers share this machine's memory and device: each sizes its batches to its share
    environ[DEVICE_SHARE_ENVIRONMENT] = str(workers)
    if not log.isEnabledFor(logging.INFO):
        environ["DASK_LOGGING__DISTRIBUTED"] = "warning"
        logging.getLogger("distributed").setLevel(logging.WARNING)
    with dask.config.set({"distributed.nanny.pre-spawn-environ": environ}):
        try:
            return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                dashboard_address=None)
        except Exception as error:
            # the usual cause: a script that starts a study at import time; each worker
            # process imports the script's module again and starts one more (Dask's "Nanny
            # failed to start", nothing about why)
            raise RuntimeError(
                f"workers: a local Dask cluster of {workers} process(es) did not start "
                f"({type(error).__name__}: {error}). Python starts each worker by importing "
                "the main module again: in a script, call run_study under `if __name__ == "
                "'__main__':`; or run the study in this process (workers=0)") from error
