"""BLAS on one thread where the work is many small dense products (the iteration, a
substructure's condensation): there BLAS threads cost more than they give."""

from __future__ import annotations

import functools
from typing import Any

from threadpoolctl import ThreadpoolController

__all__ = ["one_blas_thread"]


@functools.cache
def _blas_controller() -> ThreadpoolController:
    """One inspection of the loaded BLAS libraries per process (``threadpool_limits``
    repeated it on every solve: 1.4 % of a B1 study)."""
    return ThreadpoolController()


def one_blas_thread() -> Any:
    """A context in which BLAS runs on one thread: measured 3 × slower per iteration with 2
    OpenBLAS threads on b1-9; a substructure's condensation (``condensation.condense``)
    has dense blocks of the interface's size only."""
    return _blas_controller().limit(limits=1, user_api="blas")
