"""The LATIN solver (paper §2.3–4; method.md §4): options (``options``), the
geometry-dependent linear-stage operators and the macro problem (``operators``; each
substructure's condensed operator from ``condensation``), the local
stage's closed-form interface behaviours (``local_stage``), their compiled point-wise kernels
(``kernels``, Numba when installed), Anderson mixing (``acceleration``) and the iteration
itself (``solver``).

May import: ``decomposition``, ``fem``, ``errors``, ``limits``. Not ``reference`` (the
references must stay an independent check) nor ``io``/``study``.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .operators import LatinOperators
    from .options import LatinOptions
    from .signatures import operator_signature
    from .solver import solve_latin, solve_latin_batch

#: loaded on first use, so that ``LatinOptions`` comes without the solver's imports
_EXPORTS = {"LatinOperators": "operators", "operator_signature": "signatures",
            "LatinOptions": "options", "solve_latin": "solver", "solve_latin_batch": "solver"}

__all__ = ["LatinOperators", "LatinOptions", "operator_signature", "solve_latin",
           "solve_latin_batch"]


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{_EXPORTS[name]}"), name)
    globals()[name] = value
    return value
