"""A study's search direction chosen on one of its cases (``--kappa auto``, session 38).

The converged answer does not depend on κ (k = κ E / L), the iterations do, and by model:
B1's models converge fastest at the default 0.5, curved contacts at 2–5 (the roller 319
iterations at 0.5, 64 at 5; the Hertz cylinder at h = 0.05 mm 988 → 79 at 10;
``benchmarks/kappa_scan.py``, docs/convergence.md "κ on every bundled model"). No rule
found yet picks κ from the model, so ``choose_kappa`` measures: the case solved from zero
at κ = 0.5, 1, 2, … in turn under the study's own stopping rule, each capped at one
iteration fewer than the best so far, the climb stopped at the first κ that does not beat
it; where 0.5 stays the best, 0.25 and 0.1 by the same rule, kept only where they are no
slower on the grid's corners either (session 49). A study of many cases pays two to eight
solves of one for it. Where no κ converges on that case (no equilibrium there), the grid's
corners are read in turn (session 43).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

from ..errors import ModelError
from ..latin import LatinOptions, solve_latin
from ..model import Model

__all__ = ["KAPPA_DOWN", "KAPPA_LADDER", "KappaChoice", "choose_kappa"]

log = logging.getLogger(__name__)

#: the κ tried, in turn from the default up (the bundled models' best lie in 0.5 … 10)
KAPPA_LADDER = (0.5, 1.0, 2.0, 5.0, 10.0)
#: then, where the first of the ladder stays the best, down (session 49: a lap joint whose
#: overhang lifts off converges at 0.1 in 65 iterations, at 0.5 in 116)
KAPPA_DOWN = (0.25, 0.1)


@dataclass(frozen=True)
class KappaChoice:
    """The κ kept, and per κ tried its iterations (None: it did not converge in fewer
    than the best before it, or at all where none converged before it), the case they
    were read on, the seconds it took, and the cases read before on which no κ
    converged."""

    kappa: float
    iterations: dict[float, int | None]
    params: dict[str, float]
    seconds: float
    #: the cases tried before, on which no κ converged
    skipped: list[dict[str, float]] = field(default_factory=list)
    #: a κ below the ladder's first, checked on the other cases: per case, its iterations
    #: at the ladder's first and at that κ (None: not in as few); one None keeps the first
    checked: list[tuple[dict[str, float], int, int | None]] = field(default_factory=list)
    #: the κ the case read chose before the check
    proposed: float | None = None

    def describe(self) -> str:
        """One line: the κ kept and each κ tried — its iterations, "no fewer" where it did
        not beat the best before it, "not converged" where none converged before it."""
        labels, converged = [], False
        for kappa, n in self.iterations.items():
            converged |= n is not None
            label = n if n is not None else "no fewer" if converged else "not converged"
            labels.append(f"{kappa:g}: {label}")
        def named(params: dict[str, float]) -> str:
            return ", ".join(f"{name}={value:g}" for name, value in params.items())
        case = named(self.params)
        kept = "" if converged else ", none converged: the default kept"
        before = "".join(f"no kappa converged at ({named(p) or 'the defaults'}); "
                         for p in self.skipped)
        first = next(iter(self.iterations), self.kappa)  # the ladder's first
        after = "".join(f"; checked at ({named(p)}): {first:g}: {n_first}, "
                        f"{self.proposed:g}: {'no fewer' if n is None else n}"
                        for p, n_first, n in self.checked)
        if self.checked and self.proposed != self.kappa:
            after += f" - {self.kappa:g} kept"
        return (f"kappa auto: {self.kappa:g} ({before}iterations from zero at "
                f"({case or 'the defaults'}): {', '.join(labels)}{kept}{after}; "
                f"{self.seconds:.2f} s)")


def choose_kappa(model: Model, mu: Mapping[str, float] | None = None,
                 options: LatinOptions | None = None,
                 ladder: Sequence[float] = KAPPA_LADDER,
                 others: Sequence[Mapping[str, float]] = (),
                 down: Sequence[float] = KAPPA_DOWN) -> KappaChoice:
    """The κ of ``ladder`` (increasing) under which the case ``mu`` converges from zero in
    the fewest iterations, with ``options``' other settings and stopping rule (module
    docstring); where the ladder's first stays the best, the κ of ``down`` (decreasing)
    in turn, by the same rule, kept only if it takes no more iterations than the ladder's
    first on each of the ``others`` after that case either (``checked``; a softer κ wins
    B1's central case, 42 iterations against 76, and loses its corner (0.6, 0.6) and its
    study: session 49). Where no κ converges on it (a case with no equilibrium), the cases
    ``others`` in turn, until one converges; where none does, ``options.kappa``: the study
    then reports its cases as it would have. ``skipped``: the cases read before the one
    that decided."""
    start = time.perf_counter()
    options = options or LatinOptions()
    cases = [mu, *others]
    skipped: list[dict[str, float]] = []
    for case in cases:
        choice = _on_one_case(model, case, options, ladder, down)
        if any(n is not None for n in choice.iterations.values()) or case is cases[-1]:
            break
        skipped.append(choice.params)
    if ladder and choice.kappa < ladder[0]:
        after = [c for c in cases[len(skipped) + 1:] if c is not None]
        checked = _check_down(model, after, options, ladder[0], choice.kappa)
        kept = choice.kappa if all(n is not None for _, _, n in checked) else ladder[0]
        choice = replace(choice, kappa=kept, checked=checked, proposed=choice.kappa)
    choice = replace(choice, seconds=time.perf_counter() - start, skipped=skipped)
    log.info("%s", choice.describe())
    return choice


def _check_down(model: Model, cases: Sequence[Mapping[str, float]], options: LatinOptions,
                first: float, softer: float) -> list[tuple[dict[str, float], int, int | None]]:
    """Per case of ``cases`` that converges at ``first``: its iterations there, and at
    ``softer`` capped at as many (None where it needs more); stops at the first None."""
    out: list[tuple[dict[str, float], int, int | None]] = []
    for case in cases:
        try:
            assembly = model.assemble(case)
        except ModelError:  # a corner the study will refuse itself, naming it
            continue
        at_first = solve_latin(assembly, replace(options, kappa=first), check=False)
        if not at_first.converged:
            continue  # no equilibrium there, or not within max_iter: it tells nothing
        soft = solve_latin(assembly, replace(options, kappa=softer,
                                             max_iter=at_first.iterations), check=False)
        out.append(({name: float(v) for name, v in case.items()}, at_first.iterations,
                    soft.iterations if soft.converged else None))
        if not soft.converged:
            break
    return out


def _on_one_case(model: Model, mu: Mapping[str, float] | None, options: LatinOptions,
                 ladder: Sequence[float], down: Sequence[float]) -> KappaChoice:
    start = time.perf_counter()
    assembly = model.assemble(mu)
    params = {name: float(value) for name, value in (mu or {}).items()}
    tried: dict[float, int | None] = {}
    best: tuple[int, float] | None = None

    def climb(kappas: Sequence[float]) -> None:
        nonlocal best
        for kappa in kappas:
            cap = options.max_iter if best is None else best[0] - 1
            if cap < 1:
                break
            result = solve_latin(assembly, replace(options, kappa=kappa, max_iter=cap),
                                 check=False)
            if not result.converged:
                tried[kappa] = None
                if best is not None:
                    break  # the iterations rise beyond the best: going on costs more
                continue
            tried[kappa] = result.iterations
            best = (result.iterations, kappa)

    climb(ladder)
    if best is not None and ladder and best[1] == ladder[0]:
        climb(down)
    return KappaChoice(options.kappa if best is None else best[1], tried, params,
                       time.perf_counter() - start)
