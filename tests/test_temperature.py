"""Temperature changes (``[[temperature]]``, a material's ``alpha``): the initial strain
α ΔT loads each substructure as ∫ Bᵀ D ε₀ and stresses are D (ε − ε₀). Closed forms: a
bar between two walls (σ = −E α ΔT, exact), free expansion of a plate in plane strain and
of a plate with a level-set hole (stress-free, u exact on Q4: the X-FEM load and stiffness
share their quadrature), and a shrink fit released by heating its rim (Lamé); LATIN equals
the reference on both backends and at two κ."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from conftest import has_torch

import multilatin as ml
from multilatin.errors import ModelError

E, NU, ALPHA = 2e5, 0.3, 1.2e-5

#: a bar 100 x 10 mm (two substructures) between two smooth walls at x = 0 and 100, on a
#: smooth floor, heated by dT in two steps
WALLS = f"""
[parameters.dT]
default = 100.0
unit = "K"
[materials.m]
E = {E}
nu = {NU}
alpha = {ALPHA}
[[bodies]]
name = "bar"
x = [0.0, 100.0]
y = [0.0, 10.0]
elements = [20, 2]
split = [2, 1]
material = "m"
[history.factors]
heat = [0.5, 1.0]
[[boundary]]
name = "left"
face = "bar.left"
type = "mixed"
components = ["displacement", "force"]
value = [0.0, 0.0]
[[boundary]]
name = "right"
face = "bar.right"
type = "mixed"
components = ["displacement", "force"]
value = [0.0, 0.0]
[[boundary]]
name = "floor"
face = "bar.bottom"
type = "mixed"
components = ["force", "displacement"]
value = [0.0, 0.0]
[[temperature]]
name = "heating"
value = "dT"
factor = "heat"
[[qoi]]
name = "R"
type = "reaction"
boundary = "right"
component = "x"
[[qoi]]
name = "s_xx"
type = "stress"
point = [25.0, 5.0]
component = "xx"
[[qoi]]
name = "s_yy"
type = "stress"
point = [75.0, 2.5]
component = "yy"
[[qoi]]
name = "v_top"
type = "displacement"
point = [50.0, 10.0]
component = "y"
"""


def _walls(text: str = WALLS) -> ml.Model:
    return ml.Model(ml.ModelSpec.from_string(text, name="walls"))


def test_a_bar_heated_between_walls_is_compressed_as_the_closed_form() -> None:
    """σ_xx = −E α ΔT, σ_yy = 0, the walls' reaction E α ΔT × 10 mm, the top rising by
    (1 + ν) α ΔT × 10 mm (plane stress), at both steps: the reference exactly, LATIN at
    two κ, on both backends, its QoIs recovered or read from the interface fields."""
    expected = [{"R": -E * ALPHA * t * 10.0, "s_xx": -E * ALPHA * t, "s_yy": 0.0,
                 "v_top": (1.0 + NU) * ALPHA * t * 10.0} for t in (50.0, 100.0)]
    model = _walls()
    results = [model.reference()]
    for backend in ["numpy"] + (["torch"] if has_torch() else []):
        for kappa in (0.5, 2.0):
            for recover in (True, False):
                results.append(model.solve(options=ml.LatinOptions(
                    tol=1e-10, kappa=kappa, backend=backend, recover_displacements=recover)))
    for result in results:
        assert result.converged
        for name in expected[0]:
            got = np.asarray(result.qoi[name])
            want = np.array([e[name] for e in expected])
            assert np.abs(got - want).max() < 1e-7 * 240.0 * (10.0 if name == "R" else 1.0) \
                + 1e-9 * np.abs(want).max(), name


def _free_plate(hypothesis: str, hole: bool) -> ml.Model:
    """A plate 60 x 40 mm (3 x 2 substructures) on smooth walls at its left and bottom,
    heated by 100 K: free to expand (with a hole of radius 6 in the middle-top
    substructure where ``hole``)."""
    text = WALLS.replace('[[boundary]]\nname = "right"\nface = "bar.right"\ntype = "mixed"\n'
                         'components = ["displacement", "force"]\nvalue = [0.0, 0.0]\n', "")
    text = text.replace('x = [0.0, 100.0]\ny = [0.0, 10.0]\nelements = [20, 2]\n'
                        'split = [2, 1]', 'x = [0.0, 60.0]\ny = [0.0, 40.0]\n'
                        'elements = [24, 16]\nsplit = [3, 2]')
    text = text.replace('[materials.m]', f'[analysis]\nhypothesis = "{hypothesis}"\n'
                        '[materials.m]')
    text = text.replace('name = "R"\ntype = "reaction"\nboundary = "right"',
                        'name = "R"\ntype = "reaction"\nboundary = "left"')
    text = text.replace("point = [50.0, 10.0]", "point = [60.0, 40.0]")
    text = text.replace("point = [75.0, 2.5]", "point = [45.0, 2.5]")
    text += '[[qoi]]\nname = "u_corner"\ntype = "displacement"\npoint = [60.0, 40.0]\n' \
            'component = "x"\n'
    if hole:
        text += ('[[holes]]\nname = "hole"\nbody = "bar"\nshape = "circle"\n'
                 'centre = [30.0, 30.0]\nradius = 6.0\n')
        text = text.replace("point = [25.0, 5.0]", "point = [30.0, 23.0]")
    return _walls(text)


@pytest.mark.parametrize(("hypothesis", "hole"), [("plane_strain", False),
                                                  ("plane_stress", True)])
def test_a_plate_expands_freely_and_stress_free(hypothesis: str, hole: bool) -> None:
    """Free thermal expansion: u = s α ΔT x (s = 1 + ν in plane strain, 1 in plane
    stress), no stress and no reaction, exact on Q4 with or without a level-set hole
    (its cut cells' load and stiffness share their quadrature); in plane strain the VTK's
    von Mises stress is |σ_zz| = E α ΔT at every cell."""
    model = _free_plate(hypothesis, hole)
    scale = (1.0 + NU) if hypothesis == "plane_strain" else 1.0
    for result in (model.reference(mesh="same"),
                   model.solve(options=ml.LatinOptions(tol=1e-10))):
        assert result.converged
        assert np.asarray(result.qoi["u_corner"]) == pytest.approx(
            [scale * ALPHA * t * 60.0 for t in (50.0, 100.0)], rel=1e-8)
        assert np.asarray(result.qoi["v_top"]) == pytest.approx(
            [scale * ALPHA * t * 40.0 for t in (50.0, 100.0)], rel=1e-8)
        for name in ("R", "s_xx", "s_yy"):
            assert np.abs(result.qoi[name]).max() < 1e-7 * E * ALPHA * 100.0, name
        if hypothesis == "plane_strain" and result.method == "latin":
            from multilatin.io.output import _solid

            cell_data = _solid(result)[3]
            assert cell_data["von_mises"][-1] == pytest.approx(E * ALPHA * 100.0, rel=1e-7)
            assert np.abs(cell_data["stress_xx"][-1]).max() < 1e-7 * E * ALPHA * 100.0


def _spinning_fit() -> ml.ModelSpec:
    spec = importlib.util.spec_from_file_location(
        "gallery_spinning_fit_heated", Path(__file__).parents[1] / "examples" /
        "spinning_fit.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module  # type: ignore[return-value]


def test_heating_the_rim_releases_the_shrink_fit_as_the_closed_form(tmp_path: Path) -> None:
    """The gallery's spinning fit at rest, its rim heated by ΔT: the rim's bore grows by
    α ΔT b, so the fit's pressure is Lamé's with δ − α ΔT b, zero from ΔT = δ / (α b) =
    83.3 K; the reference within the meshes' 1.5 % of p₀, LATIN equal to it."""
    pytest.importorskip("gmsh")
    module = _spinning_fit()
    module.load(tmp_path)  # the meshes
    text = module.MODEL.read_text() + ('\n[parameters.dT]\ndefault = 0.0\n[[temperature]]\n'
                                       'name = "heat"\nbodies = ["rim"]\nvalue = "dT"\n')
    model = ml.Model(ml.ModelSpec.from_string(text, name="heated_fit", folder=tmp_path))
    alpha, delta, seat = 1.2e-5, 0.01, module.SEAT
    at_rest = module.fit_pressure(0.0, delta)
    for heat in (0.0, 40.0, 100.0):
        expected = module.fit_pressure(0.0, delta - alpha * heat * seat)
        reference = model.reference({"dT": heat})
        assert abs(reference.qoi["p_fit"] - expected) < 0.015 * at_rest
        latin = model.solve({"dT": heat}, options=ml.LatinOptions(tol=1e-9, max_iter=5000))
        # the mean pressure within 1e-3: split otherwise at the arc's ends, held on both
        # sides by the symmetry (``test_interference``); the rim's displacement to 1e-7
        assert latin.qoi["u_out"] == pytest.approx(reference.qoi["u_out"], rel=1e-7)
        assert latin.qoi["p_fit"] == pytest.approx(reference.qoi["p_fit"], rel=1e-3,
                                                   abs=1e-6 * at_rest)
        if heat == 100.0:
            assert reference.qoi["p_fit"] == 0.0 and latin.qoi["p_fit"] == 0.0


@pytest.mark.parametrize(("change", "message"), [
    ({"bodies": ["beam"]}, "temperature[0] ('heating').bodies: no body named 'beam'"),
    ({"value": [1.0, 2.0]}, "temperature[0] ('heating').value: a temperature change is one"),
    ({"factor": "cool"}, "temperature[0] ('heating').factor: 'cool' is not a load factor"),
    ({"value": "dT * z"}, "temperature[0] ('heating').value"),
])
def test_a_bad_temperature_names_its_field(change: dict[str, object], message: str) -> None:
    import tomllib

    data = tomllib.loads(WALLS)
    data["temperature"][0].update(change)
    with pytest.raises(ModelError) as info:
        ml.ModelSpec.from_dict(data, name="walls")
    assert message in str(info.value)


def test_a_temperature_on_a_material_without_expansion_is_refused() -> None:
    """A change that would do nothing (α = 0) is an error, not a silent no-op; a negative
    α is refused too."""
    with pytest.raises(ModelError, match=r"temperature\[0\] \('heating'\)\.bodies: body "
                                         r"'bar' has no thermal expansion"):
        _walls(WALLS.replace(f"alpha = {ALPHA}\n", ""))
    with pytest.raises(ModelError, match=r"materials\.m\.alpha: .* >= 0, got -1"):
        _walls(WALLS.replace(f"alpha = {ALPHA}", "alpha = -1e-5"))


def test_show_lists_the_temperature_changes(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    from multilatin.cli import main

    path = tmp_path / "walls.toml"
    path.write_text(WALLS)
    assert main(["show", str(path)]) == 0
    assert "heating: ΔT = 100 × factor 'heat' on every body" in capsys.readouterr().out
