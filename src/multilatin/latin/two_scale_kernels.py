"""The two-scale search direction's point-wise products, for ``kernels`` to compile with
Numba (plain Python here; compiled, the same formulas): ``project_columns`` (Eᵀ M0 x along
contiguous steps), ``coupling_shift`` (G x), ``correction_row`` and
``two_scale_correction`` (out += (H − D) x = E G Eᵀ M0 x, ``two_scale.TwoScaleDirection``),
``direction_update`` (out = base + H (a − b), the linear stage's forces). ``kernels._compile``
puts the compiled helpers in this module's namespace before it compiles their callers."""

from __future__ import annotations

import numpy as np

from ..fem.elasticity import FloatArray, IntArray

__all__ = ["correction_row", "coupling_shift", "direction_update", "project_columns",
           "two_scale_correction"]


def project_columns(rows: FloatArray, support: IntArray, slot: IntArray, starts: IntArray,
                     values: FloatArray, columns: FloatArray, sums: FloatArray,
                     out: FloatArray) -> None:  # pragma: no cover - compiled
    """out[t, j] += Σ values[e] rows[t, flat[e]] over function j's entries e (in order), the
    rows' support gathered first into compact columns (work arrays ``columns`` (n_support,
    T), ``sums`` (r, T)): the steps then run along contiguous memory."""
    n_steps = rows.shape[0]
    for u in range(support.size):
        for t in range(n_steps):
            columns[u, t] = rows[t, support[u]]
    for j in range(starts.size - 1):
        for t in range(n_steps):
            sums[j, t] = out[t, j]
        for e in range(starts[j], starts[j + 1]):
            u, value = slot[e], values[e]
            for t in range(n_steps):
                sums[j, t] += value * columns[u, t]
        for t in range(n_steps):
            out[t, j] = sums[j, t]


def coupling_shift(projected: FloatArray, coupling_starts: IntArray,
                    coupling_columns: IntArray, coupling_values: FloatArray,
                    shift: FloatArray) -> None:  # pragma: no cover - compiled
    """shift = G projected over G's nonzeros row by row (G is block diagonal)."""
    shift[:] = 0.0
    for i in range(coupling_starts.size - 1):
        for e in range(coupling_starts[i], coupling_starts[i + 1]):
            shift[coupling_columns[e]] += projected[i] * coupling_values[e]


def correction_row(out: FloatArray, field: FloatArray, starts: IntArray, flat: IntArray,
                    basis: FloatArray, weighted: FloatArray, coupling_starts: IntArray,
                    coupling_columns: IntArray, coupling_values: FloatArray,
                    projected: FloatArray, shift: FloatArray
                    ) -> None:  # pragma: no cover - compiled
    """out += (H − D) x = E G Eᵀ M0 x for one row x = ``field`` (2P,), function after
    function; ``projected`` and ``shift`` are (r,) work arrays."""
    for j in range(starts.size - 1):  # Eᵀ M0 x
        total = 0.0
        for e in range(starts[j], starts[j + 1]):
            total += weighted[e] * field[flat[e]]
        projected[j] = total
    coupling_shift(projected, coupling_starts, coupling_columns, coupling_values, shift)
    for j in range(starts.size - 1):  # += E G (Eᵀ M0 x)
        for e in range(starts[j], starts[j + 1]):
            out[flat[e]] += basis[e] * shift[j]


def two_scale_correction(out: FloatArray, field: FloatArray, starts: IntArray,
                          flat: IntArray, basis: FloatArray, weighted: FloatArray,
                          coupling_starts: IntArray, coupling_columns: IntArray,
                          coupling_values: FloatArray) -> None:  # pragma: no cover - compiled
    r = coupling_starts.size - 1
    projected, shift = np.empty(r), np.empty(r)
    for t in range(field.shape[0]):
        correction_row(out[t], field[t], starts, flat, basis, weighted, coupling_starts,
                        coupling_columns, coupling_values, projected, shift)


def direction_update(out: FloatArray, base: FloatArray, a: FloatArray, b: FloatArray,
                      use_base: bool, use_b: bool, k: FloatArray, starts: IntArray,
                      flat: IntArray, basis: FloatArray, weighted: FloatArray,
                      coupling_starts: IntArray, coupling_columns: IntArray,
                      coupling_values: FloatArray) -> None:  # pragma: no cover - compiled
    """Rows (n, 2P): out = base + (k d + (H − D) d), d = a − b, with the operations and
    their order of NumPy's k x then ``two_scale_correction`` (``use_b`` False: d = a;
    ``use_base`` False: out = H d). ``out`` may be ``base``. Row by row, so that the
    fields are read once."""
    r = coupling_starts.size - 1
    n = a.shape[1]
    projected, shift = np.empty(r), np.empty(r)
    difference, row = np.empty(n), np.empty(n)
    for t in range(a.shape[0]):
        if use_b:
            for i in range(n):
                difference[i] = a[t, i] - b[t, i]
        else:
            difference[:] = a[t]
        for i in range(n):
            row[i] = k[i] * difference[i]
        correction_row(row, difference, starts, flat, basis, weighted, coupling_starts,
                        coupling_columns, coupling_values, projected, shift)
        if use_base:
            for i in range(n):
                out[t, i] = base[t, i] + row[i]
        else:
            out[t] = row
