"""The bundled ``lug`` model's mesh files, made with gmsh: a lug [0, 60] × [−20, 20] mm with
a hole of radius 8 mm at (40, 0), whose right half (the bore the pin bears on) is the named
group ``bore``; and the pin, a disc of the same radius with a hub hole of radius 2 mm, the
right half of its rim the group ``bearing`` and its hub's halves ``hub_right``, ``hub_left``.
Triangles of ``size`` (default 0.5 mm) along the hole, growing to 5 mm 15 mm away; the pin's
1.6 times coarser, so that the two arcs do not match.

Run: ``python examples/lug_meshes.py [--size 0.5] [--out src/multilatin/models]``
"""

from __future__ import annotations

import argparse
from pathlib import Path

CENTRE, RADIUS, HUB = 40.0, 8.0, 2.0  # mm


def make(folder: Path, size: float = 0.5) -> tuple[Path, Path]:
    """Write ``lug_plate.msh`` and ``lug_pin.msh`` into ``folder``; returns their paths."""
    import gmsh

    cx, r = CENTRE, RADIUS
    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Verbosity", 0)
        geo = gmsh.model.geo
        gmsh.model.add("lug")
        corners = [geo.addPoint(x, y, 0.0) for x, y in ((0, -20), (60, -20), (60, 20), (0, 20))]
        sides = [geo.addLine(corners[i], corners[(i + 1) % 4]) for i in range(4)]
        centre = geo.addPoint(cx, 0.0, 0.0)
        bottom, right, top, left = (geo.addPoint(cx, -r, 0.0), geo.addPoint(cx + r, 0.0, 0.0),
                                    geo.addPoint(cx, r, 0.0), geo.addPoint(cx - r, 0.0, 0.0))
        bore = [geo.addCircleArc(bottom, centre, right), geo.addCircleArc(right, centre, top)]
        back = [geo.addCircleArc(top, centre, left), geo.addCircleArc(left, centre, bottom)]
        plate = geo.addPlaneSurface([geo.addCurveLoop(sides), geo.addCurveLoop(bore + back)])
        geo.synchronize()
        gmsh.model.addPhysicalGroup(1, bore, name="bore")
        gmsh.model.addPhysicalGroup(2, [plate], name="lug")
        field = gmsh.model.mesh.field
        distance = field.add("Distance")
        field.setNumbers(distance, "CurvesList", bore + back)
        threshold = field.add("Threshold")
        field.setNumber(threshold, "InField", distance)
        field.setNumber(threshold, "SizeMin", size)
        field.setNumber(threshold, "SizeMax", 5.0)
        field.setNumber(threshold, "DistMin", 1.0)
        field.setNumber(threshold, "DistMax", 15.0)
        field.setAsBackgroundMesh(threshold)
        for option in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints",
                       "Mesh.MeshSizeFromCurvature"):
            gmsh.option.setNumber(option, 0)
        gmsh.model.mesh.generate(2)
        plate_path = folder / "lug_plate.msh"
        gmsh.write(str(plate_path))
        gmsh.model.remove()
        gmsh.model.add("pin")
        centre = geo.addPoint(cx, 0.0, 0.0)
        bottom, right, top, left = (geo.addPoint(cx, -r, 0.0), geo.addPoint(cx + r, 0.0, 0.0),
                                    geo.addPoint(cx, r, 0.0), geo.addPoint(cx - r, 0.0, 0.0))
        bearing = [geo.addCircleArc(bottom, centre, right), geo.addCircleArc(right, centre, top)]
        back = [geo.addCircleArc(top, centre, left), geo.addCircleArc(left, centre, bottom)]
        h = HUB
        hub_points = (geo.addPoint(cx, -h, 0.0), geo.addPoint(cx + h, 0.0, 0.0),
                      geo.addPoint(cx, h, 0.0), geo.addPoint(cx - h, 0.0, 0.0))
        hub = [geo.addCircleArc(hub_points[k], centre, hub_points[(k + 1) % 4])
               for k in range(4)]
        pin = geo.addPlaneSurface([geo.addCurveLoop(bearing + back), geo.addCurveLoop(hub)])
        geo.synchronize()
        gmsh.model.addPhysicalGroup(1, bearing, name="bearing")
        gmsh.model.addPhysicalGroup(1, hub[:2], name="hub_right")
        gmsh.model.addPhysicalGroup(1, hub[2:], name="hub_left")
        gmsh.model.addPhysicalGroup(2, [pin], name="pin")
        gmsh.option.setNumber("Mesh.MeshSizeMax", 1.6 * size)
        gmsh.model.mesh.generate(2)
        pin_path = folder / "lug_pin.msh"
        gmsh.write(str(pin_path))
    finally:
        gmsh.finalize()
    return plate_path, pin_path


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=float, default=0.5)
    parser.add_argument("--out", type=Path, default=Path("src/multilatin/models"))
    args = parser.parse_args()
    for written in make(args.out, args.size):
        print(written)
