"""multilatin: parametric studies of elastic assemblies with frictional contact, by the
micro-macro LATIN domain decomposition method (Boucard, Buytet & Guidault, 2007)."""

from __future__ import annotations

import logging

from .errors import ModelError, NotConvergedError
from .latin import LatinOptions, solve_latin
from .model import Model, bundled_models, load_model
from .monolithic import solve_monolithic
from .operators import LatinOperators
from .parameters import Grid, Mu, Parameter, Parameters, ParameterSpace
from .result import SolveResult
from .runner import StudyResult, run_study
from .spec import ModelSpec
from .uniqueness import FreeMotion

__version__ = "0.1.0"
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
    "load_model",
    "run_study",
    "solve_latin",
    "solve_monolithic",
]

logging.getLogger(__name__).addHandler(logging.NullHandler())
