"""Model files: a TOML description of an assembly, validated with errors that name the
offending field and value. See ``docs/model-format.md`` for the format.

``ModelSpec.build(mu)`` evaluates every expression with the parameter values ``mu`` and
returns a concrete ``Assembly``.
"""

from __future__ import annotations

import itertools
import math
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .assembly import (
    DISPLACEMENT,
    FORCE,
    STOP,
    Assembly,
    BoundaryCondition,
    ContactLaw,
    History,
    Interface,
    Material,
    QuantityOfInterest,
    SideRef,
    Substructure,
)
from .errors import ModelError
from .expressions import evaluate
from .fem.elasticity import PLANE_STRAIN, PLANE_STRESS
from .fem.mesh import SIDES, RectMesh, normal_axis
from .holes import place_holes
from .limits import check_meshes
from .parameters import Mu, Parameter, Parameters

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

_TOP_LEVEL = {"title", "description", "analysis", "parameters", "materials", "bodies",
              "substructures", "interfaces", "boundary", "history", "qoi", "holes"}
_OPPOSITE = {"left": "right", "right": "left", "bottom": "top", "top": "bottom"}


def _require(table: Mapping[str, Any], key: str, where: str) -> Any:
    if key not in table:
        raise ModelError(f"{where}: missing field {key!r}")
    return table[key]


def _check_keys(table: Mapping[str, Any], allowed: set[str], where: str) -> None:
    unknown = set(table) - allowed
    if unknown:
        raise ModelError(
            f"{where}: unknown field {sorted(unknown)[0]!r} (allowed: {', '.join(sorted(allowed))})"
        )


def _pair(value: Any, where: str) -> tuple[Any, Any]:
    if not isinstance(value, list) or len(value) != 2:
        raise ModelError(f"{where}: expected a list of two values, got {value!r}")
    return value[0], value[1]


def _positive_int(value: Any, where: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ModelError(f"{where}: expected a positive integer, got {value!r}")
    return value


@dataclass(frozen=True)
class ModelSpec:
    """A parsed, validated model file (parameters still symbolic)."""

    name: str
    data: Mapping[str, Any]
    parameters: Parameters
    source: str = ""

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
    def from_string(text: str, name: str = "model", source: str = "") -> ModelSpec:
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise ModelError(f"model file {source or name!r} is not valid TOML: {exc}") from None
        except RecursionError:
            raise ModelError(f"model file {source or name!r}: arrays or tables nested too "
                             "deeply") from None
        return ModelSpec.from_dict(data, name=name, source=source)

    @staticmethod
    def from_dict(data: Mapping[str, Any], name: str = "model", source: str = "") -> ModelSpec:
        _check_keys(data, _TOP_LEVEL, "model")
        params: dict[str, Parameter] = {}
        for pname, table in dict(data.get("parameters", {})).items():
            where = f"parameters.{pname}"
            if not pname.isidentifier():
                raise ModelError(f"{where}: parameter names must be identifiers")
            if not isinstance(table, Mapping):
                table = {"default": table}
            _check_keys(table, {"default", "min", "max", "description", "unit"}, where)
            param = Parameter(
                name=pname,
                default=evaluate(_require(table, "default", where), {}, f"{where}.default"),
                minimum=evaluate(table.get("min", -math.inf), {}, f"{where}.min", infinite=True),
                maximum=evaluate(table.get("max", math.inf), {}, f"{where}.max", infinite=True),
                description=str(table.get("description", "")),
                unit=str(table.get("unit", "")),
            )
            param.check(param.default)
            params[pname] = param
        spec = ModelSpec(name, data, Parameters(params), source)
        spec.build()  # validate everything once, with the defaults
        return spec

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
        refine = _positive_int(refine, "refine")
        builder = _Builder(self.data, mu, refine, dict(split or {}))
        return builder.assembly(self.name)


#: Young's moduli outside this window are a units error, and would over- or underflow the
#: solvers' norms (E² and 1/E appear in them)
YOUNG_RANGE = (1e-100, 1e100)


class _Builder:
    """Evaluates a model table with one parameter set into an ``Assembly``."""

    def __init__(
        self, data: Mapping[str, Any], mu: Mu, refine: int, split: dict[str, tuple[int, int]]
    ) -> None:
        self.data = data
        self.mu = mu
        self.refine = refine
        self.split = split

    def num(self, value: Any, where: str) -> float:
        return evaluate(value, self.mu, where)

    # -------------------------------------------------------------- materials
    def materials(self) -> dict[str, tuple[float, float]]:
        out = {}
        for mname, table in dict(self.data.get("materials", {})).items():
            where = f"materials.{mname}"
            if not isinstance(table, Mapping):
                raise ModelError(f"{where}: expected a table with E and nu")
            _check_keys(table, {"E", "nu"}, where)
            young = self.num(_require(table, "E", where), f"{where}.E")
            poisson = self.num(_require(table, "nu", where), f"{where}.nu")
            if not young > 0.0:
                raise ModelError(f"{where}.E: Young's modulus must be > 0, got {young:g}")
            if not YOUNG_RANGE[0] <= young <= YOUNG_RANGE[1]:
                raise ModelError(f"{where}.E: {young:g} is outside the range the solvers "
                                 f"represent [{YOUNG_RANGE[0]:g}, {YOUNG_RANGE[1]:g}]; check "
                                 "the units (e.g. MPa with mm and N)")
            if not -1.0 < poisson < 0.5:
                raise ModelError(f"{where}.nu: Poisson's ratio must lie in (-1, 0.5), got {poisson:g}")
            out[mname] = (young, poisson)
        return out

    def material(self, table: Mapping[str, Any], where: str,
                 materials: dict[str, tuple[float, float]]) -> Material:
        mname = _require(table, "material", where)
        if mname not in materials:
            known = ", ".join(sorted(materials)) or "none"
            raise ModelError(
                f"{where}.material: {mname!r} is not defined in [materials] (defined: {known})"
            )
        analysis = dict(self.data.get("analysis", {}))
        _check_keys(analysis, {"hypothesis", "thickness"}, "analysis")
        hypothesis = table.get("hypothesis", analysis.get("hypothesis", PLANE_STRESS))
        if hypothesis not in (PLANE_STRESS, PLANE_STRAIN):
            raise ModelError(
                f"{where}.hypothesis: expected {PLANE_STRESS!r} or {PLANE_STRAIN!r}, "
                f"got {hypothesis!r}"
            )
        thickness = self.num(table.get("thickness", analysis.get("thickness", 1.0)),
                             f"{where}.thickness")
        if not thickness > 0.0:
            raise ModelError(f"{where}.thickness: must be > 0, got {thickness:g}")
        young, poisson = materials[mname]
        return Material(young, poisson, hypothesis, thickness)

    # -------------------------------------------------------------- substructures
    def rectangle(self, table: Mapping[str, Any], where: str) -> tuple[float, float, float, float]:
        x0, x1 = (self.num(v, f"{where}.x") for v in _pair(_require(table, "x", where), f"{where}.x"))
        y0, y1 = (self.num(v, f"{where}.y") for v in _pair(_require(table, "y", where), f"{where}.y"))
        if not x1 > x0:
            raise ModelError(f"{where}.x: expected [xmin, xmax] with xmax > xmin, got {[x0, x1]}")
        if not y1 > y0:
            raise ModelError(f"{where}.y: expected [ymin, ymax] with ymax > ymin, got {[y0, y1]}")
        return x0, x1, y0, y1

    def substructures(self) -> tuple[list[Substructure], dict[str, tuple[float, ...]]]:
        materials = self.materials()
        subs: list[Substructure] = []
        planned: list[tuple[str, str, Material, tuple[float, float, float, float], int, int]] = []
        bodies: dict[str, tuple[float, ...]] = {}
        common = {"name", "x", "y", "elements", "material", "hypothesis", "thickness"}
        for b, table in enumerate(self.data.get("bodies", [])):
            where = f"bodies[{b}]"
            _check_keys(table, common | {"split", "mesh"}, where)
            name = str(_require(table, "name", where))
            where = f"bodies[{b}] ({name!r})"
            if name in bodies:
                raise ModelError(f"{where}.name: body {name!r} is defined twice")
            x0, x1, y0, y1 = self.rectangle(table, where)
            bodies[name] = (x0, x1, y0, y1)
            nx, ny = (_positive_int(v, f"{where}.elements")
                      for v in _pair(_require(table, "elements", where), f"{where}.elements"))
            sx, sy = self.split.get(name) or tuple(
                _positive_int(v, f"{where}.split") for v in _pair(table.get("split", [1, 1]),
                                                                   f"{where}.split"))
            if nx % sx or ny % sy:
                raise ModelError(
                    f"{where}.split: {sx} x {sy} substructures do not divide the "
                    f"{nx} x {ny} elements evenly"
                )
            mat = self.material(table, where, materials)
            xs = np.linspace(x0, x1, sx + 1)
            ys = np.linspace(y0, y1, sy + 1)
            # a split chosen by the caller (a discretisation choice) replaces the file's
            # per-substructure meshes of that body
            own = ({} if name in self.split else
                   self.own_meshes(table.get("mesh", []), where, (sx, sy)))
            for j, i in itertools.product(range(sy), range(sx)):
                sub_name = name if sx * sy == 1 else f"{name}[{i},{j}]"
                ex, ey = own.get((i, j), (nx // sx, ny // sy))
                planned.append((sub_name, name, mat, (float(xs[i]), float(xs[i + 1]),
                                                      float(ys[j]), float(ys[j + 1])),
                                ex * self.refine, ey * self.refine))
        unknown = sorted(set(self.split) - set(bodies))
        if unknown:
            raise ModelError(f"--split {unknown[0]}: no body of that name in [[bodies]] "
                             f"(bodies: {', '.join(bodies) or 'none'})")
        for s, table in enumerate(self.data.get("substructures", [])):
            where = f"substructures[{s}]"
            _check_keys(table, common | {"body"}, where)
            name = str(_require(table, "name", where))
            where = f"substructures[{s}] ({name!r})"
            x0, x1, y0, y1 = self.rectangle(table, where)
            nx, ny = (_positive_int(v, f"{where}.elements")
                      for v in _pair(_require(table, "elements", where), f"{where}.elements"))
            body = str(table.get("body", name))
            planned.append((name, body, self.material(table, where, materials),
                            (x0, x1, y0, y1), nx * self.refine, ny * self.refine))
            lo = bodies.get(body, (x0, x1, y0, y1))
            bodies[body] = (min(lo[0], x0), max(lo[1], x1), min(lo[2], y0), max(lo[3], y1))
        # the size guard, before any mesh is built (a 3000 x 3000 mesh would take the
        # machine's memory)
        check_meshes([(name, ex, ey) for name, _, _, _, ex, ey in planned])
        for name, body, mat, (x0, x1, y0, y1), ex, ey in planned:
            subs.append(Substructure(name, body, RectMesh(x0, x1, y0, y1, ex, ey), mat))
        if not subs:
            raise ModelError("model: no [[bodies]] or [[substructures]] defined")
        names = [s.name for s in subs]
        for name in names:
            if names.count(name) > 1:
                raise ModelError(f"substructures: the name {name!r} is used twice")
        self._check_overlaps(subs)
        subs = place_holes(self.data.get("holes", []), subs, self.mu, self.num, _check_keys)
        return subs, bodies

    @staticmethod
    def own_meshes(tables: Any, where: str, split: tuple[int, int]
                   ) -> dict[tuple[int, int], tuple[int, int]]:
        """``[[bodies.mesh]]``: element counts of single substructures of a split body
        (``substructure = [i, j]``, ``elements = [nx, ny]``); their sides then meet their
        neighbours' with non-matching meshes (declare those interfaces ``type = "macro"``)."""
        out = {}
        if not isinstance(tables, list):
            raise ModelError(f"{where}.mesh: expected a list of tables, got {tables!r}")
        for m, table in enumerate(tables):
            here = f"{where}.mesh[{m}]"
            _check_keys(table, {"substructure", "elements"}, here)
            i, j = _pair(_require(table, "substructure", here), f"{here}.substructure")
            if not (isinstance(i, int) and isinstance(j, int)
                    and 0 <= i < split[0] and 0 <= j < split[1]):
                raise ModelError(f"{here}.substructure: expected [i, j] with 0 <= i < {split[0]} "
                                 f"and 0 <= j < {split[1]}, got {[i, j]}")
            out[(i, j)] = tuple(_positive_int(v, f"{here}.elements") for v in
                                _pair(_require(table, "elements", here), f"{here}.elements"))
        return out  # type: ignore[return-value]

    @staticmethod
    def _check_overlaps(subs: list[Substructure]) -> None:
        box = np.array([[s.mesh.x0, s.mesh.x1, s.mesh.y0, s.mesh.y1] for s in subs])
        scale = 1e-9 * float(np.max(box[:, [1, 3]] - box[:, [0, 2]]))
        ox = np.minimum(box[:, None, 1], box[None, :, 1]) - np.maximum(box[:, None, 0], box[None, :, 0])
        oy = np.minimum(box[:, None, 3], box[None, :, 3]) - np.maximum(box[:, None, 2], box[None, :, 2])
        overlap = (ox > scale) & (oy > scale)
        np.fill_diagonal(overlap, False)
        if overlap.any():
            i, j = np.argwhere(overlap)[0]
            a, b = subs[i], subs[j]
            raise ModelError(
                f"substructures {a.name!r} and {b.name!r} overlap: "
                f"x {[a.mesh.x0, a.mesh.x1]} y {[a.mesh.y0, a.mesh.y1]} and "
                f"x {[b.mesh.x0, b.mesh.x1]} y {[b.mesh.y0, b.mesh.y1]}"
            )

    # -------------------------------------------------------------- interfaces
    def contact_law(self, table: Mapping[str, Any], where: str) -> ContactLaw:
        friction = self.num(table.get("friction", 0.0), f"{where}.friction")
        gap = self.num(table.get("gap", 0.0), f"{where}.gap")
        if friction < 0.0:
            raise ModelError(f"{where}.friction: the friction coefficient must be >= 0, "
                             f"got {friction:g}")
        if gap < 0.0:
            raise ModelError(f"{where}.gap: the initial gap must be >= 0, got {gap:g}")
        return ContactLaw(friction, gap)

    def interfaces(self, subs: list[Substructure]) -> list[Interface]:
        declared: dict[frozenset[str], tuple[str, ContactLaw | None, str]] = {}
        for d, table in enumerate(self.data.get("interfaces", [])):
            where = f"interfaces[{d}]"
            _check_keys(table, {"between", "type", "friction", "gap"}, where)
            a, b = _pair(_require(table, "between", where), f"{where}.between")
            kind = table.get("type", "perfect")
            if kind not in ("perfect", "contact", "macro"):
                raise ModelError(f"{where}.type: unknown interface type {kind!r} "
                                 "(known: perfect, contact, macro)")
            if kind != "contact" and ({"friction", "gap"} & set(table)):
                raise ModelError(f"{where}: friction and gap apply to type = 'contact' only")
            known = {s.name for s in subs} | {s.body for s in subs}
            if self.split and not {a, b} <= known:
                continue  # names substructures that a caller's split has replaced
            for end in (a, b):
                if end not in known:
                    raise ModelError(f"{where}.between: no body or substructure named {end!r}")
            if a == b:
                raise ModelError(f"{where}.between: an interface joins two different parts, "
                                 f"got {a!r} twice")
            law = self.contact_law(table, where) if kind == "contact" else None
            declared[frozenset((a, b))] = (kind, law, where)
        scale = 1e-9 * max(max(s.mesh.x1 - s.mesh.x0, s.mesh.y1 - s.mesh.y0) for s in subs)
        found: list[Interface] = []
        used_declarations: set[frozenset[str]] = set()
        for i, j in itertools.combinations(range(len(subs)), 2):
            for side in SIDES:
                other = _OPPOSITE[side]
                axis, level, lo, hi = subs[i].mesh.side_line(side)
                axis_b, level_b, lo_b, hi_b = subs[j].mesh.side_line(other)
                if abs(level - level_b) > scale:
                    continue
                if min(hi, hi_b) - max(lo, lo_b) <= scale:
                    continue  # touching at a corner at most
                a, b = subs[i], subs[j]
                where = f"interface between {a.name!r} ({side} side) and {b.name!r} ({other} side)"
                if abs(lo - lo_b) > scale or abs(hi - hi_b) > scale:
                    raise ModelError(
                        f"{where}: sides do not match: {a.name!r} spans [{lo:g}, {hi:g}] and "
                        f"{b.name!r} spans [{lo_b:g}, {hi_b:g}] along {'yx'[axis]}; "
                        "an interface must be a whole side of both substructures"
                    )
                kind, law = "perfect", None
                # the most specific declaration wins: body-body, then with one name, then names
                for key in (frozenset((a.body, b.body)), frozenset((a.name, b.body)),
                            frozenset((a.body, b.name)), frozenset((a.name, b.name))):
                    if key in declared:
                        kind, law, _ = declared[key]
                        used_declarations.add(key)
                na, nb = a.mesh.side_nodes(side), b.mesh.side_nodes(other)
                matching = na.size == nb.size and np.allclose(a.mesh.nodes[na], b.mesh.nodes[nb],
                                                              atol=scale)
                if not matching and kind != "macro":
                    raise ModelError(
                        f"{where}: meshes do not match: {na.size - 1} and {nb.size - 1} "
                        f"elements along the interface; a {kind} interface needs matching "
                        "nodes (declare it type = 'macro' to transmit macro quantities only, "
                        "paper eq. [20])"
                    )
                found.append(Interface(f"{a.name}|{b.name}", kind,
                                       (SideRef(i, side), SideRef(j, other)), contact=law))
        for key, (_, _, where) in declared.items():
            if key not in used_declarations:
                a, b = sorted(key)
                raise ModelError(
                    f"{where}.between: {a!r} and {b!r} do not face each other (they share no side)"
                )
        return found

    # -------------------------------------------------------------- boundary conditions
    def history(self) -> History:
        table = dict(self.data.get("history", {}))
        _check_keys(table, {"factors"}, "history")
        factors_raw = dict(table.get("factors", {}))
        if "history" in self.data and not factors_raw:
            raise ModelError("history.factors: a load history with no steps (no load factors)")
        factors: dict[str, np.ndarray] = {}
        n_steps = None
        for fname, values in factors_raw.items():
            where = f"history.factors.{fname}"
            if not isinstance(values, list) or not values:
                raise ModelError(f"{where}: a load history with no steps (got {values!r})")
            arr = np.array([self.num(v, f"{where}[{t}]") for t, v in enumerate(values)])
            if n_steps is not None and arr.size != n_steps:
                raise ModelError(
                    f"{where}: {arr.size} steps, but other load factors have {n_steps}"
                )
            n_steps = arr.size
            factors[fname] = arr
        return History(factors, n_steps or 1)

    def boundaries(
        self,
        subs: list[Substructure],
        bodies: dict[str, tuple[float, ...]],
        history: History,
        used: set[tuple[int, str]],
    ) -> list[Interface]:
        out: list[Interface] = []
        names: set[str] = set()
        for b, table in enumerate(self.data.get("boundary", [])):
            where = f"boundary[{b}]"
            _check_keys(table, {"name", "face", "substructure", "side", "type", "value",
                                "components", "factor", "friction", "gap"}, where)
            name = str(table.get("name", f"boundary{b}"))
            where = f"boundary[{b}] ({name!r})"
            if name in names:
                raise ModelError(f"{where}.name: boundary {name!r} is defined twice")
            names.add(name)
            kind = _require(table, "type", where)
            refs = self._select_sides(table, where, subs, bodies)
            law = None
            if {"friction", "gap"} & set(table) and kind != STOP:
                raise ModelError(f"{where}: friction and gap apply to type = 'stop' only")
            if kind in (DISPLACEMENT, FORCE):
                kinds: tuple[str, ...] = (kind, kind)
            elif kind == "mixed":
                kinds = tuple(_pair(_require(table, "components", where), f"{where}.components"))
                for k in kinds:
                    if k not in (DISPLACEMENT, FORCE):
                        raise ModelError(
                            f"{where}.components: each component is 'displacement' or 'force', "
                            f"got {k!r}"
                        )
            elif kind == "wall":
                # smooth wall: normal displacement prescribed, tangential force zero
                axis = normal_axis(refs[0].side) if refs else 0
                kinds = (DISPLACEMENT, FORCE) if axis == 0 else (FORCE, DISPLACEMENT)
                table = {**table, "value": table.get("value", [0.0, 0.0])}
            elif kind == STOP:
                kinds = (STOP, STOP)
                law = self.contact_law(table, where)
                table = {**table, "value": [0.0, 0.0]}
            else:
                raise ModelError(
                    f"{where}.type: unknown boundary type {kind!r} "
                    "(known: displacement, force, mixed, wall, stop)"
                )
            vx, vy = (self.num(v, f"{where}.value")
                      for v in _pair(_require(table, "value", where), f"{where}.value"))
            factor = table.get("factor")
            if factor is not None and factor not in history.factors:
                known = ", ".join(sorted(history.factors)) or "none"
                raise ModelError(
                    f"{where}.factor: {factor!r} is not a load factor of [history.factors] "
                    f"(defined: {known})"
                )
            condition = BoundaryCondition(name, (kinds[0], kinds[1]), (vx, vy), factor)
            if not refs:
                raise ModelError(f"{where}.face: no substructure side lies on {table['face']!r}")
            for ref in refs:
                key = (ref.substructure, ref.side)
                if key in used:
                    raise ModelError(
                        f"{where}: side {ref.side!r} of {subs[ref.substructure].name!r} already "
                        "belongs to an interface or another boundary condition"
                    )
                used.add(key)
                out.append(Interface(f"{name}@{subs[ref.substructure].name}", "boundary",
                                     (ref,), condition, law))
        return out

    @staticmethod
    def _select_sides(
        table: Mapping[str, Any], where: str, subs: list[Substructure],
        bodies: dict[str, tuple[float, ...]],
    ) -> list[SideRef]:
        if "face" in table:
            body, _, side = str(table["face"]).partition(".")
            if body not in bodies:
                raise ModelError(f"{where}.face: no body named {body!r} in {table['face']!r}")
            if side not in SIDES:
                raise ModelError(f"{where}.face: side must be one of {SIDES}, got {side!r}")
            x0, x1, y0, y1 = bodies[body]
            level = {"left": x0, "right": x1, "bottom": y0, "top": y1}[side]
            return [
                SideRef(i, side) for i, s in enumerate(subs)
                if s.body == body and abs(s.mesh.side_line(side)[1] - level) <= 1e-9 * (
                    1.0 + abs(level))
            ]
        sub_name = _require(table, "substructure", where)
        side = _require(table, "side", where)
        if side not in SIDES:
            raise ModelError(f"{where}.side: must be one of {SIDES}, got {side!r}")
        for i, s in enumerate(subs):
            if s.name == sub_name:
                return [SideRef(i, side)]
        raise ModelError(f"{where}.substructure: no substructure named {sub_name!r}")

    # -------------------------------------------------------------- quantities of interest
    def qois(self, subs: list[Substructure], boundary_names: set[str],
             history: History) -> list[QuantityOfInterest]:
        out = []
        for q, table in enumerate(self.data.get("qoi", [])):
            where = f"qoi[{q}]"
            _check_keys(table, {"name", "type", "point", "component", "boundary", "scale",
                                "step", "between", "segment"}, where)
            name = str(_require(table, "name", where))
            where = f"qoi[{q}] ({name!r})"
            scale = self.num(table.get("scale", 1.0), f"{where}.scale")
            step = table.get("step")
            if step is not None:
                if isinstance(step, bool) or not isinstance(step, int) \
                        or not 1 <= step <= history.n_steps:
                    raise ModelError(f"{where}.step: expected a step in 1..{history.n_steps}, "
                                     f"got {step!r}")
            kind = _require(table, "type", where)
            if kind == "contact_pressure":
                a, b = (str(v) for v in _pair(_require(table, "between", where),
                                              f"{where}.between"))
                bodies = {s.body for s in subs}
                for end in (a, b):
                    if end not in bodies:
                        raise ModelError(f"{where}.between: no body named {end!r}")
                lo, hi = (self.num(v, f"{where}.segment")
                          for v in _pair(_require(table, "segment", where), f"{where}.segment"))
                if not hi > lo:
                    raise ModelError(f"{where}.segment: expected [start, end] with end > start, "
                                     f"got {[lo, hi]}")
                out.append(QuantityOfInterest(name, kind, 0, scale=scale, step=step,
                                              bodies=(a, b), segment=(lo, hi)))
                continue
            comp = _require(table, "component", where)
            if comp not in ("x", "y"):
                raise ModelError(f"{where}.component: expected 'x' or 'y', got {comp!r}")
            if kind == "displacement":
                px, py = (self.num(v, f"{where}.point")
                          for v in _pair(_require(table, "point", where), f"{where}.point"))
                if not any(s.mesh.contains((px, py)) for s in subs):
                    raise ModelError(f"{where}.point: {[px, py]} lies in no substructure")
                if any(s.hole is not None and s.mesh.contains((px, py))
                       and float(s.hole(np.array([px, py]))) < 0.0 for s in subs):
                    raise ModelError(f"{where}.point: {[px, py]} lies in a hole")
                out.append(QuantityOfInterest(name, kind, "xy".index(comp), (px, py), None, scale,
                                              step))
            elif kind == "reaction":
                bname = _require(table, "boundary", where)
                if bname not in boundary_names:
                    raise ModelError(f"{where}.boundary: no boundary named {bname!r}")
                out.append(QuantityOfInterest(name, kind, "xy".index(comp), None, bname, scale,
                                              step))
            else:
                raise ModelError(f"{where}.type: unknown kind {kind!r} "
                                 "(known: displacement, reaction, contact_pressure)")
        return out

    def assembly(self, name: str) -> Assembly:
        subs, bodies = self.substructures()
        interfaces = self.interfaces(subs)
        used = {(ref.substructure, ref.side) for itf in interfaces for ref in itf.sides}
        history = self.history()
        boundaries = self.boundaries(subs, bodies, history, used)
        if not any(DISPLACEMENT in itf.condition.kinds for itf in boundaries if itf.condition):
            raise ModelError(
                "boundary: no displacement is prescribed anywhere; the assembly can move as a "
                "rigid body"
            )
        qois = self.qois(subs, {itf.condition.name for itf in boundaries if itf.condition},
                         history)
        return Assembly(name, tuple(subs), tuple(interfaces + boundaries), history, tuple(qois),
                        self.mu)
