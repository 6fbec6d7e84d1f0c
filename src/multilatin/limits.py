"""Guards before work: estimate the memory (and time) a model or a study needs before building
it, and refuse what would not fit, with the estimate and the way to raise the limit; and
refuse data whose scale the solver's norms cannot represent in double precision
(``check_scale``, called by ``solve_latin`` before iterating).

The limit is ``MULTILATIN_MAX_MEMORY_GB`` when set (the command line's ``--max-memory-gb``
sets it), else 80 % of the memory available now.

The per-substructure estimate follows what the operators hold (``operators.LatinOperators``),
calibrated on square Q4 substructures (24² to 192² elements: factor entries per unknown
77, 142, 239, 313; build peak 1.97 GB measured against 1.84 GB estimated at 192²):
the sparse factor of K_E + Tᵀ M0 k T (≈ 25 log2(n) entries of 12 bytes per unknown), the
dense right-hand side and solution of the condensation (n × q doubles, twice) and the dense
condensed operator (q² doubles), with n the unknowns and q the interface unknowns.

Base room: imports only ``errors`` at run time (the solver's types for type checking only).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from .errors import ModelError

if TYPE_CHECKING:  # types only: the solver's modules import this one
    from .decomposition.assembly import Assembly
    from .decomposition.interfaces import InterfacePoints
    from .fem.elasticity import FloatArray
    from .latin.local_stage import LocalStage

MEMORY_ENVIRONMENT = "MULTILATIN_MAX_MEMORY_GB"
#: how many processes share this machine's memory and device for their batches (a local Dask
#: cluster's workers get their number): each batch then takes its share of the budget
DEVICE_SHARE_ENVIRONMENT = "MULTILATIN_DEVICE_SHARE"
#: a grid parameter may take at most this many values (a guard against a typo in a count)
MAX_VALUES_PER_PARAMETER = 1_000_000
#: bytes a study keeps per case and mode (its plan entry, journal record and dataset cells),
#: measured order of magnitude for B1 (15 steps, three QoIs)
BYTES_PER_CASE = 8_000
#: effective speed of the triangular solves of the condensation (bytes-bound), flop/s
CONDENSATION_FLOPS = 2e9
#: the indicator's norm squares fields scaled by √k and 1/√k: data whose scaled size leaves
#: this window would overflow or underflow in double precision
SCALE_RANGE = (1e-120, 1e120)


def available_memory() -> float:
    """Bytes of memory available now (Linux ``MemAvailable``; 8 GiB when unknown)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as handle:
            for line in handle:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except OSError:  # pragma: no cover - not Linux
        pass
    return 8.0 * 2**30  # pragma: no cover


def memory_limit() -> tuple[float, str]:
    """The limit in bytes and where it comes from."""
    text = os.environ.get(MEMORY_ENVIRONMENT)
    if text:
        try:
            value = float(text)
        except ValueError:
            raise ModelError(f"{MEMORY_ENVIRONMENT}: expected a number of GB, got {text!r}"
                             ) from None
        if not value > 0 or not math.isfinite(value):
            raise ModelError(f"{MEMORY_ENVIRONMENT}: must be a number > 0, got {text!r}")
        return value * 1e9, f"{MEMORY_ENVIRONMENT} = {text}"
    return 0.8 * available_memory(), "80 % of the memory available now"


def device_share() -> int:
    """How many processes share the memory a batch's fields are sized against
    (``MULTILATIN_DEVICE_SHARE``, 1 when unset)."""
    text = os.environ.get(DEVICE_SHARE_ENVIRONMENT, "").strip()
    if not text:
        return 1
    try:
        share = int(text)
    except ValueError:
        share = 0
    if share < 1:
        raise ModelError(f"{DEVICE_SHARE_ENVIRONMENT}: expected a number of processes >= 1, "
                         f"got {text!r}")
    return share


def batch_memory(free: float, total: float, source: str) -> tuple[float, str]:
    """The memory one process's batch may size its fields against: ``free`` bytes (from
    ``source``) of ``total``, at most ``MULTILATIN_MAX_MEMORY_GB`` where set, and at most
    its share of the whole (``total`` or that limit) where ``device_share()`` processes
    share it: they start their batches at once, and each seeing the whole free would
    overfill it."""
    if os.environ.get(MEMORY_ENVIRONMENT):
        cap, cap_source = memory_limit()
        total = min(total, cap)
        if cap < free:
            free, source = cap, cap_source
    share = device_share()
    if share > 1 and total / share < free:
        free, source = total / share, (f"{total / share / 2**30:.1f} GiB, one process's "
                                       f"share ({DEVICE_SHARE_ENVIRONMENT} = {share}) of "
                                       f"{source}")
    return free, source


def _refuse(what: str, needed: float, seconds: float | None = None) -> None:
    limit, source = memory_limit()
    if needed <= limit:
        return
    took = f" and about {_duration(seconds)}" if seconds is not None else ""
    raise ModelError(
        f"{what}: needs about {needed / 1e9:.3g} GB of memory{took}, above the limit of "
        f"{limit / 1e9:.3g} GB ({source}); make it smaller, or raise the limit with "
        f"--max-memory-gb (or {MEMORY_ENVIRONMENT})")


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.3g} h"


def substructure_cost(nx: int, ny: int) -> tuple[float, float, float]:
    """(bytes kept, bytes at the peak of its build, seconds to build) for a Q4 substructure
    of ``nx`` × ``ny`` elements (see the module's docstring)."""
    unknowns = 2.0 * (nx + 1) * (ny + 1)
    interface = 2.0 * 2.0 * (nx + ny + 2)
    factor_entries = 25.0 * math.log2(max(unknowns, 2.0)) * unknowns
    kept = 12.0 * factor_entries + 8.0 * interface**2
    transient = 16.0 * unknowns * interface
    seconds = 2.0 * factor_entries * interface / CONDENSATION_FLOPS
    return kept, kept + transient, seconds


def check_meshes(element_counts: Sequence[tuple[str, int, int]]) -> None:
    """Refuse meshes whose operators would not fit in memory; ``element_counts`` holds
    (substructure, nx, ny) per substructure."""
    if not element_counts:
        return
    costs = [substructure_cost(nx, ny) for _, nx, ny in element_counts]
    kept = sum(c[0] for c in costs)
    peak = max(c[1] - c[0] for c in costs)
    seconds = sum(c[2] for c in costs)
    largest = max(range(len(costs)), key=lambda i: costs[i][1])
    name, nx, ny = element_counts[largest]
    _refuse(f"the model's meshes ({len(costs)} substructure(s), the largest {name!r} with "
            f"{nx} x {ny} elements)", kept + peak, seconds)


def check_grid_count(item: str, count: int) -> None:
    if count > MAX_VALUES_PER_PARAMETER:
        raise ModelError(f"--grid {item!r}: {count} values, at most "
                         f"{MAX_VALUES_PER_PARAMETER} per parameter")


def check_study(cases: int, modes: int) -> None:
    """Refuse a study whose bookkeeping alone would not fit in memory."""
    _refuse(f"the study ({cases} cases x {modes} mode(s))", float(cases) * modes
            * BYTES_PER_CASE)


def check_scale(assemblies: Sequence[Assembly], points: InterfacePoints, k: FloatArray,
                local: LocalStage) -> None:
    """Refuse, before iterating, data whose size the solver cannot represent: the indicator
    squares F/√k and W√k (paper §4.3), so prescribed forces, displacements and gaps scaled
    so, and k itself, must stay inside ``SCALE_RANGE``."""
    k_min, k_max = float(k.min()), float(k.max())
    young = [s.material.young for a in assemblies for s in a.substructures]
    if not SCALE_RANGE[0] <= k_min <= k_max <= SCALE_RANGE[1]:
        raise ModelError(
            f"the search direction k = κ E / L runs from {k_min:.3g} to {k_max:.3g} (E from "
            f"{min(young):.3g} to {max(young):.3g}): beyond what double precision represents "
            f"(k must stay within [{SCALE_RANGE[0]:g}, {SCALE_RANGE[1]:g}]); rescale the "
            "units of the model (e.g. mm, N, MPa)")
    root_w = np.sqrt(points.weights)
    root_k = np.sqrt(k)
    sizes: list[tuple[float, str]] = []
    boundary = local.boundary
    if boundary.size:
        scaled = np.where(local.is_displacement, root_k[boundary] * root_w[boundary, None],
                          root_w[boundary, None] / root_k[boundary])
        values = np.abs(local.prescribed) * scaled
        at = np.unravel_index(int(np.argmax(values)), values.shape)
        point = int(boundary[at[2]])
        itf = assemblies[int(at[0])].interfaces[int(points.interface[point])]
        kind = "displacement" if local.is_displacement[at[2], at[3]] else "force"
        sizes.append((float(values.max()), f"prescribed {kind} {local.prescribed[at]:.3g} on "
                                           f"boundary {itf.name!r}"))
    for gaps, where in ((local.gap_contact, points.contact_pairs[0]),
                        (local.gap_stop, points.stops)):
        if gaps.size:
            scaled_gap = np.abs(gaps) * (root_k[where].max(axis=1) * root_w[where])
            sizes.append((float(scaled_gap.max()), f"a gap of {float(np.abs(gaps).max()):.3g}"))
    for size, what in sizes:
        if size > SCALE_RANGE[1] or 0 < size < SCALE_RANGE[0]:
            raise ModelError(
                f"{what}: with the search direction k from {k_min:.3g} to {k_max:.3g} the "
                f"solver's norms would {'overflow' if size > 1 else 'underflow'} in double "
                f"precision (scaled size {size:.3g} outside [{SCALE_RANGE[0]:g}, "
                f"{SCALE_RANGE[1]:g}]); rescale the units of the model (e.g. mm, N, MPa)")
