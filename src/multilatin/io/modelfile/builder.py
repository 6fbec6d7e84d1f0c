"""One parameter set through every section of a model file into an ``Assembly``."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ...decomposition.assembly import (
    DISPLACEMENT,
    STOP,
    Assembly,
    History,
    Interface,
    Substructure,
)
from ...decomposition.holes import parameters_named
from ...errors import ModelError
from .bodies import BodySections
from .joints import InterfaceSections
from .loading import LoadingSections
from .qois import QoiSections


class Builder(BodySections, InterfaceSections, LoadingSections, QoiSections):
    """Evaluates a model table with one parameter set into an ``Assembly``."""

    def assembly(self, name: str) -> Assembly:
        subs, bodies = self.substructures()
        interfaces = self.interfaces(subs)
        used: dict[tuple[int, str], list[tuple[float, float] | None]] = {}
        for itf in interfaces:  # the sides (or their segments) the interfaces take
            for ref in itf.sides:
                used.setdefault((ref.substructure, ref.side), []).append(ref.segment)
        history = self.history()
        boundaries = self.boundaries(subs, bodies, history, used)
        _check_held(subs, interfaces, boundaries)
        _check_one_displacement_per_node(subs, boundaries, history,
                                         self.data.get("boundary", []), self.mu)
        qois = self.qois(subs, {itf.condition.name for itf in boundaries if itf.condition},
                         history, interfaces)
        return Assembly(name, tuple(subs), tuple(interfaces + boundaries), history, tuple(qois),
                        self.mu, tuple(self.body_forces(subs, history)),
                        tuple(self.temperatures(subs, history)),
                        tuple(self.point_loads(subs, history, interfaces)))


def _check_held(subs: list[Substructure], interfaces: list[Interface],
                boundaries: list[Interface]) -> None:
    """Every group of substructures joined by interfaces must touch something that can hold
    it: a prescribed displacement component or a rigid stop (a body held by friction on a
    stop alone is accepted; whether the load finds an equilibrium is the solve's to say)."""
    group = list(range(len(subs)))

    def root(i: int) -> int:
        while group[i] != i:
            group[i] = group[group[i]]
            i = group[i]
        return i

    for itf in interfaces:
        if len(itf.sides) == 2:
            a, b = (root(ref.substructure) for ref in itf.sides)
            group[a] = b
    held = {root(itf.sides[0].substructure) for itf in boundaries
            if itf.condition is not None
            and (DISPLACEMENT in itf.condition.kinds or itf.condition.kinds[0] == STOP)}
    free = sorted({subs[i].body for i in range(len(subs)) if root(i) not in held})
    if free:
        raise ModelError(
            f"boundary: nothing holds {', '.join(repr(b) for b in free)}: no prescribed "
            "displacement and no rigid stop on it or on a body it touches; it can move as a "
            "rigid body")


def _check_one_displacement_per_node(subs: list[Substructure], boundaries: list[Interface],
                                     history: History, tables: Sequence[Any],
                                     mu: Mapping[str, float]) -> None:
    """Two boundary conditions that prescribe the same displacement component of one node
    (a corner shared by two faces) must prescribe the same value at every step: a node
    cannot take two, the monolithic reference would keep one of them silently, and LATIN
    would find no equilibrium between them. ``tables``: the file's ``[[boundary]]``, for
    the parameters their values read (named in the error: a study's case)."""
    # a node is shared only by conditions on one body and component: where each such pair
    # has one condition at most (one side's nodes are distinct), nothing can conflict
    held = [(subs[itf.sides[0].substructure].body, c) for itf in boundaries
            if itf.condition is not None and not itf.condition.pressure
            for c in range(2) if itf.condition.kinds[c] == DISPLACEMENT]
    if len(held) == len(set(held)):
        return
    keys: list[np.ndarray] = []
    values: list[np.ndarray] = []
    owners: list[np.ndarray] = []
    names: list[str] = []
    bodies = {name: i for i, name in enumerate(dict.fromkeys(s.body for s in subs))}
    for itf in boundaries:
        condition = itf.condition
        if condition is None or condition.pressure:
            continue
        sub = subs[itf.sides[0].substructure]
        nodes = sub.mesh.nodes[itf.sides[0].nodes(sub.mesh)]
        at, prescribed = np.round(nodes, 9), condition.values_at(nodes)
        for c in range(2):
            if condition.kinds[c] == DISPLACEMENT:
                keys.append(np.column_stack([np.full(len(at), bodies[sub.body]), at,
                                             np.full(len(at), c)]))
                values.append(prescribed[:, c, None] * history.factor(condition.factor)[None])
                owners.append(np.full(len(at), len(names)))
                names.append(condition.name)
    if len(names) < 2:
        return
    key, value, owner = np.concatenate(keys), np.concatenate(values), np.concatenate(owners)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    first = first[inverse.ravel()]
    gap = np.abs(value - value[first]).max(axis=1)
    scale = np.maximum(np.abs(value).max(axis=1), np.abs(value[first]).max(axis=1))
    wrong = np.flatnonzero(gap > 1e-12 * np.maximum(scale, 1e-300))
    if wrong.size:
        row, other = int(wrong[0]), int(first[wrong[0]])
        step = int(np.argmax(np.abs(value[row] - value[other])))
        x, y, c = key[row, 1], key[row, 2], int(key[row, 3])
        body = next(name for name, i in bodies.items() if i == key[row, 0])
        pair = (names[owner[other]], names[owner[row]])
        read = {f"{table.get('name')}.value": table.get("value") for table in tables
                if isinstance(table, Mapping) and table.get("name") in pair}
        params = parameters_named(read, mu)
        raise ModelError(
            f"boundary: {pair[0]!r} and {pair[1]!r} both prescribe the "
            f"{'xy'[c]} displacement of the node at ({x:g}, {y:g}) of body {body!r}, "
            f"differently ({value[other, step]:g} and {value[row, step]:g} at step "
            f"{step + 1}){params}; a node cannot take both: make one of them a force or "
            "mixed condition on that component, or give them equal values")
