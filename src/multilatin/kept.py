"""``Kept``: a small least-recently-used map for what a study computes once and its cases
share (meshes' arrays, element stiffnesses, orderings), safe across threads."""

from __future__ import annotations

import threading
import weakref
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

Key = TypeVar("Key", bound=Hashable)
Value = TypeVar("Value")


class Kept(Generic[Key, Value]):
    """Values by key, each computed once by ``get`` (outside the lock: two threads may both
    compute a missing value, the first one kept), the least recently used forgotten beyond
    ``size``."""

    #: every map made, so that a benchmark can forget them all (``clear_all``)
    _made: weakref.WeakSet[Kept[object, object]] = weakref.WeakSet()

    def __init__(self, size: int) -> None:
        self.size = size
        self._values: OrderedDict[Key, Value] = OrderedDict()
        self._lock = threading.Lock()
        Kept._made.add(self)  # type: ignore[arg-type]

    def get(self, key: Key, compute: Callable[[], Value]) -> Value:
        with self._lock:
            if key in self._values:
                self._values.move_to_end(key)
                return self._values[key]
        value = compute()
        with self._lock:
            value = self._values.setdefault(key, value)
            while len(self._values) > self.size:
                self._values.popitem(last=False)
        return value

    def clear(self) -> None:
        with self._lock:
            self._values.clear()

    @classmethod
    def clear_all(cls) -> None:
        """Forget every map's values: the process then builds as a fresh one does."""
        for kept in list(cls._made):
            kept.clear()

    def __len__(self) -> int:
        return len(self._values)
