"""Macro-only perfect interfaces between non-matching meshes (paper eq. [20])."""

from pathlib import Path

import numpy as np
import pytest

from multilatin.decomposition.interfaces import interface_functions
from multilatin.errors import ModelError
from multilatin.io.modelfile import ModelSpec
from multilatin.latin import LatinOperators, LatinOptions, solve_latin
from multilatin.latin.local_stage import LocalStage

BAR = """
[materials.m]
E = 1000.0
nu = 0.3
[[bodies]]
name = "bar"
x = [0.0, 3.0]
y = [0.0, 1.0]
elements = [12, 4]
split = [3, 1]
material = "m"
[[bodies.mesh]]
substructure = [1, 0]
elements = [NX, NY]
INTERFACE
[[boundary]]
name = "left"
face = "bar.left"
type = "mixed"
components = ["displacement", "force"]
value = [0.0, 0.0]
[[boundary]]
name = "pin"
face = "bar.bottom"
type = "mixed"
components = ["force", "displacement"]
value = [0.0, 0.0]
[[boundary]]
name = "pull"
face = "bar.right"
type = "force"
value = [2.0, 0.0]
[[qoi]]
name = "u_tip"
type = "displacement"
point = [3.0, 1.0]
component = "x"
[[qoi]]
name = "v_tip"
type = "displacement"
point = [3.0, 1.0]
component = "y"
"""
MACRO = '[[interfaces]]\nbetween = ["bar[1,0]", "bar"]\ntype = "macro"'


def bar(nx, ny, interface=MACRO):
    text = BAR.replace("NX", str(nx)).replace("NY", str(ny)).replace("INTERFACE", interface)
    return ModelSpec.from_string(text).build()


@pytest.mark.parametrize("elements", [(4, 4), (7, 5)])
def test_uniform_tension_is_exact_across_non_matching_meshes(elements):
    """A linear displacement field has no micro part: macro-only interfaces transmit it
    exactly, whether the meshes match or not."""
    assembly = bar(*elements)
    assert sum(itf.kind == "macro" for itf in assembly.interfaces) == 2
    result = solve_latin(assembly, LatinOptions(tol=1e-10, max_iter=2000))
    assert result.qoi["u_tip"] == pytest.approx(2.0 * 3.0 / 1000.0, rel=1e-7)
    assert result.qoi["v_tip"] == pytest.approx(-0.3 * 2.0 / 1000.0, rel=1e-7)


def test_local_stage_of_macro_only_interfaces():
    """From any (W, F): F̂ has no micro part, the macro forces balance, the macro
    displacements are continuous, ŝ lies on E+, and an admissible ŝ is a fixed point."""
    assembly = bar(7, 5)
    ops = LatinOperators(assembly, LatinOptions())
    pts, k = ops.points, ops.search_direction
    local = LocalStage([assembly], [pts], k)
    rng = np.random.default_rng(0)
    w, f = rng.normal(size=(2, 2, pts.n_points, 2))
    w_hat, f_hat = (field[0] for field in local(w[None], f[None]))
    for i in pts.macro_only:
        functions = interface_functions(pts, i, 2)
        sides = [pts.side_points[(i, s)] for s in range(2)]
        for comp in range(2):
            resultants, macro = [], []
            for g, p in zip(functions, sides, strict=True):
                weighted = g.T * pts.weights[p]
                resultants.append(weighted @ f_hat[:, p, comp].T)
                macro.append(np.linalg.solve(weighted @ g, weighted @ w_hat[:, p, comp].T))
                coefficients = np.linalg.lstsq(g, f_hat[:, p, comp].T, rcond=None)[0]
                np.testing.assert_allclose(g @ coefficients, f_hat[:, p, comp].T, atol=1e-10)
            np.testing.assert_allclose(resultants[0] + resultants[1], 0.0, atol=1e-10)
            np.testing.assert_allclose(macro[0], macro[1], atol=1e-12)
        for p in sides:
            np.testing.assert_allclose(f_hat[:, p] - f[:, p], k[p] * (w_hat[:, p] - w[:, p]),
                                       atol=1e-10)
    again = [field[0] for field in local(w_hat[None], f_hat[None])]
    m = local.macro_points
    np.testing.assert_allclose(again[0][:, m], w_hat[:, m], atol=1e-12)
    np.testing.assert_allclose(again[1][:, m], f_hat[:, m], atol=1e-10)


B0 = Path(__file__).parents[1] / "src" / "multilatin" / "models" / "b0.toml"


@pytest.mark.parametrize("elements", ["[8, 8]", "[16, 16]", "[5, 5]"])
def test_cantilever_with_a_non_matching_substructure(elements):
    """B0 with its middle substructure meshed differently, joined by macro-only interfaces:
    the tip deflection stays within 0.2 % of the matching decomposition (which equals the
    monolithic solution); the micro jump is a discretisation-level difference."""
    text = B0.read_text()
    matching = solve_latin(ModelSpec.from_string(text).build(), LatinOptions(tol=1e-8))
    changed = text.replace('material = "steel"\n', 'material = "steel"\n[[bodies.mesh]]\n'
                           f'substructure = [4, 0]\nelements = {elements}\n[[interfaces]]\n'
                           'between = ["beam[4,0]", "beam"]\ntype = "macro"\n', 1)
    result = solve_latin(ModelSpec.from_string(changed).build(), LatinOptions(tol=1e-8))
    assert result.qoi["v_tip"] == pytest.approx(matching.qoi["v_tip"], rel=2e-3)


def test_non_matching_perfect_interfaces_are_mortar_ones_and_bad_overrides_are_refused():
    assert [itf.kind for itf in bar(7, 5, interface="").interfaces[:2]] == ["perfect"] * 2
    with pytest.raises(ModelError, match=r"mesh\[0\].substructure"):
        ModelSpec.from_string(BAR.replace("[1, 0]", "[3, 0]").replace("NX", "4")
                              .replace("NY", "4").replace("INTERFACE", ""))
