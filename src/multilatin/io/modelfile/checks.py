"""Shared by every section of a model file: the field checks whose errors name the
offending field and value, and ``SectionReader`` (one parameter set, numbers evaluated)."""

from __future__ import annotations

import threading
from collections.abc import Collection, Iterator, Mapping
from typing import Any

from ...decomposition.assembly import ContactLaw
from ...errors import ModelError
from ...parameters import Mu
from ..expressions import evaluate

TOP_LEVEL = {"title", "description", "analysis", "parameters", "materials", "bodies",
             "substructures", "interfaces", "boundary", "history", "qoi", "holes",
             "body_force", "temperature", "point_load"}
OPPOSITE = {"left": "right", "right": "left", "bottom": "top", "top": "bottom"}
#: study.nc's variables per case (``study.store.to_dataset``): numbers, flags and texts
CASE_NUMBERS = ("iterations", "indicator", "wall_s", "setup_s")
CASE_FLAGS = ("finished", "converged", "unique", "small_sliding")
CASE_TEXTS = ("log", "start")
#: names the study's outputs give their own variables and coordinates (study.nc, table.csv):
#: no parameter or quantity of interest may take them
RESERVED_NAMES = ("mode", "step", *CASE_NUMBERS, *CASE_FLAGS, *CASE_TEXTS)


def require(table: Mapping[str, Any], key: str, where: str) -> Any:
    if key not in table:
        raise ModelError(f"{where}: missing field {key!r}")
    return table[key]


def check_keys(table: Mapping[str, Any], allowed: set[str], where: str) -> None:
    unknown = set(table) - allowed
    if unknown:
        raise ModelError(
            f"{where}: unknown field {sorted(unknown)[0]!r} (allowed: {', '.join(sorted(allowed))})"
        )


def named_tables(data: Mapping[str, Any], section: str, allowed: set[str]
                 ) -> Iterator[tuple[Mapping[str, Any], str, str]]:
    """The tables of an array ``[[section]]``, checked (tables, ``allowed`` keys, unique
    names): each one's table, name (``<section><index>`` where none is given) and where,
    for errors (``section[index] ('name')``)."""
    tables = data.get(section, [])
    if not isinstance(tables, list):
        raise ModelError(f"{section}: expected an array of tables ([[{section}]])")
    names: set[str] = set()
    for index, table in enumerate(tables):
        where = f"{section}[{index}]"
        if not isinstance(table, Mapping):
            raise ModelError(f"{where}: expected a table, got {table!r}")
        check_keys(table, allowed, where)
        name = str(table.get("name", f"{section}{index}"))
        where = f"{section}[{index}] ({name!r})"
        if name in names:
            raise ModelError(f"{where}.name: {section} {name!r} is defined twice")
        names.add(name)
        yield table, name, where


def load_factor(table: Mapping[str, Any], where: str, factors: Collection[str]
                ) -> str | None:
    """A table's ``factor``, checked against the history's load factors (None: none)."""
    factor = table.get("factor")
    if factor is not None and factor not in factors:
        known = ", ".join(sorted(factors)) or "none"
        raise ModelError(f"{where}.factor: {factor!r} is not a load factor of "
                         f"[history.factors] (defined: {known})")
    return None if factor is None else str(factor)


def pair(value: Any, where: str) -> tuple[Any, Any]:
    if not isinstance(value, list) or len(value) != 2:
        raise ModelError(f"{where}: expected a list of two values, got {value!r}")
    return value[0], value[1]


def positive_int(value: Any, where: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ModelError(f"{where}: expected a positive integer, got {value!r}")
    return value


def unit_text(value: Any, where: str) -> str:
    """A ``unit`` field: a short text such as "mm", "N", "MPa", or "1" for a dimensionless
    quantity (shown as [–])."""
    if not isinstance(value, str) or len(value) > 20 or "\n" in value:
        raise ModelError(f"{where}: expected a short text such as \"mm\", \"N\" or \"1\", "
                         f"got {value!r}")
    return value.strip()


class BuildCache(list[Any]):
    """What a model keeps between builds (``BodySections.substructures``), with a lock for
    builds from several threads; not pickled (a model sent to a worker process carries its
    file's table, not its meshes)."""

    def __init__(self) -> None:
        super().__init__()
        self.lock = threading.Lock()
        #: interfaces found per geometry (``joints.InterfaceSections._found``)
        self.interfaces: list[Any] = []

    def __reduce__(self) -> tuple[type[BuildCache], tuple[()]]:
        return BuildCache, ()


class ReadRecorder(Mapping[str, float]):
    """A parameter set that records which names were looked up (present or not): a section
    built from it is a function of those values alone, so that a later parameter set equal
    on them builds the same (``BodySections.substructures``' cache)."""

    def __init__(self, mu: Mapping[str, float]) -> None:
        self.mu = mu
        self.read: dict[str, float | None] = {}

    def __getitem__(self, key: str) -> float:
        self.read[key] = self.mu.get(key)
        return self.mu[key]

    def __contains__(self, key: object) -> bool:
        if isinstance(key, str):
            self.read.setdefault(key, self.mu.get(key))
        return key in self.mu

    def __iter__(self) -> Iterator[str]:
        self.read.update(self.mu)  # whoever iterates may read every value
        return iter(self.mu)

    def __len__(self) -> int:
        return len(self.mu)


class SectionReader:
    """What every section reader shares: the model table, one parameter set, the
    discretisation choices, and evaluation of numbers and contact laws. ``cache``: kept by
    the model between builds (``BodySections.substructures``)."""

    def __init__(
        self, data: Mapping[str, Any], mu: Mu, refine: int, split: dict[str, tuple[int, int]],
        cache: BuildCache | None = None,
    ) -> None:
        self.data = data
        self.mu = mu
        #: where expressions look their parameters up (a ``ReadRecorder`` while one is kept)
        self.lookup: Mapping[str, float] = mu
        self.refine = refine
        self.split = split
        self.cache = cache

    def num(self, value: Any, where: str) -> float:
        return evaluate(value, self.lookup, where)

    def contact_law(self, table: Mapping[str, Any], where: str) -> ContactLaw:
        """A contact's or a stop's friction (>= 0) and initial gap: the sides' (or the face's
        and the obstacle's) distance at rest, negative for an interference (they overlap
        by -gap at rest, and are pushed apart from the first step: a shrink fit)."""
        friction = self.num(table.get("friction", 0.0), f"{where}.friction")
        gap = self.num(table.get("gap", 0.0), f"{where}.gap")
        if friction < 0.0:
            raise ModelError(f"{where}.friction: the friction coefficient must be >= 0, "
                             f"got {friction:g}")
        return ContactLaw(friction, gap)

