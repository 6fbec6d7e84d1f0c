"""spinning_fit — a hub shrink-fitted into a rim, spun up: the fit's pressure falls as ω²
(each ring carries the body force ρ ω² r and the rim's bore grows more than the hub's rim)
until the fit opens at ω_s; a study over ω against the closed form (Lamé's shrink fit plus
two free spinning annuli, plane stress).

Run: ``python examples/spinning_fit.py --out results/gallery/spinning-fit`` (needs gmsh,
``pip install 'multilatin[reference]'``, for the two meshes)
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

import multilatin as ml

MODEL = Path(__file__).with_name("spinning_fit.toml")
HUB, SEAT, OUTER = 5.0, 10.0, 20.0  # mm: the hub's bore, the fit's radius, the rim's outside
YOUNG, NU, RHO = 210_000.0, 0.3, 7.85e-9  # MPa, 1, t/mm³ (spinning_fit.toml)


def free_spin_u(r: float, inner: float, outer: float, omega: float) -> float:
    """Radial displacement at r of an annulus inner ≤ r ≤ outer spinning free at ω (plane
    stress): u = r (σ_θ − ν σ_r) / E."""
    c = (3.0 + NU) / 8.0 * RHO * omega**2
    sigma_r = c * (inner**2 + outer**2 - inner**2 * outer**2 / r**2 - r**2)
    sigma_t = c * (inner**2 + outer**2 + inner**2 * outer**2 / r**2
                   - (1.0 + 3.0 * NU) / (3.0 + NU) * r**2)
    return r * (sigma_t - NU * sigma_r) / YOUNG


def fit_pressure(omega: float, delta: float) -> float:
    """The fit's pressure: the interference δ less what the spin opens, over the two rings'
    compliance under a pressure at the fit (Lamé: b / E × ((c² + b²) / (c² − b²) + (b² + a²)
    / (b² − a²)); ν cancels between two rings of one material); zero once open."""
    opened = free_spin_u(SEAT, SEAT, OUTER, omega) - free_spin_u(SEAT, HUB, SEAT, omega)
    compliance = SEAT / YOUNG * ((OUTER**2 + SEAT**2) / (OUTER**2 - SEAT**2)
                                 + (SEAT**2 + HUB**2) / (SEAT**2 - HUB**2))
    return max(0.0, (delta - opened) / compliance)


def separation_speed(delta: float) -> float:
    """ω_s, where the spin opens the whole interference (the opening grows as ω²)."""
    opened_at_one = free_spin_u(SEAT, SEAT, OUTER, 1.0) - free_spin_u(SEAT, HUB, SEAT, 1.0)
    return math.sqrt(delta / opened_at_one)


def ring_mesh(path: Path, inner: float, outer: float, size: float,
              names: tuple[str | None, str | None]) -> Path:
    """The quarter ring inner ≤ r ≤ outer, x, y ≥ 0, in triangles of at most ``size``,
    written by gmsh to ``path``; its arcs are the physical groups ``names`` (inner arc,
    outer arc; None: none), the ring the group ``ring``."""
    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Verbosity", 0)
        occ = gmsh.model.occ
        disc = occ.addDisk(0.0, 0.0, 0.0, outer, outer)
        occ.cut([(2, disc)], [(2, occ.addDisk(0.0, 0.0, 0.0, inner, inner))])
        occ.intersect([(2, disc)], [(2, occ.addRectangle(0.0, 0.0, 0.0, outer, outer))])
        occ.synchronize()
        for _, tag in gmsh.model.getEntities(1):
            x0, y0, _, x1, y1, _ = gmsh.model.getBoundingBox(1, tag)
            if x1 - x0 > 1e-6 and y1 - y0 > 1e-6:  # an arc
                name = names[0] if max(x1, y1) < 0.5 * (inner + outer) else names[1]
                if name is not None:
                    gmsh.model.addPhysicalGroup(1, [tag], name=name)
        gmsh.model.addPhysicalGroup(2, [tag for _, tag in gmsh.model.getEntities(2)],
                                    name="ring")
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.option.setNumber("Mesh.Algorithm", 6)
        gmsh.model.mesh.generate(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    return path


def load(folder: Path, size: float = 1.0) -> ml.Model:
    """The model with its two meshes written into ``folder`` (the rim's cells 1.6 times the
    hub's)."""
    ring_mesh(folder / "hub.msh", HUB, SEAT, size, ("bore", "rim"))
    ring_mesh(folder / "rim.msh", SEAT, OUTER, 1.6 * size, ("seat", None))
    return ml.Model(ml.ModelSpec.from_string(MODEL.read_text(), name="spinning_fit",
                                             source=str(MODEL), folder=folder))


def run(out: Path | None = None, speeds: int = 11, size: float = 1.0,
        delta: float = 0.01) -> dict[str, Any]:
    """A study over ω from 0 to 1.25 ω_s (``speeds`` values) at interference ``delta``."""
    with tempfile.TemporaryDirectory() as meshes:
        model = load(Path(meshes), size)
        omega_s = separation_speed(delta)
        grid = ml.Grid({"omega": np.linspace(0.0, 1.25 * omega_s, speeds), "delta": [delta]})
        study = ml.run_study(model, grid, out=out, progress=False)
    pressure = study.dataset["p_fit"].sel(mode="multiresolution").squeeze()
    omegas = [float(w) for w in grid["omega"]]
    found = {"omega": omegas, "omega_s": omega_s, "p_fit": pressure.values.tolist(),
             "closed_form": [fit_pressure(w, delta) for w in omegas]}
    if out is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6, 4))
        rpm = 30.0 / math.pi
        fine = np.linspace(0.0, omegas[-1], 200)
        ax.plot(rpm * fine / 1e3, [fit_pressure(w, delta) for w in fine], "k--", lw=0.8,
                label="closed form (Lamé + spinning annuli)")
        ax.plot(rpm * np.array(omegas) / 1e3, found["p_fit"], "o", label="LATIN study")
        ax.axvline(rpm * omega_s / 1e3, color="0.6", lw=0.8)
        ax.set(xlabel="spin speed [1000 rpm]", ylabel="mean fit pressure p_fit [MPa]",
               title=f"spinning fit, δ = {1e3 * delta:g} µm: the fit opens at "
                     f"{rpm * omega_s:,.0f} rpm")
        ax.legend()
        fig.savefig(out / "spinning_fit.png", dpi=100, bbox_inches="tight")
        plt.close(fig)
    return found


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None)
    result = run(parser.parse_args().out)
    print(f"the fit opens at ω_s = {result['omega_s']:.0f} rad/s")
    for omega, value, exact in zip(result["omega"], result["p_fit"], result["closed_form"],
                                   strict=True):
        print(f"ω = {omega:7.0f} rad/s: p_fit = {value:8.3f} MPa (closed form {exact:8.3f})")
