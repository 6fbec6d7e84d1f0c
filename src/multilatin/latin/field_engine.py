"""What ``solver._iterate`` asks of a backend's field work, iteration after iteration: the
``FieldEngine`` protocol of ``engine.NumpyFields`` and ``torch_engine.TorchFields``."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol

from ..fem.elasticity import FloatArray, IntArray

__all__ = ["FieldEngine"]


class FieldEngine(Protocol):
    """What ``solver._iterate`` asks of a backend, iteration after iteration."""

    t_linear: float  # linear stage with the macro problem and relaxation, seconds
    t_macro: float
    t_local: float

    def linear_stage(self, relaxation: FloatArray) -> None:
        """s ← linear(ŝ), relaxed by ω per active case (or mixed, with Anderson)."""

    def local_stage(self) -> None:
        """ŝ ← local(s)."""

    def qoi_values(self) -> FloatArray:
        """The tracked QoIs (n_active, n_qoi, n_steps) of the current fields, on the host."""

    def qoi_magnitudes(self) -> FloatArray:
        """``QoiFunctionals.magnitudes`` of the current fields, as ``qoi_values``."""

    def indicator(self) -> tuple[FloatArray, FloatArray]:
        """Per active case ‖s − ŝ‖ and ½(‖s‖ + ‖ŝ‖) (paper §4.3), on the host."""

    def fields(self, cases: IntArray | None = None
               ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        """(W, F, Ŵ, F̂) of the active cases at positions ``cases`` (all: None), as NumPy
        arrays on the host."""

    def keep(self, cases: IntArray) -> None:
        """Only the active cases at positions ``cases`` go on."""

    def shift(self, cases: IntArray, dw: Sequence[Any], df: Sequence[Any]) -> None:
        """s ← s + (dw, df) for the active cases at positions ``cases`` (one row
        ``(n_steps, n_points, 2)`` per case, the engine's arrays; ``sliding``)."""

    def local_stage_of(self, cases: IntArray) -> None:
        """The local stage again for the active cases at positions ``cases`` (after a
        ``shift``), the others' ŝ left as it is where the backend can (NumPy: a case's
        iterates then do not depend on its batch; the coupled local stage's inner passes
        start from the last ŝ, so another pass would move them a little)."""

    def state(self, cases: IntArray) -> tuple[Any, Any]:
        """Copies of (W, F) of the active cases at positions ``cases``, kept where the
        fields live (torch: on its device): the sliding extrapolation's marks."""

    def saved(self, cases: IntArray) -> tuple[Any, ...]:
        """Copies of everything the next iteration of the active cases at positions
        ``cases`` starts from (s and ŝ, and what the local stage keeps), for ``restore``."""

    def restore(self, cases: IntArray, saved: tuple[Any, ...]) -> None:
        """The active cases at positions ``cases`` as ``saved`` had them (the same cases,
        in the same order, that batch's numbering)."""

    def take(self, rows: Any, index: IntArray) -> Any:
        """The rows ``index`` of ``state``'s arrays (or of their differences)."""

    def state_norms(self, dw: Any, df: Any) -> FloatArray:
        """‖(dw, df)‖ per row in the indicator's norm (§4.3), on the host."""

    def host(self, rows: Any) -> FloatArray:
        """``state``'s arrays (or rows of them) as NumPy arrays on the host."""
