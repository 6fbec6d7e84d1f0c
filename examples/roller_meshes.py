"""The bundled ``roller`` model's mesh files, made with gmsh: a half roller (the part of the
disc of radius 10 mm centred at (0, 10) below its centre) and a plate [−30, 30] × [−20, 0] mm,
triangles of ``size`` (default 0.05 mm) within 0.3 mm of the contact zone |x| ≤ 2 mm,
growing to 1/6 of the part's height 8 mm away.

Run: ``python examples/roller_meshes.py [--size 0.05] [--out src/multilatin/models]``
(writes ``roller_roller.msh`` and ``roller_plate.msh``; the bundled files were made so with
gmsh 4.x: another gmsh version may place the nodes a little differently)
"""

from __future__ import annotations

import argparse
from pathlib import Path

RADIUS, PLATE_HALF_WIDTH, PLATE_DEPTH = 10.0, 30.0, 20.0  # mm
ZONE = 2.0  # mm: the refined contact zone |x| <= ZONE


def make(folder: Path, size: float = 0.05) -> tuple[Path, Path]:
    """Write the two mesh files into ``folder``; returns their paths (roller, plate)."""
    import gmsh

    paths = []
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Verbosity", 0)
        for part in ("roller", "plate"):
            gmsh.model.add(part)
            occ = gmsh.model.occ
            if part == "roller":
                disc = occ.addDisk(0.0, RADIUS, 0.0, RADIUS, RADIUS)
                box = occ.addRectangle(-RADIUS, 0.0, 0.0, 2 * RADIUS, RADIUS)
                occ.intersect([(2, disc)], [(2, box)])
                coarse = RADIUS / 6
            else:
                occ.addRectangle(-PLATE_HALF_WIDTH, -PLATE_DEPTH, 0.0, 2 * PLATE_HALF_WIDTH,
                                 PLATE_DEPTH)
                coarse = PLATE_DEPTH / 6
            zone = occ.addLine(occ.addPoint(-ZONE, 0.0, 0.0), occ.addPoint(ZONE, 0.0, 0.0))
            occ.synchronize()
            field = gmsh.model.mesh.field
            distance = field.add("Distance")
            field.setNumbers(distance, "CurvesList", [zone])
            field.setNumber(distance, "Sampling", 400)
            threshold = field.add("Threshold")
            field.setNumber(threshold, "InField", distance)
            field.setNumber(threshold, "SizeMin", size)
            field.setNumber(threshold, "SizeMax", coarse)
            field.setNumber(threshold, "DistMin", 0.3)
            field.setNumber(threshold, "DistMax", 8.0)
            field.setAsBackgroundMesh(threshold)
            for option in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints",
                           "Mesh.MeshSizeFromCurvature"):
                gmsh.option.setNumber(option, 0)
            gmsh.model.mesh.generate(2)
            path = folder / f"roller_{part}.msh"
            gmsh.write(str(path))
            gmsh.model.remove()
            paths.append(path)
    finally:
        gmsh.finalize()
    return paths[0], paths[1]


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=float, default=0.05)
    parser.add_argument("--out", type=Path, default=Path("src/multilatin/models"))
    args = parser.parse_args()
    for written in make(args.out, args.size):
        print(written)
