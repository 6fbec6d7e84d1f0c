"""A concrete assembly: substructures, interfaces, boundary conditions, load history and
quantities of interest, with every parameter already evaluated (paper §2.1, figure 1).

An ``Assembly`` is what the solvers consume; ``spec.ModelSpec.build`` makes one from a model
file and a parameter set ``Mu``.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from ..fem.elasticity import (
    AXISYMMETRIC,
    FloatArray,
    IntArray,
    hooke_matrix,
    thermal_strain,
)
from ..fem.levelset import CutCells, LevelSet, cut_cells
from ..fem.mesh import RectMesh, UnstructuredMesh, shape_at
from ..fem.xfem import mesh_pattern, xfem_initial_strain_load, xfem_load_vector, xfem_stiffness
from ..parameters import Mu

DISPLACEMENT = "displacement"
FORCE = "force"
STOP = "stop"
COMPONENTS = ("x", "y")


@dataclass(frozen=True)
class Material:
    young: float
    poisson: float
    hypothesis: str
    thickness: float
    #: the thermal expansion coefficient α (1/K); not in the repr: the stiffness, which the
    #: operators' signatures digest, does not depend on it
    expansion: float = field(default=0.0, repr=False)

    @property
    def hooke(self) -> FloatArray:
        return hooke_matrix(self.young, self.poisson, self.hypothesis)

    @property
    def radial(self) -> bool:
        """Axisymmetric (x = r, y = z): integrals over the whole revolution."""
        return self.hypothesis == AXISYMMETRIC

    def thickness_at(self, coords: FloatArray) -> FloatArray:
        """What multiplies a traction into a force per unit length at points (n, 2): the
        thickness, or 2π r axisymmetric (the revolution's circumference there)."""
        coords = np.asarray(coords, dtype=np.float64).reshape(-1, 2)
        if self.radial:
            return np.asarray(2.0 * np.pi * coords[:, 0], dtype=np.float64)
        return np.full(coords.shape[0], float(self.thickness))

    @property
    def thermal_strain(self) -> FloatArray:
        """The in-plane strain (xx, yy, γ_xy) of a free unit temperature change."""
        return thermal_strain(self.expansion, self.poisson, self.hypothesis)


@dataclass(frozen=True)
class Substructure:
    """A substructure: its own mesh (Q4 or T3) and material, and optionally a hole, the
    region where the level set ``hole`` is negative, integrated X-FEM style on the fixed mesh
    (paper §5)."""

    name: str
    body: str
    mesh: RectMesh | UnstructuredMesh
    material: Material
    hole: LevelSet | None = None

    def signature(self) -> str:
        """A digest of everything the substructure's stiffness depends on (mesh, material,
        hole): equal signatures mean its operators can be reused."""
        return self._stiffness_digest

    @cached_property
    def _stiffness_digest(self) -> str:  # once per substructure: a study's cases share it
        return hashlib.sha1(repr((self.mesh, self.material, self.hole)).encode()).hexdigest()

    @cached_property
    def description(self) -> str:
        """What its interfaces' points depend on, as text: name, body, mesh and material
        (``latin.signatures.interface_signature``; once per substructure)."""
        return repr((self.name, self.body, self.mesh, self.material))

    @cached_property
    def cut(self) -> CutCells | None:
        """Cells classified against the hole (None without a hole)."""
        if self.hole is None:
            return None
        return cut_cells(self.mesh, self.hole)

    def stiffness(self) -> sp.csr_matrix:
        """K_E (eq. [2]–[3]), on the material part only when there is a hole."""
        return xfem_stiffness(self.mesh, self.material.hooke, self.material.thickness, self.cut)

    def stiffness_pattern(self) -> sp.csr_matrix | None:
        """With a hole, a pattern containing the stiffness's for any hole in this mesh (the
        uncut mesh's): the condensation orders the interior once for all hole positions
        (``latin.condensation.interior_ordering``). None without a hole."""
        return mesh_pattern(self.mesh) if self.hole is not None else None


@dataclass(frozen=True)
class SideRef:
    """One side (``bottom``/``right``/``top``/``left``) of one substructure, or the part of
    it that ``segment`` spans along the side (an interface with a shorter neighbour)."""

    substructure: int
    side: str
    segment: tuple[float, float] | None = None
    reach: float = 0.0  # > 0: a curved face near the side (``UnstructuredMesh.side_nodes``)

    def all_nodes(self, mesh: RectMesh | UnstructuredMesh) -> IntArray:
        """Every node of the side (or of the curved face within ``reach``), in order."""
        return mesh.side_nodes(self.side, self.reach)

    def nodes(self, mesh: RectMesh | UnstructuredMesh) -> IntArray:
        """The side's nodes (ordered along it) that the reference covers."""
        nodes = self.all_nodes(mesh)
        if self.segment is None:
            return nodes
        axis, _, lo, hi = mesh.side_line(self.side)
        along = mesh.nodes[nodes, 1 - axis]
        tolerance = 1e-9 * (hi - lo)
        keep = (along >= self.segment[0] - tolerance) & (along <= self.segment[1] + tolerance)
        return np.asarray(nodes[keep], dtype=np.int64)


@dataclass(frozen=True)
class BoundaryCondition:
    """Prescribed data on the outer boundary, component by component (x, y).

    ``kinds[c]`` is ``"displacement"`` or ``"force"``; ``value[c]`` is the prescribed
    displacement or traction density, multiplied at each step by the load factor ``factor``
    (1 at every step when ``factor`` is None).
    """

    name: str
    kinds: tuple[str, str]
    value: tuple[float, float]
    factor: str | None = None
    #: a pressure ``value[0]`` normal to the face (traction −p n, n its outward normal at
    #: each point: curved faces), instead of a uniform traction vector
    pressure: bool = False
    #: values that vary along the face: points (n, 2) → values (n, 2), the components of
    #: ``value`` that do not vary included (a model file's expressions of x and y); None:
    #: ``value`` everywhere
    varying: Callable[[FloatArray], FloatArray] | None = None

    def values_at(self, points: FloatArray) -> FloatArray:
        """The prescribed values (n, 2) at ``points`` (n, 2), before the load factor (a
        pressure's in column 0)."""
        if self.varying is not None:
            return np.asarray(self.varying(np.asarray(points, dtype=np.float64)),
                              dtype=np.float64)
        return np.tile(np.asarray(self.value, dtype=np.float64), (len(points), 1))


def consistent_densities(points: FloatArray, tractions: FloatArray) -> FloatArray:
    """Traction densities (n, 2) at the nodes ``points`` (n, 2) of a face, in order along
    it, whose products with the nodes' dual lengths are the consistent loads of the
    tractions' linear interpolant, ∫ N_i t ds = Σ_e h_e (2 t_i + t_j) / 6: exact resultant
    and moment for a traction linear along the face (the dual lengths' own product, the
    lumped load, puts a linear traction's moment 12.5 % off on four cells). A uniform
    traction is its own density."""
    lengths = np.linalg.norm(np.diff(points, axis=0), axis=1)[:, None]  # (n − 1, 1)
    load = np.zeros_like(tractions)
    load[:-1] += lengths * (2.0 * tractions[:-1] + tractions[1:]) / 6.0
    load[1:] += lengths * (2.0 * tractions[1:] + tractions[:-1]) / 6.0
    dual = np.zeros((len(points), 1))
    dual[:-1] += 0.5 * lengths
    dual[1:] += 0.5 * lengths
    return np.asarray(load / np.where(dual > 0.0, dual, 1.0), dtype=np.float64)


@dataclass(frozen=True)
class ContactLaw:
    """Unilateral contact with an initial gap and Coulomb friction (paper §3, figure 6)."""

    friction: float = 0.0
    gap: float = 0.0


@dataclass(frozen=True)
class Interface:
    """An interface Γ_EE' between two substructure sides (``perfect`` or ``contact``), or
    between one side and the outside (``boundary``, with its ``condition``; a rigid stop is
    a boundary with ``kinds = ("stop", "stop")`` and a ``contact`` law)."""

    name: str
    kind: str
    sides: tuple[SideRef, ...]
    condition: BoundaryCondition | None = None
    contact: ContactLaw | None = None

    @property
    def is_stop(self) -> bool:
        return self.condition is not None and self.condition.kinds[0] == STOP


@dataclass(frozen=True)
class History:
    """Quasi-static load history: named load factors, one value per step."""

    factors: dict[str, FloatArray] = field(default_factory=dict)
    n_steps: int = 1

    def factor(self, name: str | None) -> FloatArray:
        if name is None:
            return np.ones(self.n_steps)
        return self.factors[name]


@dataclass(frozen=True)
class QuantityOfInterest:
    """``displacement`` at ``point`` (component: x, y), ``stress`` there (component: xx,
    yy, xy; ``decomposition.qoi.point_functional``), ``reaction``: the resultant force that a
    boundary exerts on the structure (component), or ``contact_pressure``: the mean contact
    pressure on the contact interfaces between two bodies over ``segment`` (a range of the
    coordinate along the interface). ``step`` (1-based) keeps one load step only.
    ``body`` / ``substructure``: the part whose displacement a point on the boundary between
    parts reads (``point_substructure``)."""

    name: str
    kind: str
    component: int
    point: tuple[float, float] | None = None
    boundary: str | None = None
    scale: float = 1.0
    step: int | None = None
    bodies: tuple[str, str] | None = None
    segment: tuple[float, float] | None = None
    unit: str = ""
    body: str | None = None
    substructure: str | None = None


@dataclass(frozen=True)
class BodyForce:
    """A force per unit volume (N/mm³ in N, mm) on the substructures of ``bodies`` (every
    body where empty): gravity ρ g, a spinning part's ρ ω² r. ``value`` is uniform, or
    ``varying`` gives it at points (n, 2) → (n, 2) (a model file's expressions of x and
    y); multiplied at each step by the load factor ``factor`` (1 where None). The data f_d
    on Ω_E of the substructures' equilibrium (paper eq. [1])."""

    name: str
    value: tuple[float, float]
    bodies: tuple[str, ...] = ()
    factor: str | None = None
    varying: Callable[[FloatArray], FloatArray] | None = None

    def acts_on(self, sub: Substructure) -> bool:
        return not self.bodies or sub.body in self.bodies

    def values_at(self, points: FloatArray) -> FloatArray:
        """The force densities (n, 2) at ``points`` (n, 2), before the load factor."""
        if self.varying is not None:
            return np.asarray(self.varying(np.asarray(points, dtype=np.float64)),
                              dtype=np.float64)
        return np.tile(np.asarray(self.value, dtype=np.float64), (len(points), 1))

    def unit_load(self, sub: Substructure) -> FloatArray:
        """Its load vector ∫ N f t dΩ on ``sub``'s material (2π r for t axisymmetric), at
        a unit load factor."""
        material = sub.material
        return xfem_load_vector(sub.mesh, self.values_at(sub.mesh.nodes), material.thickness,
                                sub.cut, material.radial)


@dataclass(frozen=True)
class TemperatureChange:
    """A temperature change ΔT (K) from the stress-free state on the substructures of
    ``bodies`` (every body where empty), uniform (``value``) or given at points (n, 2) →
    (n,) by ``varying``, multiplied at each step by the load factor ``factor``: the
    initial strain α ΔT of each part's material (``Material.thermal_strain``)."""

    name: str
    value: float
    bodies: tuple[str, ...] = ()
    factor: str | None = None
    varying: Callable[[FloatArray], FloatArray] | None = None

    def acts_on(self, sub: Substructure) -> bool:
        return not self.bodies or sub.body in self.bodies

    def values_at(self, points: FloatArray) -> FloatArray:
        """ΔT (n,) at ``points`` (n, 2), before the load factor."""
        if self.varying is not None:  # (n,), or a model file's pair of expressions (n, 2)
            values = np.asarray(self.varying(np.asarray(points, dtype=np.float64)),
                                dtype=np.float64)
            return values[:, 0] if values.ndim == 2 else values
        return np.full(len(points), float(self.value))


@dataclass(frozen=True)
class PointLoad:
    """A force ``value`` (N, through the part's whole thickness) at ``point`` of the
    substructure named ``substructure``, multiplied at each step by the load factor
    ``factor``: nodal forces N_a(point) × value on the cell that holds the point (the
    point's own node where it is one)."""

    name: str
    point: tuple[float, float]
    value: tuple[float, float]
    substructure: str
    factor: str | None = None


@dataclass(frozen=True)
class Assembly:
    name: str
    substructures: tuple[Substructure, ...]
    interfaces: tuple[Interface, ...]
    history: History
    qois: tuple[QuantityOfInterest, ...]
    mu: Mu
    body_forces: tuple[BodyForce, ...] = ()
    temperatures: tuple[TemperatureChange, ...] = ()
    point_loads: tuple[PointLoad, ...] = ()

    @property
    def interior_loads(self) -> bool:
        """Whether anything loads the substructures inside (body forces, temperatures,
        point loads)."""
        return bool(self.body_forces or self.temperatures or self.point_loads)

    def interior_load(self, s: int) -> FloatArray | None:
        """Substructure ``s``'s load vectors per step (n_steps, n_dofs), load factors
        applied, over its material: its body forces' ∫ N f t dΩ, its temperature changes'
        ∫ Bᵀ D ε₀ t dΩ (paper eq. [1]) and its point loads' N(point) F; None where none
        acts on it. Computed once per assembly and substructure."""
        sub = self.substructures[s]
        forces = [force for force in self.body_forces if force.acts_on(sub)]
        changes = [change for change in self.temperatures if change.acts_on(sub)]
        points = [load for load in self.point_loads if load.substructure == sub.name]
        if not forces and not changes and not points:
            return None
        if s not in self._interior_loads:
            load = np.zeros((self.n_steps, 2 * sub.mesh.n_nodes))
            material, nodes = sub.material, sub.mesh.nodes
            for force in forces:  # each load once, at a unit factor
                load += (self.history.factor(force.factor)[:, None]
                         * force.unit_load(sub)[None, :])
            for change in changes:
                unit = xfem_initial_strain_load(sub.mesh, material.hooke,
                                                material.thermal_strain,
                                                change.values_at(nodes), material.thickness,
                                                sub.cut)
                load += self.history.factor(change.factor)[:, None] * unit[None, :]
            for point in points:
                at, shape = shape_at(sub.mesh, point.point)
                for c in range(2):
                    load[:, 2 * at + c] += (self.history.factor(point.factor)[:, None]
                                            * (point.value[c] * shape)[None, :])
            self._interior_loads[s] = load
        return self._interior_loads[s]

    def temperature(self, s: int) -> FloatArray | None:
        """Substructure ``s``'s temperature change at its nodes per step (n_steps,
        n_nodes), load factors applied; None where none acts on it."""
        sub = self.substructures[s]
        changes = [change for change in self.temperatures if change.acts_on(sub)]
        if not changes:
            return None
        return np.asarray(sum(self.history.factor(change.factor)[:, None]
                              * change.values_at(sub.mesh.nodes)[None, :]
                              for change in changes), dtype=np.float64)

    @cached_property
    def _interior_loads(self) -> dict[int, FloatArray]:
        return {}

    @cached_property
    def digests(self) -> dict[object, str]:
        """Digests of this assembly computed once (``latin.signatures.interface_signature``),
        by what else they depend on."""
        return {}

    @property
    def label(self) -> str:
        """The model's name and the case's parameters, for log lines: ``b1 (mu1=0.3,
        mu2=0.2)``."""
        values = ", ".join(f"{name}={value:g}" for name, value in dict(self.mu).items())
        return f"{self.name} ({values})" if values else self.name

    @property
    def n_steps(self) -> int:
        return self.history.n_steps

    @property
    def n_dofs(self) -> int:
        return sum(2 * s.mesh.n_nodes for s in self.substructures)

    def body_box(self, body: str) -> tuple[float, float, float, float]:
        """``(xmin, xmax, ymin, ymax)`` of the substructures of ``body``."""
        meshes = [s.mesh for s in self.substructures if s.body == body]
        return (min(m.x0 for m in meshes), max(m.x1 for m in meshes),
                min(m.y0 for m in meshes), max(m.y1 for m in meshes))

    def substructure_index(self, name: str) -> int:
        for i, sub in enumerate(self.substructures):
            if sub.name == name:
                return i
        raise KeyError(name)
