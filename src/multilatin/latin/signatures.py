"""Digests that key the operators a study reuses: ``interface_signature`` (what the
interface points, the search direction and the macro basis depend on) and
``operator_signature`` (those and the substructures' stiffnesses), and ``digest`` of arrays
and other parts (``LatinOperators``' kept interface terms)."""

from __future__ import annotations

import hashlib
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp

from ..decomposition.assembly import Assembly
from ..decomposition.interfaces import free_macro_components
from ..kept import Kept

if TYPE_CHECKING:
    from .options import LatinOptions

__all__ = ["digest", "interface_signature", "operator_signature", "with_substructures"]


def interface_signature(assembly: Assembly, options: LatinOptions) -> str:
    """A digest of everything the interface points, the search direction and the macro
    basis depend on: the substructures' meshes, bodies and materials, the interface topology
    and kinds (with the components that carry free macro unknowns: a stop's depend on
    whether it has friction), and the discretisation choices. Holes (inside the
    substructures), friction coefficients, gaps and loads are not in it."""
    choices = (options.kappa, options.macro, options.interface_elements,
               options.dirichlet_stiffening, options.tangential_ratio, options.search_modulus,
               options.held_nodes, options.corner_stiffening, options.corner_reach,
               options.micro_stiffening)
    key = ("interfaces", choices)
    if key not in assembly.digests:  # a study asks twice per case
        interfaces = tuple((itf.kind, itf.sides,
                            itf.condition.kinds if itf.condition else None,
                            itf.contact is not None, free_macro_components(itf))
                           for itf in assembly.interfaces)
        described = (tuple(s.description for s in assembly.substructures), interfaces, choices)

        def computed() -> str:
            text = repr((list(described[0]), list(interfaces), choices))
            return hashlib.sha1(text.encode()).hexdigest()

        # the cases of a study share it: kept by the description itself
        assembly.digests[key] = _INTERFACE_DIGESTS.get(described, computed)
    return assembly.digests[key]


def operator_signature(assembly: Assembly, options: LatinOptions) -> str:
    """A digest of everything the linear-stage operators depend on: the interfaces'
    (``interface_signature``) and the substructures' stiffnesses (holes included).
    Friction coefficients (but whether a stop has one), gaps and loads are not in it: they
    change no operator."""
    return with_substructures(interface_signature(assembly, options), assembly)


def with_substructures(interfaces: str, assembly: Assembly) -> str:
    """``operator_signature`` from the ``interface_signature`` already computed."""
    text = repr((interfaces, [s.signature() for s in assembly.substructures]))
    return hashlib.sha1(text.encode()).hexdigest()


def digest(*parts: object) -> str:
    """SHA-1 of ``parts``: arrays and sparse matrices by their bytes and shapes, anything
    else by its repr (``LatinOperators``' keys of kept interface terms)."""
    hasher = hashlib.sha1()
    for part in parts:
        if isinstance(part, np.ndarray):
            hasher.update(np.ascontiguousarray(part).tobytes())
            hasher.update(repr(part.shape).encode())
        elif isinstance(part, sp.spmatrix | sp.sparray):
            matrix = sp.csr_matrix(part)
            for array in (matrix.data, matrix.indices, matrix.indptr):
                hasher.update(np.ascontiguousarray(array).tobytes())
            hasher.update(repr(matrix.shape).encode())
        else:
            hasher.update(repr(part).encode())
    return hasher.hexdigest()


#: ``interface_signature``'s digests by what they digest (its text's repr took 0.13 ms a b3
#: case, 9 s of the whole B3 study on a GPU's host; a hash of the same tuple ~0.05)
_INTERFACE_DIGESTS: Kept[tuple[object, ...], str] = Kept(64)
