"""Files a user opens: a ParaView time series (via meshio) of the fields and of the contact
tractions and status, the convergence plot, and the JSON/CSV of the result."""

from __future__ import annotations

import csv
import json
import logging
from pathlib import Path
from xml.sax.saxutils import quoteattr

import meshio
import numpy as np

from ..decomposition.qoi import determined_steps
from ..decomposition.result import SolveResult
from ..fem.elasticity import FloatArray, IntArray, cell_strains, cell_stresses, von_mises
from ..parameters import label
from .files import ensure_writable_folder
from .plots import contact_jump, plot_deformed, plot_histories, status_indices

log = logging.getLogger(__name__)


def safe_file_name(name: str) -> str:
    """``name`` as part of a file name: letters, digits, "-" and "_" kept, others "_"."""
    return "".join(c if c.isalnum() or c in "-_" else "_" for c in name)


#: contact status codes in the VTK interface fields
STATUS_CODES = {"open": 0, "stick": 1, "slip": 2}


def _solid(result: SolveResult) -> tuple[FloatArray, list[tuple[str, IntArray]], FloatArray,
                                          dict[str, FloatArray]]:
    """All substructures as one mesh: points (each substructure's own, so that contact
    openings show; no point that no cell uses, e.g. nodes of a hole's void cells), cell
    blocks, displacement (n_steps, n_points, 2) and cell data (n_steps, n_cells) each."""
    points, blocks, displacement = [], [], []
    data: dict[str, list[FloatArray]] = {}
    offset = 0
    for s, sub in enumerate(result.assembly.substructures):
        mesh = sub.mesh
        u = result.displacements[sub.name]
        # void cells of a hole are left out; cut cells carry their material fraction
        fraction = np.ones(mesh.n_cells) if sub.cut is None else sub.cut.material_fraction
        kept = fraction > 0.0
        cells = mesh.cells[kept]
        used, renumbered = np.unique(cells, return_inverse=True)
        strain = cell_strains(mesh.nodes, cells, u, sub.material.radial)
        stress = cell_stresses(mesh.nodes, cells, sub.material.hooke, u)
        n_steps, n_cells = stress.shape[0], cells.shape[0]
        change = result.assembly.temperature(s)  # σ = D (ε − ε₀), ε₀ at the cells' centres
        heat = change[:, cells].mean(axis=2) if change is not None else None
        if heat is not None:
            material = sub.material
            stress = stress - heat[..., None] * (material.hooke @ material.thermal_strain)
        columns = {
            "stress_xx": stress[..., 0], "stress_yy": stress[..., 1], "stress_xy": stress[..., 2],
            "strain_xx": strain[..., 0], "strain_yy": strain[..., 1],
            "strain_xy": 0.5 * strain[..., 2],  # tensor component: half the engineering γ_xy
            "von_mises": von_mises(stress, sub.material.poisson, sub.material.hypothesis,
                                   None if heat is None else
                                   -sub.material.young * sub.material.expansion * heat),
            "substructure": np.full((n_steps, n_cells), float(s)),
            "material_fraction": np.broadcast_to(fraction[kept], (n_steps, n_cells)),
            # 0 where a free rigid motion leaves the part's position undetermined
            "displacement_determined": np.broadcast_to(determined_steps(
                result.free_motions, n_steps, [sub.body in m.bodies for m in result.free_motions]
            )[:, None].astype(float), (n_steps, n_cells)),
        }
        if stress.shape[-1] == 4:  # axisymmetric: the hoop components
            columns.update({"stress_tt": stress[..., 3], "strain_tt": strain[..., 3]})
        for name, values in columns.items():
            data.setdefault(name, []).append(values)
        points.append(mesh.nodes[used])
        displacement.append(u[:, used])
        kind = "quad" if cells.shape[1] == 4 else "triangle"
        blocks.append((kind, renumbered.reshape(cells.shape) + offset))
        offset += used.size
    merged: list[tuple[str, IntArray]] = []
    for kind, cells in blocks:  # one block per cell type, as VTK readers like
        if merged and merged[-1][0] == kind:
            merged[-1] = (kind, np.vstack([merged[-1][1], cells]))
        else:
            merged.append((kind, cells))
    return (np.vstack(points), merged, np.concatenate(displacement, axis=1),
            {name: np.concatenate(v, axis=1) for name, v in data.items()})


def _contact(result: SolveResult) -> dict[str, FloatArray] | None:
    """Contact interfaces and stops, on the first side's points: coordinates, outward
    normal, traction (force per unit area: F̂, per unit length, over the contact's thickness),
    normal pressure (positive in compression), tangential traction, displacement jump and
    status (0 open, 1 stick, 2 slip) per step."""
    itf = result.interface
    if itf is None:
        return None
    chosen: list[IntArray] = []
    normals: list[FloatArray] = []
    thicknesses: list[FloatArray] = []
    jumps: list[FloatArray] = []
    for i, interface in enumerate(result.assembly.interfaces):
        if interface.contact is None:
            continue
        first, jump = contact_jump(result, i)
        jumps.append(jump)
        normal = result.assembly.substructures[interface.sides[0].substructure].mesh \
            .outward_normal(interface.sides[0].side)
        chosen.append(first)
        normals.append(np.tile(normal, (first.size, 1)))
        # the face that touches: the thinner side's (LATIN's forces are per unit length;
        # 2π r axisymmetric)
        thicknesses.append(np.min([
            result.assembly.substructures[ref.substructure].material.thickness_at(
                itf.coords[first]) for ref in interface.sides], axis=0))
    if not chosen:
        return None
    index = np.concatenate(chosen)
    normal = np.vstack(normals)
    n_steps = itf.force_hat.shape[0]
    status = np.zeros((n_steps, itf.coords.shape[0]))
    for step in range(n_steps):
        for name, points in status_indices(result, step).items():
            status[step, points] = STATUS_CODES[name]
    thickness = np.concatenate(thicknesses)
    traction = np.divide(itf.force_hat[:, index], thickness[:, None],  # 0 on the axis
                         out=np.zeros_like(itf.force_hat[:, index]),
                         where=thickness[:, None] > 0.0)
    pressure = -np.einsum("tpd,pd->tp", traction, normal)
    tangent = np.column_stack([-normal[:, 1], normal[:, 0]])
    jump = np.concatenate(jumps, axis=1)
    return {"coords": itf.coords[index], "normal": normal, "traction": traction,
            "pressure": pressure, "tangential_traction": np.einsum("tpd,pd->tp", traction, tangent),
            "status": status[:, index], "weights": itf.weights[index] * thickness,
            "jump": jump, "slip": np.einsum("tpd,pd->tp", jump, tangent)}


def _planar(vectors: FloatArray) -> FloatArray:
    return np.column_stack([vectors, np.zeros(vectors.shape[0])])


def write_vtk(result: SolveResult, folder: Path) -> Path:
    """``<model>.pvd``, one time series that ParaView opens at once (load steps as time 1,
    2, …): per step ``<model>_stepNNN.vtu`` (every substructure; point data displacement;
    cell data stresses, strains (tensor components), von Mises stress, substructure index,
    material fraction, ``displacement_determined`` (0 where a free rigid motion leaves the
    part's position undetermined, ``qoi.determined_steps``); a hole's void cells and their
    nodes left out) and, for a LATIN result with contact, ``<model>_contact_stepNNN.vtu``
    (the contact points with traction, pressure, tangential traction, normal, area, status:
    0 open, 1 stick, 2 slip, the displacement jump across the contact and its tangential
    part, the slip, along the normal turned by +90°)."""
    folder.mkdir(parents=True, exist_ok=True)
    points, blocks, displacement, cell_data = _solid(result)
    contact = _contact(result)
    name = safe_file_name(result.assembly.name)
    datasets = []
    sizes = [cells.shape[0] for _, cells in blocks]
    splits = np.cumsum(sizes)[:-1]
    for step in range(displacement.shape[0]):
        solid = f"{name}_step{step + 1:03d}.vtu"
        meshio.write(folder / solid, meshio.Mesh(
            _planar(points), blocks,
            point_data={"displacement": _planar(displacement[step])},
            cell_data={key: np.split(values[step], splits) for key, values in cell_data.items()},
        ))
        datasets.append((step + 1, 0, solid))
        if contact is not None:
            file = f"{name}_contact_step{step + 1:03d}.vtu"
            n = contact["coords"].shape[0]
            meshio.write(folder / file, meshio.Mesh(
                _planar(contact["coords"]), [("vertex", np.arange(n)[:, None])],
                point_data={"traction": _planar(contact["traction"][step]),
                            "pressure": contact["pressure"][step],
                            "tangential_traction": contact["tangential_traction"][step],
                            "status": contact["status"][step],
                            "displacement_jump": _planar(contact["jump"][step]),
                            "slip": contact["slip"][step],
                            "normal": _planar(contact["normal"]),
                            "area": contact["weights"]},
            ))
            datasets.append((step + 1, 1, file))
    pvd = folder / f"{name}.pvd"
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
