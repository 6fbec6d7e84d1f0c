"""Named, immutable model parameters (after pyMOR's ``Parameters`` and ``Mu``).

A model declares its parameters with defaults and admissible ranges; a ``Mu`` is one
complete, validated assignment of values. Discretisation choices (mesh refinement, search
direction, tolerance) are solver arguments, never parameters.

Base room: imports only ``errors`` and ``limits``; every other room may import it.
"""

from __future__ import annotations

import logging
import math
import numbers
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass

import numpy as np

from .errors import ModelError
from .limits import check_grid_count

log = logging.getLogger(__name__)


def label(name: str, unit: str) -> str:
    """An axis or column label with its unit: ``R_stop [N]``, ``mu1 [–]`` (unit "1" or "-":
    dimensionless); the name alone where no unit was given."""
    if not unit:
        return name
    return f"{name} [{'–' if unit in ('1', '-', '–') else unit}]"


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
            merged[name] = self._params[name].check(_number(name, value))
        return Mu(merged)


def _number(name: str, value: object) -> float:
    """A parameter's value as a float: a real number (a NumPy one too), not a bool, None or
    text."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ModelError(f"parameter {name!r}: expected a number, got {value!r}")
    return float(value)


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


class Grid(Mapping[str, tuple[float, ...]]):
    """A tensor grid of parameter values: name -> values, in the order the user gave them
    when that order is monotone (rising or falling), sorted rising when it is not.

    A study starts each case from its neighbours along a grid line and plots each line in
    the grid's order, so values given out of order (``mu2=0.5,0.1,0.3``) would start cases
    from far-off ones and draw zig-zag lines: they are sorted, with a warning.

    Built from command-line items (``parse``) or, after pyMOR's ``ParameterSpace``, by
    sampling admissible ranges (``ParameterSpace.sample_uniformly``). Every value is checked
    against the model's parameters on ``validate``.
    """

    __slots__ = ("_values",)

    def __init__(self, values: Mapping[str, Iterable[float]]) -> None:
        self._values: dict[str, tuple[float, ...]] = {}
        for name, items in values.items():
            grid_values = tuple(float(v) for v in items)
            if not grid_values:
                raise ModelError(f"grid {name!r}: no values")
            if len(set(grid_values)) != len(grid_values):
                raise ModelError(f"grid {name!r}: repeated values {grid_values}")
            steps = np.diff(grid_values)
            if not (np.all(steps > 0) or np.all(steps < 0)):
                grid_values = tuple(sorted(grid_values))
                log.warning("grid %r: values given out of order, run and stored in rising "
                            "order %s (a case starts from its neighbours along a grid line)",
                            name, ", ".join(f"{v:g}" for v in grid_values))
            self._values[name] = grid_values

    @classmethod
    def parse(cls, items: Iterable[str]) -> Grid:
        """``["mu2=0:0.6:13", "mu1=0.1,0.3", "rc=3"]``: ``start:stop:count`` (count values,
        both ends included), a comma-separated list, or one value."""
        values: dict[str, tuple[float, ...]] = {}
        for item in items:
            name, sep, text = item.partition("=")
            name = name.strip()
            if not sep or not name:
                raise ModelError(f"--grid {item!r}: expected name=start:stop:count, "
                                 "name=v1,v2,... or name=value")
            if name in values:
                raise ModelError(f"--grid {item!r}: parameter {name!r} given twice")
            values[name] = _parse_values(item, text)
        if not values:
            raise ModelError("--grid: no parameter to vary")
        return cls(values)

    def __getitem__(self, key: str) -> tuple[float, ...]:
        return self._values[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._values)

    def __len__(self) -> int:
        return len(self._values)

    def __repr__(self) -> str:
        return "Grid(" + ", ".join(f"{k}: {len(v)}" for k, v in self._values.items()) + ")"

    @property
    def shape(self) -> tuple[int, ...]:
        return tuple(len(v) for v in self._values.values())

    @property
    def size(self) -> int:
        return math.prod(self.shape)

    def validate(self, parameters: Parameters) -> None:
        """Every name known and every value admissible, before any computation starts."""
        for name, grid_values in self._values.items():
            if name not in parameters:
                known = ", ".join(sorted(parameters)) or "none"
                raise ModelError(f"--grid {name}: unknown parameter (this model's "
                                 f"parameters: {known})")
            for value in grid_values:
                parameters[name].check(value)

    def mu(self, index: tuple[int, ...], parameters: Parameters) -> Mu:
        """The full parameter set at grid ``index`` (defaults for parameters not varied)."""
        return parameters.parse({name: self._values[name][i]
                                 for name, i in zip(self._values, index, strict=True)})


def _parse_values(item: str, text: str) -> tuple[float, ...]:
    text = text.strip()
    if not text:
        raise ModelError(f"--grid {item!r}: empty grid")
    parts = text.split(":")
    try:
        if len(parts) == 1:
            return tuple(float(v) for v in text.split(","))
        if len(parts) != 3:
            raise ValueError
        start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError:
        raise ModelError(f"--grid {item!r}: expected start:stop:count (count an integer), "
                         "a comma-separated list of numbers, or one number") from None
    if count < 1:
        raise ModelError(f"--grid {item!r}: empty grid (count {count})")
    check_grid_count(item, count)
    if count == 1 and start != stop:
        raise ModelError(f"--grid {item!r}: one value cannot span {start}:{stop}")
    return tuple(float(v) for v in np.round(np.linspace(start, stop, count), 12))


@dataclass(frozen=True)
class ParameterSpace:
    """Parameters with the ranges to explore (pyMOR's ``ParameterSpace``)."""

    parameters: Parameters
    ranges: Mapping[str, tuple[float, float]]

    def __post_init__(self) -> None:
        for name, (low, high) in self.ranges.items():
            if name not in self.parameters:
                raise ModelError(f"ParameterSpace: unknown parameter {name!r}")
            if not low <= high:
                raise ModelError(f"ParameterSpace {name!r}: empty range [{low}, {high}]")
            self.parameters[name].check(low)
            self.parameters[name].check(high)

    def sample_uniformly(self, counts: int | Mapping[str, int]) -> Grid:
        """A tensor grid with ``counts`` values per range (ends included)."""
        per = {name: counts if isinstance(counts, int) else counts[name] for name in self.ranges}
        return Grid({name: np.round(np.linspace(low, high, per[name]), 12)
                     for name, (low, high) in self.ranges.items()})
