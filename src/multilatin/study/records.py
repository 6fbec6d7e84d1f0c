"""A study case's journal record (``case_record``): its parameters, answer, QoIs, start
and costs, as the store, table.csv and study.nc keep them."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING, Any

import numpy as np

from ..decomposition.result import SolveResult
from ..parameters import Grid
from .predictors import start_text

if TYPE_CHECKING:
    from .plan import Case


def peak_memory_mb() -> float:
    """Peak resident memory of this process so far (MiB); NaN where not measurable."""
    try:
        import resource
    except ImportError:  # pragma: no cover - not on Unix
        return float("nan")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return float(peak / 1024 if sys.platform != "darwin" else peak / 2**20)


def case_record(grid: Grid, case: Case, mode: str, result: SolveResult, wall_s: float,
                setup_s: float, built: bool, start_index: tuple[int, ...] | None, batch: int,
                warm_attempt: int = 0, extra: tuple[tuple[int, ...], ...] = (),
                set_aside: str = "not unique") -> dict[str, Any]:
    """A case's journal record. ``warm_attempt``: iterations of a warm start given up for a
    solve from zero (``set_aside`` says why: not unique, or not converged); they count in
    ``iterations``. ``extra``: the other neighbours of a secant or parallelogram start
    (``predictors``)."""
    start = start_text(grid, start_index, extra, case.axes)
    if warm_attempt:
        start = f"zero ({set_aside}: the warm start was set aside)"
    elif start_index is not None and result.iterations == 1 and result.indicator == 0.0:
        # η = 0 at once: the state is zero (a warm start dropped, ``latin.guards.
        # drop_unloaded_starts``, or a neighbour's zero fields)
        start = "zero (nothing loads it)"
    params = {name: case.mu[name] for name in grid}
    text = ", ".join(f"{k}={v:g}" for k, v in params.items())
    iterations = int(result.iterations) + warm_attempt
    undetermined = [m.describe() for m in result.free_motions if m.reaches_last_step]
    slips = [s.describe() for s in result.large_slips]
    status = ("converged" if result.converged else f"NOT CONVERGED ({result.failure})")
    return {
        "mode": mode,
        "number": case.number,
        "chain": case.chain,
        "index": list(case.index),
        "params": params,
        "converged": bool(result.converged),
        "unique": bool(result.unique),
        "free_motions": undetermined,
        # the QoIs with a value the discrete problem does not determine (``SolveResult.
        # qoi_determined``), each shaped as its value: False there
        "qoi_determined": {name: value for name, value in result.qoi_determined.items()
                           if not np.all(value)},
        "large_slips": slips,
        "iterations": iterations,
        "indicator": float(result.indicator),
        "wall_s": wall_s,
        "setup_s": setup_s,
        "operators_built": built,
        "start": start,
        "batch": batch,
        "peak_rss_mb": peak_memory_mb(),
        "qoi": result.qoi,
        "qoi_error": result.qoi_error,
        "stopped_on_qoi": bool(result.stopped_on_qoi),
        "state_change": (float(result.state_change) if np.isfinite(result.state_change)
                         else None),
        "log": (f"{mode} #{case.number + 1} ({text}): {status} in "
                f"{iterations} iterations, eta={result.indicator:.2e}, "
                f"{wall_s:.3f} s{f' (share of a batch of {batch})' if batch > 1 else ''}, "
                f"start: {start}, operators {'built' if built else 'reused'}"
                + ("; NOT UNIQUE: " + "; ".join(undetermined) if undetermined else "")
                + ("; LARGE SLIP: " + "; ".join(slips) if slips else "")),
    }
