"""The mixed decomposition (paper §2.1–2.2): an ``Assembly`` of substructures and
interfaces with every parameter evaluated (``assembly``), the interface fields' discretisation
and macro basis (``interfaces``), holes placed by level set (``holes``), quantities of
interest (``qoi``), free rigid motions at the friction limit (``uniqueness``) and the solver
result both solvers return (``result``).

May import: ``fem``, ``errors``, ``parameters``, ``limits``. Not the solvers: the LATIN
solver and the reference solvers both build on this room and stay independent of each other.
"""

from .assembly import Assembly, Interface, Substructure
from .result import InterfaceFields, SolveResult

__all__ = ["Assembly", "Interface", "InterfaceFields", "SolveResult", "Substructure"]
