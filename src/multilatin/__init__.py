"""multilatin: parametric studies of elastic assemblies with frictional contact, by the
micro-macro LATIN domain decomposition method (Boucard, Buytet & Guidault, 2007).

The package is laid out by the method's layers, each a folder ("room") that imports only
the rooms below it (a test walks the imports and fails on a cycle):

- ``errors``, ``parameters``, ``limits``: the vocabulary every room uses;
- ``fem``: meshes, plane elasticity, level sets, X-FEM;
- ``decomposition``: substructures, interfaces, holes, quantities of interest, results;
- ``io``: model files, expressions, VTK/JSON output, plots;
- ``latin``: the LATIN solver; ``reference``: the independent reference solvers;
- ``model``: ``Model`` with ``solve(mu)`` and ``reference(mu)``;
- ``study``: parametric studies with multiresolution, the store and the report;
- ``cli``: the ``multilatin`` command.

The public names below are imported lazily (PEP 562), so ``import multilatin`` stays cheap
until a solver is used.
"""

from __future__ import annotations

import importlib
import logging
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

#: public name → the module that defines it
_EXPORTS = {
    "FreeMotion": "multilatin.decomposition.uniqueness",
    "Grid": "multilatin.parameters",
    "LatinOperators": "multilatin.latin.operators",
    "LatinOptions": "multilatin.latin.options",
    "Model": "multilatin.model",
    "ModelError": "multilatin.errors",
    "ModelSpec": "multilatin.io.modelfile",
    "Mu": "multilatin.parameters",
    "NotConvergedError": "multilatin.errors",
    "Parameter": "multilatin.parameters",
    "ParameterSpace": "multilatin.parameters",
    "Parameters": "multilatin.parameters",
    "SolveResult": "multilatin.decomposition.result",
    "StudyResult": "multilatin.study.runner",
    "bundled_models": "multilatin.model",
    "choose_kappa": "multilatin.study.kappa",
    "load_model": "multilatin.model",
    "run_study": "multilatin.study.runner",
    "solve_latin": "multilatin.latin.solver",
    "solve_monolithic": "multilatin.reference.monolithic",
}
__all__ = [
    "FreeMotion",
    "Grid",
    "LatinOperators",
    "LatinOptions",
    "Model",
    "ModelError",
    "ModelSpec",
    "Mu",
    "NotConvergedError",
    "Parameter",
    "ParameterSpace",
    "Parameters",
    "SolveResult",
    "StudyResult",
    "bundled_models",
    "choose_kappa",
    "load_model",
    "run_study",
    "solve_latin",
    "solve_monolithic",
]

if TYPE_CHECKING:  # for type checkers and IDEs: the same names, eagerly
    from .decomposition.result import SolveResult
    from .decomposition.uniqueness import FreeMotion
    from .errors import ModelError, NotConvergedError
    from .io.modelfile import ModelSpec
    from .latin.operators import LatinOperators
    from .latin.options import LatinOptions
    from .latin.solver import solve_latin
    from .model import Model, bundled_models, load_model
    from .parameters import Grid, Mu, Parameter, Parameters, ParameterSpace
    from .reference.monolithic import solve_monolithic
    from .study.kappa import choose_kappa
    from .study.runner import StudyResult, run_study


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'multilatin' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_EXPORTS])


logging.getLogger(__name__).addHandler(logging.NullHandler())
