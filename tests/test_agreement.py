"""``study.agreement.mode_agreement``: the largest difference between a study's modes, over
the values both converged to and both determine, relative to max(|cold|, 1 % of the QoI's
largest |cold|)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from multilatin.study.agreement import mode_agreement


def _record(number: int, qoi: dict[str, Any], converged: bool = True,
            determined: dict[str, Any] | None = None) -> dict[str, Any]:
    return {"number": number, "converged": converged, "qoi": qoi,
            "qoi_determined": determined or {}}


def test_differences_are_relative_to_the_cold_value_with_a_floor() -> None:
    cold = [_record(0, {"R": 100.0, "u": [0.0, 2.0]}), _record(1, {"R": 0.5, "u": [1.0, 4.0]})]
    warm = [_record(0, {"R": 100.1, "u": [0.01, 2.0]}), _record(1, {"R": 0.6, "u": [1.0, 4.0]})]
    within = mode_agreement(warm, cold)
    # R: case 1 differs by 0.1 on a floor of 1 (1 % of 100): 0.1; case 0 by 1e-3
    assert within["R"] == pytest.approx(0.1)
    # u: 0.01 on a floor of 0.04 (1 % of 4)
    assert within["u"] == pytest.approx(0.25)


def test_failed_cases_and_undetermined_values_are_left_out() -> None:
    cold = [_record(0, {"u": [1.0, 2.0]}), _record(1, {"u": [1.0, 2.0]})]
    warm = [_record(0, {"u": [5.0, 2.0]}, determined={"u": [False, True]}),
            _record(1, {"u": [np.nan, np.nan]}, converged=False)]
    assert mode_agreement(warm, cold) == {"u": 0.0}
    assert mode_agreement([_record(0, {"u": 1.0}, converged=False)], cold[:1]) == {}
    only_undetermined = mode_agreement(warm[:1], [_record(0, {"u": [1.0, 2.0]},
                                                          determined={"u": [True, False]})])
    assert np.isnan(only_undetermined["u"])
