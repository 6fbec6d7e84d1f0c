"""Body forces (``[[body_force]]``: gravity, a spinning part's inertia), against closed
forms: a bar hanging under its own weight (ν = 0: a 1-D problem that Q4 cells solve
exactly at the nodes, and exactly in stress at the cells' centres), a block pressed on a
foundation by its own weight and pushed until it slides (the friction force μ × weight),
a holed plate whose weight is its material's only, and a spinning ring (plane stress,
ρ ω² r): LATIN equals the monolithic reference, on both backends and at two κ."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest
from conftest import has_torch, write_gmsh_ring

import multilatin as ml
from multilatin.errors import ModelError

#: a bar 10 x 100 mm in two substructures, hung from its top face, its weight rho_g per
#: unit volume applied in two steps (half, then all)
BAR = """
[parameters.rho_g]
default = 0.1
unit = "N/mm3"
[materials.m]
E = 1e4
nu = 0.0
[[bodies]]
name = "bar"
x = [0.0, 10.0]
y = [0.0, 100.0]
elements = [2, 20]
split = [1, 2]
material = "m"
[history.factors]
g = [0.5, 1.0]
[[boundary]]
name = "hook"
face = "bar.top"
type = "displacement"
value = [0.0, 0.0]
[[body_force]]
name = "gravity"
value = [0.0, "-rho_g"]
factor = "g"
[[qoi]]
name = "v_tip"
type = "displacement"
point = [5.0, 0.0]
component = "y"
[[qoi]]
name = "v_mid"
type = "displacement"
point = [5.0, 50.0]
component = "y"
body = "bar"
[[qoi]]
name = "R_hook"
type = "reaction"
boundary = "hook"
component = "y"
[[qoi]]
name = "s_yy"
type = "stress"
point = [5.0, 27.5]
component = "yy"
"""


#: a plate 60 x 40 mm in three substructures hung from its top face, a hole of radius 8 in
#: the middle one, its weight 0.01 N/mm³
HOLED_PLATE = """
[materials.m]
E = 2e5
nu = 0.3
[[bodies]]
name = "plate"
x = [0.0, 60.0]
y = [0.0, 40.0]
elements = [24, 16]
split = [3, 1]
material = "m"
[[holes]]
name = "hole"
body = "plate"
shape = "circle"
centre = [30.0, 20.0]
radius = 8.0
[[boundary]]
name = "hook"
face = "plate.top"
type = "displacement"
value = [0.0, 0.0]
[[body_force]]
value = [0.0, -0.01]
[[qoi]]
name = "R"
type = "reaction"
boundary = "hook"
component = "y"
[[qoi]]
name = "v"
type = "displacement"
point = [30.0, 0.0]
component = "y"
"""


def _bar() -> ml.Model:
    return ml.Model(ml.ModelSpec.from_string(BAR, name="bar"))


def _bar_closed_form(rho_g: float, factor: float) -> dict[str, float]:
    """Bar of length L = 100 hung at y = L: σ_yy = ρ g y, v = −ρ g (L² − y²) / (2 E)."""
    load, length, young = rho_g * factor, 100.0, 1e4
    return {"v_tip": -load * length**2 / (2.0 * young),
            "v_mid": -load * (length**2 - 50.0**2) / (2.0 * young),
            "R_hook": load * 10.0 * length, "s_yy": load * 27.5}


def _close(result: ml.SolveResult, expected: list[dict[str, float]], rel: float) -> None:
    for name in expected[0]:
        values = [float(v) for v in np.atleast_1d(result.qoi[name])]
        assert values == pytest.approx([e[name] for e in expected], rel=rel), name


def test_a_bar_hanging_under_its_own_weight_is_the_closed_form() -> None:
    """Nodal displacements, the hook's reaction (the weight) and the stress at a cell's
    centre are exact with ν = 0; LATIN gives them at two κ, on both backends and with its
    QoIs read from the interface fields (``recover_displacements=False``, as studies do:
    the body forces' share of a point QoI is its constant)."""
    model = _bar()
    expected = [_bar_closed_form(0.1, factor) for factor in (0.5, 1.0)]
    _close(model.reference(), expected, 1e-10)
    backends = ["numpy"] + (["torch"] if has_torch() else [])
    for backend in backends:
        for kappa in (0.5, 2.0):
            for recover in (True, False):
                options = ml.LatinOptions(tol=1e-10, kappa=kappa, backend=backend,
                                          recover_displacements=recover)
                result = model.solve(options=options)
                assert result.converged
                _close(result, expected, 1e-7)


def test_the_recovered_bar_holds_its_weight_everywhere() -> None:
    """The recovered displacement field (interior included: S⁻¹ f added) is the parabola at
    every node of both substructures."""
    result = _bar().solve(options=ml.LatinOptions(tol=1e-11))
    assembly = result.assembly
    for sub in assembly.substructures:
        y = sub.mesh.nodes[:, 1]
        exact = -0.1 * (100.0**2 - y**2) / (2.0 * 1e4)
        field = result.displacements[sub.name][1]
        assert np.abs(field[:, 1] - exact).max() < 1e-9 * 0.05
        assert np.abs(field[:, 0]).max() < 1e-12


SLIDE = Path(__file__).parents[1] / "src" / "multilatin" / "models" / "slide.toml"


def _weighted_slide() -> ml.Model:
    """The bundled slide with no pressure on the block: its own weight, 0.5 N/mm³ × 400
    mm² = 200 N (what the pressure of 10 MPa gave), presses it on the foundation."""
    return ml.Model(ml.ModelSpec.from_string(_weighted_slide_text(), name="weighted_slide"))


def _weighted_slide_text() -> str:
    text = SLIDE.read_text().replace('name = "pressure"\nface = "block.top"\ntype = "force"\n'
                                     'value = [0.0, "-p"]\nfactor = "press"\n',
                                     'name = "pressure"\nface = "block.top"\ntype = "force"\n'
                                     'value = [0.0, 0.0]\n')
    assert 'value = [0.0, "-p"]' not in text
    text += ('\n[[body_force]]\nname = "weight"\nbodies = ["block"]\nvalue = [0.0, -0.5]\n'
             'factor = "press"\n')
    return text


def test_a_block_pressed_by_its_weight_slides_at_mu_times_its_weight() -> None:
    """Once the block slides, the push's force is μ × its weight (the contact's normal
    resultant, by the block's vertical equilibrium), whatever the elasticity; before, the
    reference's stick. LATIN equals the reference at every step at two κ."""
    model = _weighted_slide()
    reference = model.reference({"mu": 0.3})
    push = np.asarray(reference.qoi["R_push"])
    assert push[-3:] == pytest.approx([0.3 * 200.0] * 3, rel=1e-9)
    assert 0.0 < push[3] < 0.3 * 200.0
    for kappa in (0.5, 2.0):
        latin = model.solve({"mu": 0.3}, options=ml.LatinOptions(tol=1e-9, kappa=kappa,
                                                                 max_iter=5000))
        assert latin.converged
        assert np.asarray(latin.qoi["R_push"]) == pytest.approx(push, rel=1e-5, abs=1e-6)


def _incline(theta: float) -> ml.Model:
    """The weighted slide without its push: the block rests on the foundation under its
    weight tilted by θ (a foundation inclined by θ), held by friction alone."""
    text = _weighted_slide_text().replace('value = [0.0, -0.5]',
                                          f'value = ["0.5 * sin({theta})", '
                                          f'"-0.5 * cos({theta})"]')
    start = text.index('[[boundary]]\nname = "push"')
    text = text[:start] + text[text.index("[[qoi]]", start):]
    text = text.replace('name = "R_push"', 'name = "R_clamp"').replace('boundary = "push"',
                                                                     'boundary = "clamp"')
    return ml.Model(ml.ModelSpec.from_string(text, name="incline"))


def test_a_block_on_an_incline_holds_below_its_friction_angle_only() -> None:
    """Below the friction angle (tan θ < μ) the block sticks and the foundation's clamp
    holds its weight's slope component W sin θ (equilibrium); beyond it no equilibrium
    exists: LATIN says so (never an answer) and the reference does not converge."""
    weight, mu = 200.0, 0.3
    for theta in (0.2, 0.4):
        model = _incline(theta)
        latin = model.solve({"mu": mu}, check=False)
        if math.tan(theta) < mu:
            assert latin.converged
            assert latin.qoi["R_clamp"][-1] == pytest.approx(-weight * math.sin(theta),
                                                             rel=1e-6)
        else:
            assert not latin.converged and "no equilibrium" in latin.failure
            with pytest.raises(ml.NotConvergedError):
                model.reference({"mu": mu})


@pytest.mark.parametrize("padded", [False, True])
def test_a_weighted_batch_on_the_device_equals_the_numpy_one(
        padded: bool, monkeypatch: pytest.MonkeyPatch) -> None:
    """Three frictions of the weighted slide in one batch, leaving at different iterations,
    on PyTorch (``padded``: rows kept and the whole iteration as one function, as a GPU
    runs it) and on NumPy: the same iterations and answers, under the QoI rule too (the
    QoIs' constants on the device's side)."""
    pytest.importorskip("torch")
    from dataclasses import replace

    from multilatin.latin import solve_latin_batch, torch_engine

    if padded:
        monkeypatch.setattr(torch_engine, "PADDED_DEVICES", ("cuda", "cpu"))
        monkeypatch.setattr(torch_engine, "FUSED_DEVICES", ("cuda", "cpu"))
    model = _weighted_slide()
    batch = [model.assemble({"mu": mu}) for mu in (0.1, 0.3, 0.6)]
    options = ml.LatinOptions(qoi_rtol=1e-3, settled_steps=0.0)
    reference = solve_latin_batch(batch, options)
    got = solve_latin_batch(batch, replace(options, backend="torch", device="cpu"))
    assert len({r.iterations for r in reference}) > 1
    read = solve_latin_batch(batch, replace(options, recover_displacements=False))
    for one, other, functional in zip(reference, got, read, strict=True):
        assert one.iterations == other.iterations == functional.iterations
        assert one.stopped_on_qoi
        for name in ("R_push", "u_right"):  # u_right: the weight's share is a constant
            for result in (other, functional):
                assert np.asarray(result.qoi[name]) == pytest.approx(
                    np.asarray(one.qoi[name]), rel=1e-9, abs=1e-15), name


def test_a_holed_plate_weighs_its_material_only() -> None:
    """A plate 60 x 40 mm (three substructures) hung from its top, a hole of radius 8
    (level set) in the middle one: the hook carries ρ g (60 × 40 − π 8²) t, the hole's
    cut cells integrated on their material part (9.6e-5 off; the conforming mesh's
    polygon 2.6e-4); LATIN equals the reference on the same meshes."""
    model = ml.Model(ml.ModelSpec.from_string(HOLED_PLATE, name="holed_plate"))
    weight = 0.01 * (60.0 * 40.0 - math.pi * 8.0**2)
    reference = model.reference(mesh="same")
    assert reference.qoi["R"] == pytest.approx(weight, rel=1e-3)
    latin = model.solve(options=ml.LatinOptions(tol=1e-10, max_iter=5000))
    assert latin.qoi["R"] == pytest.approx(reference.qoi["R"], rel=1e-8)
    assert latin.qoi["v"] == pytest.approx(reference.qoi["v"], rel=1e-7)


def _spinning_annulus() -> ModuleType:
    """The spinning-fit gallery script (``free_spin_u``: a free spinning annulus's radial
    displacement, plane stress, steel: E = 210 000 MPa, ν = 0.3, ρ = 7.85e-9 t/mm³)."""
    spec = importlib.util.spec_from_file_location(
        "gallery_spinning_fit", Path(__file__).parents[1] / "examples" / "spinning_fit.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def spinning_rings(load: float) -> str:
    """The rings of ``data/rings.toml`` in plane stress, their bore's pressure replaced by
    the body force ``load`` × (x, y) (ρ ω² r), and the hub's rim displacement a QoI."""
    rings = (Path(__file__).parent / "data" / "rings.toml").read_text()
    text = rings.replace('hypothesis = "plane_strain"', 'hypothesis = "plane_stress"')
    text = text.replace('[[boundary]]\nname = "p"\nface = "inner.bore"\ntype = "pressure"\n'
                        'value = 100.0\n', "")
    assert "inner.bore" not in text
    return text + (f'\n[[body_force]]\nname = "spin"\nvalue = ["{load} * x", "{load} * y"]\n'
                   '[[qoi]]\nname = "u_rim"\ntype = "displacement"\npoint = [10.0, 0.0]\n'
                   'component = "x"\nbody = "inner"\n')


def test_two_spinning_rings_part_and_each_spins_as_the_closed_form(tmp_path: Path) -> None:
    """Rings 5–10 and 10–20 mm in contact (quarter model), spun: the outer one's bore grows
    more than the inner one's rim, the contact opens and each ring expands as a free
    spinning annulus (plane stress); the reference converges to it under refinement and
    LATIN equals the reference."""
    pytest.importorskip("gmsh")
    a, b, c, young, nu, load = 5.0, 10.0, 20.0, 210_000.0, 0.3, 100.0
    (tmp_path / "rings.toml").write_text(spinning_rings(load))
    spin = _spinning_annulus()
    assert (spin.YOUNG, spin.NU) == (young, nu)
    omega = math.sqrt(load / spin.RHO)  # ρ ω² = load
    exact = {"u_out": spin.free_spin_u(c, b, c, omega),
             "u_rim": spin.free_spin_u(b, a, b, omega)}
    errors = []
    for size in (1.0, 0.5):
        write_gmsh_ring(tmp_path / "inner.msh", a, b, size, ("bore", "rim"))
        write_gmsh_ring(tmp_path / "outer.msh", b, c, 1.6 * size, ("seat", None))
        model = ml.load_model(tmp_path / "rings.toml")
        reference = model.reference()
        assert reference.qoi["p_c"] == pytest.approx(0.0, abs=1e-9)
        errors.append(max(abs(reference.qoi[name] / exact[name] - 1.0) for name in exact))
        if size == 1.0:
            latin = model.solve(options=ml.LatinOptions(tol=1e-9, max_iter=20000))
            assert latin.converged
            for name in exact:
                assert latin.qoi[name] == pytest.approx(reference.qoi[name], rel=1e-6)
            assert latin.qoi["p_c"] == pytest.approx(0.0, abs=1e-6 * load * c**2)
    assert errors[0] < 0.02 and errors[1] < errors[0] / 2.0


def test_a_study_over_the_weight_is_linear_in_it() -> None:
    """A study over ρ g (warm starts from one weight to the next, QoIs from the interface
    fields): the tip's displacement is the closed form at every case within the study's
    accuracy."""
    study = ml.run_study(_bar(), ml.Grid.parse(["rho_g=0.05:0.2:4"]))
    for record in study.mode_records("multiresolution"):
        rho_g = record["params"]["rho_g"]
        assert record["qoi"]["v_tip"][1] == pytest.approx(
            _bar_closed_form(rho_g, 1.0)["v_tip"], rel=1e-3)


@pytest.mark.parametrize(("change", "message"), [
    ({"bodies": ["beam"]}, "body_force[0] ('gravity').bodies: no body named 'beam'"),
    ({"factor": "G"}, "body_force[0] ('gravity').factor: 'G' is not a load factor"),
    ({"value": [0.0, "-rho_g * z"]}, "body_force[0] ('gravity').value"),
    ({"value": [0.0]}, "body_force[0] ('gravity').value"),
    ({"density": 7.8e-9}, "body_force[0]: unknown field 'density'"),
])
def test_a_bad_body_force_names_its_field(change: dict[str, object], message: str) -> None:
    import tomllib

    data = tomllib.loads(BAR)
    data["body_force"][0].update(change)
    with pytest.raises(ModelError) as info:
        ml.ModelSpec.from_dict(data, name="bar")
    assert message in str(info.value)


def test_show_lists_the_body_forces(tmp_path: Path,
                                    capsys: pytest.CaptureFixture[str]) -> None:
    """``multilatin show`` names each body force, its factor, bodies and resultant (the
    bar's weight at a unit factor: 0.1 × 1 000 mm³)."""
    from multilatin.cli import main

    path = tmp_path / "bar.toml"
    path.write_text(BAR)
    assert main(["show", str(path)]) == 0
    out = capsys.readouterr().out
    assert ("gravity: (0, -0.1) per unit volume × factor 'g' on every body; resultant "
            "(0, -100)") in out
