"""A moved hole's condensed operator as a low-rank update of the uncut substructure's
(issue 16: B3's position studies spend a third of their clock on new operators): measured
outside the library, not adopted (docs/performance.md, session 46).

    python benchmarks/hole_update.py            # the update against today's build
    python benchmarks/hole_update.py --overlap  # builds in a thread beside iterations

The holed substructure's S = K + Tᵀ M0 H T differs from the uncut one's, S₀, on the
unknowns R of the cut and void cells only (void unknowns are pinned): S = S₀ + P_R A P_Rᵀ.
Woodbury then gives C = T S⁻¹ Tᵀ M0 = C₀ − (T X) (I + A X_R)⁻¹ A (T X)ᵀ M0 with X = S₀⁻¹ P_R,
from S₀'s factorisation made once. Prints the update's and today's times per position
(median), the rank |R| and the update's largest error against today's C (relative), with
the positions whose I + A X_R is worse conditioned than 1e6. ``--overlap``: the next
positions' operators built in a second thread while the main one iterates, against the
two one after the other (the GIL decides how much they overlap).
"""

from __future__ import annotations

import argparse
import threading
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import multilatin as ml
from multilatin.fem.elasticity import assemble_cells, element_dofs, stiffness_matrix
from multilatin.fem.xfem import _cell_stiffness, inactive_dofs
from multilatin.latin import LatinOptions, solve_latin
from multilatin.latin.condensation import condense
from multilatin.latin.operators import LatinOperators
from multilatin.study.plan import _operators


def low_rank() -> None:
    model = ml.load_model("b3")
    first = model.assemble({"xc": 25, "yc": 75, "rc": 3})
    ops = LatinOperators(first, LatinOptions())
    s = next(i for i, sub in enumerate(first.substructures) if sub.hole is not None)
    sub, pts = first.substructures[s], ops.points
    lo, hi = 2 * pts.offsets[s], 2 * pts.offsets[s + 1]
    trace, m0 = pts.traces[s], ops.m0[lo:hi]
    k = ops.search_direction.reshape(-1)[lo:hi]
    coupling = ops.two_scale.block(lo, hi) if ops.two_scale is not None else None
    m0_h = sp.diags(m0 * k) + (sp.csr_matrix(coupling) if coupling is not None else 0)
    term = sp.csr_matrix(trace.T @ m0_h @ trace)
    mesh, hooke, thickness = sub.mesh, sub.material.hooke, sub.material.thickness
    cells = _cell_stiffness(mesh, hooke, thickness)
    uncut = (assemble_cells(cells, mesh.cells, mesh.n_nodes) + term).tocsc()
    n = uncut.shape[0]
    started = time.perf_counter()
    factor = spla.splu(uncut)
    _, condensed_uncut, _ = condense(uncut, trace, m0, pattern=sub.stiffness_pattern())
    print(f"holed substructure: {n} unknowns, {trace.shape[0]} interface values; the uncut "
          f"one's factorisation and C₀ once: {1e3 * (time.perf_counter() - started):.1f} ms")
    errors, ranks, direct, update, poor = [], [], [], [], []
    for xc in np.linspace(22.0, 28.0, 7):
        for yc in np.linspace(72.0, 78.0, 4):
            for rc in (1.0, 3.0, 4.5):
                holed = model.assemble({"xc": xc, "yc": yc, "rc": rc}).substructures[s]
                started = time.perf_counter()
                _, condensed, _ = condense((holed.stiffness() + term).tocsc(), trace, m0,
                                           pattern=holed.stiffness_pattern())
                direct.append(time.perf_counter() - started)
                started = time.perf_counter()
                cut = holed.cut
                assert cut is not None
                changed = np.concatenate([cut.cut, cut.void])
                delta = -assemble_cells(cells[changed], mesh.cells[changed], mesh.n_nodes)
                if cut.cut.size:
                    delta = delta + stiffness_matrix(mesh.nodes, mesh.cells[cut.cut], hooke,
                                                     thickness, cut.cut_quadrature)
                pin = np.zeros(n)
                pin[inactive_dofs(cut)] = 1.0
                delta = (delta + sp.diags(pin)).tocsr()
                rows = np.unique(element_dofs(mesh.cells[changed]).ravel())
                block = delta[rows][:, rows].toarray()
                units = np.zeros((n, rows.size))
                units[rows, np.arange(rows.size)] = 1.0
                response = factor.solve(units)  # X = S₀⁻¹ P_R
                small = np.eye(rows.size) + block @ response[rows]
                on_trace = trace @ response
                updated = condensed_uncut - on_trace @ np.linalg.solve(small, block) @ (
                    on_trace.T * m0[None, :])
                update.append(time.perf_counter() - started)
                ranks.append(rows.size)
                errors.append(float(np.abs(updated - condensed).max()
                                    / np.abs(condensed).max()))
                if np.linalg.cond(small) > 1e6:
                    poor.append((xc, yc, rc, errors[-1]))
    print(f"{len(errors)} positions (xc 22–28, yc 72–78, rc 1, 3, 4.5): today's build "
          f"{1e3 * np.median(direct):.1f} ms, the update {1e3 * np.median(update):.1f} ms "
          f"(medians); rank |R| {min(ranks)}–{max(ranks)} of {n}; the update's error "
          f"{min(errors):.1e}–{max(errors):.1e}")
    print(f"{len(poor)} positions with cond(I + A X_R) > 1e6; the worst error among them "
          f"{max(e for *_, e in poor):.1e}" if poor else "none worse conditioned than 1e6")


def overlap() -> None:
    model, options = ml.load_model("b3"), LatinOptions(max_iter=60, tol=1e-30)
    first = model.assemble({"xc": 25, "yc": 75, "rc": 3})
    operators = _operators(first, options)[0]
    solve_latin(first, options, operators=operators, check=False)
    positions = [(x + 0.25, y) for x in (23, 24, 26, 27) for y in (73, 74, 76, 77)]

    def builds() -> None:
        for x, y in positions:
            _operators(model.assemble({"xc": x, "yc": y, "rc": 3}), options)

    def iterations() -> None:
        for _ in range(3):
            solve_latin(first, options, operators=operators, check=False)

    for _ in range(2):
        started = time.perf_counter()
        builds()
        middle = time.perf_counter()
        iterations()
        done = time.perf_counter()
        thread = threading.Thread(target=builds)
        thread.start()
        iterations()
        thread.join()
        print(f"{len(positions)} builds {middle - started:.3f} s + 180 iterations "
              f"{done - middle:.3f} s one after the other; in two threads "
              f"{time.perf_counter() - done:.3f} s")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--overlap", action="store_true")
    if parser.parse_args().overlap:
        overlap()
    else:
        low_rank()
