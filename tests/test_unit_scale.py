"""The solver has no unit of its own: B1 written in metres and pascals (lengths × 1e-3,
stresses × 1e6, so forces in newtons stay as they are) takes the same iterations under
both stopping rules, with the same forces and displacements × 1e-3. An absolute threshold
anywhere (a tolerance in mm, a floor in N) would break it."""

from __future__ import annotations

import re
from importlib.resources import files
from pathlib import Path

import numpy as np
import pytest

import multilatin as ml


def _in_metres_and_pascals() -> str:
    text = (files("multilatin") / "models" / "b1.toml").read_text()

    def metres(match: re.Match[str]) -> str:
        return f"{match[1]} = [{float(match[2]) * 1e-3!r}, {float(match[3]) * 1e-3!r}]"

    replaced, count = re.subn(r"(x|y|point) = \[([\d.]+), ([\d.]+)\]", metres, text)
    assert count == 7  # three bodies' x and y, and point A
    for old, new in [("thickness = 1.0", "thickness = 0.001"), ("E = 2e5", "E = 2e11"),
                     ("default = 0.04", "default = 4e-05"),
                     ("value = [0.0, -1.0]", "value = [0.0, -1e6]"),
                     ("value = [1.0, 0.0]", "value = [1e6, 0.0]"),
                     ('segment = ["50 - 50 / 6", 50.0]', 'segment = ["0.05 - 0.05 / 6", 0.05]')]:
        assert old in replaced, old
        replaced = replaced.replace(old, new)
    return replaced


@pytest.mark.parametrize("qoi_rtol", [None, 1e-3])
def test_b1_in_metres_and_pascals_is_b1(tmp_path: Path, qoi_rtol: float | None) -> None:
    (tmp_path / "b1_si.toml").write_text(_in_metres_and_pascals())
    options = ml.LatinOptions(qoi_rtol=qoi_rtol)
    for mu in ({"mu1": 0.1, "mu2": 0.3}, {"mu1": 0.3, "mu2": 0.15}):
        mm = ml.load_model("b1").solve(mu, options=options)
        si = ml.load_model(tmp_path / "b1_si.toml").solve(mu, options=options)
        assert si.iterations == mm.iterations
        assert si.qoi["R_stop"] == pytest.approx(mm.qoi["R_stop"], rel=1e-9)
        np.testing.assert_allclose(si.qoi["u_A"], 1e-3 * np.asarray(mm.qoi["u_A"]),
                                   rtol=1e-9, atol=1e-12 * 1e-3)
        np.testing.assert_allclose(si.qoi["p_B"], 1e6 * np.asarray(mm.qoi["p_B"]),
                                   rtol=1e-9, atol=1e-12 * 1e6)
