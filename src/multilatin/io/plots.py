"""Figures a reader of the paper looks for: the deformed assembly with the interface status
and the macro displacements (paper fig. 10b), and quantities of interest against the load
(fig. 11). Matplotlib, written to files (no screen needed)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from ..decomposition.result import SolveResult
from ..fem.elasticity import FloatArray
from ..parameters import label

STATUS_COLOURS = {"open": "tab:blue", "stick": "tab:green", "slip": "tab:red"}


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def contact_jump(result: SolveResult, i: int) -> tuple[npt.NDArray[np.int64], FloatArray]:
    """The points of contact interface (or stop) ``i``'s first side, and the displacement
    jump there per step (n_steps, n, 2): the other side's Ŵ less this one's (a stop's
    obstacle stays put)."""
    itf = result.interface
    assert itf is not None
    interface = result.assembly.interfaces[i]
    pts = np.flatnonzero(itf.interface == i)
    first = pts[itf.substructure[pts] == interface.sides[0].substructure]
    w = itf.displacement_hat[:, first]
    if len(interface.sides) == 2:
        second = pts[itf.substructure[pts] == interface.sides[1].substructure]
        return first, itf.displacement_hat[:, second] - w
    return first, -w


def status_indices(result: SolveResult, step: int,
                   slip_tol: float = 1e-6) -> dict[str, npt.NDArray[np.int64]]:
    """Interface point indices (side E of contact interfaces and stops) by status at
    ``step``: open (no contact force), stick (no tangential slip increment) or slip."""
    itf = result.interface
    assert itf is not None
    out: dict[str, list[npt.NDArray[np.int64]]] = {k: [] for k in STATUS_COLOURS}
    scale = max(float(np.abs(itf.displacement_hat).max()), 1e-300)
    force_scale = max(float(np.abs(itf.force_hat).max()), 1.0)
    for i, interface in enumerate(result.assembly.interfaces):
        if interface.contact is None:
            continue
        first, jump = contact_jump(result, i)
        increment = jump[step] - (jump[step - 1] if step > 0 else 0.0)
        normal = result.assembly.substructures[interface.sides[0].substructure].mesh \
            .outward_normal(interface.sides[0].side)
        tangential = increment - np.outer(increment @ normal, normal)
        is_open = np.linalg.norm(itf.force_hat[step, first], axis=1) <= 1e-9 * force_scale
        sliding = np.linalg.norm(tangential, axis=1) > slip_tol * scale
        out["open"].append(first[is_open])
        out["stick"].append(first[~is_open & ~sliding])
        out["slip"].append(first[~is_open & sliding])
    return {k: np.concatenate(v) if v else np.zeros(0, dtype=np.int64) for k, v in out.items()}


def contact_status(result: SolveResult, step: int, slip_tol: float = 1e-6) -> dict[str, FloatArray]:
    """Coordinates of the contact points (side E) by status at ``step``: open, stick, slip."""
    assert result.interface is not None
    coords = result.interface.coords
    return {k: coords[v] for k, v in status_indices(result, step, slip_tol).items()}


def _macro_part(result: SolveResult, step: int) -> list[tuple[FloatArray, FloatArray]]:
    """Per interface side: point coordinates and the macro (linear) part of Ŵ there, the
    M0-orthogonal projection onto constant + linear functions (paper eq. [6])."""
    itf = result.interface
    assert itf is not None
    out = []
    for i in np.unique(itf.interface):
        pts = np.flatnonzero(itf.interface == i)
        pts = pts[itf.substructure[pts] == itf.substructure[pts].min()]
        xy = itf.coords[pts]
        s = np.linalg.norm(xy - xy[0], axis=1)
        basis = np.column_stack([np.ones_like(s), s])
        w = itf.weights[pts]
        gram = basis.T @ (w[:, None] * basis)
        coeff = np.linalg.solve(gram, basis.T @ (w[:, None] * itf.displacement_hat[step, pts]))
        out.append((xy, basis @ coeff))
    return out


def plot_deformed(result: SolveResult, path: Path, step: int | None = None,
                  amplification: float | None = None) -> Path:
    """Deformed assembly (amplified) with the contact status, and the macro displacements of
    the interfaces (paper fig. 10b)."""
    plt = _pyplot()
    from matplotlib.collections import PolyCollection

    step = result.assembly.n_steps - 1 if step is None else step
    size = max(max(s.mesh.x1 for s in result.assembly.substructures)
               - min(s.mesh.x0 for s in result.assembly.substructures),
               max(s.mesh.y1 for s in result.assembly.substructures)
               - min(s.mesh.y0 for s in result.assembly.substructures))
    umax = max(float(np.abs(u[step]).max()) for u in result.displacements.values())
    amp = amplification or (0.08 * size / umax if umax > 0 else 1.0)
    fig, (ax, ax_macro) = plt.subplots(1, 2, figsize=(11, 6))
    for sub in result.assembly.substructures:
        mesh = sub.mesh
        xy = mesh.nodes + amp * result.displacements[sub.name][step]
        fraction = np.ones(mesh.n_cells) if sub.cut is None else sub.cut.material_fraction
        quads = xy[mesh.cells[fraction > 0.0]]
        if sub.cut is not None and sub.cut.cut.size:  # cut cells shaded by material fraction
            shade = [(0.3, 0.3, 0.3, 0.6 * f) for f in fraction[sub.cut.cut]]
            ax.add_collection(PolyCollection(xy[mesh.cells[sub.cut.cut]], facecolor=shade,
                                             edgecolor="none"))
        for axis in (ax, ax_macro):
            outline = np.concatenate([xy[mesh.side_nodes("bottom")], xy[mesh.side_nodes("right")],
                                      xy[mesh.side_nodes("top")][::-1],
                                      xy[mesh.side_nodes("left")][::-1]])
            axis.plot(outline[:, 0], outline[:, 1], color="k", lw=0.8)
        ax.add_collection(PolyCollection(quads, facecolor="none", edgecolor="0.8", lw=0.3))
    if result.interface is not None:
        itf = result.interface
        for status, index in status_indices(result, step).items():
            if not index.size:
                continue
            shown = itf.coords[index] + amp * itf.displacement_hat[step, index]
            ax.scatter(shown[:, 0], shown[:, 1], s=12, color=STATUS_COLOURS[status], label=status,
                       zorder=3)
        for xy, macro in _macro_part(result, step):
            shown = xy + amp * macro
            ax_macro.plot(shown[:, 0], shown[:, 1], color="tab:orange", lw=2.0)
    ax.set_title(f"{result.assembly.name}: deformed (×{amp:.3g}), step {step + 1}, contact status")
    ax_macro.set_title("macro displacements of the interfaces (orange)")
    for axis in (ax, ax_macro):
        axis.set_aspect("equal")
        axis.set_xlabel("x")
        axis.set_ylabel("y")
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def driving_factor(result: SolveResult) -> str | None:
    """The load factor that varies last in the history (B1: the lateral push P2)."""
    best, best_step = None, -1
    for name, values in result.assembly.history.factors.items():
        changes = np.flatnonzero(np.diff(values) != 0)
        if changes.size and changes[-1] > best_step:
            best, best_step = name, int(changes[-1])
    return best


def plot_histories(results: dict[str, SolveResult], path: Path,
                   factor: str | None = None) -> Path | None:
    """Each quantity of interest given per step, against the driving load factor (fig. 11);
    one curve per result (e.g. LATIN and reference)."""
    first = next(iter(results.values()))
    names = [n for n, v in first.qoi.items() if isinstance(v, list)]
    if not names:
        return None
    plt = _pyplot()
    factor = factor or driving_factor(first)
    x = (first.assembly.history.factors[factor] if factor
         else np.arange(1, first.assembly.n_steps + 1))
    units = {q.name: q.unit for q in first.assembly.qois}
    fig, axes = plt.subplots(1, len(names), figsize=(5 * len(names), 4), squeeze=False)
    for ax, name in zip(axes[0], names, strict=True):
        for legend, res in results.items():
            ax.plot(x, res.qoi[name], marker="o", ms=3, label=legend)
        ax.set_xlabel(f"load factor {factor} [–]" if factor else "load step")
        ax.set_ylabel(label(name, units.get(name, "")))
        ax.set_title(f"{first.assembly.name}: {name} over the load history", fontsize=10)
        ax.grid(True, alpha=0.3)
        ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
