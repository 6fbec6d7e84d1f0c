"""Which cases of a batch share what (``solve_latin_batch``): one ``LatinOperators`` per
distinct geometry, and *families* of geometries that share their interfaces — the same
interface points, search direction and macro basis, their substructures differing inside
only (a hole's position) — whose cases can share one batch; and the backend that iterates
a batch (``make_engine``)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..decomposition.assembly import Assembly
from ..errors import ModelError
from ..fem.elasticity import FloatArray, IntArray
from .engine import NumpyFields
from .field_engine import FieldEngine
from .local_stage import LocalStage
from .operators import LatinOperators
from .options import LatinOptions
from .signatures import operator_signature
from .tracking import QoiFunctionals

__all__ = ["interface_families", "make_engine", "operators_per_case", "same_interfaces"]


def operators_per_case(assemblies: Sequence[Assembly], options: LatinOptions,
                       operators: LatinOperators | Sequence[LatinOperators] | None = None
                       ) -> tuple[list[LatinOperators], IntArray]:
    """The distinct operators of a batch's cases and each case's index into them.

    operators: None (built here, one per distinct geometry, each reusing the unchanged
        substructures of the one before), one ``LatinOperators`` for every case, or one per
        case. Each is checked against its case's signature. Which geometries may share a
        batch: ``interface_families``."""
    if operators is None or isinstance(operators, LatinOperators):
        given: list[LatinOperators | None] = [operators] * len(assemblies)
    else:
        given = list(operators)
        if len(given) != len(assemblies):
            raise ModelError(f"operators: expected one per case ({len(assemblies)}), got "
                             f"{len(given)}")
    distinct: dict[str, int] = {}
    built: list[LatinOperators] = []
    geometry = np.zeros(len(assemblies), dtype=np.int64)
    for c, (assembly, ops) in enumerate(zip(assemblies, given, strict=True)):
        signature = operator_signature(assembly, options)
        if ops is not None and ops.signature != signature:
            raise ModelError("operators: they were built for another geometry or search "
                             f"direction than this assembly's ({assembly.name}, case {c})")
        if signature not in distinct:
            distinct[signature] = len(built)
            built.append(ops if ops is not None else
                         LatinOperators(assembly, options, reuse=built[-1] if built else None))
        geometry[c] = distinct[signature]
    return built, geometry


def interface_families(operators: Sequence[LatinOperators]) -> IntArray:
    """Per operators, the index of its family: operators of one family act on the same
    interface points with the same search direction and macro basis (``same_interfaces``;
    their geometries differ inside the substructures only, e.g. a hole's position), so that
    their cases can share a batch."""
    heads: list[LatinOperators] = []
    family = np.zeros(len(operators), dtype=np.int64)
    for i, ops in enumerate(operators):
        found = next((j for j, head in enumerate(heads) if same_interfaces(head, ops)), None)
        if found is None:
            found = len(heads)
            heads.append(ops)
        family[i] = found
    return family


def same_interfaces(first: LatinOperators, other: LatinOperators) -> bool:
    """Both operators act on the same interface points, with the same search direction and
    macro basis: their fields can share a batch."""
    a, b = first.points, other.points
    if a.n_points != b.n_points or not all(
            np.array_equal(x, y) for x, y in ((a.coords, b.coords), (a.interface, b.interface),
                                              (a.substructure, b.substructure),
                                              (first.search_direction, other.search_direction),
                                              (first.m0, other.m0))):
        return False
    if (first.macro_basis is None) != (other.macro_basis is None):
        return False
    if first.macro_basis is None or other.macro_basis is None:
        return True
    return bool(first.macro_basis.shape == other.macro_basis.shape
                and (first.macro_basis != other.macro_basis).nnz == 0)


def make_engine(ops: LatinOperators, local: LocalStage, options: LatinOptions,
                w_hat: FloatArray, f_hat: FloatArray, macro_data: FloatArray | None,
                functionals: list[QoiFunctionals] | None,
                geometries: tuple[list[LatinOperators], IntArray]) -> FieldEngine:
    """The backend that does the iteration's field work (``LatinOptions.backend``)."""
    if options.backend == "torch":
        from .torch_engine import TorchFields  # PyTorch loads only when asked for

        return TorchFields(geometries[0], geometries[1], local, options, w_hat, f_hat,
                           macro_data, functionals)
    return NumpyFields(ops, local, options, w_hat, f_hat, macro_data, functionals,
                       geometries)
