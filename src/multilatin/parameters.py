"""Named, immutable model parameters (after pyMOR's ``Parameters`` and ``Mu``).

A model declares its parameters with defaults and admissible ranges; a ``Mu`` is one
complete, validated assignment of values. Discretisation choices (mesh refinement, search
direction, tolerance) are solver arguments, never parameters.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass

from .errors import ModelError


@dataclass(frozen=True)
class Parameter:
    """A named scalar parameter with a default and an admissible closed range."""

    name: str
    default: float
    minimum: float = -math.inf
    maximum: float = math.inf
    description: str = ""
    unit: str = ""

    def check(self, value: float) -> float:
        if not math.isfinite(value):
            raise ModelError(f"parameter {self.name!r}: value {value!r} is not a finite number")
        if not self.minimum <= value <= self.maximum:
            raise ModelError(
                f"parameter {self.name!r}: value {value!r} is outside its admissible range "
                f"[{self.minimum}, {self.maximum}]"
            )
        return value


class Mu(Mapping[str, float]):
    """An immutable assignment of a value to every parameter of a model."""

    __slots__ = ("_values",)

    def __init__(self, values: Mapping[str, float]) -> None:
        self._values = dict(sorted((k, float(v)) for k, v in values.items()))

    def __getitem__(self, key: str) -> float:
        return self._values[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._values)

    def __len__(self) -> int:
        return len(self._values)

    def __hash__(self) -> int:
        return hash(tuple(self._values.items()))

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Mu) and self._values == other._values

    def __repr__(self) -> str:
        inner = ", ".join(f"{k}={v:g}" for k, v in self._values.items())
        return f"Mu({inner})"


class Parameters(Mapping[str, Parameter]):
    """The parameters a model declares, by name."""

    __slots__ = ("_params",)

    def __init__(self, params: Mapping[str, Parameter] | None = None) -> None:
        self._params = dict(params or {})

    def __getitem__(self, key: str) -> Parameter:
        return self._params[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._params)

    def __len__(self) -> int:
        return len(self._params)

    def __repr__(self) -> str:
        return f"Parameters({', '.join(self._params)})"

    def defaults(self) -> Mu:
        return Mu({name: p.default for name, p in self._params.items()})

    def parse(self, values: Mapping[str, float] | None = None) -> Mu:
        """A full ``Mu``: the defaults overridden by ``values``, each name and range checked."""
        merged = {name: p.default for name, p in self._params.items()}
        for name, value in (values or {}).items():
            if name not in self._params:
                known = ", ".join(sorted(self._params)) or "none"
                raise ModelError(f"unknown parameter {name!r} (this model's parameters: {known})")
            merged[name] = self._params[name].check(float(value))
        return Mu(merged)


def parse_assignments(assignments: list[str]) -> dict[str, float]:
    """``["name=value", ...]`` from the command line into a mapping; errors name the item."""
    values: dict[str, float] = {}
    for item in assignments:
        name, sep, text = item.partition("=")
        if not sep or not name.strip():
            raise ModelError(f"--set {item!r}: expected name=value")
        try:
            values[name.strip()] = float(text)
        except ValueError:
            raise ModelError(f"--set {item!r}: value {text!r} is not a number") from None
    return values
