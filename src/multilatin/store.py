"""A study's results on disk, written as they come, so that a study survives a crash.

The folder holds:

``study.json``
    what the study is (model, grid, solver options, chains): a study started again with the
    same command in the same folder resumes; a different study there is refused.
``cases.jsonl``
    one line per finished case, appended and flushed as soon as the case ends: the durable
    record. A line cut short by a crash is ignored.
``chains/<mode>-<chain>.npz``
    each multiresolution chain's warm-start state after its latest case (written before the
    case's line, atomically, with that case's record inside: a resumed chain starts from
    exactly where the interrupted one stood, and a case whose line was lost is recovered).
``study.nc``
    the xarray Dataset (one dimension per grid parameter, plus ``mode`` and ``step``),
    rebuilt from the records every few seconds and at the end (netCDF, atomically replaced).
"""

from __future__ import annotations

import json
import logging
import os
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from .errors import ModelError
from .parameters import Grid
from .study import ChainState

log = logging.getLogger(__name__)

Key = tuple[str, int]  # (mode, case number)


class StudyStore:
    """The results folder of one study (see the module's docstring)."""

    def __init__(self, folder: str | Path, identity: dict[str, Any],
                 write_interval: float = 2.0) -> None:
        self.folder = Path(folder)
        self.identity = identity
        self.write_interval = write_interval
        self._write_cost = 0.0  # seconds the latest dataset write took
        self.folder.mkdir(parents=True, exist_ok=True)
        (self.folder / "chains").mkdir(exist_ok=True)
        meta = self.folder / "study.json"
        if meta.exists():
            existing = json.loads(meta.read_text(encoding="utf-8"))
            if existing.get("identity") != identity:
                differing = sorted(k for k in set(identity) | set(existing.get("identity", {}))
                                   if identity.get(k) != existing.get("identity", {}).get(k))
                raise ModelError(
                    f"--out {self.folder}: the folder holds a different study (differs in "
                    f"{', '.join(differing)}); use another folder or the same arguments")
        else:
            _write_atomic(meta, json.dumps({"identity": identity}, indent=1))
        self.records: dict[Key, dict[str, Any]] = {}
        self._journal_path = self.folder / "cases.jsonl"
        self._read_journal()
        self._journal = self._journal_path.open("a", encoding="utf-8")
        self._recover_from_chain_states()
        self._last_write = 0.0

    # reading -----------------------------------------------------------------
    def _read_journal(self) -> None:
        if not self._journal_path.exists():
            return
        text = self._journal_path.read_text(encoding="utf-8")
        complete = text if text.endswith("\n") else text[: text.rfind("\n") + 1]
        if complete != text:
            log.warning("%s: ignoring a line cut short by an interruption", self._journal_path)
            _write_atomic(self._journal_path, complete)
        for line in complete.splitlines():
            if line.strip():
                record = json.loads(line)
                self.records[(record["mode"], record["number"])] = record

    def _recover_from_chain_states(self) -> None:
        for path in sorted((self.folder / "chains").glob("*.npz")):
            with np.load(path) as data:
                record = json.loads(str(data["record"]))
            if (record["mode"], record["number"]) not in self.records:
                log.warning("recovering case %d of %s from its chain state", record["number"],
                            path.name)
                self._append(record)

    def finished(self, mode: str, number: int) -> bool:
        return (mode, number) in self.records

    def chain_state(self, mode: str, chain: int) -> ChainState | None:
        path = self.folder / "chains" / f"{mode}-{chain}.npz"
        if not path.exists():
            return None
        with np.load(path) as data:
            return ChainState.from_arrays({k: data[k] for k in data.files if k != "record"})

    # writing -----------------------------------------------------------------
    def add(self, record: dict[str, Any], state: ChainState | None) -> None:
        """Keep a finished case: its chain state first, then its line in the journal."""
        if state is not None:
            path = self.folder / "chains" / f"{record['mode']}-{record['chain']}.npz"
            tmp = path.with_name(path.stem + ".tmp.npz")
            arrays: dict[str, Any] = {"record": np.array(json.dumps(record)),
                                      **state.to_arrays()}
            np.savez(tmp, **arrays)
            os.replace(tmp, path)
        self._append(record)

    def _append(self, record: dict[str, Any]) -> None:
        self._journal.write(json.dumps(record) + "\n")
        self._journal.flush()
        self.records[(record["mode"], record["number"])] = record

    def maybe_write_dataset(self, grid: Grid, attrs: dict[str, Any]) -> None:
        """Rewrite study.nc when ``write_interval`` has passed, and at least ten times as
        long as the latest write took: on a study of thousands of cases the rewrite stays a
        small share of the client's time (the journal has every finished case anyway)."""
        interval = max(self.write_interval, 10.0 * self._write_cost)
        if time.monotonic() - self._last_write >= interval:
            self.write_dataset(grid, attrs)

    def write_dataset(self, grid: Grid, attrs: dict[str, Any]) -> xr.Dataset:
        start = time.monotonic()
        dataset = to_dataset(grid, self.records.values(), attrs)
        tmp = self.folder / "study.tmp.nc"
        dataset.to_netcdf(tmp, engine="scipy")
        os.replace(tmp, self.folder / "study.nc")
        self._last_write = time.monotonic()
        self._write_cost = self._last_write - start
        return dataset

    def close(self) -> None:
        self._journal.close()


def to_dataset(grid: Grid, records: Iterable[dict[str, Any]], attrs: dict[str, Any]
               ) -> xr.Dataset:
    """The labelled results: dimensions ``mode``, one per grid parameter, and ``step`` for
    quantities of interest given per load step. Cases not computed are NaN (``finished``
    says which were)."""
    records = list(records)
    modes = [m for m in ("multiresolution", "cold") if any(r["mode"] == m for r in records)]
    names = list(grid)
    shape = (len(modes), *grid.shape)
    dims = ("mode", *names)
    scalars = {name: np.full(shape, np.nan) for name in
               ("iterations", "indicator", "wall_s", "setup_s")}
    finished = np.zeros(shape, dtype=bool)
    converged = np.zeros(shape, dtype=bool)
    texts = {name: np.full(shape, "", dtype=object) for name in ("log", "start")}
    qoi_values: dict[str, np.ndarray] = {}
    for record in records:
        at = (modes.index(record["mode"]), *record["index"])
        for name in scalars:
            scalars[name][at] = record[name]
        finished[at] = True
        converged[at] = record["converged"]
        for name in texts:
            texts[name][at] = record[name]
        for name, value in record["qoi"].items():
            value = np.asarray(value, dtype=float)
            if name not in qoi_values:
                qoi_values[name] = np.full(shape + value.shape, np.nan)
            qoi_values[name][at] = value
    variables: dict[str, Any] = {name: (dims, values) for name, values in scalars.items()}
    variables["finished"] = (dims, finished)
    variables["converged"] = (dims, converged)
    variables.update({name: (dims, values) for name, values in texts.items()})
    for name, values in qoi_values.items():
        variables[name] = ((*dims, "step") if values.ndim > len(dims) else dims, values)
    coords: dict[str, Any] = {"mode": modes, **{name: list(grid[name]) for name in names}}
    step_counts = [values.shape[-1] for values in qoi_values.values() if values.ndim > len(dims)]
    if step_counts:
        coords["step"] = np.arange(1, max(step_counts) + 1)
    dataset = xr.Dataset(variables, coords=coords, attrs=_netcdf_attrs(attrs))
    dataset["wall_s"].attrs["units"] = "s"
    dataset["setup_s"].attrs["units"] = "s"
    dataset["iterations"].attrs["long_name"] = "LATIN iterations to the tolerance"
    return dataset


def _netcdf_attrs(attrs: dict[str, Any]) -> dict[str, Any]:
    """netCDF attributes are numbers or strings: anything else goes as JSON."""
    out: dict[str, Any] = {}
    for key, value in attrs.items():
        if isinstance(value, (int, float, str)) and not isinstance(value, bool):
            out[key] = value
        else:
            out[key] = json.dumps(value)
    return out


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)


def load_study(folder: str | Path) -> xr.Dataset:
    """The Dataset of a study folder (``study.nc``)."""
    path = Path(folder) / "study.nc"
    if not path.exists():
        raise ModelError(f"{folder}: no study.nc (not a study folder, or nothing finished yet)")
    return xr.load_dataset(path, engine="scipy")
