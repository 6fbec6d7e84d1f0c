"""The linear stage (eq. [13]–[15]) on a torch device, for the cases of one or several
geometries at once (issue 19).

The operators are built with SciPy (``LatinOperators``, once per geometry) and moved to the
device once. The condensed operators C_Eᵀ of the substructures that every geometry shares
are stacked by size, (G, n, n), so that one batched product serves all the substructures of
a size; the macro problem acts on each substructure's own macro unknowns (its rows of
Π = Ẽᵀ M0, of Q = C k Ẽ and of Ẽ, stacked the same way, padded to the widest with a zero
column). A substructure whose operators differ between the geometries of a batch (the one
with the moving hole) keeps one block per geometry and is applied geometry by geometry to
that geometry's columns, as is L⁻¹.

Fields are flat per column (a case's step): ``(n_columns, 2 n_points)``; ``rows`` lists,
for each geometry present, the columns of its cases (a slice when they are contiguous).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from .operators import LatinOperators

Tensor = Any  # torch.Tensor (PyTorch is optional)
#: per geometry present in a batch: its index and the columns of its cases
Rows = list[tuple[int, Any]]


class DeviceOperators:
    """The linear stage of ``operators`` (one per geometry, sharing the interface
    discretisation: ``batching.same_interfaces``) on a torch device."""

    def __init__(self, operators: Sequence[LatinOperators], torch: Any, device: Any) -> None:
        self.torch = torch
        first = operators[0]

        def tensor(array: Any) -> Tensor:
            return torch.as_tensor(np.ascontiguousarray(array, dtype=np.float64),
                                   device=device)

        self.n_points = first.points.n_points
        self.k = tensor(first.search_direction)
        #: H − D on the device (``two_scale``; the same for every geometry of a batch)
        self.two_scale = (first.two_scale.on(torch, device) if first.two_scale is not None
                          else None)
        basis = first.macro_basis.tocsr() if first.macro_basis is not None else None
        self.n_macro = basis.shape[1] if basis is not None else 0
        n_subs = len(first.flat_ranges)
        varying = [len({ops.substructure_operators[s].key for ops in operators}) > 1
                   for s in range(n_subs)]
        sizes: dict[int, list[int]] = {}
        for s, (lo, hi) in enumerate(first.flat_ranges):
            if not varying[s]:
                sizes.setdefault(hi - lo, []).append(s)
        # shared substructures, by block size: flat indices (G, n), C_Eᵀ (G, n, n), and for
        # the macro problem each one's own macro unknowns (G, m), Q_Eᵀ, Ẽ_Eᵀ (G, m, n) and
        # M0 Ẽ_E (G, n, m)
        self.groups: list[dict[str, Tensor]] = []
        for n, members in sizes.items():
            blocks = [first.substructure_operators[s] for s in members]
            group = {"indices": torch.as_tensor(
                np.stack([np.arange(*first.flat_ranges[s]) for s in members]), device=device),
                "condensed_t": tensor(np.stack([b.condensed_transposed for b in blocks]))}
            if basis is not None:
                width = max(b.macro_columns.size for b in blocks)
                columns = np.full((len(members), width), self.n_macro, dtype=np.int64)
                response_t = np.zeros((len(members), width, n))
                basis_t = np.zeros((len(members), width, n))
                project = np.zeros((len(members), n, width))
                for i, (s, block) in enumerate(zip(members, blocks, strict=True)):
                    lo, hi = first.flat_ranges[s]
                    used = block.macro_columns.size
                    columns[i, :used] = block.macro_columns
                    response_t[i, :used] = block.macro_response.T
                    own = basis[lo:hi][:, block.macro_columns].toarray()
                    basis_t[i, :used] = own.T
                    project[i, :, :used] = first.m0[lo:hi, None] * own
                group.update(columns=torch.as_tensor(columns, device=device),
                             response_t=tensor(response_t), basis_t=tensor(basis_t),
                             project=tensor(project))
            self.groups.append(group)
        # substructures whose operators differ between the geometries: one block each
        self.varying: list[dict[str, Any]] = []
        for s in np.flatnonzero(varying).tolist():
            lo, hi = first.flat_ranges[s]
            blocks = [ops.substructure_operators[s] for ops in operators]
            entry: dict[str, Any] = {"range": slice(int(lo), int(hi)), "condensed_t": tensor(
                np.stack([b.condensed_transposed for b in blocks]))}
            if basis is not None:
                columns = blocks[0].macro_columns
                own = basis[lo:hi][:, columns].toarray()
                entry.update(columns=torch.as_tensor(columns, device=device),
                             response_t=tensor(np.stack([b.macro_response.T for b in blocks])),
                             basis_t=tensor(own.T), project=tensor(first.m0[lo:hi, None] * own))
            self.varying.append(entry)
        if basis is not None:
            self.homogenised_inverse = tensor(np.stack([ops.homogenised_inverse
                                                        for ops in operators]))

    def micro_stage(self, w_hat: Tensor, f_hat: Tensor, rows: Rows, body: Tensor | None = None
                    ) -> tuple[Tensor, Tensor]:
        """W = C (F̂ + H Ŵ) (+ ``body``, T S⁻¹ f per row: body forces), F = F̂ + H (Ŵ − W)
        (eq. [13]) on fields (n, n_points, 2)."""
        torch = self.torch
        shape = w_hat.shape
        rhs = (f_hat + self.apply_direction(w_hat)).reshape(shape[0], -1)
        flat = torch.empty_like(rhs)
        for group in self.groups:
            indices = group["indices"]
            # (G, columns, n) @ (G, n, n): one batched product per block size
            part = torch.matmul(rhs[:, indices].transpose(0, 1), group["condensed_t"])
            flat[:, indices] = part.transpose(0, 1)
        for entry in self.varying:
            own = entry["range"]
            for g, columns in rows:
                flat[columns, own] = rhs[columns, own] @ entry["condensed_t"][g]
        displacement = flat.reshape(shape) if body is None else flat.reshape(shape) + body
        return displacement, f_hat + self.apply_direction(w_hat - displacement)

    def apply_direction(self, field: Tensor) -> Tensor:
        """H x: k x, plus the two-scale part where there is one; fields (n, n_points, 2)."""
        out = self.k * field
        if self.two_scale is not None:
            self.two_scale.add_correction(out.reshape(field.shape[0], -1),
                                          field.reshape(field.shape[0], -1))
        return out

    def macro_correction(self, displacement: Tensor, force: Tensor, data: Tensor, rows: Rows
                         ) -> tuple[Tensor, Tensor]:
        """W̃ᴹ = L⁻¹ (F_dᴹ − Π F), W += Q W̃ᴹ, F += k (Ẽ W̃ᴹ − Q W̃ᴹ) (eq. [14]–[15])."""
        torch = self.torch
        shape = displacement.shape
        n_columns = shape[0]
        flat_force = force.reshape(n_columns, -1)
        residual = torch.zeros((n_columns, self.n_macro + 1), dtype=force.dtype,
                               device=force.device)
        residual[:, :self.n_macro] = data
        for group in self.groups:  # − Π F, substructure by substructure
            part = torch.matmul(flat_force[:, group["indices"]].transpose(0, 1),
                                group["project"])
            residual.index_add_(1, group["columns"].reshape(-1),
                                part.transpose(0, 1).reshape(n_columns, -1), alpha=-1.0)
        for entry in self.varying:
            residual.index_add_(1, entry["columns"], flat_force[:, entry["range"]]
                                @ entry["project"], alpha=-1.0)
        macro = torch.zeros_like(residual)
        for g, columns in rows:
            macro[columns, :self.n_macro] = (residual[columns, :self.n_macro]
                                             @ self.homogenised_inverse[g])
        correction = torch.empty_like(flat_force)
        extension = torch.empty_like(flat_force)
        for group in self.groups:  # Q_E W̃ᴹ and Ẽ_E W̃ᴹ on E's own macro unknowns
            indices = group["indices"]
            own = macro[:, group["columns"]].transpose(0, 1)  # (G, columns, m)
            correction[:, indices] = torch.matmul(own, group["response_t"]).transpose(0, 1)
            extension[:, indices] = torch.matmul(own, group["basis_t"]).transpose(0, 1)
        for entry in self.varying:
            own_range, own = entry["range"], macro[:, entry["columns"]]
            extension[:, own_range] = own @ entry["basis_t"]
            for g, columns in rows:
                correction[columns, own_range] = own[columns] @ entry["response_t"][g]
        correction_field = correction.reshape(shape)
        return (displacement + correction_field,
                force + self.apply_direction(extension.reshape(shape) - correction_field))
