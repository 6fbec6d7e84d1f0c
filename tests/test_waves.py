"""The wave schedule of a study on Dask workers (``multilatin.study.waves``): grid lines as
tasks that start from their parent line, instead of chains that start from zero."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import multilatin as ml
from multilatin.errors import ModelError
from multilatin.latin import LatinOptions
from multilatin.parameters import Grid
from multilatin.study.plan import plan_study
from multilatin.study.runner import run_study
from multilatin.study.waves import line_tasks, run_line_task


def _distance(a: tuple[int, ...], b: tuple[int, ...]) -> int:
    return sum(abs(x - y) for x, y in zip(a, b, strict=True))


@pytest.mark.parametrize("workers", [0, 2, 16])
def test_every_piece_starts_from_neighbours_one_step_away(workers: int) -> None:
    """Every case once; parents before children; every case of a later line has a case
    one grid step away in its parent pieces; the first line is the middle one, its pieces
    two chains from its middle piece, each piece's first case next to the piece before;
    the graph is as deep as the grid's half-widths (positions and μ1 lines side by side)."""
    model = ml.load_model("b3")
    grid = Grid.parse(["xc=23:27:5", "mu1=0:0.6:7", "mu2=0:0.6:5", "rc=3"])
    plan = plan_study(model, grid, None, 1)
    tasks = line_tasks(plan, plan.chains[0], workers, 16)
    numbers = sorted(c.number for task in tasks for c in task.cases)
    assert numbers == list(range(grid.size))
    roots = 0
    for t, task in enumerate(tasks):
        assert all(p < t for p in task.parents)
        assert 1 <= len(task.cases) <= 16
        held = [c.index for p in task.parents for c in tasks[p].cases]
        if task.depth == 0:
            assert all(c.index[:2] == (2, 3) for c in task.cases)  # the middle line
            if not task.parents:
                roots += 1
                continue
            assert min(_distance(task.cases[0].index, h) for h in held) == 1
        else:
            assert {tasks[p].depth for p in task.parents} == {task.depth - 1}
            assert all(min(_distance(c.index, h) for h in held) == 1 for c in task.cases)
    assert roots == 1
    assert max(task.depth for task in tasks) == 2 + 3
    if workers == 16:
        assert max(len(task.cases) for task in tasks) < 5  # lines cut for the workers


def test_from_zero_on_dask_each_batch_is_a_task_of_its_own(tmp_path: Path) -> None:
    """``start="zero"``: no batch needs another's output, so on Dask (``schedule="waves"``,
    the default) every batch is an independent task of one chain, handed to the workers as
    they free up (a GPU's processes then finish together), with the serial answers."""
    pytest.importorskip("dask.distributed")
    b1 = ml.load_model("b1")
    grid = Grid({"mu1": [0.1, 0.2, 0.3], "mu2": [0.0, 0.2, 0.4]})
    serial = run_study(b1, grid, start="zero", batch=3, out=tmp_path / "serial",
                       progress=False)
    tasks = run_study(b1, grid, start="zero", batch=3, workers=2, out=tmp_path / "tasks",
                      progress=False)
    by_number = {r["number"]: r for r in serial.records}
    assert {r["chain"] for r in tasks.records} == {0}
    assert sorted(r["batch"] for r in tasks.records) == [3] * 9
    for record in tasks.records:
        same = by_number[record["number"]]
        assert record["start"] == same["start"] == "zero" and record["converged"]
        assert abs(record["iterations"] - same["iterations"]) <= 2  # BLAS threads' rounding
        assert record["qoi"]["R_stop"] == pytest.approx(same["qoi"]["R_stop"], rel=1e-4)


def test_waves_on_dask_give_the_serial_answers_with_one_cold_start(
        tmp_path: Path) -> None:
    pytest.importorskip("dask.distributed")
    b1 = ml.load_model("b1")
    grid = Grid({"mu1": [0.1, 0.2, 0.3], "mu2": [0.0, 0.2, 0.4]})
    serial = run_study(b1, grid, out=tmp_path / "serial", progress=False)
    waves = run_study(b1, grid, workers=2, out=tmp_path / "waves", progress=False)
    chains = run_study(b1, grid, workers=2, schedule="chains", out=tmp_path / "chains",
                       progress=False)
    by_number = {r["number"]: r for r in serial.records}
    assert {r["chain"] for r in waves.records} == {0}
    assert len({r["chain"] for r in chains.records}) == 2
    # one cold start; the other cases from zero are at the friction limit, foreseen from
    # their neighbour's state (``starts.at_limit``: (0.1, 0.2), not unique)
    zero = [r for r in waves.records if r["start"] == "zero"]
    (cold,) = [r for r in zero if r["unique"]]
    assert len(zero) == 2
    assert cold["index"][0] == 1  # in the middle line
    for record in waves.records:  # the serial study starts by the waves' rule too
        same = by_number[record["number"]]
        assert record["converged"] and record["unique"] == same["unique"]
        assert record["start"] == same["start"]
        # the same iterates but for rounding (Dask's workers run BLAS on one thread, the
        # cases are batched otherwise), which a contact status flipping mid-iteration can
        # carry up to the stopping accuracy (1e-5 here; the QoI rule asks 1e-3)
        assert abs(record["iterations"] - same["iterations"]) <= 2
        assert record["qoi"]["R_stop"] == pytest.approx(same["qoi"]["R_stop"], rel=1e-4)
    # the same warm starts on one worker (the line not cut): no answer depends on the
    # number of workers beyond the batches' rounding
    one = run_study(b1, grid, workers=1, out=tmp_path / "one", progress=False)
    alone = {r["number"]: r for r in one.records}
    for record in waves.records:
        assert record["start"] == alone[record["number"]]["start"]
        assert record["qoi"]["R_stop"] == pytest.approx(alone[record["number"]]["qoi"]["R_stop"],
                                                        rel=1e-6)
    # one cold start as in the serial study; each of two chains starts from zero
    iterations = {name: sum(r["iterations"] for r in study.records)
                  for name, study in (("serial", serial), ("waves", waves),
                                      ("chains", chains))}
    assert iterations["waves"] < iterations["chains"], iterations


def test_waves_on_dask_retime_as_the_serial_study_does(tmp_path: Path) -> None:
    """B1 on 5 × 3 frictions (lines along μ2, the middle one at μ1 = 0.2): the lines two
    steps from the middle one start retimed from their parent line and its parent
    (``partner_lines``), on Dask's line tasks as in the serial rolling batch — the same
    start and the same iterations at every case."""
    pytest.importorskip("dask.distributed")
    b1 = ml.load_model("b1")
    grid = Grid({"mu1": [0.1, 0.15, 0.2, 0.25, 0.3], "mu2": [0.0, 0.05, 0.1]})
    serial = run_study(b1, grid, out=tmp_path / "serial", progress=False)
    waves = run_study(b1, grid, workers=2, out=tmp_path / "waves", progress=False)
    by_number = {r["number"]: r for r in serial.records}
    retimed = [r for r in waves.records if "retimed" in r["start"]]
    assert len(retimed) >= 2
    assert all(r["params"]["mu1"] in (0.1, 0.3) for r in retimed)
    for record in waves.records:
        same = by_number[record["number"]]
        assert record["start"] == same["start"]
        assert abs(record["iterations"] - same["iterations"]) <= 2  # rounding, as above
        assert record["qoi"]["R_stop"] == pytest.approx(same["qoi"]["R_stop"], rel=1e-4)


def test_a_waves_study_resumes_after_losing_cases(tmp_path: Path) -> None:
    pytest.importorskip("dask.distributed")
    b1 = ml.load_model("b1")
    grid = Grid({"mu1": [0.1, 0.2, 0.3], "mu2": [0.0, 0.2, 0.4]})
    first = run_study(b1, grid, workers=2, out=tmp_path, progress=False)
    journal = tmp_path / "cases.jsonl"
    lines = journal.read_text().splitlines()
    kept = sorted(lines, key=lambda line: json.loads(line)["number"])[:4]
    journal.write_text("\n".join(kept) + "\n")
    (tmp_path / "chains" / "multiresolution-0.npz").unlink()
    computed: list[dict[str, object]] = []
    again = run_study(b1, grid, workers=2, out=tmp_path, progress=False,
                      on_case=computed.append)
    assert sorted(r["number"] for r in computed) == list(range(4, 9))
    before = {r["number"]: r["qoi"]["R_stop"] for r in first.records}
    for record in again.records:
        assert record["converged"]
        assert record["qoi"]["R_stop"] == pytest.approx(before[record["number"]], rel=1e-3)


def test_a_bad_schedule_is_named() -> None:
    with pytest.raises(ModelError, match="--schedule: expected one of"):
        run_study(ml.load_model("b1"), Grid({"mu1": [0.1]}), schedule="rings",
                  progress=False)


def test_a_single_valued_parameter_last_does_not_cut_the_grid_lines() -> None:
    """``--grid rc=3`` given last: the lines that multiresolution batches run along μ2
    (before, along rc: lines of one case, nothing batched); the traversal is unchanged."""
    model = ml.load_model("b3")
    plan = plan_study(model, Grid.parse(["xc=23:27:3", "mu1=0:0.6:4", "mu2=0:0.6:5",
                                         "rc=3"]), None, 1)
    assert plan.inner == 2
    lines = plan.batches(plan.chains[0], 16)
    assert [len(line) for line in lines] == [5] * 12
    assert [c.index[:3] for c in lines[1]] == [(0, 1, j) for j in (4, 3, 2, 1, 0)]


def test_a_task_hands_on_its_own_cases_only() -> None:
    """A line task's output (kept by Dask until its children are done) retains its own
    converged cases, not its parents' as well; its children still find a neighbour one
    step away in it and start from the same cases as before the trim."""
    model = ml.load_model("b1")
    grid = Grid({"mu1": [0.1, 0.2, 0.3, 0.4, 0.5], "mu2": [0.0, 0.2]})
    plan = plan_study(model, grid, None, 1)
    tasks = line_tasks(plan, plan.chains[0], 1, 16)
    root, child, grandchild = (next(t for t in tasks if t.depth == d) for d in range(3))
    outputs = {}
    for task in (root, child, grandchild):
        parents = [outputs[id(tasks[p])] for p in task.parents]
        outputs[id(task)] = run_line_task(model, grid, task.cases, "multiresolution",
                                          LatinOptions(), parents, None)
        records, state = outputs[id(task)]
        assert state is not None
        assert set(state.retained) == {case.index for case in task.cases}
        if task.depth:  # from zero only at the friction limit ((0.1, 0.2): ``starts.at_limit``)
            assert all(r["start"] != "zero" or not r["unique"] for r in records)


def test_hole_positions_are_batched_as_lines_on_numpy_only(tmp_path: Path) -> None:
    """Only hole positions vary: on NumPy the lines along the innermost one are batched
    (several geometries sharing their interfaces, ``solve_latin_batch``), each case of a
    later line from its neighbour one step away in the line before, and the answers are the
    cold ones; the torch backend's wavefront keeps lines of one geometry (none here)."""
    model = ml.load_model("b3")
    grid = Grid.parse(["xc=24:26:2", "yc=74:76:3", "rc=3"])
    assert plan_study(model, grid, LatinOptions(backend="torch"), 1).inner is None
    plan = plan_study(model, grid, None, 1)
    assert plan.inner == 1
    assert [len(line) for line in plan.batches(plan.chains[0], 16)] == [3, 3]
    options = LatinOptions(tol=1e-7)
    result = run_study(model, grid, options=options, modes=("multiresolution", "cold"),
                       out=tmp_path, progress=False, rolling=False)
    warm, cold = result.mode_records("multiresolution"), result.mode_records("cold")
    assert [r["batch"] for r in warm] == [1, 1, 1, 3, 3, 3]
    for record in warm[3:]:
        start = [float(part.split("=")[1]) for part in record["start"].split(", ")]
        assert start[0] == 24.0 and start[1] == record["params"]["yc"]
    for w in warm:
        c = next(r for r in cold if r["params"] == w["params"])
        assert w["qoi"]["R_stop"] == pytest.approx(c["qoi"]["R_stop"], rel=1e-4)


@pytest.mark.parametrize("schedule, chains", [("waves", {0}), ("chains", {0, 1})])
def test_the_command_line_takes_the_schedule(tmp_path: Path, capsys, schedule, chains) -> None:
    pytest.importorskip("dask.distributed")
    from multilatin.cli import main

    out = tmp_path / schedule
    assert main(["study", "b1", "--grid", "mu1=0.2,0.3", "--grid", "mu2=0,0.3", "--workers",
                 "2", "--schedule", schedule, "--json", "--out", str(out)]) == 0
    assert json.loads(capsys.readouterr().out)["converged"]
    records = [json.loads(line) for line in (out / "cases.jsonl").read_text().splitlines()]
    assert {r["chain"] for r in records} == chains


def test_a_study_run_as_chains_says_how_to_resume_it(tmp_path: Path) -> None:
    b1 = ml.load_model("b1")
    grid = Grid({"mu1": [0.3], "mu2": [0.0, 0.3]})
    run_study(b1, grid, chains=2, out=tmp_path, progress=False)
    with pytest.raises(ModelError, match="resume it with --schedule chains --chains 2"):
        run_study(b1, grid, out=tmp_path, progress=False)


def test_a_dask_study_leaves_the_callers_environment_as_it_was(tmp_path: Path) -> None:
    """Dask's nanny writes its workers' settings (OMP_NUM_THREADS=1, its logging level)
    into the calling process's environment; a study restores it."""
    import os

    pytest.importorskip("dask.distributed")
    before = dict(os.environ)
    run_study(ml.load_model("b1"), Grid({"mu1": [0.3], "mu2": [0.0, 0.3]}), workers=1,
              out=tmp_path, progress=False)
    assert dict(os.environ) == before


def test_partner_lines_are_earlier_and_span_a_geometric_step() -> None:
    """Each line's partners (``partner_lines``) are nearer the first line than it is: the
    line one step beyond its parent along a geometric axis (secant), or the two lines
    beside it and its parent one step back along another axis, one of the two geometric
    (parallelogram); none on a grid of frictions alone or without extrapolation but the
    line beyond the parent where starts are retimed."""
    from multilatin.study.waves import line_graph, partner_lines

    model = ml.load_model("b3")
    grid = Grid.parse(["mu1=0:0.6:5", "mu2=0.1,0.2", "xc=23:27:5", "rc=3"])
    kinds = {0: 0, 1: 0, 2: 0}
    for extrapolate in (True, False):
        plan = plan_study(model, grid, None, 1, extrapolate=extrapolate)
        graph = line_graph(plan, plan.chains[0])
        for n in graph.order:
            partners = partner_lines(graph, n, graph.lines[n][0].axes)
            if not extrapolate:
                assert partners == ()
                continue
            kinds[len(partners)] += 1
            assert all(graph.depth[m] < graph.depth[n] for m in partners)
            parent = graph.parent[n]
            if parent is None:
                assert partners == ()
                continue
            key, p = np.array(graph.keys[n]), np.array(graph.keys[parent])
            (a,) = np.flatnonzero(key != p)
            if len(partners) == 1:  # key = (mu1, xc): xc is geometric
                assert a == 1 and graph.keys[partners[0]] == tuple(2 * p - key)
            elif len(partners) == 2:
                q, r = (np.array(graph.keys[m]) for m in partners)
                assert list(np.abs(q - key)).count(1) == 1 and np.array_equal(q - key, r - p)
                assert 1 in (a, int(np.flatnonzero(q != key)[0]))
    assert kinds[1] and kinds[2]  # both kinds occur
    b1 = ml.load_model("b1")
    friction = Grid.parse(["mu1=0:0.6:5", "mu2=0:0.6:5"])
    plan = plan_study(b1, friction, None, 1)
    graph = line_graph(plan, plan.chains[0])
    assert all(partner_lines(graph, n, graph.lines[n][0].axes) == () for n in graph.order)
    # a grid of frictions retimes (``retiming``): a line two steps or more from the middle
    # one holds the line one step beyond its parent, its parent's parent
    for n in graph.order:
        partners = partner_lines(graph, n, (), graph.lines[n][0].retime)
        parent = graph.parent[n]
        if graph.depth[n] >= 2:
            assert parent is not None and partners == (graph.parent[parent],)
            key, p = np.array(graph.keys[n]), np.array(graph.keys[parent])
            assert graph.keys[partners[0]] == tuple(2 * p - key)
        else:
            assert partners == ()


def test_line_tasks_start_from_parallelograms_across_geometries(tmp_path: Path) -> None:
    """B3, 2 hole positions × 2 × 2 frictions as line tasks (Dask's waves, one after the
    other): the last line starts each case from the parallelogram of its parent line's
    case and the same frictions' at the other geometry (its partner lines); R_stop within
    0.1 % of the nearest neighbour's starts."""
    from multilatin.study.waves import run_line_tasks

    model = ml.load_model("b3")
    grid = Grid.parse(["mu1=0.3,0.4", "mu2=0.1,0.2", "xc=24:25:2", "rc=3"])
    runs = {}
    for extrapolate in (True, False):
        plan = plan_study(model, grid, None, 1, extrapolate=extrapolate)
        records: list[dict] = []
        run_line_tasks(model, grid, plan, plan.chains[0], "multiresolution", LatinOptions(),
                       {c.number for c in plan.chains[0]}, 16, None, "neighbour",
                       lambda got, _, into=records: into.extend(got))
        runs[extrapolate] = sorted(records, key=lambda r: r["number"])
    across = [r for r in runs[True] if "parallelogram" in r["start"]]
    assert len(across) == 2 and not any("parallelogram" in r["start"] for r in runs[False])
    for got, nearest in zip(runs[True], runs[False], strict=True):
        assert got["converged"] and got["unique"]
        assert got["qoi"]["R_stop"] == pytest.approx(nearest["qoi"]["R_stop"], rel=1e-3)


def test_geometry_waves_go_outward_one_hole_step_at_a_time() -> None:
    """The torch backend's multiresolution (``StudyPlan.geometry_waves``): the 21 125-case
    study's 125 hole geometries in waves from the middle one (1, 6, 18, 32, 36, 24, 8
    geometries: an octahedron's shells in the 5 × 5 × 5 box), each geometry's 169 frictions
    in its wave, and every geometry of a wave one step (along one of xc, yc, rc) from one
    of the wave before; with 8 chains each chain's waves alike over its own geometries. A
    grid of one geometry has none (the lines' wavefront then)."""
    model = ml.load_model("b3")
    grid = Grid.parse(["mu1=0:0.6:13", "mu2=0:0.6:13", "xc=23:27:5", "yc=73:77:5",
                       "rc=1:5:5"])
    options = LatinOptions(backend="torch")
    for chains in (1, 8):
        plan = plan_study(model, grid, options, chains)
        for chain in plan.chains:
            waves = plan.geometry_waves(chain)
            assert sorted(c.number for wave in waves for c in wave) == sorted(
                c.number for c in chain)
            shells = [{c.index[2:] for c in wave} for wave in waves]
            assert len(shells[0]) == 1
            for before, wave in zip(shells, shells[1:], strict=False):
                assert all(min(_distance(g, b) for b in before) == 1 for g in wave)
            if chains == 1:
                assert [len(s) for s in shells] == [1, 6, 18, 32, 36, 24, 8]
                assert shells[0] == {(2, 2, 2)} and all(len(w) % 169 == 0 for w in waves)
    one = plan_study(model, Grid.parse(["mu1=0:0.6:13", "mu2=0:0.6:13"]), options, 1)
    assert one.geometry_waves(one.chains[0]) == []
