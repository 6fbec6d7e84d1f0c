"""Bad input gets a clear error naming the offending field and value."""

import copy
import re

import numpy as np
import pytest

import multilatin as ml
from multilatin.cli import main

GOOD = {
    "materials": {"steel": {"E": 2e5, "nu": 0.3}},
    "substructures": [
        {"name": "a", "x": [0, 10], "y": [0, 10], "elements": [4, 4], "material": "steel"},
        {"name": "b", "x": [10, 20], "y": [0, 10], "elements": [4, 4], "material": "steel"},
    ],
    "boundary": [
        {"name": "clamp", "substructure": "a", "side": "left", "type": "displacement",
         "value": [0, 0]},
        {"name": "pull", "substructure": "b", "side": "right", "type": "force",
         "value": [1, 0]},
    ],
}


def spec_with(change):
    data = copy.deepcopy(GOOD)
    change(data)
    return lambda: ml.ModelSpec.from_dict(data)


def test_good_model_is_accepted():
    spec = spec_with(lambda d: None)()
    assert len(spec.build().interfaces) == 3


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        (lambda d: d["substructures"][1].pop("material"),
         "substructures[1] ('b'): missing field 'material'"),
        (lambda d: d["substructures"][1].update(material="brass"),
         "substructures[1] ('b').material: 'brass' is not defined in [materials]"),
        (lambda d: d["materials"]["steel"].update(E=-2e5),
         "materials.steel.E: Young's modulus must be > 0, got -200000"),
        (lambda d: d["materials"]["steel"].update(nu=0.5),
         "materials.steel.nu: Poisson's ratio must lie in (-1, 0.5), got 0.5"),
        (lambda d: d["substructures"][1].update(x=[5, 20]),
         "substructures 'a' and 'b' overlap"),
        (lambda d: d["substructures"][1].update(y=[3, 13]),
         "interface between 'a' (right side) and 'b' (left side): the shared part [3, 10] "
         "along y does not start and end on nodes of 'a' or of 'b'"),
        (lambda d: d["substructures"][1].update(elements=[4, 0]),
         "substructures[1] ('b').elements: expected a positive integer, got 0"),
        (lambda d: d["boundary"][0].update(type="glue"),
         "boundary[0] ('clamp').type: unknown boundary type 'glue'"),
        (lambda d: d["boundary"][0].update(side="middle"),
         "boundary[0] ('clamp').side: substructure 'a' has no side or group named 'middle' "
         "(sides: bottom, right, top, left; groups of its mesh files: none)"),
        (lambda d: d["boundary"][1].update(side="left"),
         "boundary[1] ('pull'): side 'left' of 'b' already belongs to an interface"),
        (lambda d: d["boundary"].pop(0),
         "boundary: nothing holds 'a', 'b': no prescribed displacement and no rigid stop"),
        (lambda d: d["substructures"].append(
            {"name": "c", "x": [30, 40], "y": [0, 10], "elements": [4, 4], "material": "steel"}),
         "boundary: nothing holds 'c'"),
        (lambda d: d["boundary"][1].update(value=[1, "2 * Q"]),
         "boundary[1] ('pull').value: expression '2 * Q' uses unknown parameter 'Q'"),
        (lambda d: d["boundary"][1].update(factor="push"),
         "boundary[1] ('pull').factor: 'push' is not a load factor"),
        (lambda d: d.update(history={"factors": {}}),
         "history.factors: a load history with no steps"),
        (lambda d: d.update(history={"factors": {"push": []}}),
         "history.factors.push: a load history with no steps"),
        (lambda d: d.update(qoi=[{"name": "u", "type": "displacement", "point": [50, 0],
                                   "component": "x"}]),
         "qoi[0] ('u').point: [50.0, 0.0] lies in no substructure"),
        (lambda d: d.update(colour="red"), "model: unknown field 'colour'"),
        # a field the substructure takes from [analysis]: named where the user wrote it
        (lambda d: d.update(analysis={"thickness": -1.0}),
         "analysis.thickness: must be > 0, got -1"),
        (lambda d: d["substructures"][1].update(thickness=0.0),
         "substructures[1] ('b').thickness: must be > 0, got 0"),
        (lambda d: d.update(analysis={"hypothesis": "plane"}),
         "analysis.hypothesis: expected one of 'plane_stress', 'plane_strain', "
         "'axisymmetric', got 'plane'"),
        # a field another type reads is refused, not dropped (session 49: a user's
        # `components` under type = "displacement" held both components)
        (lambda d: d["boundary"][1].update(type="displacement",
                                           components=["displacement", "force"]),
         "boundary[1] ('pull').components: components apply to type = 'mixed' only, got "
         "type = 'displacement'"),
        (lambda d: d["boundary"][1].update(type="stop", value=[0, 0]),
         "boundary[1] ('pull').value: a stop takes no value"),
        (lambda d: d.update(qoi=[{"name": "R", "type": "reaction", "boundary": "clamp",
                                   "component": "x", "point": [0, 5]}]),
         "qoi[0] ('R').point: a reaction QoI takes no point (it reads boundary, component)"),
        (lambda d: d.update(qoi=[{"name": "u", "type": "displacement", "point": [5, 5],
                                   "component": "x", "boundary": "clamp"}]),
         "qoi[0] ('u').boundary: a displacement QoI takes no boundary"),
    ],
)
def test_model_errors_name_field_and_value(change, expected):
    with pytest.raises(ml.ModelError) as info:
        spec_with(change)()
    assert expected in str(info.value)


def test_unknown_parameter_in_set():
    model = ml.load_model("b0")
    with pytest.raises(ml.ModelError, match="unknown parameter 'Q' .*parameters: P"):
        model.parameters.parse({"Q": 1.0})


def test_parameter_outside_its_range():
    with pytest.raises(ml.ModelError, match="parameter 'P': value -1.0 is outside"):
        ml.load_model("b0").parameters.parse({"P": -1.0})


@pytest.mark.parametrize("value", [None, True, "0.1", [0.1]])
def test_a_parameter_value_that_is_not_a_number_is_refused(value):
    """``solve({"P": None})`` raised a TypeError from ``float``; True and "0.1" passed as 1
    and 0.1 (session 44)."""
    with pytest.raises(ml.ModelError, match=rf"parameter 'P': expected a number, got "
                       rf"{re.escape(repr(value))}"):
        ml.load_model("b0").parameters.parse({"P": value})
    assert ml.load_model("b0").parameters.parse({"P": np.float32(2.5)})["P"] == 2.5


def test_cli_reports_bad_input_with_exit_status_2(capsys, tmp_path):
    assert main(["solve", "b0", "--set", "Q=1"]) == 2
    assert "unknown parameter 'Q'" in capsys.readouterr().err
    assert main(["solve", "b0", "--set", "P=abc"]) == 2
    assert "--set 'P=abc': value 'abc' is not a number" in capsys.readouterr().err
    assert main(["solve", str(tmp_path / "missing.toml")]) == 2
    assert "no such file and no bundled model" in capsys.readouterr().err
    bad = tmp_path / "bad.toml"
    bad.write_text('[materials.steel]\nE = -1\nnu = 0.3\n')
    assert main(["solve", str(bad)]) == 2
    assert "materials.steel.E: Young's modulus must be > 0, got -1" in capsys.readouterr().err
    assert main(["solve", "b0", "--kappa", "-1"]) == 2
    assert "kappa: the search direction k = κ E / L needs κ in [0.001, 1000]" in capsys.readouterr().err


CONTACT = {
    "materials": {"steel": {"E": 2e5, "nu": 0.3}},
    "bodies": [
        {"name": "low", "x": [0, 10], "y": [0, 10], "elements": [4, 4], "material": "steel"},
        {"name": "high", "x": [0, 10], "y": [10, 20], "elements": [4, 4], "material": "steel"},
        {"name": "side", "x": [20, 30], "y": [0, 10], "elements": [4, 4], "material": "steel"},
    ],
    "interfaces": [{"between": ["low", "high"], "type": "contact", "friction": 0.2,
                    "gap": 0.0}],
    "history": {"factors": {"P": [1.0, 2.0]}},
    "boundary": [
        {"name": "clamp", "face": "low.bottom", "type": "displacement", "value": [0, 0]},
        {"name": "clamp2", "face": "side.bottom", "type": "displacement", "value": [0, 0]},
        {"name": "press", "face": "high.top", "type": "force", "value": [0, -1],
         "factor": "P"},
        {"name": "stop", "face": "high.right", "type": "stop", "gap": 0.01},
    ],
}


def contact_with(change):
    data = copy.deepcopy(CONTACT)
    change(data)
    return lambda: ml.ModelSpec.from_dict(data)


def test_good_contact_model_is_accepted():
    assembly = contact_with(lambda d: None)().build()
    assert {i.kind for i in assembly.interfaces} == {"contact", "boundary"}


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        (lambda d: d["interfaces"][0].update(friction=-0.1),
         "interfaces[0].friction: the friction coefficient must be >= 0, got -0.1"),
        (lambda d: d["interfaces"][0].update(gap=-np.inf),
         "interfaces[0].gap: -inf is not a finite number"),
        (lambda d: d["boundary"][3].update(friction=-1),
         "boundary[3] ('stop').friction: the friction coefficient must be >= 0, got -1"),
        (lambda d: d["history"]["factors"].update(P=[]),
         "history.factors.P: a load history with no steps"),
        (lambda d: d["interfaces"].append({"between": ["low", "side"], "type": "contact"}),
         "interfaces[1].between: 'low' and 'side' do not face each other"),
        (lambda d: d["interfaces"][0].update(type="glue"),
         "interfaces[0].type: unknown interface type 'glue'"),
        (lambda d: d["interfaces"][0].update(type="perfect"),
         "interfaces[0]: friction, gap and reach apply to type = 'contact' only"),
    ],
)
def test_contact_errors_name_field_and_value(change, expected):
    with pytest.raises(ml.ModelError) as info:
        contact_with(change)()
    assert expected in str(info.value)


@pytest.mark.parametrize("field, value", [("stagnation_window", 1), ("stagnation_ratio", 0.0),
                                          ("stagnation_ratio", 1.5), ("relaxation", 0.0),
                                          ("kappa", -1.0)])
def test_solver_options_name_field_and_value(field, value):
    from multilatin.errors import ModelError
    from multilatin.latin import LatinOptions

    with pytest.raises(ModelError, match=rf"{field}: .*{value!r}"):
        LatinOptions(**{field: value})


def test_a_study_batch_of_zero_is_refused(tmp_path):
    """``batch=0`` is an error naming the option, not the default (``study_defaults`` fills
    in only what was not given)."""
    with pytest.raises(ml.ModelError, match="--batch: must be >= 1, got 0"):
        ml.run_study(ml.load_model("b1"), ml.Grid({"mu1": [0.1]}), batch=0, out=tmp_path,
                     progress=False)


def test_two_conditions_prescribing_one_node_differently_are_refused():
    """A corner shared by a held face and a pushed one: the monolithic reference kept one
    of the two values silently and LATIN found no equilibrium; refused when built. Equal
    values (a clamp beside a face held in x only) are accepted."""
    def pushed(value):
        def change(d):
            d["boundary"].append({"name": "hold", "substructure": "a", "side": "bottom",
                                  "type": "mixed", "components": ["displacement", "force"],
                                  "value": [value, 0.0]})
        return change
    with pytest.raises(ml.ModelError, match=r"boundary: 'clamp' and 'hold' both prescribe "
                       r"the x displacement of the node at \(0, 0\) of body 'a', differently "
                       r"\(0 and 0.5 at step 1\)"):
        spec_with(pushed(0.5))().build()
    assert spec_with(pushed(0.0))().build().interfaces

    def by_parameter(d):  # a study's case: the parameter named
        pushed("P / 2")(d)
        d["parameters"] = {"P": {"default": 0.0}}
    spec = spec_with(by_parameter)()
    assert spec.build().interfaces
    with pytest.raises(ml.ModelError, match=r"\(0 and 0.5 at step 1\) \(parameters P = 1\); a "
                       r"node cannot take both"):
        spec.build({"P": 1.0})


@pytest.mark.parametrize("name", ["a.b", "a[0,0]", "", 3])
def test_part_names_that_faces_cannot_name_are_refused(name):
    """A body named "a.b" gave a confusing error about named groups of mesh files, and ""
    was accepted (session 44)."""
    def renamed(d):
        d["substructures"][1]["name"] = name
    with pytest.raises(ml.ModelError, match=r"substructures\[1\]\.name: expected a name "
                       r"without '\.', '\[' or '\]'"):
        spec_with(renamed)()
