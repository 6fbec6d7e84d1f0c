"""Files a user opens: VTK fields per substructure (ParaView, via meshio), a ParaView
collection over the load steps, the convergence plot, and the JSON/CSV of the result."""

from __future__ import annotations

import csv
import json
import logging
from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np

from ..decomposition.result import SolveResult
from ..fem.elasticity import cell_stresses, von_mises
from ..parameters import label
from .files import ensure_writable_folder
from .plots import plot_deformed, plot_histories

log = logging.getLogger(__name__)


def _safe(name: str) -> str:
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in name)


def write_vtk(result: SolveResult, folder: Path) -> Path:
    """One .vtu per substructure and load step, and ``<model>.pvd`` that opens them all in
    ParaView (load steps as time 1, 2, …). Point data: displacement; cell data: stresses,
    von Mises stress, the substructure index and the material fraction (void cells of a
    hole are left out)."""
    folder.mkdir(parents=True, exist_ok=True)
    datasets = []
    for s, sub in enumerate(result.assembly.substructures):
        mesh = sub.mesh
        points = np.column_stack([mesh.nodes, np.zeros(mesh.n_nodes)])
        u = result.displacements[sub.name]
        # void cells of a hole are left out; cut cells carry their material fraction
        fraction = np.ones(mesh.n_cells) if sub.cut is None else sub.cut.material_fraction
        kept = fraction > 0.0
        cells = mesh.cells[kept]
        stress = cell_stresses(mesh.nodes, cells, sub.material.hooke, u)
        vm = von_mises(stress, sub.material.poisson, sub.material.hypothesis)
        for step in range(u.shape[0]):
            name = f"{_safe(sub.name)}_step{step + 1:03d}.vtu"
            meshio.write(
                folder / name,
                meshio.Mesh(
                    points,
                    [("quad", cells)],
                    point_data={"displacement": np.column_stack([u[step], np.zeros(mesh.n_nodes)])},
                    cell_data={
                        "stress_xx": [stress[step, :, 0]],
                        "stress_yy": [stress[step, :, 1]],
                        "stress_xy": [stress[step, :, 2]],
                        "von_mises": [vm[step]],
                        "substructure": [np.full(cells.shape[0], s, dtype=np.int32)],
                        "material_fraction": [fraction[kept]],
                    },
                ),
            )
            datasets.append((step + 1, s, name))
    pvd = folder / f"{_safe(result.assembly.name)}.pvd"
    lines = ['<?xml version="1.0"?>',
             '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
             "  <Collection>"]
    lines += [f'    <DataSet timestep="{t}" part="{p}" file={quoteattr(f)}/>'
              for t, p, f in datasets]
    lines += ["  </Collection>", "</VTKFile>", ""]
    pvd.write_text("\n".join(lines), encoding="utf-8")
    return pvd


def plot_convergence(results: dict[str, SolveResult], path: Path, tol: float | None = None) -> Path:
    """Indicator η against the iteration number, one curve per result."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for name, res in results.items():
        ax.semilogy(np.arange(1, res.history.size + 1), res.history, label=name)
    if tol is not None:
        ax.axhline(tol, color="k", lw=0.8, ls="--", label=f"tolerance {tol:g}")
    ax.set_xlabel("LATIN iteration")
    ax.set_ylabel("error indicator η [–]")
    ax.set_title(f"{', '.join(results)}: convergence of the LATIN iteration", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def write_result(result: SolveResult, folder: Path) -> list[Path]:
    """``result.json``, ``qoi.csv`` (a row per load step), VTK files, and for LATIN the
    convergence plot. A result that did not converge gets ``result.json`` (QoIs null,
    ``converged`` false, ``failure``) and the convergence plot only."""
    ensure_writable_folder(folder)
    written = []
    js = folder / "result.json"
    js.write_text(json.dumps(result.to_json_dict(), indent=2), encoding="utf-8")
    written.append(js)
    if not result.converged:  # no answer: the diagnosis only, no fields or QoI tables
        if result.method == "latin":
            written.append(plot_convergence({result.assembly.name: result},
                                            folder / "convergence.png", result.options.get("tol")))
        log.warning("%s: not converged (%s): wrote %s only", folder, result.failure,
                    ", ".join(p.name for p in written))
        return written
    table = folder / "qoi.csv"
    with table.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        units = {q.name: q.unit for q in result.assembly.qois}
        writer.writerow(["step", *(label(n, units.get(n, "")) for n in result.qoi)])
        for step in range(result.assembly.n_steps):
            writer.writerow([step + 1, *(
                v[step] if isinstance(v, list) else v for v in result.qoi.values())])
    written.append(table)
    written.append(write_vtk(result, folder / "vtk"))
    if result.method == "latin":
        tol = result.options.get("tol")
        written.append(plot_convergence({result.assembly.name: result},
                                        folder / "convergence.png", tol))
        written.append(plot_deformed(result, folder / "deformed.png"))
    history = plot_histories({result.method: result}, folder / "history.png")
    if history is not None:
        written.append(history)
    log.info("wrote %s", ", ".join(str(p) for p in written))
    return written
