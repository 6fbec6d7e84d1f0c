"""Bodies that slide as one: a free motion of several clusters together (session 51).

B1 without its smooth wall: the top block rides on the centre block, held to it by
friction (μ2) alone, and the push on the centre block drives the pair over the bottom
block. At μ1 = 0.3 the push reaches the bottom contact's capacity at step 10 (15 MPa ×
50 mm = 750 N = 0.3 × 2500 N) while the stop (gap 0.2 mm) is still open: the pair's
position at that step is one of many. Neither block alone is free (the top block sticks
to the centre one), so a search cluster by cluster missed it: the case went unflagged and a
study's warm start from μ1 = 0.25 returned u_A at step 10 = 0.172 mm against the cold
0.0761 mm (``benchmarks/stacked_blocks.py --line``). ``rigid_clusters.contact_unions``
searches the pair too.
"""

from __future__ import annotations

import logging
from collections import OrderedDict
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

import multilatin as ml
from multilatin.decomposition import rigid_clusters
from multilatin.latin import LatinOptions
from multilatin.parameters import Grid
from multilatin.study.plan import clear_operator_cache
from multilatin.study.report import summary_lines
from multilatin.study.runner import run_study

WALL = '''[[boundary]]
name = "wall"
face = "top.right"
type = "wall"           # smooth wall: u_x = 0, no friction
'''


@pytest.fixture(scope="module")
def stack() -> ml.Model:
    text = (resources.files("multilatin") / "models" / "b1.toml").read_text()
    assert WALL in text
    return ml.Model(ml.ModelSpec.from_string(text.replace(WALL, ""), name="stack"))


def test_two_blocks_sliding_as_one_are_flagged(stack: ml.Model) -> None:
    """The pair's motion at step 10 is found and described; the later steps' answers are
    flagged with it (friction carries the position); LATIN equals the reference there."""
    mu = {"mu1": 0.3, "mu2": 0.3, "gap": 0.2}
    result = stack.solve(mu, options=LatinOptions(tol=1e-9, max_iter=5000))
    (motion,) = result.free_motions
    assert motion.step == 10 and motion.bodies == ("centre", "top")
    assert motion.velocity == pytest.approx((1.0, 0.0)) and motion.carried_on
    assert motion.describe().startswith("step 10: centre+top is free to move (translation")
    assert not result.unique
    assert result.qoi_determined["u_A"] == [True] * 9 + [False] * 6
    reference = stack.reference(mu)
    assert result.qoi["R_stop"] == pytest.approx(reference.qoi["R_stop"], rel=1e-6)


def test_a_study_solves_the_stack_from_zero_and_matches_cold(
        stack: ml.Model, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Along μ1 the case at the limit is flagged and solved from zero, so the study's u_A
    equals the cold solve's; with the search cluster by cluster (``MAX_UNIONS`` = 0: the
    behaviour before session 51) the warm answer stands, far off and unflagged — but for the
    study's own comparison of its modes, which says they disagree."""
    grid = Grid({"mu1": [0.25, 0.3], "mu2": [0.3], "gap": [0.2]})

    def u_a_at_step_10(out: Path) -> tuple[np.ndarray, np.ndarray, list[str]]:
        clear_operator_cache()
        result = run_study(stack, grid, modes=("multiresolution", "cold"), out=out,
                           progress=False)
        data = result.dataset.sel(mu2=0.3, gap=0.2, mu1=0.3)
        return data["u_A"].values[:, 9], data["unique"].values, summary_lines(result)

    u_a, unique, summary = u_a_at_step_10(tmp_path / "unions")
    assert not unique.any()
    assert u_a[0] == pytest.approx(u_a[1], rel=1e-4)
    assert not any(line.startswith("MODES DISAGREE") for line in summary)
    monkeypatch.setattr(rigid_clusters, "MAX_UNIONS", 0)
    monkeypatch.setattr(rigid_clusters, "_GEOMETRIES", OrderedDict())  # clusters found anew
    before, unique_before, summary = u_a_at_step_10(tmp_path / "clusters")
    assert unique_before.all() and abs(before[0] / before[1] - 1) > 0.01
    # the study's own comparison of its modes says so (session 52, ``study.agreement``)
    assert "MODES DISAGREE: u_A beyond that bound" in "\n".join(summary)


def test_a_block_nothing_holds_sideways_starts_from_zero_at_once(stack: ml.Model,
                                                                 tmp_path: Path) -> None:
    """At μ2 = 0 nothing holds the top block sideways (its contact frictionless, no wall):
    free at every step, no case is unique. The start predictor (``predictors.
    at_friction_limit``) reads that from the neighbour's state — a motion with no capacity
    at all and nil load along it — so the second case starts from zero at once; before
    session 52 it read only motions with a capacity, and a warm attempt (~100–190
    iterations on this line) was set aside first."""
    clear_operator_cache()
    study = run_study(stack, Grid({"mu1": [0.1, 0.15], "mu2": [0.0], "gap": [0.2]}),
                      modes=("multiresolution",), out=tmp_path, progress=False)
    records = study.mode_records("multiresolution")
    assert [r["unique"] for r in records] == [False, False]
    assert [r["start"] for r in records] == ["zero", "zero"]


def test_unions_follow_the_contacts_smallest_first_and_are_bounded(
        caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch) -> None:
    """A column of five free blocks, each on the next: the unions are its runs of 2–5
    neighbours (4 + 3 + 2 + 1), none of blocks that do not touch; at most ``MAX_UNIONS``,
    with a warning naming the bound."""
    lines = ["[materials.steel]", "E = 2e5", "nu = 0.3"]
    for i in range(6):
        lines += ["[[bodies]]", f'name = "b{i}"', "x = [0.0, 10.0]",
                  f"y = [{10.0 * i}, {10.0 * (i + 1)}]", "elements = [2, 2]",
                  'material = "steel"']
    for i in range(5):
        lines += ["[[interfaces]]", f'between = ["b{i}", "b{i + 1}"]', 'type = "contact"',
                  "friction = 0.2"]
    lines += ["[[boundary]]", 'name = "clamp"', 'face = "b0.bottom"', 'type = "displacement"',
              "value = [0.0, 0.0]", "[[boundary]]", 'name = "press"', 'face = "b5.top"',
              'type = "force"', "value = [0.0, -1.0]"]
    assembly = ml.Model(ml.ModelSpec.from_string("\n".join(lines), name="column")).assemble()
    groups = [g for g in rigid_clusters.clusters(assembly)
              if assembly.substructures[int(g[0])].body != "b0"]  # b0 is clamped
    bodies = [sorted({assembly.substructures[s].body for s in union})
              for union in rigid_clusters.contact_unions(assembly, groups)]
    assert [len(b) for b in bodies] == [2] * 4 + [3] * 3 + [4] * 2 + [5]
    assert ["b1", "b2"] in bodies and ["b1", "b2", "b3", "b4", "b5"] in bodies
    assert all(int(b[-1][1:]) - int(b[0][1:]) == len(b) - 1 for b in bodies)  # runs
    monkeypatch.setattr(rigid_clusters, "MAX_UNIONS", 6)
    with caplog.at_level(logging.WARNING, logger="multilatin.decomposition.rigid_clusters"):
        bounded = rigid_clusters.contact_unions(assembly, groups)
    assert len(bounded) == 6 and "MAX_UNIONS" in caplog.text
