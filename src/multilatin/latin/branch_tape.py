"""A record of the branches the contact local stage takes (``LocalStage.tape``): replayed,
the local stage is the affine map of those statuses (``benchmarks/frozen_krylov.py``)."""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt


class BranchTape:
    """The branches the contact local stage takes (contact or open, stop closed, stick or
    slip with its direction and the sign of N), in the order it takes them. The local stage
    is piecewise affine in (W, F); replaying a tape gives the affine map of those branches
    (statuses frozen), which a Krylov method can solve exactly
    (``benchmarks/frozen_krylov.py``)."""

    def __init__(self) -> None:
        self.entries: list[npt.NDArray[Any]] = []
        self.replaying = False
        self.position = 0

    def decide(self, value: npt.NDArray[Any]) -> npt.NDArray[Any]:
        if not self.replaying:
            self.entries.append(value)
            return value
        out = self.entries[self.position]
        self.position += 1
        return out

    def replay(self) -> None:
        """Read the recorded branches back from the start at the next local stage."""
        self.replaying = True
        self.position = 0

    def same_statuses(self, other: BranchTape) -> bool:
        """Whether ``other`` took the same branches: the same statuses, and slip in the same
        direction where it slips (a direction follows its slip mask on the tape)."""
        if len(self.entries) != len(other.entries):
            return False
        for i, (a, b) in enumerate(zip(self.entries, other.entries, strict=True)):
            if a.dtype == np.bool_:
                if not np.array_equal(a, b):
                    return False
            elif np.any(self.entries[i - 1] & (np.sum(a * b, axis=-1) <= 0.0)):
                return False
        return True
