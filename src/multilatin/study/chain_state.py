"""What a multiresolution chain carries from batch to batch: the converged interface fields
of its latest cases by grid index (``ChainState``), the nearest of them to start a case from,
and the bounded part a study's store keeps for a resume."""

from __future__ import annotations

import functools
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..fem.elasticity import FloatArray


def nearest_index(indices: Sequence[tuple[int, ...]], index: tuple[int, ...]
                  ) -> tuple[tuple[int, ...] | None, int | None]:
    """Of ``indices`` (oldest first), the one nearest ``index`` in grid steps (L1; ties: the
    latest), never ``index`` itself, and its distance; (None, None) when there is none."""
    best, best_distance = None, None
    for other in reversed(indices):
        if other == index:
            continue
        distance = sum(abs(a - b) for a, b in zip(other, index, strict=True))
        if best_distance is None or distance < best_distance:
            best, best_distance = other, distance
    return best, best_distance


#: converged cases a chain's stored state keeps (``ChainState.stored``): the most that
#: ``_retained_capacity`` asks for
STORED_CASES = 64


@dataclass
class ChainState:
    """What a chain carries from case to case: the converged interface fields ŝ of its
    latest converged cases, by grid index (most recent last)."""

    capacity: int = 32
    retained: OrderedDict[tuple[int, ...], tuple[FloatArray, FloatArray]] = field(
        default_factory=OrderedDict)
    #: retained cases flagged not unique: a case at the same frictions one hole position
    #: away starts from zero (``predictors.not_unique_beside``)
    unsettled: frozenset[tuple[int, ...]] = frozenset()

    def nearest(self, index: tuple[int, ...]) -> tuple[tuple[int, ...] | None,
                                                      tuple[FloatArray, FloatArray] | None]:
        """The retained case nearest to ``index`` (``nearest_index``), never ``index``
        itself: a case recomputed after its record was lost must not start from its own
        earlier answer."""
        near = self._one_step(index)
        best = (max(near, key=self._positions.__getitem__) if near else
                nearest_index(list(self.retained), index)[0])
        return (best, self.retained[best]) if best is not None else (None, None)

    def _one_step(self, index: tuple[int, ...]) -> list[tuple[int, ...]]:
        """The retained cases one grid step from ``index``, by lookup (a torch wavefront
        retains thousands of cases): the scan's nearest whenever there is one."""
        return [n for d in range(len(index)) for n in (
            index[:d] + (index[d] - 1,) + index[d + 1:],
            index[:d] + (index[d] + 1,) + index[d + 1:]) if n in self.retained]

    @functools.cached_property
    def _positions(self) -> dict[tuple[int, ...], int]:
        """Each retained index's place, oldest first (a state is not changed once made:
        ``added`` and ``keeping`` make new ones)."""
        return {index: n for n, index in enumerate(self.retained)}

    def distance(self, index: tuple[int, ...]) -> int | None:
        """Grid steps (L1) to the nearest retained case other than ``index``; None when
        there is none."""
        return 1 if self._one_step(index) else nearest_index(list(self.retained), index)[1]

    def added(self, index: tuple[int, ...], fields: tuple[FloatArray, FloatArray],
              unsettled: bool = False) -> ChainState:
        """A new state with ``fields`` retained, flagged ``unsettled`` or not (this one is
        left unchanged: distributed tasks share their inputs)."""
        return self.added_all([(index, fields, unsettled)])

    def added_all(self, cases: Sequence[tuple[tuple[int, ...], tuple[FloatArray, FloatArray],
                                              bool]]) -> ChainState:
        """``added`` for several cases (index, fields, unsettled) in order, copying the
        retained ones once (a torch wavefront adds thousands at a time)."""
        retained = OrderedDict(self.retained)
        flagged = set(self.unsettled)
        for index, fields, unsettled in cases:
            retained[index] = fields
            retained.move_to_end(index)
            (flagged.add if unsettled else flagged.discard)(index)
        while len(retained) > self.capacity:
            retained.popitem(last=False)
        return ChainState(self.capacity, retained, frozenset(flagged & retained.keys()))

    def keeping(self, retained: OrderedDict[tuple[int, ...], tuple[FloatArray, FloatArray]],
                unsettled: frozenset[tuple[int, ...]] | None = None,
                capacity: int | None = None) -> ChainState:
        """These retained cases, with their flags (this state's, or ``unsettled``)."""
        flagged = (self.unsettled if unsettled is None else unsettled) & retained.keys()
        return ChainState(capacity or self.capacity, retained, frozenset(flagged))

    def stored(self, limit: int = STORED_CASES) -> ChainState:
        """The ``limit`` most recent retained cases, with their flags: what a study's store
        keeps for a resume. A torch wavefront retains two batches' worth (a 1 625-case B3
        batch: 1.5 GB of fields), which writing every batch to disk, and on Dask sending to
        the client, would cost more than the iterations; a resumed chain starts its next
        cases from the nearest of these, or from zero."""
        if len(self.retained) <= limit:
            return self
        return self.keeping(OrderedDict(list(self.retained.items())[-limit:]))

    def to_arrays(self) -> dict[str, FloatArray]:
        out: dict[str, FloatArray] = {"capacity": np.array(self.capacity)}
        for n, (index, (w_hat, f_hat)) in enumerate(self.retained.items()):
            out[f"index_{n}"] = np.array(index)
            out[f"w_hat_{n}"] = w_hat
            out[f"f_hat_{n}"] = f_hat
        if self.unsettled:
            out["unsettled"] = np.array(sorted(self.unsettled))
        return out

    @classmethod
    def from_arrays(cls, arrays: dict[str, FloatArray]) -> ChainState:
        state = cls(int(arrays["capacity"]))
        n = 0
        while f"index_{n}" in arrays:
            index = tuple(int(i) for i in arrays[f"index_{n}"])
            state.retained[index] = (arrays[f"w_hat_{n}"], arrays[f"f_hat_{n}"])
            n += 1
        if "unsettled" in arrays:
            state = state.keeping(state.retained, frozenset(
                tuple(int(i) for i in row) for row in arrays["unsettled"]))
        return state
