import importlib.util
import os

if os.environ.get("PYTEST_XDIST_WORKER"):
    # pytest-xdist runs one worker per core (pyproject's ``-n auto``): each on one thread.
    # PyTorch's and OpenBLAS's threads, two per worker on two cores, spin against the
    # other worker's (a torch test measured 8 s alone, 155 s beside another worker)
    for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_name, "1")

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import multilatin as ml

#: friction pairs that open, close, stick and slip on the bundled B models
FRICTIONS = [(0.3, 0.0), (0.1, 0.3), (0.35, 0.25), (0.0, 0.0)]


@pytest.fixture(scope="session")
def b0() -> ml.Model:
    return ml.load_model("b0")


@pytest.fixture
def random_local_stage_input() -> Callable[[str, int], tuple[Any, ...]]:
    """``make(model, seed)``: ``local_stage_input``."""
    return local_stage_input


def local_stage_input(name: str, seed: int) -> tuple[Any, ...]:
    """The local stage of ``FRICTIONS``'s cases of a bundled model (NumPy, uncompiled) and
    random fields (W, F) of the sizes of a solve, whose contact points open, close, stick
    and slip: (assemblies, points, operators, local stage, W, F)."""
    from multilatin.decomposition.interfaces import build_points
    from multilatin.latin import LatinOperators, LatinOptions
    from multilatin.latin.local_stage import LocalStage

    model = ml.load_model(name)
    assemblies = [model.assemble({"mu1": a, "mu2": b}) for a, b in FRICTIONS]
    ops = LatinOperators(assemblies[0], LatinOptions())
    points = [build_points(a) for a in assemblies]
    rng = np.random.default_rng(seed)
    shape = (len(assemblies), assemblies[0].n_steps, points[0].n_points, 2)
    w, f = 1e-2 * rng.normal(size=shape), 1e3 * rng.normal(size=shape)
    stage = LocalStage(assemblies, points, ops.search_direction, compiled=False,
                       macro_only=ops.macro_only)
    return assemblies, points, ops, stage, w, f


def warm_b1_4_batch(options: Any) -> tuple[Any, ...]:
    """``FRICTIONS``'s cases of b1-4 with their operators and starts: cold, warm (from a
    converged neighbour), cold, warm — cases that leave a batch at different iterations."""
    from multilatin.latin import LatinOperators, solve_latin

    model = ml.load_model("b1-4")
    assemblies = [model.assemble({"mu1": a, "mu2": b}) for a, b in FRICTIONS]
    ops = LatinOperators(assemblies[0], options)
    neighbour = solve_latin(model.assemble({"mu1": 0.3, "mu2": 0.05}), operators=ops)
    assert neighbour.interface is not None
    warm = (neighbour.interface.displacement_hat, neighbour.interface.force_hat)
    return assemblies, ops, [None, warm, None, warm]


def write_gmsh_mesh(path: Any, geometry: Callable[[Any], object], size: float,
                    recombine: bool = False) -> Any:
    """Mesh with gmsh the 2-D geometry that ``geometry(gmsh)`` builds (OCC; it may add
    physical groups after synchronising) with elements of at most ``size``, quadrilaterals
    when ``recombine``, and write it to ``path``."""
    gmsh = pytest.importorskip("gmsh")
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Verbosity", 0)
        geometry(gmsh)
        gmsh.model.occ.synchronize()
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.option.setNumber("Mesh.RecombineAll", 1 if recombine else 0)
        gmsh.option.setNumber("Mesh.Algorithm", 8 if recombine else 6)
        gmsh.model.mesh.generate(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path


def rectangle(x0: float, y0: float, width: float, height: float, name: str
              ) -> Callable[[Any], None]:
    """A geometry for ``write_gmsh_mesh``: the rectangle from (x0, y0), its surface the
    physical group ``name`` (a mesh file's part)."""
    def geometry(gmsh: Any) -> None:
        tag = gmsh.model.occ.addRectangle(x0, y0, 0.0, width, height)
        gmsh.model.occ.synchronize()
        gmsh.model.addPhysicalGroup(2, [tag], name=name)
    return geometry


def write_gmsh_ring(path: Any, inner: float, outer: float, size: float,
                    names: tuple[str | None, str | None]) -> Any:
    """The quarter ring inner <= r <= outer, x, y >= 0; its arcs are physical groups
    ``names`` (inner arc, outer arc; None: none): the spinning-fit gallery script's mesher
    (``examples/spinning_fit.ring_mesh``)."""
    pytest.importorskip("gmsh")
    spec = importlib.util.spec_from_file_location(
        "gallery_spinning_fit_meshes",
        Path(__file__).resolve().parents[1] / "examples" / "spinning_fit.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.ring_mesh(Path(path), inner, outer, size, names)


def has_torch() -> bool:
    """Whether PyTorch is installed (the torch backend's tests run on its CPU build)."""
    try:
        import torch  # noqa: F401
    except ImportError:
        return False
    return True
