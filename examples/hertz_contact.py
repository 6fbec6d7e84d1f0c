"""hertz — a cylinder pressed on a plate (plane strain): the gmsh workflow end to end, and the
contact half-width and peak pressure against Hertz's closed form under mesh refinement.

Both bodies are meshed by gmsh (triangles, finer near the contact) and read from ``.msh``
files; by symmetry the model is the half x ≥ 0. The cylinder's curved face meets the
plate's flat top through a contact interface declared with ``reach``: the cylinder's
boundary nodes within ``reach`` of the plate take part, each with its initial gap from the
geometry, joined to the plate's non-matching mesh by mortar projection.

Hertz (two cylinders of equal material, one of infinite radius), force P per unit length:
a = √(4 P R / (π E*)), p0 = 2 P / (π a), 1/E* = 2 (1 − ν²) / E.

Run: ``python examples/hertz_contact.py --out results/gallery/hertz`` (needs gmsh:
``pip install gmsh``)
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path

import numpy as np

import multilatin as ml

RADIUS, YOUNG, POISSON = 10.0, 210_000.0, 0.3  # mm, MPa, –
HALF_WIDTH = 1.0  # mm: the contact half-width a the load is chosen for
E_STAR = YOUNG / (2.0 * (1.0 - POISSON**2))
LOAD = math.pi * HALF_WIDTH**2 * E_STAR / (4.0 * RADIUS)  # P, N per mm of length
PEAK = 2.0 * LOAD / (math.pi * HALF_WIDTH)  # p0, MPa
PLATE = 30.0  # mm: the half plate's width and depth
SAMPLES = np.linspace(0.0, 2.0 * HALF_WIDTH, 81)  # where the contact pressure is read

MODEL = """
title = "Cylinder on a plate (Hertz), half model"
[analysis]
hypothesis = "plane_strain"
[materials.steel]
E = {young}
nu = {poisson}
[[substructures]]
name = "cylinder"
mesh_file = "{cylinder}"
material = "steel"
[[substructures]]
name = "plate"
mesh_file = "{plate}"
material = "steel"
[[interfaces]]
between = ["cylinder", "plate"]
type = "contact"
friction = 0.0
reach = {reach}                   # the cylinder's nodes within this distance of the plate
[[boundary]]
name = "load"
face = "cylinder.top"
type = "force"
value = [0.0, {traction}]
[[boundary]]
name = "axis_cylinder"
face = "cylinder.left"
type = "mixed"
components = ["displacement", "force"]
value = [0.0, 0.0]
[[boundary]]
name = "axis_plate"
face = "plate.left"
type = "mixed"
components = ["displacement", "force"]
value = [0.0, 0.0]
[[boundary]]
name = "base"
face = "plate.bottom"
type = "displacement"
value = [0.0, 0.0]
"""


def mesh_files(folder: Path, size: float) -> tuple[Path, Path]:
    """The quarter cylinder (centre (0, R), x ≥ 0, below its centre) and the half plate
    [0, 30] × [−30, 0], meshed by gmsh with triangles of ``size`` near the contact point
    (0, 0), growing away from it."""
    import gmsh

    paths = []
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Verbosity", 0)
        for name in ("cylinder", "plate"):
            gmsh.model.add(name)
            occ = gmsh.model.occ
            if name == "cylinder":
                disk = occ.addDisk(0.0, RADIUS, 0.0, RADIUS, RADIUS)
                box = occ.addRectangle(0.0, 0.0, 0.0, RADIUS, RADIUS)
                occ.intersect([(2, disk)], [(2, box)])
                coarse = RADIUS / 8
            else:
                occ.addRectangle(0.0, -PLATE, 0.0, PLATE, PLATE)
                coarse = PLATE / 8
            occ.synchronize()
            corner = gmsh.model.occ.addPoint(0.0, 0.0, 0.0)
            occ.synchronize()
            field = gmsh.model.mesh.field
            distance = field.add("Distance")
            field.setNumbers(distance, "PointsList", [corner])
            threshold = field.add("Threshold")
            field.setNumber(threshold, "InField", distance)
            field.setNumber(threshold, "SizeMin", size)
            field.setNumber(threshold, "SizeMax", coarse)
            field.setNumber(threshold, "DistMin", 2.5 * HALF_WIDTH)
            field.setNumber(threshold, "DistMax", 10.0 * HALF_WIDTH)
            field.setAsBackgroundMesh(threshold)
            gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
            gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
            gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
            gmsh.model.mesh.generate(2)
            path = folder / f"{name}.msh"
            gmsh.write(str(path))
            gmsh.model.remove()
            paths.append(path)
    finally:
        gmsh.finalize()
    return paths[0], paths[1]


def model(folder: Path, size: float) -> ml.Model:
    """The half model with meshes of ``size`` near the contact, files in ``folder``, and
    QoIs p(x): the contact pressure at the ``SAMPLES``."""
    cylinder, plate = mesh_files(folder, size)
    text = MODEL.format(young=YOUNG, poisson=POISSON, cylinder=cylinder.name,
                        plate=plate.name, reach=0.3 * RADIUS,
                        traction=-LOAD / 2.0 / RADIUS)
    for k, x in enumerate(SAMPLES):  # the mean over a segment of 1e-6 mm: p at x
        text += (f'[[qoi]]\nname = "p{k}"\ntype = "contact_pressure"\nbetween = ["cylinder", '
                 f'"plate"]\nsegment = [{float(x)!r}, {float(x) + 1e-6!r}]\nunit = "MPa"\n')
    path = folder / "hertz.toml"
    path.write_text(text, encoding="utf-8")
    return ml.load_model(path)


def half_width_and_peak(result: ml.SolveResult) -> tuple[float, float]:
    """a: halfway between the last node in contact and the first one open (the nodal
    contact forces, ``SolveResult.contact``); p0: the contact pressure on the axis (the
    QoI, recovered consistently from the nodal forces)."""
    assert result.contact is not None
    order = np.argsort(result.contact.positions[:, 0])
    x = result.contact.positions[order, 0]
    pressure = result.contact.pressure[-1, order]
    closed = np.flatnonzero(pressure > 1e-9 * pressure.max())
    last = int(closed[-1])
    edge = 0.5 * (x[last] + x[last + 1]) if last + 1 < x.size else float("nan")
    return float(edge), float(result.qoi["p0"])


def run(sizes: tuple[float, ...] = (0.2, 0.1, 0.05), solver: str = "reference",
        out: Path | None = None, kappa: float = ml.LatinOptions.kappa
        ) -> list[dict[str, float]]:
    """a and p0 for each mesh size near the contact, by ``solver`` ("reference":
    monolithic, or "latin", with the search direction ``kappa``), against Hertz's values."""
    rows = []
    profiles = []
    with tempfile.TemporaryDirectory() as tmp:
        for size in sizes:
            folder = Path(tmp) / f"h{size:g}"
            folder.mkdir()
            hertz = model(folder, size)
            result = (hertz.reference() if solver == "reference"
                      else hertz.solve(options=ml.LatinOptions(tol=1e-8, max_iter=20000,
                                                               kappa=kappa)))
            a, p0 = half_width_and_peak(result)
            rows.append({"size": size, "a": a, "p0": p0, "a_error": a / HALF_WIDTH - 1.0,
                         "p0_error": p0 / PEAK - 1.0,
                         "iterations": float(result.iterations)})
            profiles.append([float(result.qoi[f"p{k}"]) for k in range(SAMPLES.size)])
    if out is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        out.mkdir(parents=True, exist_ok=True)
        fig, ax = plt.subplots(figsize=(6, 4))
        exact = PEAK * np.sqrt(np.clip(1.0 - (SAMPLES / HALF_WIDTH) ** 2, 0.0, None))
        ax.plot(SAMPLES, exact, "k--", label="Hertz")
        for size, profile in zip(sizes, profiles, strict=True):
            ax.plot(SAMPLES, profile, label=f"{solver}, h = {size:g} mm at the contact")
        ax.set(xlabel="x [mm]", ylabel="contact pressure [MPa]",
               title="Cylinder on a plate: contact pressure against Hertz")
        ax.legend()
        fig.savefig(out / "hertz.png", dpi=100, bbox_inches="tight")
        plt.close(fig)
    return rows


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--solver", choices=["reference", "latin"], default="latin")
    parser.add_argument("--kappa", type=float, default=ml.LatinOptions.kappa,
                        help="LATIN's search direction k = κ E / L (the answer does not "
                             "depend on it, the iterations do)")
    args = parser.parse_args()
    print(f"Hertz: a = {HALF_WIDTH:g} mm, p0 = {PEAK:.1f} MPa (P = {LOAD:.1f} N/mm)")
    print("| h at contact | a [mm] | error | p0 [MPa] | error | iterations |")
    print("|---|---|---|---|---|---|")
    for row in run(solver=args.solver, out=args.out, kappa=args.kappa):
        print(f"| {row['size']:g} | {row['a']:.4f} | {100 * row['a_error']:+.2f} % | "
              f"{row['p0']:.1f} | {100 * row['p0_error']:+.2f} % | {row['iterations']:g} |")
