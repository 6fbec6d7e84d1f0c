"""Quantities of interest from displacement fields, boundary reactions and contact
pressures."""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from ..errors import ModelError
from ..fem.elasticity import (
    FloatArray,
    IntArray,
    element_dofs,
    interpolate,
    point_stress_matrix,
)
from ..fem.mesh import shape_at
from .assembly import Assembly, QuantityOfInterest, Substructure
from .interfaces import InterfacePoints

if TYPE_CHECKING:
    from .uniqueness import FreeMotion

#: how a mean contact pressure is recovered from the nodal contact forces
PRESSURE_RECOVERIES = ("consistent", "lumped")
#: the components of a ``stress`` QoI, in ``QuantityOfInterest.component``'s order
STRESS_COMPONENTS = ("xx", "yy", "xy", "tt")  # tt: the hoop stress (axisymmetric)


@dataclass(frozen=True)
class ContactPressures:
    """Contact pressure (positive in compression) at the contact nodes, as the solvers give
    it: the nodal normal force over the node's dual cell (a *lumped* value).

    ``bodies[i]`` names the two bodies the node ``i`` joins; ``extents[i]`` is its dual cell
    (start and end along the interface); ``pressure`` is shaped (n_steps, n_nodes);
    ``positions[i]`` is where the node is (on a curved face, the node of that face);
    ``shear`` the tangential traction there, (n_steps, n_nodes), along the first side's
    normal turned by +90° (the same lumped value as ``pressure``).
    """

    bodies: list[frozenset[str]] = field(default_factory=list)
    extents: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))
    pressure: FloatArray = field(default_factory=lambda: np.zeros((1, 0)))
    positions: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))
    shear: FloatArray = field(default_factory=lambda: np.zeros((1, 0)))

    def mean(self, bodies: frozenset[str], segment: tuple[float, float],
             recovery: str = "consistent") -> FloatArray:
        """Mean pressure over ``segment`` of the interfaces between ``bodies``, per step.

        ``"consistent"`` (default): the piecewise-linear pressure p_h whose consistent
        boundary mass matrix M gives the nodal forces (M p = f, the recovery of the
        independent FE codes), integrated over the segment: exact whenever the pressure is
        linear along the interface. ``"lumped"``: the dual-cell values averaged by overlap
        (before issue 17; 0.1–0.3 % above the consistent value on B1's p_B).
        """
        if recovery not in PRESSURE_RECOVERIES:
            raise ValueError(f"recovery: expected one of {PRESSURE_RECOVERIES}, got {recovery!r}")
        key = (self.extents.tobytes(), tuple(self.bodies), bodies, tuple(segment), recovery)
        with _WEIGHTS_LOCK:
            weights = _WEIGHTS.get(key)
            if weights is not None:
                _WEIGHTS.move_to_end(key)
        if weights is None:  # linear in the pressures: their weights, once per geometry
            chosen = np.array([b == bodies for b in self.bodies], dtype=bool)
            weights = np.zeros(chosen.size)
            weights[chosen] = _mean(self.extents[chosen], np.eye(int(chosen.sum())), bodies,
                                    segment, recovery)
            with _WEIGHTS_LOCK:
                _WEIGHTS[key] = weights
                while len(_WEIGHTS) > _WEIGHTS_CACHE_SIZE:
                    _WEIGHTS.popitem(last=False)
        return np.asarray(self.pressure @ weights, dtype=np.float64)


#: per contact geometry, QoI segment and recovery, the weights of the nodal pressures in
#: the mean (``ContactPressures.mean``); the cases of a study share them
_WEIGHTS: OrderedDict[tuple[Any, ...], FloatArray] = OrderedDict()
_WEIGHTS_CACHE_SIZE = 32
_WEIGHTS_LOCK = threading.Lock()


def _mean(extents: FloatArray, pressure: FloatArray, bodies: frozenset[str],
          segment: tuple[float, float], recovery: str) -> FloatArray:
    """``ContactPressures.mean`` of the nodes of ``extents`` (their ``pressure``, (n, n_nodes)).
    The contact must cover ``segment``, or lie wholly inside it (the mean over the whole
    contact); a segment that reaches past part of it only is refused."""
    spans = _spans(extents)
    covered = sum(max(0.0, min(b, segment[1]) - max(a, segment[0])) for a, b in spans)
    tol = 1e-9 * (segment[1] - segment[0])
    whole = bool(spans) and all(segment[0] - tol <= a and b <= segment[1] + tol
                                for a, b in spans)  # "[0, 100]": the whole contact
    if not whole and covered < (segment[1] - segment[0]) - tol:
        between = " and ".join(map(repr, sorted(bodies)))
        raise ModelError(
            f"segment {list(segment)} is not covered by the contact between {between}: "
            + (f"it covers {', '.join(f'[{a:g}, {b:g}]' for a, b in spans)} (the coordinate "
               "along the interface; arc length on a curved face)" if spans else
               "there is no contact interface between them"))
    lo = np.maximum(extents[:, 0], segment[0])
    hi = np.minimum(extents[:, 1], segment[1])
    overlap = np.clip(hi - lo, 0.0, None)
    if recovery == "lumped":
        return np.asarray(pressure @ overlap / overlap.sum(), dtype=np.float64)
    total = np.zeros(pressure.shape[0])
    for nodes, forces in _lines(extents, pressure * (extents[:, 1] - extents[:, 0])):
        total += _integral(nodes, _consistent(nodes, forces), segment)
    return np.asarray(total / overlap.sum(), dtype=np.float64)


def _spans(extents: FloatArray) -> list[tuple[float, float]]:
    """The ranges the cells ``extents`` cover, joined where they meet."""
    spans: list[tuple[float, float]] = []
    if not extents.size:
        return spans
    tol = 1e-9 * max(float(np.ptp(extents)), 1.0)
    for a, b in sorted(map(tuple, extents.tolist())):
        if spans and a <= spans[-1][1] + tol:
            spans[-1] = (spans[-1][0], max(spans[-1][1], b))
        else:
            spans.append((a, b))
    return spans


def _lines(extents: FloatArray, forces: FloatArray
           ) -> list[tuple[FloatArray, FloatArray]]:
    """Node positions and nodal forces (n_steps, n_nodes) of each straight run of contact
    nodes, from their dual cells: a line's first node sits at the start of its cell, and
    each next node as far past a cell boundary as the previous one lies before it. Where two
    interfaces meet, the two half cells of the shared node become one node."""
    order = np.argsort(extents[:, 0], kind="stable")
    scale = max(float(np.ptp(extents)), 1e-300)
    lines: list[tuple[FloatArray, FloatArray]] = []
    nodes: list[float] = []
    columns: list[FloatArray] = []
    end = -np.inf
    for i in order:
        lo, hi = extents[i]
        if abs(lo - end) > 1e-9 * scale:  # not adjacent: a new line starts at this cell
            if nodes:
                lines.append((np.array(nodes), np.stack(columns, axis=1)))
            nodes, columns = [float(lo)], [forces[:, i].copy()]
        elif abs(nodes[-1] - end) <= 1e-9 * scale:  # the previous node ends its cell: the
            columns[-1] = columns[-1] + forces[:, i]  # same node, its other half cell
        else:
            nodes.append(2.0 * float(lo) - nodes[-1])
            columns.append(forces[:, i].copy())
        end = float(hi)
    if nodes:
        lines.append((np.array(nodes), np.stack(columns, axis=1)))
    return lines


def _consistent(nodes: FloatArray, forces: FloatArray) -> FloatArray:
    """Nodal values p of the piecewise-linear pressure with M p = f (per step), M the
    consistent mass matrix of the 1-D linear elements between ``nodes``."""
    from scipy.linalg import solve_banded

    n = nodes.size
    if n == 1:  # a lone node: no element to spread it over, nothing to integrate
        return np.zeros_like(forces)
    h = np.diff(nodes)
    bands = np.zeros((3, n))
    bands[1, :-1] += h / 3.0
    bands[1, 1:] += h / 3.0
    bands[0, 1:] = h / 6.0
    bands[2, :-1] = h / 6.0
    return np.asarray(solve_banded((1, 1), bands, forces.T).T, dtype=np.float64)


def _integral(nodes: FloatArray, values: FloatArray, segment: tuple[float, float]) -> FloatArray:
    """∫ over ``segment`` of the piecewise-linear field with ``values`` (n_steps, n_nodes)."""
    if nodes.size < 2:
        return np.zeros(values.shape[0])
    a = np.clip(segment[0], nodes[:-1], nodes[1:])
    b = np.clip(segment[1], nodes[:-1], nodes[1:])
    h = np.diff(nodes)
    ta, tb = (a - nodes[:-1]) / h, (b - nodes[:-1]) / h
    left, right = values[:, :-1], values[:, 1:]
    at_a, at_b = left + ta * (right - left), left + tb * (right - left)
    return np.asarray(((b - a) * 0.5 * (at_a + at_b)).sum(axis=1), dtype=np.float64)


def latin_contact_pressures(assembly: Assembly, points: InterfacePoints,
                            pressure: FloatArray, shear: FloatArray | None = None
                            ) -> ContactPressures:
    """``ContactPressures`` on the first side of every contact pair of the interface
    ``points``, with ``pressure`` (n, n_pairs) there (LATIN's fields, or unit columns for the
    mean's weights) and ``shear`` (zero when not given), forces per unit length as LATIN's
    fields are: divided into pressures by the contact's thickness (the thinner side's, the
    face that touches; the reference's ``ContactSet.weight``)."""
    first = points.contact_pairs[0]
    interfaces = points.interface[first].tolist()
    joined = {j: frozenset(assembly.substructures[ref.substructure].body
                           for ref in assembly.interfaces[j].sides) for j in set(interfaces)}
    bodies = [joined[j] for j in interfaces]
    thickness = np.minimum(*(point_thickness(assembly, points, side)
                             for side in points.contact_pairs))
    return ContactPressures(bodies, points.extents[first], per_area(pressure, thickness),
                            points.coords[first],
                            per_area(np.zeros_like(pressure) if shear is None else shear,
                                     thickness))


def per_area(force: FloatArray, area: FloatArray) -> FloatArray:
    """Forces (…, n) over their areas (n,), 0 where the area is 0 (an axisymmetric part's
    axis, r = 0): the contact pressures of both solvers."""
    out: FloatArray = np.divide(force, area, out=np.zeros_like(force), where=area > 0.0)
    return out


def point_substructure(substructures: Sequence[Substructure], q: QuantityOfInterest) -> int:
    """The substructure whose displacement the ``displacement`` QoI ``q`` reads
    (``part_holding``). (The model reader refuses a point shared by parts that are not
    joined by a perfect interface unless one is named, ``io.modelfile.points``.)"""
    assert q.point is not None
    found = part_holding(substructures, q.point, q.substructure, q.body)
    if found is None:
        raise ValueError(f"qoi {q.name!r}: the point {list(q.point)} lies in no cell")
    return found


def part_holding(substructures: Sequence[Substructure], point: tuple[float, float],
                 substructure: str | None = None, body: str | None = None) -> int | None:
    """The first substructure whose cells hold ``point``, among those named
    ``substructure`` (else of ``body``) where given; None where no cell holds it."""
    holding = [s for s, sub in enumerate(substructures) if sub.mesh.holds(point)]
    named = [s for s in holding if substructures[s].name == substructure]
    if not named and body is not None:
        named = [s for s in holding if substructures[s].body == body]
    chosen = named or holding
    return chosen[0] if chosen else None


def point_functional(substructures: Sequence[Substructure], q: QuantityOfInterest
                     ) -> tuple[int, FloatArray]:
    """A ``displacement`` or ``stress`` QoI at a point: the substructure it reads
    (``point_substructure``) and the row φ over that substructure's interleaved dofs whose
    product with its displacements is the QoI (before ``scale``). A displacement
    interpolates the nodes' with the shape functions at the point; a stress is D B there, in
    the cell that holds the point (stresses jump between cells: on an edge, the cell
    ``locate`` finds first, the same in every solver)."""
    assert q.point is not None
    s = point_substructure(substructures, q)
    sub = substructures[s]
    mesh = sub.mesh
    phi = np.zeros(2 * mesh.n_nodes)
    if q.kind == "displacement":
        at, shape = shape_at(mesh, q.point)
        phi[2 * at + q.component] = shape
    else:
        cell, ref = mesh.locate(q.point)
        row = point_stress_matrix(mesh.nodes[mesh.cells[cell]], ref, sub.material.hooke)
        phi[element_dofs(mesh.cells[cell][None])[0]] = row[q.component]
    return s, phi


def initial_stress(assembly: Assembly, q: QuantityOfInterest) -> FloatArray | None:
    """A ``stress`` QoI's share of the initial strain per step (n_steps,), before
    ``scale``: σ = D (B u − ε₀), so −D ε₀ at the point, ε₀ the thermal strain of the
    temperature change interpolated there; None where no temperature change acts."""
    assert q.point is not None
    s = point_substructure(assembly.substructures, q)
    change = assembly.temperature(s)
    if change is None:
        return None
    sub = assembly.substructures[s]
    at, shape = shape_at(sub.mesh, q.point)
    at_point = change[:, at] @ shape
    unit = sub.material.hooke @ sub.material.thermal_strain
    return np.asarray(-unit[q.component] * at_point, dtype=np.float64)


def point_thickness(assembly: Assembly, points: InterfacePoints, at: IntArray
                    ) -> FloatArray:
    """The thickness (2π r axisymmetric) of each interface point ``at``'s substructure,
    there: what divides LATIN's forces per unit length into tractions."""
    out = np.empty(at.size)
    owner = points.substructure[at]
    for s in np.unique(owner).tolist():
        mine = owner == s
        out[mine] = assembly.substructures[s].material.thickness_at(points.coords[at[mine]])
    return out


def evaluate_qois(
    assembly: Assembly,
    displacements: Mapping[str, FloatArray],
    reactions: Mapping[str, FloatArray],
    pressures: ContactPressures | None = None,
) -> dict[str, float | list[float]]:
    """Each QoI as a number (one load step, or ``step`` chosen) or a list over the steps."""
    out: dict[str, float | list[float]] = {}
    for q in assembly.qois:
        if q.kind == "displacement":
            assert q.point is not None
            sub = assembly.substructures[point_substructure(assembly.substructures, q)]
            cell, ref = sub.mesh.locate(q.point)
            values = interpolate(sub.mesh.nodes, sub.mesh.cells, displacements[sub.name],
                                 cell, ref)[:, q.component]
        elif q.kind == "stress":
            s, phi = point_functional(assembly.substructures, q)
            u = displacements[assembly.substructures[s].name]
            values = u.reshape(u.shape[0], -1) @ phi
            initial = initial_stress(assembly, q)
            if initial is not None:
                values = values + initial
        elif q.kind == "reaction":
            assert q.boundary is not None
            values = reactions[q.boundary][:, q.component]
        elif q.kind == "contact_pressure":
            assert q.bodies is not None and q.segment is not None
            try:
                values = (pressures or ContactPressures()).mean(frozenset(q.bodies),
                                                                q.segment)
            except ModelError as exc:
                raise ModelError(f"qoi {q.name!r}: {exc}") from None
        else:  # pragma: no cover - rejected when the model is read
            raise ValueError(q.kind)
        values = q.scale * values + 0.0  # + 0.0: no "-0" for a zero force
        if q.step is not None:
            values = values[q.step - 1:q.step]
        out[q.name] = float(values[0]) if values.size == 1 else [float(v) for v in values]
    return out


def determined_values(assembly: Assembly, motions: Sequence[FreeMotion]
                      ) -> dict[str, bool | list[bool]]:
    """Which QoI values the discrete problem determines, shaped as ``evaluate_qois``'s,
    given the converged state's free motions (``uniqueness.free_motions``). A rigid motion
    changes no force, stress or pressure: at its step only a displacement QoI of a part it
    moves, in a component it moves, is undetermined (``determined_steps``)."""
    out: dict[str, bool | list[bool]] = {}
    for q in assembly.qois:
        moved = [False] * len(motions)
        if q.kind == "displacement":  # the part its point reads, located once
            body = assembly.substructures[point_substructure(assembly.substructures, q)].body
            moved = [not _still(q, body, motion) for motion in motions]
        determined = determined_steps(motions, assembly.n_steps, moved)
        if q.step is not None:
            determined = determined[q.step - 1:q.step]
        out[q.name] = (bool(determined[0]) if determined.size == 1
                       else [bool(d) for d in determined])
    return out


def determined_steps(motions: Sequence[FreeMotion], n_steps: int, moved: Sequence[bool]
                     ) -> npt.NDArray[np.bool_]:
    """Per load step, whether a value is determined: not at the step of a free motion that
    moves it (``moved``, per motion), nor at any step after a motion that reaches the last
    step (friction builds on the position, gaps change with it)."""
    determined = np.ones(n_steps, dtype=bool)
    for motion, moves in zip(motions, moved, strict=True):
        if motion.reaches_last_step:
            determined[motion.step:] = False
        if moves:
            determined[motion.step - 1] = False
    return determined


def _still(q: QuantityOfInterest, body: str, motion: FreeMotion) -> bool:
    """The displacement QoI ``q``, read on a part of ``body``, does not move with
    ``motion``: another body's, or a component the motion leaves (B1's horizontal slide
    leaves v; a beam's vertical deflection on sliding supports stays determined)."""
    assert q.point is not None
    if body not in motion.bodies:
        return True
    (vx, vy), omega, (cx, cy) = motion.velocity, motion.rotation, motion.centre
    velocity = (vx - omega * (q.point[1] - cy), vy + omega * (q.point[0] - cx))
    return abs(velocity[q.component]) <= 1e-9 * max(abs(vx), abs(vy), 1.0)
