"""One answer per parameter set whatever the path (issue 14, item 1).

B1 at μ1 + μ2 = 0.3 reaches the sliding limit at step 10 (push 15 MPa × 50 mm = 750 N =
0.3 × 2500 N): the centre block's position at that step is not determined by the discrete
problem, and friction carries it into steps 11–15. A warm start from (0.05, 0.2) picks
another solution than a cold start or the reference (R_stop 786.2 N against 777.1 N). Such
states are detected (``multilatin.decomposition.uniqueness``), flagged, and solved from zero in studies.
"""

from __future__ import annotations

import json
import logging
from importlib import resources
from pathlib import Path

import meshio
import numpy as np
import pytest

import multilatin as ml
from multilatin.cli import main
from multilatin.decomposition.rigid_clusters import clusters
from multilatin.latin import LatinOptions, solve_latin
from multilatin.parameters import Grid
from multilatin.study import starts
from multilatin.study.plan import clear_operator_cache
from multilatin.study.report import summary_lines, write_study_outputs
from multilatin.study.runner import run_study
from multilatin.study.store import load_study


@pytest.fixture(scope="module")
def b1() -> ml.Model:
    return ml.load_model("b1")


def test_clusters_are_the_bodies_of_b1_9() -> None:
    assembly = ml.load_model("b1-9").assemble()
    groups = clusters(assembly)
    assert len(groups) == 3
    assert sorted({assembly.substructures[s].body for s in g}.pop() for g in groups) == [
        "bottom", "centre", "top"]
    assert all(len({assembly.substructures[s].body for s in g}) == 1 for g in groups)


@pytest.mark.parametrize(("mu", "free_steps", "unique"), [
    ((0.05, 0.25), [10], False),  # sliding limit at step 10, friction carries it on
    ((0.15, 0.15), [10], False),
    ((0.3, 0.3), [15], False),  # sliding limit at the last step
    ((0.3, 0.0), [], True),
    ((0.1, 0.3), [], True),
    ((0.0, 0.0), [1, 2, 3, 4, 5], True),  # floats in the frictionless preload only
])
def test_free_motions_at_the_friction_limit_are_found(b1: ml.Model, mu: tuple[float, float],
                                                      free_steps: list[int],
                                                      unique: bool) -> None:
    result = b1.solve({"mu1": mu[0], "mu2": mu[1]})
    assert [m.step for m in result.free_motions] == free_steps
    assert result.unique is unique
    for motion in result.free_motions:
        assert motion.bodies == ("centre",)
        assert motion.velocity == pytest.approx((1.0, 0.0), abs=1e-9)  # sliding along +x
        assert motion.reserve < 1e-3
    assert result.to_json_dict()["unique"] is unique
    # which values are determined: a free motion moves u_A (the centre's, along x) at its
    # step, not the forces; after a motion that friction carries on, nothing is
    later = {t for s in free_steps if not unique for t in range(s + 1, 16)}
    determined = result.qoi_determined
    assert determined["u_A"] == [t not in set(free_steps) | later for t in range(1, 16)]
    assert determined["p_B"] == [t not in later for t in range(1, 16)]
    assert determined["R_stop"] is (15 not in later)  # a force, at step 15 only
    assert result.to_json_dict()["qoi_determined"] == determined


def test_a_warm_start_alone_picks_another_solution(b1: ml.Model, tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """What the study guards against, shown with the guard removed: warm-started from
    (0.05, 0.2) alone (``start="nearest"``; the retimed start from (0.05, 0.2) and (0.05,
    0.15) happens to land within 1e-7 of the reference, which proves nothing), case (0.05,
    0.25) converges to a state 1.2 % away from the reference's, and the state is flagged as
    not unique."""
    monkeypatch.setattr(starts, "set_aside", lambda result, start: None)
    monkeypatch.setattr(starts, "at_limit",  # and no start from zero foreseen
                        lambda assemblies, ops, fields: [False] * len(assemblies))
    clear_operator_cache()
    result = run_study(b1, Grid({"mu2": [0.15, 0.2, 0.25], "mu1": [0.05]}), out=tmp_path,
                       progress=False, start="nearest")  # from the middle case outward
    warm = result.mode_records("multiresolution")[2]
    assert warm["start"] == "mu2=0.2, mu1=0.05"
    reference = b1.reference({"mu1": 0.05, "mu2": 0.25}).qoi["R_stop"]
    assert reference == pytest.approx(777.097, abs=0.01)
    assert abs(warm["qoi"]["R_stop"] - reference) > 5e-3 * reference
    assert warm["unique"] is False


def test_the_grid_in_both_orders_and_cold_gives_the_reference_answers(
        b1: ml.Model, tmp_path: Path) -> None:
    """The acceptance test of issue 14 item 1 on a 3 x 3 corner of the B1 grid holding three
    sliding-limit cases (the 13 x 13 grid: ``benchmarks/path_independence.py``): every case,
    in either traversal order and cold, within 0.1 % of the reference solver, or flagged."""
    values_1, values_2 = [0.0, 0.05, 0.1], [0.2, 0.25, 0.3]
    answers: dict[tuple[float, float], list[tuple[float, bool]]] = {}
    for name, grid, modes in (
            ("mu1 outer", Grid({"mu1": values_1, "mu2": values_2}), ("multiresolution", "cold")),
            ("mu2 outer", Grid({"mu2": values_2, "mu1": values_1}), ("multiresolution",))):
        clear_operator_cache()
        result = run_study(b1, grid, out=tmp_path / name, progress=False, modes=modes)
        for record in result.records:
            key = (record["params"]["mu1"], record["params"]["mu2"])
            answers.setdefault(key, []).append((record["qoi"]["R_stop"], record["unique"]))
    flagged, flagged_by_the_reference = set(), set()
    for (mu1, mu2), found in answers.items():
        assert len(found) == 3
        monolithic = b1.reference({"mu1": mu1, "mu2": mu2})
        if not monolithic.unique:
            flagged_by_the_reference.add((mu1, mu2))
        reference = monolithic.qoi["R_stop"]
        for value, unique in found:
            if not unique:
                flagged.add((mu1, mu2))
            assert abs(value - reference) <= 1e-3 * max(abs(reference), 1.0), (mu1, mu2)
        # one answer per parameter set, whatever the path
        assert max(v for v, _ in found) - min(v for v, _ in found) <= 1e-3 * max(
            abs(reference), 1.0)
    assert flagged == {(0.0, 0.3), (0.05, 0.25), (0.1, 0.2)}
    # the reference says so too (its state read by the same rule, session 44)
    assert flagged_by_the_reference == flagged


def test_solve_reports_a_state_that_is_not_unique(b1: ml.Model) -> None:
    assembly = b1.assemble({"mu1": 0.05, "mu2": 0.25})
    result = solve_latin(assembly, LatinOptions())
    data = result.to_json_dict()
    assert data["unique"] is False
    assert "step 10: centre is free to move" in data["free_motions"][0]


def test_a_case_at_the_friction_limit_is_predicted_from_a_neighbour_s_state(
        b1: ml.Model) -> None:
    """``predictors.at_friction_limit`` on B1 (push 750 N at step 10): read with (0.05,
    0.25)'s friction coefficients (capacity 0.3 × 2500 N = 750 N), the converged state of
    (0.05, 0.3) (the block sticks) and that of (0.05, 0.2) (it slid onto the stop, which
    holds 125 N) both leave the block at its friction limit at step 10: the case is not
    unique, as its own solve says. Not predicted: (0.05, 0.35) from (0.05, 0.3) (12.5 % of
    the capacity left), nor (0.45, 0.15) from (0.4, 0.15), at its limit at step 15 but
    on the stop since step 13 (unique)."""
    from multilatin.study.predictors import at_friction_limit

    def predicted(case: tuple[float, float], neighbour: tuple[float, float]
                  ) -> ml.FreeMotion | None:
        result = b1.solve({"mu1": neighbour[0], "mu2": neighbour[1]})
        assert result.interface is not None
        assembly = b1.assemble({"mu1": case[0], "mu2": case[1]})
        ops = ml.LatinOperators(assembly, LatinOptions())
        fields = (result.interface.displacement_hat, result.interface.force_hat)
        return at_friction_limit([assembly], [ops.points], [fields])[0]

    for neighbour in ((0.05, 0.3), (0.05, 0.2)):
        motion = predicted((0.05, 0.25), neighbour)
        assert motion is not None and motion.step == 10 and motion.bodies == ("centre",)
        assert motion.velocity == pytest.approx((1.0, 0.0), abs=1e-9)
        assert abs(motion.reserve) < 1e-3
    assert b1.solve({"mu1": 0.05, "mu2": 0.25}).unique is False
    assert predicted((0.05, 0.35), (0.05, 0.3)) is None
    assert b1.solve({"mu1": 0.05, "mu2": 0.35}).unique is True
    assert predicted((0.45, 0.15), (0.4, 0.15)) is None
    assert b1.solve({"mu1": 0.45, "mu2": 0.15}).unique is True


def test_a_study_starts_a_case_at_the_friction_limit_from_zero(
        b1: ml.Model, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        caplog: pytest.LogCaptureFixture) -> None:
    """B1, μ1 = 0.05, μ2 from 0.35 down to 0.25 (a line, case after case): (0.05, 0.25)
    is at the friction limit and not unique; predicted from (0.05, 0.3)'s state it starts
    from zero at once, where without the prediction its warm attempt is set aside and it is
    solved again from zero. Fewer iterations, the same answers; ``start`` says zero, the
    record is still flagged."""
    grid = Grid({"mu1": [0.05], "mu2": [0.35, 0.3, 0.25]})
    runs = {}
    for name in ("predicted", "without"):
        if name == "without":
            monkeypatch.setattr(starts, "at_limit",
                                lambda assemblies, ops, fields: [False] * len(assemblies))
        clear_operator_cache()
        with caplog.at_level(logging.INFO, logger="multilatin"):
            result = run_study(b1, grid, out=tmp_path / name, progress=False,
                               modes=("multiresolution",))
        runs[name] = {r["params"]["mu2"]: r for r in result.records}
        said = [r.getMessage() for r in caplog.records if "at the friction limit" in
                r.getMessage()]
        if name == "predicted":  # the log names the case, the motion and the step
            [line] = said
            assert line.startswith("b1 (gap=0.04, mu1=0.05, mu2=0.25): at the friction "
                                   "limit from its neighbour's state (step 10: centre is "
                                   "free to move (translation (+1, +0))")
            assert line.endswith("started from zero")
        else:
            assert not said
        caplog.clear()
    limit, without = runs["predicted"][0.25], runs["without"][0.25]
    assert without["start"] == "zero (not unique: the warm start was set aside)"
    assert limit["start"] == "zero" and limit["unique"] is False
    assert limit["iterations"] < without["iterations"]
    assert sum(r["iterations"] for r in runs["predicted"].values()) < sum(
        r["iterations"] for r in runs["without"].values())
    for mu2, record in runs["predicted"].items():
        assert record["qoi"]["R_stop"] == pytest.approx(
            runs["without"][mu2]["qoi"]["R_stop"], rel=1e-4)
    assert runs["predicted"][0.3]["start"] == "mu1=0.05, mu2=0.35"


LIFTED = '''
[analysis]
hypothesis = "plane_strain"
[materials.steel]
E = 2e5
nu = 0.3
[[bodies]]
name = "foundation"
x = [0.0, 40.0]
y = [0.0, 10.0]
elements = [8, 2]
material = "steel"
[[bodies]]
name = "block"
x = [10.0, 30.0]
y = [10.0, 20.0]
elements = [4, 2]
material = "steel"
[[interfaces]]
between = ["foundation", "block"]
type = "contact"
friction = 0.3
[history.factors]
press = [1.0, 1.0, -0.1, 1.0, 1.0]
push = [0.0, 0.5, 0.0, 0.0, 0.5]
[[boundary]]
name = "clamp"
face = "foundation.bottom"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "press"
face = "block.top"
type = "mixed"
components = ["force", "displacement"]
value = [0.0, -0.01]
factor = "press"
[[boundary]]
name = "push"
face = "block.left"
type = "force"
value = [40.0, 0.0]
factor = "push"
[[qoi]]
name = "u_top"
type = "displacement"
point = [20.0, 20.0]
component = "x"
'''


def test_the_reference_says_when_its_answer_is_not_unique(b1: ml.Model, capsys) -> None:
    """The monolithic reference reads its converged state by the same rule as LATIN (session
    44; it returned one of the solutions silently). B1 at (0.05, 0.25), and a block lifted
    off its foundation at step 3 (nothing holds it along x), pressed down and pushed again:
    where it lands is not determined (the two solvers land it 2 % apart)."""
    assert main(["reference", "b1", "--set", "mu1=0.05", "--set", "mu2=0.25"]) == 0
    assert "NOT UNIQUE: step 10: centre is free to move" in capsys.readouterr().out
    assert main(["reference", "b1", "--set", "mu1=0.3", "--set", "mu2=0", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["unique"] is True
    lifted = ml.Model(ml.ModelSpec.from_string(LIFTED, name="lifted"))
    reference = lifted.reference()
    result = lifted.solve(options=LatinOptions(tol=1e-9))
    for found in (reference, result):
        assert not found.unique
        assert [(m.step, m.bodies) for m in found.free_motions] == [(3, ("block",))]


RESTING = """
[materials.steel]
E = 2e5
nu = 0.3
[[bodies]]
name = "base"
x = [0.0, 40.0]
y = [0.0, 10.0]
elements = [16, 4]
material = "steel"
[[bodies]]
name = "block"
x = [10.0, 30.0]
y = [10.0, 20.0]
elements = [8, 4]
material = "steel"
[[interfaces]]
between = ["base", "block"]
type = "contact"
friction = 0.2
gap = 0.01
[[boundary]]
name = "clamp"
face = "base.bottom"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "top"
face = "block.top"
type = "force"
value = [0.0, -1.0]
factor = "P"
[history.factors]
P = [0.0, 1.0]
"""


def test_a_free_motion_with_no_friction_to_resist_it_says_so(tmp_path: Path) -> None:
    """A block 10 µm above a base, unloaded at step 1: free in every direction with its
    contact open (no friction capacity at all, the reserve's 0 of 0); the report says
    nothing resists it, not that its friction is used to 100 %. Pressed at step 2, friction
    carries its position on: not unique, in both solvers."""
    (tmp_path / "resting.toml").write_text(RESTING)
    model = ml.load_model(tmp_path / "resting.toml")
    for result in (model.solve(), model.reference()):
        at_rest = [m for m in result.free_motions if m.step == 1]
        assert at_rest and not result.unique
        for motion in at_rest:
            assert not motion.friction_holds
            assert "nothing resists it" in motion.describe()
    pressed = ml.load_model("b1").solve({"mu1": 0.15, "mu2": 0.15}).free_motions
    assert pressed and all(m.friction_holds and "100.00 % of its capacity" in m.describe()
                           for m in pressed)
    # at step 10 of 15, friction carries the position into steps 11–15
    assert all(m.step == 10 and m.carried_on and m.describe().endswith(
        "nor are the answers of the later steps that friction builds on it")
        for m in pressed)


BEAM_ON_SLIDING_SUPPORTS = """
[analysis]
thickness = 10.0
[materials.steel]
E = 2e5
nu = 0.3
[[bodies]]
name = "beam"
x = [0.0, 100.0]
y = [0.0, 10.0]
elements = [50, 5]
split = [5, 1]
material = "steel"
[[boundary]]
name = "left"
face = "beam.bottom"
segment = [0.0, 10.0]
type = "stop"
friction = 0.2
[[boundary]]
name = "right"
face = "beam.bottom"
segment = [90.0, 100.0]
type = "stop"
friction = 0.2
[[boundary]]
name = "load"
face = "beam.top"
segment = [48.0, 52.0]
type = "force"
value = [0.0, -25.0]
[[qoi]]
name = "v_mid"
type = "displacement"
point = [50.0, 5.0]
component = "y"
[[qoi]]
name = "R_left"
type = "reaction"
boundary = "left"
component = "y"
[[qoi]]
name = "H_left"
type = "reaction"
boundary = "left"
component = "x"
"""


def test_a_beam_on_two_sliding_supports_is_free_to_translate_its_forces_are_not() -> None:
    """A beam bent on two frictional supports spreads both ends outward at the friction
    limit: its x position is free (flagged), its forces are not — each support carries
    P / 2 and μ P / 2 (symmetry, both slipping), LATIN = the reference — and the report
    says which (session 49: it said that every answer from that step on was undetermined)."""
    model = ml.Model(ml.ModelSpec.from_string(BEAM_ON_SLIDING_SUPPORTS))
    latin = model.solve(options=LatinOptions(tol=1e-9))
    reference = model.reference()
    load = 25.0 * 4.0 * 10.0
    for result in (latin, reference):
        assert result.qoi["R_left"] == pytest.approx(load / 2, rel=1e-5)
        assert result.qoi["H_left"] == pytest.approx(0.2 * load / 2, rel=1e-5)
    assert latin.qoi["v_mid"] == pytest.approx(reference.qoi["v_mid"], rel=1e-5)
    (motion,) = latin.free_motions
    assert motion.velocity == pytest.approx((1.0, 0.0)) and motion.rotation == 0.0
    assert "its position along it is not determined" in motion.describe()
    # the vertical deflection and the forces are determined, the x position is not
    assert latin.qoi_determined == {"v_mid": True, "R_left": True, "H_left": True}
    assert "(this step's forces are)" in motion.describe()
    # one load step: no later step to speak of (before session 51 the text named "the
    # steps that friction builds on it" at the last step too)
    assert not motion.carried_on and "later steps" not in motion.describe()


def test_solve_prints_the_steps_whose_displacements_are_undetermined(capsys) -> None:
    """B1 frictionless: the centre block floats during the preload (steps 1–5), so u_A
    there is one answer of many (a warm start returned four times the cold one's, session
    49); the last step is determined and the case is unique. ``solve`` says so."""
    assert main(["solve", "b1", "--set", "mu1=0", "--set", "mu2=0"]) == 0
    out = capsys.readouterr().out
    assert ("UNDETERMINED: step(s) 1, 2, 3, 4, 5: centre is free to move (translation "
            "(+1, +0)), nothing resists it") in out
    assert "only those steps' displacements are undetermined" in out
    assert "NOT UNIQUE" not in out
    (u_a,) = [line for line in out.splitlines() if line.startswith("  u_A = ")]
    assert u_a.endswith("(undetermined at step(s) 1, 2, 3, 4, 5)")
    (r_stop,) = [line for line in out.splitlines() if line.startswith("  R_stop = ")]
    assert "undetermined" not in r_stop


def test_a_study_marks_the_values_it_leaves_undetermined(b1: ml.Model, tmp_path: Path) -> None:
    """study.nc's ``<QoI>_determined``: false at B1 (0, 0)'s u_A at steps 1–5 (the centre
    block floats in the frictionless preload), true elsewhere; the summary says so (before
    session 50 those values were stored unmarked, one answer of many)."""
    clear_operator_cache()
    result = run_study(b1, Grid({"mu1": [0.0], "mu2": [0.0, 0.1]}), out=tmp_path,
                       progress=False)
    data = load_study(tmp_path).sel(mode="multiresolution", mu1=0.0)
    assert data["u_A_determined"].sel(mu2=0.0).values.tolist() == [False] * 5 + [True] * 10
    assert bool(data["u_A_determined"].sel(mu2=0.1).all())
    assert bool(data["R_stop_determined"].all()) and bool(data["p_B_determined"].all())
    assert bool(data["unique"].all())
    assert any(line.startswith("UNDETERMINED: 1 case(s)") and
               line.endswith("(mu1=0, mu2=0): u_A at step(s) 1, 2, 3, 4, 5")
               for line in summary_lines(result))
    written = {path.name for path in write_study_outputs(result, tmp_path)}
    assert "response_u_A.png" in written and "response_u_A_determined.png" not in written


def test_a_body_lifted_off_is_undetermined_there_and_determined_once_pressed_again() -> None:
    """The sliding block unloaded at steps 5–6 (``press`` 0) floats: its lift there is one
    answer of many (κ = 0.5 and 2 leave it at different heights), but contact reads the
    current gap, not its history, so once pressed again (steps 7–10) every answer is
    determined and both solves agree. Before session 50 any friction in the model made
    such a motion reach the last step: "NOT UNIQUE", every later value flagged."""
    text = (resources.files("multilatin") / "models" / "slide.toml").read_text()
    press = "press = [0.5, 1, 1, 1, 1, 1, 1, 1, 1, 1]"
    assert press in text
    model = ml.Model(ml.ModelSpec.from_string(
        text.replace(press, "press = [0.5, 1, 1, 1, 0, 0, 1, 1, 1, 1]"), name="lift"))
    results = [model.solve(options=LatinOptions(kappa=kappa, tol=1e-9, max_iter=5000))
               for kappa in (0.5, 2.0)]
    lifts = []
    for result in results:
        assert [m.step for m in result.free_motions] == [5, 6]
        assert all(m.velocity == pytest.approx((0.0, 1.0), abs=1e-9)
                   and not m.reaches_last_step for m in result.free_motions)
        assert result.unique
        # the lift is vertical: u_right (x) and the forces stay determined at every step
        assert result.qoi_determined == {"R_push": [True] * 10, "u_right": [True] * 10}
        lifts.append(result.displacements["block"][4:6, :, 1].mean(axis=1))
        assert result.qoi["R_push"][-1] == pytest.approx(0.3 * 10.0 * 20.0, rel=1e-6)
    assert abs(lifts[0][0] - lifts[1][0]) > 0.1 * abs(lifts[1][0])  # not determined
    for name in ("R_push", "u_right"):  # determined once pressed again
        assert results[0].qoi[name][6:] == pytest.approx(results[1].qoi[name][6:], rel=1e-6)


def test_the_vtk_marks_the_parts_whose_position_is_undetermined(tmp_path: Path) -> None:
    """ParaView's ``displacement_determined``: 0 on B1's centre block at (0, 0) steps 1–5
    (it floats in the frictionless preload), 1 on the other blocks and at steps 6–15."""
    assert main(["solve", "b1", "--set", "mu1=0", "--set", "mu2=0", "--out",
                 str(tmp_path)]) == 0
    for step in (1, 5, 6, 15):
        mesh = meshio.read(tmp_path / "vtk" / f"b1_step{step:03d}.vtu")
        flag = np.concatenate(mesh.cell_data["displacement_determined"])
        sub = np.concatenate(mesh.cell_data["substructure"]).astype(int)
        centre = np.isin(sub, [s for s, part in enumerate(ml.load_model("b1").assemble()
                                                         .substructures)
                               if part.body == "centre"])
        assert centre.any() and (~centre).any()
        assert np.all(flag[~centre] == 1.0)
        assert np.all(flag[centre] == (0.0 if step <= 5 else 1.0))


STRAP_AT_A_STOP = """
[analysis]
hypothesis = "plane_stress"
thickness = 2.0
[materials.strap]
E = 2e5
nu = 0.33
[materials.base]
E = 2e6
nu = 0.3
[[bodies]]
name = "base"
x = [0.0, 60.0]
y = [0.0, 10.0]
elements = [24, 4]
split = [2, 1]
material = "base"
[[bodies]]
name = "strap"
x = [0.0, 45.0]
y = [10.0, 18.0]
elements = [20, 4]
split = [2, 1]
material = "strap"
[[interfaces]]
between = ["base", "strap"]
type = "contact"
[history.factors]
press = [0.5, 1.0, 1.0, 1.0]
pull = [0.0, 0.0, 0.5, 1.0]
[[boundary]]
name = "clamp"
face = "base.bottom"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "pressure"
face = "strap.top"
type = "force"
value = [0.0, -15.29]
factor = "press"
[[boundary]]
name = "pull"
face = "strap.left"
type = "force"
value = [29.78, 0.0]
factor = "pull"
[[boundary]]
name = "stop"
face = "strap.right"
type = "stop"
gap = {gap}
[[qoi]]
name = "u_corner"
type = "displacement"
point = [45.0, 18.0]
component = "x"
"""


@pytest.mark.parametrize("gap", [0.0, -0.002])
def test_a_stop_that_touches_with_no_force_does_not_hold_a_body_back(gap: float) -> None:
    """A frictionless strap pressed on a base, touching (or pushed back by) a stop at its
    right end, pulled toward it only from step 3: at steps 1 and 2 it may move away from
    the stop (left) with no force changing, and where it sits is undetermined. The reference
    says so; LATIN said the answer was unique, read off the stop's corner point, which it
    left pressed by 3e-5 of the largest interface force — its accuracy there, not a force
    (session 61, `benchmarks/random_studies.py` seed 39: u_corner 0.019 mm apart, both
    'determined'). A normal force below ``uniqueness.PRESSED`` (1e-4) of the largest
    presses nothing."""
    model = ml.Model(ml.ModelSpec.from_string(STRAP_AT_A_STOP.format(gap=gap), name="strap"))
    for result in (model.reference(), model.solve()):
        assert sorted({m.step for m in result.free_motions}) == [1, 2]
        assert result.qoi_determined["u_corner"] == [False, False, True, True]
    # LATIN's strap rests against the stop: it may leave it, not push into it
    assert all(m.velocity[0] < 0.0 for m in result.free_motions)
