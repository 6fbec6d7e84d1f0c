"""Folders the user names for output: checked before any work, errors naming the option."""

from __future__ import annotations

from pathlib import Path

from ..errors import ModelError


def ensure_writable_folder(folder: Path, option: str = "--out") -> None:
    """Create ``folder`` (and its parents) and make sure files can be written there; the
    error names ``option`` and the path."""
    if folder.exists() and not folder.is_dir():
        raise ModelError(f"{option} {folder}: is a file, not a folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
        probe = folder / ".write-probe"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise ModelError(f"{option} {folder}: cannot write there ({exc.strerror})") from None
