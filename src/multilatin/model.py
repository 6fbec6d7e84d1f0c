"""The public model object: a validated model file with ``solve(mu)`` and ``reference(mu)``.

Joins the rooms below it (``io`` for the file, ``latin`` and ``reference`` for the solvers,
imported when first used); ``study`` and ``cli`` build on it.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

from .decomposition.assembly import Assembly
from .decomposition.result import SolveResult
from .errors import ModelError
from .fem.mesh import RectMesh
from .io.modelfile import ModelSpec
from .parameters import Mu, Parameters

if TYPE_CHECKING:
    from .latin import LatinOptions

Split = Mapping[str, tuple[int, int]]


class Model:
    """An assembly model with named parameters.

    >>> model = load_model("b0")
    >>> result = model.solve({"P": 100.0})          # LATIN micro-macro
    >>> reference = model.reference({"P": 100.0})   # monolithic finite elements
    """

    def __init__(self, spec: ModelSpec) -> None:
        self.spec = spec

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def title(self) -> str:
        return self.spec.title

    @property
    def units(self) -> dict[str, str]:
        """The unit of each parameter and quantity of interest ("" where the file gives none)."""
        return self.spec.units

    @property
    def parameters(self) -> Parameters:
        return self.spec.parameters

    def with_defaults(self, values: Mapping[str, float]) -> Model:
        """The same model with other default values (each checked) for some parameters."""
        mu = self.parameters.parse(values)
        params = Parameters({name: dataclasses.replace(p, default=mu[name])
                             for name, p in self.parameters.items()})
        return Model(dataclasses.replace(self.spec, parameters=params))

    def with_mortar(self) -> Model:
        """The same model with every interface declared ``type = "macro"`` (non-matching
        meshes joined by macro quantities only, paper eq. [20]) made a perfect interface
        joined by mortar projection, which transmits the micro forces too
        (``decomposition.mortar``). A discretisation choice: the parameters are unchanged."""
        data = copy.deepcopy(dict(self.spec.data))
        changed = 0
        for table in data.get("interfaces", []):
            if isinstance(table, dict) and table.get("type") == "macro":
                table["type"] = "perfect"
                changed += 1
        if not changed:
            raise ModelError(f"model {self.name!r}: no interface of type 'macro' to make a "
                             "mortar interface")
        data["title"] = f"{self.title} (mortar interfaces)"
        return Model(ModelSpec.from_dict(data, name=f"{self.name}-mortar",
                                         source=self.spec.source))

    def assemble(self, mu: Mu | Mapping[str, float] | None = None, *, refine: int = 1,
                 split: Split | None = None) -> Assembly:
        return self.spec.build(mu, refine=refine, split=split)

    def solve(self, mu: Mu | Mapping[str, float] | None = None, *,
              options: LatinOptions | None = None, refine: int = 1,
              split: Split | None = None, check: bool = True) -> SolveResult:
        """LATIN micro-macro solution for parameters ``mu`` (defaults for the others)."""
        from .latin import solve_latin  # the solvers load on first use, not with the model

        return solve_latin(self.assemble(mu, refine=refine, split=split), options, check=check)

    def reference(self, mu: Mu | Mapping[str, float] | None = None, *, refine: int = 1,
                  split: Split | None = None, mesh: str = "auto") -> SolveResult:
        """Monolithic finite-element solution.

        mesh: ``"same"``: on the same meshes as LATIN (holes by level set too; non-matching
            meshes joined by the same mortar constraint; not macro-only interfaces);
            ``"conforming"``: every holed body meshed with the hole cut out (gmsh,
            ``multilatin.conforming``), one substructure per body; ``"auto"``: conforming
            when the model has holes in structured rectangles or macro-only interfaces,
            else the same meshes (a hole in a mesh file is not meshed again).
        """
        if mesh not in REFERENCE_MESHES:
            raise ModelError(f"mesh: expected one of {REFERENCE_MESHES}, got {mesh!r}")
        assembly = self.assemble(mu, refine=refine, split=split)
        if mesh == "auto":  # holes in mesh files: X-FEM on the same meshes (no remeshing)
            special = any(s.hole is not None and isinstance(s.mesh, RectMesh)
                          for s in assembly.substructures) or any(
                itf.kind == "macro" for itf in assembly.interfaces)
            mesh = "conforming" if special else "same"
        if mesh == "conforming":
            from .reference.conforming import conforming_assembly

            assembly = conforming_assembly(self.spec, assembly, refine=refine)
        from .reference.monolithic import solve_monolithic

        return solve_monolithic(assembly)


REFERENCE_MESHES = ("auto", "same", "conforming")


def bundled_models() -> list[str]:
    """Names of the models shipped with multilatin."""
    folder = resources.files("multilatin") / "models"
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def load_model(name_or_path: str | Path) -> Model:
    """A bundled model by name (``"b0"``) or a model file by path."""
    text = str(name_or_path)
    if text in bundled_models():
        folder = resources.files("multilatin") / "models"
        resource = folder / f"{text}.toml"
        return Model(ModelSpec.from_string(resource.read_text(encoding="utf-8"), name=text,
                                           source=f"bundled:{text}", folder=Path(str(folder))))
    path = Path(text)
    if not path.exists():
        raise ModelError(
            f"model {text!r}: no such file and no bundled model of that name "
            f"(bundled: {', '.join(bundled_models())})"
        )
    return Model(ModelSpec.from_toml(path))
