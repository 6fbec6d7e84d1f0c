"""What a batch of LATIN iterations keeps per case (``IterationState``): the fields of the
cases that left, their η histories, and ring buffers of their last ``RECENT`` iterations'
tracked QoIs and η, which the QoIs' error estimates read (``tracking``)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from ..fem.elasticity import FloatArray, IntArray
from .tracking import WINDOW, estimates_after

#: the iterations of tracked QoIs an error estimate reads (``tracking.error_estimates``)
RECENT = WINDOW + 5

#: the per-case arrays of ``IterationState`` (first axis: the case)
PER_CASE = ("qoi_recent", "eta_recent", "qoi_scale", "qoi_terms", "qoi_reported",
            "stopped_on_qoi", "drifting", "first_size", "qoi_settled_error", "settled_steps",
            "force_eta", "jumped_at", "jump_rate", "warm")


@dataclass
class IterationState:
    """Per case: s = (W, F), ŝ = (Ŵ, F̂) at exit and the history of η; batch timings."""

    #: per case that left: (W, F, Ŵ, F̂), each (n_steps, n_points, 2)
    exits: dict[int, tuple[FloatArray, FloatArray, FloatArray, FloatArray]]
    histories: list[list[float]]
    #: per case, the tracked QoIs of its last ``RECENT`` iterations (n_cases, RECENT, n_qoi,
    #: n_steps) and their η, written round the buffer (its iteration i at (i − 1) % RECENT)
    qoi_recent: FloatArray
    eta_recent: FloatArray
    #: per case, of its last ``RECENT`` iterations and QoI: the largest |value| over the
    #: steps, round the buffer as ``qoi_recent`` (``QOI_FLOOR``)
    qoi_scale: FloatArray
    #: per case, QoI and step: ``CANCELLED`` × the size of the QoI's terms at the last
    #: iteration (``QoiFunctionals.magnitudes``), the QoI rule's floor for a small rest
    qoi_terms: FloatArray
    #: per case, QoI and step: whether the QoI reports that step (``QoiFunctionals.reported``)
    qoi_reported: npt.NDArray[np.bool_]
    stopped_on_qoi: npt.NDArray[np.bool_]  # per case: stopped by ``qoi_rtol`` before η < tol
    sizes: list[list[float]]  # per case, ½(‖s‖ + ‖ŝ‖) after each iteration
    drifting: npt.NDArray[np.bool_]  # per case: stopped as s grows without bound
    #: per case: ½(‖s‖ + ‖ŝ‖) after its first iteration (``sizes[c][0]``, as an array for
    #: the blow-up check of every step, ``guards.blows_up``)
    first_size: FloatArray = field(default_factory=lambda: np.zeros(0))
    #: per case, QoI and step: the estimate a settled step had when it settled (its QoIs
    #: move no more, so the estimate from their increments would read zero; ``settled``)
    qoi_settled_error: FloatArray = field(default_factory=lambda: np.zeros((0, 0, 0)))
    #: per case: its leading steps settled (``engine.NumpyFields.settle``)
    settled_steps: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    #: per case that left at the cap with η < tol: its forces' η_F where above its bound
    #: (``guards.forces_unsettled``: not converged), else 0
    force_eta: FloatArray = field(default_factory=lambda: np.zeros(0))
    #: per case: the iteration after which it last jumped (``sliding``), −1: none
    jumped_at: IntArray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    #: per case: its last geometric jump's slowest rate per iteration (``sliding``), 0: none
    jump_rate: FloatArray = field(default_factory=lambda: np.zeros(0))
    #: per case: started from fields other than zero (``guards.vanishes``)
    warm: npt.NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, dtype=bool))
    t_linear: float = 0.0  # linear stage, macro problem included
    t_local: float = 0.0
    t_macro: float = 0.0

    @classmethod
    def empty(cls, reported: npt.NDArray[np.bool_]) -> IterationState:
        """Room for the cases of ``reported`` (n_cases, n_qoi, n_steps)."""
        n_cases, n_qoi, n_steps = reported.shape
        return cls({}, [[] for _ in range(n_cases)], np.zeros((n_cases, RECENT, n_qoi, n_steps)),
                   np.zeros((n_cases, RECENT)), np.zeros((n_cases, RECENT, n_qoi)),
                   np.zeros(reported.shape), reported,
                   np.zeros(n_cases, dtype=bool), [[] for _ in range(n_cases)],
                   np.zeros(n_cases, dtype=bool), np.zeros(n_cases), np.zeros(reported.shape),
                   np.zeros(n_cases, dtype=np.int64), np.zeros(n_cases),
                   np.full(n_cases, -1, dtype=np.int64), np.zeros(n_cases),
                   np.zeros(n_cases, dtype=bool))

    def extend(self, reported: npt.NDArray[np.bool_]) -> None:
        """Room for more cases after these (cases joining a rolling batch): the per-case
        arrays grow by doubling, so that many joins cost linear time."""
        first, n_new = len(self.histories), reported.shape[0]
        if first + n_new > self.stopped_on_qoi.size:
            capacity = max(2 * self.stopped_on_qoi.size, first + n_new)
            for name in PER_CASE:
                old = getattr(self, name)
                grown = np.zeros((capacity, *old.shape[1:]), dtype=old.dtype)
                grown[:old.shape[0]] = old
                setattr(self, name, grown)
        self.qoi_reported[first:first + n_new] = reported
        self.histories += [[] for _ in range(n_new)]
        self.sizes += [[] for _ in range(n_new)]

    def recent_qoi(self, case: int, iterations: int) -> FloatArray:
        """The tracked QoIs of the case's last iterations (at most ``RECENT``), oldest first."""
        return np.asarray(self.qoi_recent[case, held_slots(iterations)], dtype=np.float64)

    def settled(self, case: int, iterations: int, steps: slice,
                since: int | None = None) -> None:
        """The case's ``steps`` settled after ``iterations``: keep their QoIs' estimate
        now (``estimates``), which their frozen values would read as zero from here on."""
        self.settled_steps[case] = steps.stop
        if self.qoi_recent.shape[2]:
            self.qoi_settled_error[case][:, steps] = self.estimates(case, iterations,
                                                                    since)[:, steps]

    def estimates(self, case: int, iterations: int, since: int | None = None) -> FloatArray:
        """The case's QoIs' error estimates (n_qoi, n_steps) after ``iterations``; those
        after its jump (``sliding``) alone if it jumped after iteration ``since``, within
        the iterations held (``tracking.estimates_after``)."""
        return estimates_after(self.recent_qoi(case, iterations),
                               self.eta_recent[case, held_slots(iterations)],
                               None if since is None else iterations - since,
                               float(self.jump_rate[case]))


def held_slots(iterations: int) -> IntArray:
    """Where the last iterations (at most ``RECENT``) sit in the ring buffers, oldest first
    (iteration i at (i − 1) % RECENT)."""
    held = min(iterations, RECENT)
    return np.roll(np.arange(RECENT), -(iterations % RECENT))[RECENT - held:]
