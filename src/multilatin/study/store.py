"""A study's results on disk, written as they come, so that a study survives any crash.

The folder holds:

``study.json``
    what the study is (model, grid in the order given, solver options, chains): a study
    started again with the same command in the same folder resumes; a different study there
    is refused.
``cases.jsonl``
    one line per finished case: the durable record (the journal is the truth). A batch's
    lines are appended in one write and flushed to disk.
``chains/<mode>-<chain>.npz``
    each multiresolution chain's warm-start state after its latest batch, with that batch's
    records inside. It is written (atomically) *before* the batch's journal lines: a crash
    between the two loses nothing, the records are recovered from the state on resume, and
    a resumed chain starts from exactly where the interrupted one stood.
``study.nc``
    the xarray Dataset (one dimension per grid parameter, plus ``mode`` and ``step``),
    rebuilt from the records every few seconds and at the end (atomically replaced).
``.lock``
    held (``flock``) by the process running the study, with its PID: a second study in the
    same folder is refused. The kernel releases it when the process ends, however it ends.

Whatever a crash leaves behind is repaired on the next start and said (``StudyStore.repairs``,
logged as warnings): temporary files are removed, a journal line cut short or damaged is
dropped (its case is computed again), a damaged chain state is dropped (its chain's next
case starts cold), a damaged ``study.json`` is rewritten when every journal record fits
the study being started, refused otherwise.
"""

from __future__ import annotations

import io
import json
import logging
import os
import signal
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from ..errors import ModelError
from ..io.files import ensure_writable_folder
from ..io.modelfile.checks import CASE_FLAGS, CASE_NUMBERS, CASE_TEXTS
from ..parameters import Grid
from .chain_state import ChainState

log = logging.getLogger(__name__)

Key = tuple[str, int]  # (mode, case number)
#: temporary files of the store's writes (``_write_atomic``; ``study.tmp.nc`` and
#: ``chains/*.tmp.npz`` of earlier versions) and of the writability probe
LEFTOVERS = ("study.nc.tmp", "study.json.tmp", "cases.jsonl.tmp", "study.tmp.nc", ".write-probe")
RecordCheck = Callable[[dict[str, Any]], bool]

#: testing hook (``tests/test_store_faults.py``): the process kills itself with SIGKILL at
#: the N-th write point of the store (before, inside and after every file write), after
#: appending the point's label to the file named by ``FAULT_LOG_ENVIRONMENT`` when set
FAULT_ENVIRONMENT = "_MULTILATIN_KILL_AT_WRITE_POINT"
FAULT_LOG_ENVIRONMENT = "_MULTILATIN_KILL_LOG"
_write_points = 0


def _fault_point(label: str) -> None:
    global _write_points
    target = os.environ.get(FAULT_ENVIRONMENT)
    if not target:
        return
    _write_points += 1
    if _write_points == int(target):
        log_path = os.environ.get(FAULT_LOG_ENVIRONMENT)
        if log_path:
            with open(log_path, "a", encoding="utf-8") as handle:
                handle.write(label + "\n")
        os.kill(os.getpid(), signal.SIGKILL)


class StudyStore:
    """The results folder of one study (see the module's docstring).

    record_fits: tells whether a journal record belongs to the study being started (used
        to adopt a folder whose ``study.json`` was damaged).
    """

    def __init__(self, folder: str | Path, identity: dict[str, Any],
                 write_interval: float = 2.0, record_fits: RecordCheck | None = None) -> None:
        self.folder = Path(folder)
        self.identity = identity
        self.write_interval = write_interval
        self.repairs: list[str] = []
        self._write_cost = 0.0  # seconds the latest dataset write took
        self._last_write = 0.0
        ensure_writable_folder(self.folder)
        self._lock = _FolderLock(self.folder)
        try:
            (self.folder / "chains").mkdir(exist_ok=True)
            self._remove_leftovers()
            self.records: dict[Key, dict[str, Any]] = {}
            self._journal_path = self.folder / "cases.jsonl"
            self._read_journal()
            self._check_identity(record_fits)
            self._journal = self._journal_path.open("a", encoding="utf-8")
            self._recover_from_chain_states()
        except BaseException:
            self._lock.release()
            raise

    # reading -----------------------------------------------------------------
    def _repaired(self, message: str) -> None:
        log.warning("%s: %s", self.folder, message)
        self.repairs.append(message)

    def _remove_leftovers(self) -> None:
        """Remove the temporary files of writes cut short — the store's own names only
        (files of the user's in the folder are left alone)."""
        own = [self.folder / name for name in LEFTOVERS]
        chains = self.folder / "chains"
        own += [*chains.glob("*.npz.tmp"), *chains.glob("*.tmp.npz")]
        for path in own:
            if path.is_file():
                path.unlink()
                self._repaired(f"removed {path.relative_to(self.folder)} (a write cut short)")

    def _check_identity(self, record_fits: RecordCheck | None) -> None:
        meta = self.folder / "study.json"
        if not meta.exists():
            if self.records and not _all_fit(self.records.values(), record_fits):
                raise ModelError(f"--out {self.folder}: the folder holds the journal of "
                                 "another study (and no study.json); use another folder")
            _write_atomic(meta, json.dumps({"identity": self.identity}, indent=1).encode())
            return
        try:
            existing = json.loads(meta.read_text(encoding="utf-8"))["identity"]
            if not isinstance(existing, dict):
                raise TypeError("identity is not a table")
        except (ValueError, KeyError, TypeError) as exc:
            if not _all_fit(self.records.values(), record_fits):
                raise ModelError(
                    f"--out {self.folder}: study.json is damaged ({exc}) and the journal's "
                    "records do not fit this study; use another folder") from None
            self._repaired(f"study.json was damaged ({exc}); rewritten for this study, whose "
                           f"grid every one of the {len(self.records)} journal records fits")
            _write_atomic(meta, json.dumps({"identity": self.identity}, indent=1).encode())
            return
        if existing != self.identity:
            raise ModelError(_difference_message(self.folder, existing, self.identity))

    def _read_journal(self) -> None:
        if not self._journal_path.exists():
            return
        raw = self._journal_path.read_bytes()
        complete = raw[: raw.rfind(b"\n") + 1]
        damaged = complete != raw
        if damaged:
            self._repaired("dropped the journal's last line, cut short by an interruption")
        kept: list[str] = []
        for number, line in enumerate(complete.split(b"\n"), start=1):
            if not line.strip():
                continue
            try:
                record = json.loads(line.decode("utf-8"))
                key = (str(record["mode"]), int(record["number"]))
            except (ValueError, KeyError, TypeError):
                damaged = True
                self._repaired(f"dropped damaged line {number} of cases.jsonl (its case is "
                               "computed again)")
                continue
            self.records[key] = record
            kept.append(json.dumps(record))
        if damaged:
            _write_atomic(self._journal_path, "".join(line + "\n" for line in kept).encode())

    def _recover_from_chain_states(self) -> None:
        for path in sorted((self.folder / "chains").glob("*.npz")):
            try:
                with np.load(path) as data:
                    records = json.loads(str(data["records"]))
                    ChainState.from_arrays({k: data[k] for k in data.files if k != "records"})
            except Exception as exc:  # noqa: BLE001 - any damage: the journal is the truth
                path.unlink(missing_ok=True)
                self._repaired(f"dropped damaged chain state {path.name} ({type(exc).__name__}:"
                               f" {exc}); that chain's next case starts cold")
                continue
            missing = [r for r in records if (r["mode"], r["number"]) not in self.records]
            if missing:
                self._repaired(f"recovered {len(missing)} case(s) from {path.name} whose "
                               "journal lines were lost")
                self._append(missing)

    def finished(self, mode: str, number: int) -> bool:
        return (mode, number) in self.records

    def chain_state(self, mode: str, chain: int) -> ChainState | None:
        path = self.folder / "chains" / f"{mode}-{chain}.npz"
        if not path.exists():
            return None
        with np.load(path) as data:
            return ChainState.from_arrays({k: data[k] for k in data.files if k != "records"})

    # writing -----------------------------------------------------------------
    def add_batch(self, records: list[dict[str, Any]], state: ChainState | None) -> None:
        """Keep the finished cases of a batch: the chain's state with the records inside
        first (atomically), then their journal lines in one append."""
        if state is not None:
            first = records[0]
            path = self.folder / "chains" / f"{first['mode']}-{first['chain']}.npz"
            buffer = io.BytesIO()
            arrays: dict[str, Any] = {"records": np.array(json.dumps(records)),
                                      **state.stored().to_arrays()}
            np.savez(buffer, **arrays)
            _write_atomic(path, buffer.getvalue())
        self._append(records)

    def _append(self, records: list[dict[str, Any]]) -> None:
        data = "".join(json.dumps(record) + "\n" for record in records)
        half = len(data) // 2
        _fault_point("cases.jsonl: before the append")
        self._journal.write(data[:half])
        self._journal.flush()
        _fault_point("cases.jsonl: inside the append")
        self._journal.write(data[half:])
        self._journal.flush()
        os.fsync(self._journal.fileno())
        _fault_point("cases.jsonl: after the append")
        for record in records:
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
        _write_atomic(self.folder / "study.nc", bytes(dataset.to_netcdf(engine="scipy")))
        self._last_write = time.monotonic()
        self._write_cost = self._last_write - start
        return dataset

    def close(self) -> None:
        self._journal.close()
        self._lock.release()


class _FolderLock:
    """An exclusive ``flock`` on ``folder/.lock`` holding the owner's PID."""

    def __init__(self, folder: Path) -> None:
        self.path = folder / ".lock"
        try:
            import fcntl
        except ImportError:  # pragma: no cover - not on Unix: no lock
            self._handle = None
            return
        handle = self.path.open("a+", encoding="utf-8")
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.seek(0)
            holder = handle.read().strip() or "unknown"
            handle.close()
            raise ModelError(f"--out {folder}: another study is running in this folder "
                             f"(PID {holder}); wait for it to end or use another folder"
                             ) from None
        handle.seek(0)
        handle.truncate()
        handle.write(str(os.getpid()))
        handle.flush()
        self._handle = handle

    def release(self) -> None:
        if self._handle is not None and not self._handle.closed:
            self._handle.close()  # closing the descriptor releases the flock


def _all_fit(records: Iterable[dict[str, Any]], record_fits: RecordCheck | None) -> bool:
    return record_fits is not None and all(record_fits(r) for r in records)


def _difference_message(folder: Path, existing: dict[str, Any],
                        identity: dict[str, Any]) -> str:
    differing = sorted(k for k in set(identity) | set(existing)
                       if identity.get(k) != existing.get(k))
    if differing == ["grid"]:
        old, new = existing.get("grid"), identity.get("grid")
        if (isinstance(old, list) and isinstance(new, list)
                and sorted(map(str, old)) == sorted(map(str, new))):
            order = ", ".join(str(item[0]) for item in old)
            return (f"--out {folder}: the folder holds this study with its --grid items in "
                    f"the order {order}; give them in that order (the order sets the "
                    "traversal and the dimensions of study.nc)")
    if differing == ["chains"]:
        return (f"--out {folder}: the folder holds this study run as {existing.get('chains')} "
                f"chain(s); resume it with --schedule chains --chains {existing.get('chains')}")
    named = []
    for key in differing:
        old, new = existing.get(key), identity.get(key)
        if key == "options" and isinstance(old, dict) and isinstance(new, dict):
            named += [f"options.{k} ({_given(new, k)} here, {_given(old, k)} in the folder)"
                      for k in sorted(set(old) | set(new)) if old.get(k) != new.get(k)]
        elif key == "mesh_sha1" and isinstance(new, dict):
            changed = [Path(k).name for k in sorted(new) if not isinstance(old, dict)
                       or old.get(k) != new[k]]
            named.append(f"the contents of the mesh file(s) {', '.join(changed)}"
                         + ("" if isinstance(old, dict) else
                            " (not recorded in the folder, begun by an earlier multilatin)"))
        else:
            named.append(key)
    return (f"--out {folder}: the folder holds a different study (differs in "
            f"{', '.join(named)}); use another folder or the same arguments")


def _given(options: dict[str, Any], key: str) -> str:
    return repr(options[key]) if key in options else "not set"


def to_dataset(grid: Grid, records: Iterable[dict[str, Any]], attrs: dict[str, Any]
               ) -> xr.Dataset:
    """The labelled results: dimensions ``mode``, one per grid parameter, and ``step`` for
    quantities of interest given per load step; parameters and quantities of interest carry
    their model-file units (``attrs["units"]``). Cases not computed, and cases that did not
    converge, have NaN quantities of interest (``finished`` and ``converged`` say which);
    ``unique`` is False where the discrete problem did not determine the answer
    (``multilatin.uniqueness``), ``<QoI>_determined`` where it did not determine that
    value (``SolveResult.qoi_determined``; the record's ``qoi_determined``)."""
    records = list(records)
    attrs = dict(attrs)
    units: dict[str, str] = dict(attrs.pop("units", {}))  # netCDF's per-variable "units"
    modes = [m for m in ("multiresolution", "cold") if any(r["mode"] == m for r in records)]
    names = list(grid)
    shape = (len(modes), *grid.shape)
    dims = ("mode", *names)
    # the names the model reader keeps from parameters and QoIs (``RESERVED_NAMES``)
    scalars = {name: np.full(shape, np.nan) for name in CASE_NUMBERS}
    flags = {name: np.zeros(shape, dtype=bool) for name in CASE_FLAGS}
    texts = {name: np.full(shape, "", dtype=object) for name in CASE_TEXTS}
    qoi_values: dict[str, np.ndarray] = {}
    determined_values: dict[str, list[tuple[tuple[int, ...], Any]]] = {}
    for record in records:
        at = (modes.index(record["mode"]), *record["index"])
        for name in scalars:
            scalars[name][at] = record[name]
        flags["finished"][at] = True
        flags["converged"][at] = record["converged"]
        flags["unique"][at] = record.get("unique", True)
        flags["small_sliding"][at] = not record.get("large_slips")
        for name in texts:
            texts[name][at] = record[name]
        for name, value in record["qoi"].items():
            value = np.asarray(value if value is not None else np.nan, dtype=float)
            if name not in qoi_values:
                qoi_values[name] = np.full(shape + value.shape, np.nan)
            qoi_values[name][at] = value if record["converged"] else np.nan
        for name, determined in record.get("qoi_determined", {}).items():
            determined_values.setdefault(name, []).append((at, determined))
        for name, error in record.get("qoi_error", {}).items():  # tracking.error_estimates
            shape_of = np.shape(record["qoi"].get(name))
            error = np.broadcast_to(np.asarray(error if error is not None else np.nan,
                                               dtype=float), shape_of)
            key = f"{name}_err"
            if key not in qoi_values:
                qoi_values[key] = np.full(shape + shape_of, np.nan)
            qoi_values[key][at] = error if record["converged"] else np.nan
    determined = {}  # True but where a case's record says otherwise (``records``)
    for name, values in list(qoi_values.items()):
        if not name.endswith("_err") or name[:-4] not in qoi_values:
            determined[f"{name}_determined"] = np.ones(values.shape, dtype=bool)
            for at, flag in determined_values.get(name, []):
                determined[f"{name}_determined"][at] = flag
    qoi_values.update(determined)
    variables: dict[str, Any] = {name: (dims, values) for name, values in scalars.items()}
    variables.update({name: (dims, values) for name, values in flags.items()})
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
    for name in qoi_values:
        dataset[name].attrs["note"] = "NaN where the case did not converge (see converged)"
        if name.endswith("_determined"):
            dataset[name].attrs["note"] = (
                "False where the discrete problem does not determine the value (a body free "
                "to move at the friction limit: SolveResult.qoi_determined)")
        elif name.endswith("_err"):
            dataset[name].attrs["long_name"] = (
                f"estimated |{name[:-4]} - its converged value| (multilatin.latin.tracking)")
    for name in [*qoi_values, *names]:
        unit = units.get(name[:-4] if name.endswith("_err") and name not in units else name)
        if unit:
            dataset[name].attrs["units"] = unit
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


def _write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file replaced in one step (a crash
    leaves the old file or the new one, never half of one)."""
    tmp = path.with_name(path.name + ".tmp")
    kind = "chain state" if path.parent.name == "chains" else path.name
    _fault_point(f"{kind}: before the write")
    with tmp.open("wb") as handle:
        handle.write(data[: len(data) // 2])
        handle.flush()
        _fault_point(f"{kind}: inside the write")
        handle.write(data[len(data) // 2:])
        handle.flush()
        os.fsync(handle.fileno())
    _fault_point(f"{kind}: written, not yet in place")
    os.replace(tmp, path)
    _fault_point(f"{kind}: in place")


def load_study(folder: str | Path) -> xr.Dataset:
    """The Dataset of a study folder (``study.nc``)."""
    path = Path(folder) / "study.nc"
    if not path.exists():
        raise ModelError(f"{folder}: no study.nc (not a study folder, or nothing finished yet)")
    return xr.load_dataset(path, engine="scipy")
