"""What ``multilatin solve`` prints of a result (``result_lines``): its outcome, the free
motions and large slips found in it, and each quantity of interest with its estimated
error and the steps where the discrete problem leaves it undetermined."""

from __future__ import annotations

import numpy as np

from ..decomposition.result import SolveResult
from ..decomposition.uniqueness import FreeMotion

__all__ = ["result_lines"]


def result_lines(result: SolveResult, reference: SolveResult | None,
                 settled: float) -> list[str]:
    """The lines of ``result`` (and the QoIs of ``reference``, the monolithic solve beside
    it); ``settled``: the state's remaining change below which the QoI estimates are given
    (``latin.tracking.SETTLED``)."""
    status = ("converged" + (" on its QoIs' estimated errors (--qoi-rtol)"
                             if result.stopped_on_qoi else "")
              if result.converged else f"NOT CONVERGED ({result.failure})")
    lines = [f"{result.assembly.name} ({result.method}): {status}, {result.iterations} "
             f"iterations, indicator {result.indicator:.2e}, {result.wall_s:.3f} s",
             "parameters: " + ", ".join(f"{k} = {v:g}" for k, v in result.assembly.mu.items())]
    if not result.converged:
        return lines + ["  (quantities of interest withheld: the iteration did not converge)"]
    lines += _motion_lines(result, settled)
    units = {q.name: q.unit for q in result.assembly.qois}
    for which, res in [("", result)] + ([("reference ", reference)] if reference else []):
        determined = res.qoi_determined  # once per result: it locates the QoIs' points
        for name, value in res.qoi.items():
            unit = units.get(name, "")
            unit = "" if unit in ("", "1", "-") else f" {unit}"
            note = _error_note(res, name, unit, settled)
            flags = np.atleast_1d(determined.get(name, True))
            if not flags.all():  # a body free to move (the NOT UNIQUE / UNDETERMINED lines)
                at = ", ".join(str(t + 1) for t in np.flatnonzero(~flags))
                note += f"  (undetermined{f' at step(s) {at}' * isinstance(value, list)})"
            if isinstance(value, list):
                shown = ", ".join(f"{v:.6g}" for v in value)
                lines.append(f"  {which}{name} = [{shown}]{unit}{note}")
            else:
                lines.append(f"  {which}{name} = {value:.9g}{unit}{note}")
    return lines


def _motion_lines(result: SolveResult, settled: float) -> list[str]:
    """NOT UNIQUE for each motion that reaches the last step, UNDETERMINED for the others
    (one line per motion, its steps named together), LARGE SLIP for each slip."""
    unsettled = result.state_change > settled
    lines = [f"  NOT UNIQUE: {motion.describe()}"
             + (f" (read on a state still changing by ~{result.state_change:.1e}: "
                "check with a tighter --tol)" if unsettled else "")
             for motion in result.free_motions if motion.reaches_last_step]
    groups: dict[tuple[object, ...], tuple[FreeMotion, list[int]]] = {}
    for motion in result.free_motions:  # those that leave the last step's answer standing
        if not motion.reaches_last_step:
            key = (motion.bodies, motion.velocity, motion.rotation, motion.friction_holds)
            groups.setdefault(key, (motion, []))[1].append(motion.step)
    lines += [f"  UNDETERMINED: {first.describe(steps)}" for first, steps in groups.values()]
    return lines + [f"  LARGE SLIP: {slip.describe()}" for slip in result.large_slips]


def _error_note(result: SolveResult, name: str, unit: str, settled: float) -> str:
    """The estimated remaining error of the iteration (``latin.tracking``), or why none."""
    error = result.qoi_error.get(name)
    acceleration = result.options.get("acceleration", "relaxation")
    if error is not None:
        return (f"  (estimated error {max(np.atleast_1d(error)):.2g}{unit}"
                f"{' at most' if isinstance(error, list) else ''})")
    if result.converged and acceleration != "relaxation":  # LATIN, not estimated
        return f"  (error not estimated: acceleration {acceleration})"
    if result.converged and result.state_change > settled:  # not settled enough
        return (f"  (error not estimated: the state still changes by "
                f"~{result.state_change:.1e}; a tighter --tol gives one)")
    return ""
