"""Exceptions raised by multilatin (the base room: imports nothing of the package)."""

from __future__ import annotations

from typing import Any


class ModelError(ValueError):
    """A model file or a parameter value is invalid; the message names the field and value."""


class NotConvergedError(RuntimeError):
    """The LATIN iteration did not reach its tolerance within the iteration cap.

    ``result`` holds the unconverged state (with ``converged = False``) for inspection; it is
    never an answer.
    """

    def __init__(self, message: str, result: Any) -> None:
        super().__init__(message)
        self.result = result
