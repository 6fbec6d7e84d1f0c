"""Model files: a TOML description of an assembly, validated with errors that name the
offending field and value. See ``docs/model-format.md`` for the format.

``ModelSpec.build(mu)`` evaluates every expression with the parameter values ``mu`` and
returns a concrete ``Assembly``. One module per section of the file (``bodies``, ``joints``,
``loading``, ``qois``, sharing ``checks``); ``builder`` joins them.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ...decomposition.assembly import Assembly
from ...errors import ModelError
from ...parameters import Mu, Parameter, Parameters
from ..expressions import evaluate
from .builder import Builder
from .checks import (
    RESERVED_NAMES,
    TOP_LEVEL,
    BuildCache,
    check_keys,
    positive_int,
    require,
    unit_text,
)

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["ModelSpec"]


@dataclass(frozen=True)
class ModelSpec:
    """A parsed, validated model file (parameters still symbolic)."""

    name: str
    data: Mapping[str, Any]
    parameters: Parameters
    source: str = ""
    #: the substructures of recent builds (``BodySections.substructures``), not compared
    built: BuildCache = field(default_factory=lambda: BuildCache(), init=False,
                              compare=False, repr=False)

    # ------------------------------------------------------------------ loading
    @staticmethod
    def from_toml(path: str | Path) -> ModelSpec:
        path = Path(path)
        try:
            text = path.read_text(encoding="utf-8")
        except OSError as exc:
            raise ModelError(f"model file {str(path)!r}: {exc.strerror}") from None
        except UnicodeDecodeError as exc:
            raise ModelError(f"model file {str(path)!r}: not UTF-8 text (byte "
                             f"0x{exc.object[exc.start]:02x} at offset {exc.start})") from None
        return ModelSpec.from_string(text, name=path.stem, source=str(path))

    @staticmethod
    def from_string(text: str, name: str = "model", source: str = "",
                    folder: Path | None = None) -> ModelSpec:
        """folder: where the file's mesh files are (default: the folder of ``source``, or
        the working folder without one)."""
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ModelError(f"model file {source or name!r} is not valid TOML: {exc}") from None
        except RecursionError:
            raise ModelError(f"model file {source or name!r}: arrays or tables nested too "
                             "deeply") from None
        # mesh files are named relative to the model file (to the working folder without one)
        base = folder if folder is not None else Path(source).parent if source else Path.cwd()
        for table in data.get("substructures", []):
            if isinstance(table, dict) and isinstance(table.get("mesh_file"), str):
                table["mesh_file"] = str(base / table["mesh_file"])
        return ModelSpec.from_dict(data, name=name, source=source)

    @staticmethod
    def from_dict(data: Mapping[str, Any], name: str = "model", source: str = "") -> ModelSpec:
        check_keys(data, TOP_LEVEL, "model")
        params: dict[str, Parameter] = {}
        for pname, table in dict(data.get("parameters", {})).items():
            where = f"parameters.{pname}"
            if not pname.isidentifier():
                raise ModelError(f"{where}: parameter names must be identifiers")
            if pname in RESERVED_NAMES:  # a study crashed on it after its last case
                raise ModelError(f"{where}: {pname!r} is a name the study's outputs use "
                                 f"({', '.join(RESERVED_NAMES)}): choose another")
            if not isinstance(table, Mapping):
                table = {"default": table}
            check_keys(table, {"default", "min", "max", "description", "unit"}, where)
            param = Parameter(
                name=pname,
                default=evaluate(require(table, "default", where), {}, f"{where}.default"),
                minimum=evaluate(table.get("min", -math.inf), {}, f"{where}.min", infinite=True),
                maximum=evaluate(table.get("max", math.inf), {}, f"{where}.max", infinite=True),
                description=str(table.get("description", "")),
                unit=unit_text(table.get("unit", ""), f"{where}.unit"),
            )
            param.check(param.default)
            params[pname] = param
        spec = ModelSpec(name, data, Parameters(params), source)
        spec.build()  # validate everything once, with the defaults
        return spec

    @property
    def mesh_files(self) -> list[str]:
        """The mesh files the model reads (paths as resolved when it was read)."""
        return sorted({str(table["mesh_file"]) for table in self.data.get("substructures", [])
                       if isinstance(table, Mapping) and "mesh_file" in table})

    @property
    def units(self) -> dict[str, str]:
        """The unit of each parameter and quantity of interest ("" where none is given)."""
        units = {name: p.unit for name, p in self.parameters.items()}
        units.update({str(t["name"]): str(t.get("unit", "")).strip()
                      for t in self.data.get("qoi", [])})
        return units

    @property
    def title(self) -> str:
        return str(self.data.get("title", self.name))

    # ------------------------------------------------------------------ building
    def build(
        self,
        mu: Mu | Mapping[str, float] | None = None,
        refine: int = 1,
        split: Mapping[str, tuple[int, int]] | None = None,
    ) -> Assembly:
        """The concrete assembly for parameter values ``mu``.

        ``refine`` multiplies every element count; ``split`` overrides the number of
        substructures of named bodies (both are discretisation choices, not parameters).
        """
        mu = mu if isinstance(mu, Mu) else self.parameters.parse(mu)
        refine = positive_int(refine, "refine")
        builder = Builder(self.data, mu, refine, dict(split or {}), self.built)
        return builder.assembly(self.name)


