"""The random user models' families (``random_models.py``, ``random_studies.py``): model
files a user might write, one per seed.

- strap (``model_text``, session 60): a strap, with a level-set hole or not, pressed on a
  clamped base and pulled by a force or a prescribed displacement toward a rigid stop;
- block (``block_text``): a block pushed sideways on a clamped base;
- stack (``stack_text``, session 62): a plate between a base and a block, pushed back and
  forth or with its pressure released;
- meshed (``meshed_text``, session 62): the strap of gmsh meshes, in parts;

and ``axisymmetric`` to turn any of them about x = 0.
"""

from __future__ import annotations

import random
import re
import tempfile
from pathlib import Path

#: a strap (``{strap}``: one body, or parts of mesh files) on a clamped base, pulled toward a
#: stop: the strap and meshed families
MODEL = """
title = "random {kind} {seed}"
[analysis]
hypothesis = "{hypothesis}"
thickness = 2.0
[materials.strap]
E = {e_strap}
nu = 0.33
[materials.base]
E = {e_base}
nu = 0.3
[[bodies]]
name = "base"
x = [0.0, 60.0]
y = [0.0, 10.0]
elements = [24, 4]
split = [{split_base}, 1]
material = "base"
{strap}
[[interfaces]]
between = ["base", "strap"]
type = "contact"
friction = {mu}
gap = {gap}
[history.factors]
press = {press}
pull = {pull}
[[boundary]]
name = "clamp"
face = "base.bottom"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "pressure"
face = "strap.top"
type = "force"
value = [0.0, {pressure}]
factor = "press"
{pull_condition}
[[boundary]]
name = "stop"
{stop_face}
type = "stop"
gap = {stop_gap}
friction = {stop_friction}
[[qoi]]
name = "R_stop"
unit = "N"
type = "reaction"
boundary = "stop"
component = "x"
[[qoi]]
name = "R_clamp_x"
unit = "N"
type = "reaction"
boundary = "clamp"
component = "x"
{last_qoi}
"""


#: the strap family's strap: one body, split at random
STRAP = """[[bodies]]
name = "strap"
x = [{x0}, {x1}]
y = [10.0, 18.0]
elements = [{n_strap}, 4]
split = [{split_x}, {split_y}]
material = "strap"
{hole}"""

#: the strap family's third QoI
CORNER = """[[qoi]]
name = "u_corner"
unit = "mm"
type = "displacement"
point = [{x1}, 18.0]
component = "{component}\""""


def model_text(seed: int) -> str:
    """The model file of ``seed`` (module docstring)."""
    rng = random.Random(seed)
    x0, x1 = rng.choice([0.0, 5.0]), rng.choice([40.0, 45.0])
    split_x = rng.choice([1, 2, 3])
    hole = ""
    if split_x == 1 and rng.random() < 0.5:
        hole = ("[[holes]]\nname = \"hole\"\nbody = \"strap\"\nshape = \"circle\"\n"
                f"centre = [{rng.uniform(x0 + 4, x0 + 10):.2f}, {rng.uniform(13, 15):.2f}]\n"
                f"radius = {rng.uniform(0.5, 2.5):.2f}")
    steps = rng.choice([4, 6, 8])
    press = [min(1.0, (i + 1) / 2) for i in range(steps)]
    pull = [0.0, 0.0] + [(i + 1) / (steps - 2) for i in range(steps - 2)]
    if rng.random() < 0.5:
        pull_condition = ("[[boundary]]\nname = \"pull\"\nface = \"strap.left\"\n"
                          f"type = \"force\"\nvalue = [{rng.uniform(10, 60):.2f}, 0.0]\n"
                          "factor = \"pull\"")
    else:
        pull_condition = ("[[boundary]]\nname = \"pull\"\nface = \"strap.left\"\n"
                          "type = \"mixed\"\ncomponents = [\"displacement\", \"force\"]\n"
                          f"value = [{rng.uniform(0.002, 0.03):.4f}, 0.0]\nfactor = \"pull\"")
    return MODEL.format(
        kind="strap", seed=seed, hypothesis=rng.choice(["plane_stress", "plane_strain"]),
        e_strap=rng.choice([7e4, 2e5]), e_base=rng.choice([7e4, 2.1e5, 2e6]),
        split_base=rng.choice([1, 2, 3]),
        strap=STRAP.format(x0=x0, x1=x1, n_strap=18 if split_x == 3 else 20,
                           split_x=split_x, split_y=1 if hole else rng.choice([1, 2]),
                           hole=hole),
        mu=round(rng.uniform(0.0, 0.6), 3), gap=rng.choice([0.0, 0.0, 0.001, -0.001]),
        press=press, pull=pull, pressure=-round(rng.uniform(5, 40), 2),
        pull_condition=pull_condition, stop_gap=rng.choice([0.0, 0.005, 0.02, -0.002]),
        stop_face='face = "strap.right"', stop_friction=rng.choice([0.0, 0.0, 0.2]),
        last_qoi=CORNER.format(x1=x1, component=rng.choice(["x", "y"])))


BLOCK = """
title = "random pushed block {seed}"
[analysis]
hypothesis = "{hypothesis}"
[materials.block]
E = {e_block}
nu = 0.3
[materials.base]
E = {e_base}
nu = 0.25
[[bodies]]
name = "base"
x = [0.0, 40.0]
y = [0.0, 10.0]
elements = [{n_base}, 4]
split = [{split_base}, {split_base_y}]
material = "base"
[[bodies]]
name = "block"
x = [{x0}, {x1}]
y = [10.0, 20.0]
elements = [{n_block}, 6]
split = [1, {split_block_y}]
material = "block"
[[interfaces]]
between = ["base", "block"]
type = "contact"
friction = {mu}
gap = {gap}
[history.factors]
press = {press}
push = {push}
[[boundary]]
name = "clamp"
face = "base.bottom"
type = "displacement"
value = [0.0, 0.0]
{top}
[[boundary]]
name = "push"
face = "block.left"
type = "{push_type}"
{push_components}value = [{push_value}, 0.0]
factor = "push"
{stop}
[[qoi]]
name = "R_push"
unit = "N"
type = "reaction"
boundary = "push"
component = "x"
[[qoi]]
name = "R_clamp_y"
unit = "N"
type = "reaction"
boundary = "clamp"
component = "y"
"""


def block_text(seed: int) -> str:
    """The ``--family block`` model of ``seed``: a block pushed sideways on a clamped base
    by a prescribed displacement of its left face (both components, or x alone), pressed
    by a force, a prescribed displacement of its top, or held under a smooth wall and
    loaded on its right face; a stop at the base's right face or none."""
    rng = random.Random(seed)
    steps = rng.choice([3, 4, 6])
    top = rng.choice([
        "[[boundary]]\nname = \"top\"\nface = \"block.top\"\ntype = \"force\"\n"
        f"value = [0.0, {-rng.uniform(5, 30):.2f}]\nfactor = \"press\"",
        "[[boundary]]\nname = \"top\"\nface = \"block.top\"\ntype = \"mixed\"\n"
        "components = [\"force\", \"displacement\"]\n"
        f"value = [0.0, {-rng.uniform(0.001, 0.01):.4f}]\nfactor = \"press\"",
        "[[boundary]]\nname = \"top\"\nface = \"block.top\"\ntype = \"wall\"\n"
        "[[boundary]]\nname = \"side\"\nface = \"block.right\"\ntype = \"force\"\n"
        f"value = [{-rng.uniform(1, 10):.2f}, 0.0]\nfactor = \"press\""])
    push_type = rng.choice(["displacement", "mixed"])
    stop = ""
    if rng.random() < 0.5:
        stop = ("[[boundary]]\nname = \"stop\"\nface = \"base.right\"\ntype = \"stop\"\n"
                f"gap = {rng.choice([0.0, 0.002])}\nfriction = {rng.choice([0.0, 0.2])}")
    return BLOCK.format(
        seed=seed, hypothesis=rng.choice(["plane_stress", "plane_strain"]),
        e_block=rng.choice([7e4, 2e5]), e_base=rng.choice([7e4, 2e5, 2e6]),
        n_base=rng.choice([16, 20]), split_base=rng.choice([1, 2]),
        split_base_y=rng.choice([1, 2]), x0=rng.choice([0.0, 4.0, 10.0]),
        x1=rng.choice([30.0, 36.0, 40.0]), n_block=rng.choice([10, 13, 15]),
        split_block_y=rng.choice([1, 1, 2]), mu=round(rng.uniform(0.05, 0.6), 3),
        gap=rng.choice([0.0, 0.0, 0.0005]),
        press=[min(1.0, (i + 1) / 2) for i in range(steps)],
        push=[0.0, 0.0] + [(i + 1) / (steps - 2) for i in range(steps - 2)], top=top,
        push_type=push_type,
        push_components=("components = [\"displacement\", \"force\"]\n"
                         if push_type == "mixed" else ""),
        push_value=round(rng.uniform(0.002, 0.02), 4), stop=stop)


STACK = """
title = "random stack {seed}"
[analysis]
hypothesis = "{hypothesis}"
[materials.soft]
E = 7e4
nu = 0.33
[materials.steel]
E = 2e5
nu = 0.3
[[bodies]]
name = "base"
x = [0.0, 50.0]
y = [0.0, 8.0]
elements = [{n_base}, 3]
split = [{split_base}, 1]
material = "{m_base}"
[[bodies]]
name = "plate"
x = [{p0}, {p1}]
y = [8.0, 14.0]
elements = [{n_plate}, 3]
split = [{split_plate}, 1]
material = "{m_plate}"
[[bodies]]
name = "block"
x = [{b0}, {b1}]
y = [14.0, 24.0]
elements = [{n_block}, 4]
split = [{split_block}, 1]
material = "{m_block}"
[[interfaces]]
between = ["base", "plate"]
type = "contact"
friction = {mu}
gap = {gap}
[[interfaces]]
between = ["plate", "block"]
type = "contact"
friction = {mu_top}
gap = 0.0
[history.factors]
press = {press}
push = {push}
[[boundary]]
name = "clamp"
face = "base.bottom"
type = "displacement"
value = [0.0, 0.0]
[[boundary]]
name = "pressure"
face = "block.top"
type = "force"
value = [0.0, {pressure}]
factor = "press"
[[boundary]]
name = "push"
face = "plate.left"
type = "mixed"
components = ["displacement", "force"]
value = [{push_value}, 0.0]
factor = "push"
{stop}
[[qoi]]
name = "R_push"
unit = "N"
type = "reaction"
boundary = "push"
component = "x"
[[qoi]]
name = "R_clamp_x"
unit = "N"
type = "reaction"
boundary = "clamp"
component = "x"
[[qoi]]
name = "u_block"
unit = "mm"
type = "displacement"
point = [{b1}, 24.0]
component = "x"
"""

#: load histories of ``--family stack``: the push goes and comes back (friction reverses),
#: or the pressure is released while the push holds (a slip under a falling normal force)
HISTORIES = (
    ([0.5, 1, 1, 1, 1, 1, 1, 1], [0, 0, 0.5, 1, 0.5, 0, -0.5, -1]),
    ([0.5, 1, 1, 1, 1, 1], [0, 0, 1, 0.3, -0.4, 0]),
    ([0.5, 1, 1, 1, 0.6, 0.3], [0, 0, 0.5, 1, 1, 1]),
)


def stack_text(seed: int) -> str:
    """The ``--family stack`` model of ``seed``: a plate between a clamped base and a
    pressed block, pushed by a prescribed displacement of its left face along a history
    that reverses the push or releases the pressure (``HISTORIES``: friction's path
    dependence), two contacts (the block's friction at least 0.1: nothing else holds it
    sideways), a stop at the plate's right face or none."""
    rng = random.Random(seed)
    p0, p1 = rng.choice([0.0, 5.0]), rng.choice([40.0, 45.0])
    b0, b1 = p0 + rng.choice([0.0, 5.0, 10.0]), p1 - rng.choice([0.0, 5.0, 10.0])
    press, push = rng.choice(HISTORIES)
    stop = ""
    if rng.random() < 0.4:
        stop = ("[[boundary]]\nname = \"stop\"\nface = \"plate.right\"\ntype = \"stop\"\n"
                f"gap = {rng.choice([0.002, 0.01])}\nfriction = {rng.choice([0.0, 0.2])}")
    return STACK.format(
        seed=seed, hypothesis=rng.choice(["plane_stress", "plane_strain"]),
        n_base=rng.choice([20, 24]), split_base=rng.choice([1, 2]),
        m_base=rng.choice(["soft", "steel"]), p0=p0, p1=p1, n_plate=rng.choice([16, 20]),
        split_plate=rng.choice([1, 2]), m_plate=rng.choice(["soft", "steel"]), b0=b0, b1=b1,
        n_block=rng.choice([8, 10, 12]), split_block=rng.choice([1, 2]),
        m_block=rng.choice(["soft", "steel"]), mu=round(rng.uniform(0.05, 0.6), 3),
        mu_top=round(rng.uniform(0.1, 0.6), 3), gap=rng.choice([0.0, 0.0, 0.0005]),
        press=press, push=push, pressure=-round(rng.uniform(5, 30), 2),
        push_value=round(rng.uniform(0.002, 0.02), 4), stop=stop)


#: the meshed family's third QoI
PULL = """[[qoi]]
name = "R_pull"
unit = "N"
type = "reaction"
boundary = "pull"
component = "x\""""


#: where ``--family meshed`` writes its mesh files (``main`` sets it to the model files')
MESH_FOLDER = Path(tempfile.gettempdir())


def meshed_text(seed: int) -> str:
    """The ``--family meshed`` model of ``seed``: a strap of one to three parts meshed by
    gmsh apart (T3 or Q4, random sizes; one part's hole cut out of its mesh, not a level
    set), so that every interface is mortar, on a clamped base split at random, pulled by a
    prescribed displacement toward a stop. Writes the mesh files to ``MESH_FOLDER``."""
    import gmsh  # an optional dependency: the family needs it

    rng = random.Random(seed)
    x0, x1 = rng.choice([0.0, 5.0]), rng.choice([40.0, 45.0])
    count = rng.choice([1, 2, 3])
    cuts = sorted(round(rng.uniform(x0 + 8, x1 - 8), 2) for _ in range(count - 1))
    bounds = [x0, *cuts, x1]
    holed = rng.randrange(count) if rng.random() < 0.5 else -1
    parts = []
    for i in range(count):
        path = MESH_FOLDER / f"meshed-{seed}-{i}.msh"
        gmsh.initialize()
        try:
            gmsh.option.setNumber("General.Verbosity", 0)
            occ = gmsh.model.occ
            a, b = bounds[i], bounds[i + 1]
            tag = occ.addRectangle(a, 10.0, 0.0, b - a, 8.0)
            if i == holed:
                radius = rng.uniform(0.8, 2.0)
                centre = (rng.uniform(a + radius + 1.5, b - radius - 1.5),
                          rng.uniform(12.5, 15.5))
                occ.cut([(2, tag)], [(2, occ.addDisk(*centre, 0.0, radius, radius))])
            occ.synchronize()
            recombine = rng.random() < 0.5
            # quadrilaterals by subdivision (recombination alone leaves triangles)
            gmsh.option.setNumber("Mesh.MeshSizeMax", rng.uniform(1.2, 2.5)
                                  * (2.0 if recombine else 1.0))
            gmsh.option.setNumber("Mesh.SubdivisionAlgorithm", 1 if recombine else 0)
            gmsh.option.setNumber("Mesh.RecombineAll", 1 if recombine else 0)
            gmsh.option.setNumber("Mesh.Algorithm", 8 if recombine else 6)
            gmsh.model.mesh.generate(2)
            gmsh.write(str(path))
        finally:
            gmsh.finalize()
        parts.append(f'[[substructures]]\nname = "strap{i}"\nmesh_file = "{path}"\n'
                     'material = "strap"\nbody = "strap"')
    steps = rng.choice([4, 6])
    return MODEL.format(
        kind="meshed strap", seed=seed, hypothesis=rng.choice(["plane_stress", "plane_strain"]),
        e_strap=rng.choice([7e4, 2e5]), e_base=rng.choice([7e4, 2.1e5, 2e6]),
        split_base=rng.choice([1, 2, 3]), strap="\n".join(parts),
        mu=round(rng.uniform(0.05, 0.6), 3), gap=rng.choice([0.0, 0.0, 0.001]),
        press=[min(1.0, (i + 1) / 2) for i in range(steps)],
        pull=[0.0, 0.0] + [(i + 1) / (steps - 2) for i in range(steps - 2)],
        pressure=-round(rng.uniform(5, 40), 2),
        pull_condition=('[[boundary]]\nname = "pull"\nsubstructure = "strap0"\nside = "left"\n'
                        'type = "mixed"\ncomponents = ["displacement", "force"]\n'
                        f"value = [{round(rng.uniform(0.002, 0.03), 4)}, 0.0]\n"
                        'factor = "pull"'),
        stop_gap=rng.choice([0.0, 0.005, 0.02]),
        stop_face=f'substructure = "strap{count - 1}"\nside = "right"',
        stop_friction=rng.choice([0.0, 0.2]), last_qoi=PULL)


#: the model families by ``--family`` name
FAMILIES = {"strap": model_text, "block": block_text, "stack": stack_text,
            "meshed": meshed_text}

def axisymmetric(text: str) -> str:
    """A model file of this script made axisymmetric (x = r): its hypothesis, no
    thickness."""
    text = text.replace("thickness = 2.0\n", "")
    return re.sub(r'hypothesis = "\w+"', 'hypothesis = "axisymmetric"', text, count=1)
