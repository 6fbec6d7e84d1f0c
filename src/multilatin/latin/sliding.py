"""Extrapolation of a steady sliding, and of a last slow mode (issue 15: the slow tail).

Where a body slides freely toward a stop or a contact that is still open (friction at its
limit, the gap not yet closed), nothing but the search direction resists the motion, and
LATIN moves the body by the same amount every iteration: the fields change *linearly*, at a
speed of about (unbalanced force) / k per iteration, until the gap closes. Measured on B1 at
κ = 1, (μ1, μ2) = (0, 0.05): the centre block's corner crawls toward the stop at load step 5
by 1.1e-4 mm per iteration for 250 iterations (351 iterations in all, against 108 at
(0.3, 0)); at κ = 0.5 the crawl is twice as fast and still takes ~80 iterations.

A linear crawl is extrapolated exactly: every ``WINDOW`` iterations, a case whose state
s = (W, F) moved by the same increment over the last two windows (to ``STEADY``, in the
indicator's norm) while an open gap (stop or contact, open by more than ``MATERIAL`` times
the largest displacement) closes about as fast as the fastest-moving displacement
(``LEADING``), jumps ahead along that increment to the first closing — the next contact
event. The jump is an affine combination of admissible fields (so s stays
admissible) followed by a local stage (so ŝ is on Γ again); the iteration then resumes from
there. The fixed point is unchanged — only the start of the rest of the iteration moves —
so the converged answer is the same (``tests/test_sliding.py``).

The same marks show a mode that decays *geometrically*: two windows' increments d₁, d₂
aligned (d₂ = r d₁ to ``ALIGNED``, in the indicator's norm) with r = ρ¹⁰ inside
``GEOMETRIC`` — one mode left, decaying by ρ per iteration, the others gone. The case
then jumps by the sum of that mode's increments still ahead, r / (1 − r) d₂ (an Aitken
step; an affine combination again, then a local stage). A case does not stop within
``iteration.RECENT`` iterations of any jump: the take-back check below runs first, and the
QoIs' error estimate then reads iterates after the jump alone. Measured
(docs/convergence.md, session 31), at the default tolerance η < 1e-6: B0's v_tip 4e-5 →
5e-10 off in the same 46 iterations (the relaxation's alternating mode, r = 0.107, taken
out), the lug 257 → 160 iterations, the sliding block at κ = 0.5 … 2 64 → 46–56 and 10–100
times closer to its reference; on B1's sliding cases it never applies (several modes at
once, then a crawl). Cases that stop on their QoIs jump on slower modes only
(``SLOW_ON_QOIS``).

Where one mode does not fit, two may (``MODES``): four marks' three increments fitted by
d₃ = a d₂ + b d₁ (to ``SEVERAL_ALIGNED``), whose roots z² − a z − b = 0 are the two modes'
ratios per window; where the slower is real and above ``SEVERAL_SLOWEST`` (ρ ≥ 0.93 per
iteration) and both are inside ``GEOMETRIC``, the case jumps by the increments still ahead,
((a + b) d₃ + b d₂) / (1 − a − b) (session 34). The sliding block at κ = 0.1 has two such
modes (0.66–0.70 and 0.41–0.50 per window) that no single ratio fits: 156 → 110
iterations; the lug 160 → 126, the roller 402 → 319; B1's studies do not change
(docs/convergence.md, session 34).

Where no gap closes ahead, a crawl may take back a slip instead — a warm start from a
neighbour that slid further than its case slides (a lower friction: the block crawls back
until the contact sticks): it then jumps to where the first slip it takes back is zero
(``SLIP_EVENTS``; a slip: the tangential motion of a contact pair or stop point in a step,
from the step before), the next stick. A random strap's study (μ 0.45 → 0.6, its stop then
open) crawled back for 850 iterations (920 in all, 54 from zero), now 99; B1 (0.05, 0.2)
from (0, 0.2) 169 → 106 (session 62, docs/convergence.md).

A crawl may also end before the gap closes — a warm start from a neighbour whose block slides
to a new equilibrium that friction, not the stop, sets: the jump then overshoots. So a jump
is checked one window later: if η is then above ``TAKE_BACK`` times its value at the jump,
the jump is taken back — the case set back to where it was before the jump
(``RESTORE``) — and that case makes no further jump. Measured on B1 at κ = 1, (0.05,
0.05) → (0.1, 0.05) warm, with session 14's
direction: without that check, 16 jumps and back in a cycle (η ≈ 1e-3 at the cap of 1 000
iterations). A good jump raises η for a few iterations too, while the linear stage
rebalances the forces it moved (B1 at (0.1, 0.25) cold: 1.43 × one window later, then
falling fast): until session 29 any rise took the jump back, and that case crawled on for
60 more iterations (docs/convergence.md, session 29).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..fem.elasticity import FloatArray, IntArray
from .field_engine import FieldEngine
from .local_stage import LocalStage

__all__ = ["ALIGNED", "GEOMETRIC", "GROUP_ROWS", "LEADING", "MATERIAL", "MAX_JUMP",
           "MODES", "RESTORE", "SLIP_EVENTS", "SLOW_ON_QOIS", "STEADY", "TAKE_BACK", "WINDOW",
           "SlidingExtrapolation"]

#: iterations between two looks; a crawl must hold over two windows
WINDOW = 10
#: the two windows' increments agree to this fraction of the last one (indicator's norm)
STEADY = 0.02
#: a gap counts as open when wider than this fraction of the case's largest displacement
MATERIAL = 1e-3
#: the longest jump, in iterations of the crawl
MAX_JUMP = 2000.0
#: the closing gap must close at least this fraction as fast as the fastest-moving
#: displacement: the body that slides is the one that meets the gap
LEADING = 0.5
#: a crawl that takes a slip back also jumps, to where the first such slip is zero (a
#: warm start that slid further than its case slides; session 62)
SLIP_EVENTS = True
#: a jump is taken back when η one window later is above this multiple of η at the jump:
#: the good jumps' rises measured 1.0–1.65 × over B1, B1-4 and B1-9's 13 × 13 studies and
#: cold grids at κ = 0.1 … 2 (docs/convergence.md, session 29)
TAKE_BACK = 2.0
#: a jump taken back sets the case back to where it was before the jump (s, ŝ:
#: ``FieldEngine.restore``), not s minus the jump: ten iterations after a geometric jump
#: its increment has partly decayed, and the local stage's statuses it flipped may stay
#: flipped. b1-4 at gap 0, (0.3, 0.15), under the QoI rule: a two-mode jump at η = 2.5e-7
#: flipped the stop's local stage at the corner (F̂ 8.6 N), η 1.3e-3; shifted back, η stayed
#: at 1e-4 (188 iterations in all; restored, 120; session 55)
RESTORE = True
#: cases tested at once (their marks' rows gathered): bounds the test's memory
GROUP_ROWS = 256
#: a geometric jump: the ratio r of two windows' increments (r = ρ¹⁰ for a mode decaying
#: by ρ per iteration) within these bounds, and the increments aligned, ‖d₂ − r d₁‖ at
#: most ``ALIGNED`` × ‖d₂‖ (docs/convergence.md, session 31)
GEOMETRIC = (0.02, 0.85)
ALIGNED = 0.05
#: the most modes the geometric jump fits: 1, one mode (d₂ = r d₁: session 31); m > 1,
#: also m modes from m + 2 marks where fewer do not fit (``_modes``: session 34)
MODES = 2
#: the several-mode fit's largest misfit, ‖d₀ − Σ cⱼ dⱼ‖ / ‖d₀‖
SEVERAL_ALIGNED = 0.05
#: a several-mode jump's slowest mode decays by at most this per window
SEVERAL_SLOWEST = 0.5
#: when cases stop on their QoIs' estimates, only slower modes jump (r above this, ρ ≥
#: 0.85): a jump holds a case ``iteration.RECENT`` iterations, which a fast mode — the
#: relaxation's alternating one, ρ = −0.8, r = 0.107 — does not repay there (B0, B2, the
#: punch: 35–58 iterations without, 46–66 with it, QoIs already within the request)
SLOW_ON_QOIS = 0.2


class SlidingExtrapolation:
    """Watches the active cases of a batch and makes their steady crawls jump to the next
    contact event, and a last geometric mode to its limit (module docstring).
    ``jumped_at[c]``: the iteration of case c's last jump (−1: none); ``jumps[c]``: how
    many; ``geometric_jumps``: of all cases' jumps, the geometric ones.

    The marks stay where the fields live (``FieldEngine.state``: on a GPU, the device's
    memory): the crawl's test runs there, a few rows at a time, and only a crawling case's
    rows come to the host (its openings). Measured on an H100, the whole B3 study: copying
    every watched case's fields to the host and testing them there took half its time."""

    def __init__(self, local: LocalStage, n_cases: int, on_qois: bool = False) -> None:
        self.local = local  # the whole batch's (cases by their index in the batch)
        #: the geometric jump's bounds on r (``SLOW_ON_QOIS`` when cases stop on QoIs)
        self.ratios = (max(GEOMETRIC[0], SLOW_ON_QOIS) if on_qois else GEOMETRIC[0],
                       GEOMETRIC[1])
        #: per case its last three marks: (a snapshot of (W, F) rows, its row)
        self.marks: dict[int, list[tuple[tuple[Any, Any], int]]] = {}
        self.jumped_at = np.full(n_cases, -1, dtype=np.int64)
        self.jumps = np.zeros(n_cases, dtype=np.int64)
        #: per case: the rate per iteration of the slowest mode its last geometric jump
        #: summed (0: none, or a crawl's jump): the modes left decay no faster
        self.jump_rate = np.zeros(n_cases)
        self.taken_back = np.zeros(n_cases, dtype=bool)  # then no further jump
        self.geometric_jumps = 0  # of ``jumps``, those of a geometric mode
        #: per case with a jump under check: (η at the jump, its increments dw, df, the
        #: case's fields before it: ``FieldEngine.saved``)
        self.pending: dict[int, tuple[float, Any, Any, tuple[Any, ...]]] = {}

    def forget(self, case: int) -> None:
        """Restart the case's record (its fields were moved by another rule)."""
        self.marks.pop(case, None)

    def join(self, local: LocalStage, n_new: int) -> None:
        """Cases join the batch (``local``: the whole batch's local stage, theirs last)."""
        self.local = local
        self.jumped_at = np.concatenate([self.jumped_at, np.full(n_new, -1, dtype=np.int64)])
        self.jumps = np.concatenate([self.jumps, np.zeros(n_new, dtype=np.int64)])
        self.jump_rate = np.concatenate([self.jump_rate, np.zeros(n_new)])
        self.taken_back = np.concatenate([self.taken_back, np.zeros(n_new, dtype=bool)])

    def renumber(self, kept: IntArray, local: LocalStage) -> None:
        """Cases ``kept`` become cases 0 … n − 1 (``local``: theirs); the others are let go."""
        number = {int(c): i for i, c in enumerate(kept)}
        self.marks = {number[c]: v for c, v in self.marks.items() if c in number}
        self.pending = {number[c]: v for c, v in self.pending.items() if c in number}
        self.jumped_at, self.jumps = self.jumped_at[kept], self.jumps[kept]
        self.jump_rate = self.jump_rate[kept]
        self.taken_back = self.taken_back[kept]
        self.local = local

    def __call__(self, counts: IntArray | int, active: IntArray, eta: FloatArray,
                 engine: FieldEngine, hold: np.ndarray | None = None) -> list[int]:
        """At every ``WINDOW``-th iteration of a case (``counts``: each active case's own
        iterations): check its last jump (η per active case), record s, and shift a
        steady crawl. ``hold``: per active case, no jump now (its marks are still
        recorded). Returns the cases (batch indices) moved."""
        counts = np.broadcast_to(np.asarray(counts), active.shape)  # one count for all: too
        due = counts % WINDOW == 0
        if not due.any():
            return []
        moved: list[int] = []
        positions: list[int] = []
        shifts_w: list[Any] = []
        shifts_f: list[Any] = []
        for i, case in enumerate(active.tolist()):
            if not due[i] or case not in self.pending:
                continue
            eta_at_jump, dw, df, before = self.pending.pop(case)
            if not eta[i] <= TAKE_BACK * eta_at_jump:  # overshot: back, no more jumps
                if RESTORE:
                    engine.restore(np.array([i]), before)
                else:
                    positions.append(i)
                    shifts_w.append(-dw)
                    shifts_f.append(-df)
                self.taken_back[case] = True
                self.marks.pop(case, None)
                moved.append(case)
        if positions:
            engine.shift(np.array(positions), shifts_w, shifts_f)
            engine.local_stage_of(np.array(positions))
            positions, shifts_w, shifts_f = [], [], []
        watched = [i for i, case in enumerate(active.tolist()) if due[i]
                   and not self.taken_back[case] and case not in self.pending]
        if not watched:
            return moved
        snapshot = engine.state(np.array(watched))
        # the cases with three marks, grouped by their marks' snapshots (one group when
        # the batch's cases keep step)
        groups: dict[tuple[int, ...], list[tuple[int, int, tuple[int, ...]]]] = {}
        for j, i in enumerate(watched):
            case = int(active[i])
            marks = self.marks.setdefault(case, [])
            marks.append((snapshot, j))
            del marks[:-(2 + MODES)]
            if len(marks) >= 3:
                key = tuple(id(mark[0]) for mark in marks)
                groups.setdefault(key, []).append((i, case, tuple(m[1] for m in marks)))
        for members in groups.values():
            kept = [mark[0] for mark in self.marks[members[0][1]]]
            for start in range(0, len(members), GROUP_ROWS):
                chunk = members[start:start + GROUP_ROWS]
                rows = [np.array([m[2][n] for m in chunk]) for n in range(len(kept))]
                states = [(engine.take(s[0], r), engine.take(s[1], r))
                          for s, r in zip(kept, rows, strict=True)]
                (w0, f0), (w1, f1), (w2, f2) = states[-3:]
                dw, df = w2 - w1, f2 - f1
                before_w, before_f = w1 - w0, f1 - f0
                step = engine.state_norms(dw, df)
                bend = engine.state_norms(dw - before_w, df - before_f)
                crawls = (step > 0.0) & (bend <= STEADY * step)
                ratio, _, aligned = self._geometric(engine, dw, df, before_w, before_f,
                                                    step, bend, self.ratios)
                # newest increment first: d_n, d_{n−1}, … (``_modes``); the older ones
                # only where there are more than three marks
                increments = [(dw, df), (before_w, before_f)] + [
                    (a[0] - b[0], a[1] - b[1])
                    for a, b in zip(states[-3::-1], states[-4::-1], strict=False)]
                several = np.zeros((len(chunk), MODES))
                slowest = np.zeros(len(chunk))  # per window, the several modes' slowest
                for order in range(2, len(increments)):  # the fewest modes that fit
                    fits, held, slow = self._modes(engine, increments[:order + 1],
                                                   self.ratios)
                    held &= ~(aligned | crawls)
                    several[held, :order] = fits[held]
                    slowest[held] = slow[held]
                    aligned = aligned | held
                for k in np.flatnonzero(crawls | aligned):
                    i, case, _ = chunk[k]
                    if hold is not None and hold[i]:
                        continue
                    if crawls[k]:
                        ahead = self._ahead(case, engine.host(w1[k]), engine.host(w2[k]),
                                            engine.host(dw[k]))
                        if ahead is None:
                            continue
                        jump_w, jump_f = ahead / WINDOW * dw[k], ahead / WINDOW * df[k]
                        self.jump_rate[case] = 0.0
                    elif several[k].any():  # several modes: Σ cᵢ dᵢ ahead
                        jump_w = sum(float(c) * d[0][k] for c, d in zip(
                            several[k], increments, strict=False) if c)
                        jump_f = sum(float(c) * d[1][k] for c, d in zip(
                            several[k], increments, strict=False) if c)
                        self.geometric_jumps += 1
                        self.jump_rate[case] = slowest[k] ** (1.0 / WINDOW)
                    else:  # aligned: r < 1, no crawl
                        factor = ratio[k] / (1.0 - ratio[k])
                        jump_w, jump_f = factor * dw[k], factor * df[k]
                        self.geometric_jumps += 1
                        self.jump_rate[case] = ratio[k] ** (1.0 / WINDOW)
                    positions.append(i)
                    shifts_w.append(jump_w)
                    shifts_f.append(jump_f)
                    self.marks[case].clear()
                    moved.append(case)
                    self.jumped_at[case] = int(counts[i])
                    self.jumps[case] += 1
        if positions:
            at = np.array(positions)
            saved = engine.saved(at) if RESTORE else ()
            for n, i in enumerate(positions):  # the jumps, checked one window later
                self.pending[int(active[i])] = (
                    float(eta[i]), shifts_w[n], shifts_f[n],
                    tuple(None if x is None else x[n:n + 1] for x in saved))
            engine.shift(at, shifts_w, shifts_f)
            engine.local_stage_of(at)
        return moved

    @staticmethod
    def _geometric(engine: FieldEngine, dw: Any, df: Any, before_w: Any, before_f: Any,
                   step: FloatArray, bend: FloatArray, ratios: tuple[float, float] = GEOMETRIC
                   ) -> tuple[FloatArray, FloatArray, np.ndarray]:
        """Per row: r = ⟨d₂, d₁⟩ / ‖d₁‖² of the last two windows' increments d₁, d₂ (the
        indicator's inner product, from the norms of d₂ ± d₁: ``bend`` is ‖d₂ − d₁‖), the
        misfit ‖d₂ − r d₁‖ / ‖d₂‖ (from ‖d₂ − r d₁‖² = ‖d₂‖² − r² ‖d₁‖²), and whether it is
        at most ``ALIGNED`` with r inside ``ratios``: one mode decaying by r per window,
        whose sum ahead is r / (1 − r) d₂."""
        size = engine.state_norms(before_w, before_f)
        plus = engine.state_norms(dw + before_w, df + before_f)
        positive = size > 0.0
        ratio = np.where(positive, (plus * plus - bend * bend)
                         / (4.0 * np.where(positive, size * size, 1.0)), 0.0)
        misfit = np.sqrt(np.maximum(step * step - ratio * ratio * size * size, 0.0)
                         ) / np.where(step > 0.0, step, 1.0)
        aligned = (positive & (step > 0.0) & (ratio > ratios[0]) & (ratio < ratios[1])
                   & (misfit <= ALIGNED))
        return ratio, misfit, aligned

    @staticmethod
    def _modes(engine: FieldEngine, increments: list[tuple[Any, Any]],
               ratios: tuple[float, float] = GEOMETRIC
               ) -> tuple[FloatArray, np.ndarray, FloatArray]:
        """Per row, m + 1 windows' increments (``increments``, newest first: d₀, d₁, …,
        d_m, each (dw, df)) fitted by d₀ = Σⱼ cⱼ dⱼ (least squares in the indicator's inner
        product, from norms of sums): m modes whose ratios per window are the roots of
        zᵐ − c₁ zᵐ⁻¹ − … − c_m. Where the slowest is real, inside ``ratios`` and above
        ``SEVERAL_SLOWEST``, every other root smaller than ``ratios[1]`` in modulus, and the
        fit leaves at most ``SEVERAL_ALIGNED`` of ‖d₀‖, the increments still ahead sum to
        T = Σᵢ₌₀^{m−1} (Σ_{j>i} cⱼ) dᵢ / (1 − Σ cⱼ) (a minimal polynomial extrapolation on
        the marks; docs/convergence.md, session 34). Returns those m coefficients per row
        (zero where it does not hold), where it holds, and the slowest root's real part."""
        c, misfit, usable, roots = SlidingExtrapolation._mode_fit(engine, increments)
        slowest = roots[np.arange(len(c)), np.argmax(np.abs(roots), axis=1)]
        held = (usable & (misfit <= SEVERAL_ALIGNED) & (np.abs(slowest.imag) <= 1e-12)
                & (slowest.real > max(ratios[0], SEVERAL_SLOWEST))
                & (slowest.real < ratios[1]) & (np.abs(roots).max(axis=1) < ratios[1]))
        ahead = np.cumsum(c[:, ::-1], axis=1)[:, ::-1] / np.where(
            held, 1.0 - c.sum(axis=1), 1.0)[:, None]
        return np.where(held[:, None], ahead, 0.0), held, slowest.real

    @staticmethod
    def _mode_fit(engine: FieldEngine, increments: list[tuple[Any, Any]]
                  ) -> tuple[FloatArray, FloatArray, np.ndarray, np.ndarray]:
        """``_modes``' least-squares fit d₀ = Σⱼ cⱼ dⱼ per row: (c, the misfit ‖d₀ − Σ cⱼ dⱼ‖
        / ‖d₀‖, where it is well posed, the roots of zᵐ − c₁ zᵐ⁻¹ − … − c_m)."""
        m = len(increments) - 1
        squares = [engine.state_norms(*d) ** 2 for d in increments]
        gram = np.empty((len(squares[0]), m + 1, m + 1))
        for i in range(m + 1):
            gram[:, i, i] = squares[i]
            for j in range(i + 1, m + 1):
                both = engine.state_norms(increments[i][0] + increments[j][0],
                                          increments[i][1] + increments[j][1]) ** 2
                gram[:, i, j] = gram[:, j, i] = (both - squares[i] - squares[j]) / 2.0
        normal, rhs, last = gram[:, 1:, 1:], gram[:, 1:, 0], gram[:, 0, 0]
        scale = np.sqrt(np.einsum("rii->ri", normal))
        usable = (last > 0.0) & (scale > 0.0).all(axis=1)
        unit = normal / np.where(usable[:, None, None],
                                 scale[:, :, None] * scale[:, None, :], 1.0)
        usable &= np.linalg.cond(np.where(usable[:, None, None], unit, np.eye(m))) < 1e10
        c = np.linalg.solve(np.where(usable[:, None, None], normal, np.eye(m)),
                            np.where(usable[:, None], rhs, 0.0)[..., None])[..., 0]
        misfit = np.sqrt(np.maximum(last - np.einsum("ri,ri->r", c, rhs), 0.0)
                         / np.where(usable, last, 1.0))
        companion = np.zeros((len(c), m, m))  # its eigenvalues: the polynomial's roots
        companion[:, 0, :] = c
        companion[:, np.arange(1, m), np.arange(m - 1)] = 1.0
        return c, misfit, usable, np.linalg.eigvals(companion)

    def _ahead(self, case: int, w1: FloatArray, w2: FloatArray, dw: FloatArray
               ) -> float | None:
        """How many iterations of case ``case``'s steady crawl (W from ``w1`` to ``w2`` over
        a window, increment ``dw``) until its first open gap closes; None where no gap
        closes ahead or the one that does is not what slides."""
        opening = self.local.openings(case, w2)
        rate = (opening - self.local.openings(case, w1)) / WINDOW
        closing = (opening > MATERIAL * np.abs(w2).max()) & (rate < 0.0)
        fastest = LEADING * np.abs(dw).max() / WINDOW
        ahead = np.inf
        if closing.any():
            first = np.flatnonzero(closing)[np.argmin(opening[closing] / -rate[closing])]
            if -rate[first] >= fastest:  # else the gap closes slower than the fields move
                ahead = float(opening[first] / -rate[first])
        if SLIP_EVENTS and not np.isfinite(ahead):  # no gap closes ahead, but a slip that
            # the crawl takes back reaches zero: it sticks there
            slip = slips(self.local, w2)
            change = (slip - slips(self.local, w1)) / WINDOW
            stopping = ((np.abs(slip) > MATERIAL * np.abs(w2).max()) & (slip * change < 0.0)
                        & (np.abs(change) >= fastest))
            if stopping.any():
                ahead = float((np.abs(slip[stopping]) / np.abs(change[stopping])).min())
        if not np.isfinite(ahead):  # no event ahead: a slide without end is not extrapolated
            return None
        return min(ahead, MAX_JUMP)


def slips(local: LocalStage, displacement: FloatArray) -> FloatArray:
    """The tangential slip of every stop point and contact pair in every step, from the
    step before (the first from the start), flat, from a case's displacements ``(n_steps,
    n_points, 2)``: what the contact local stage's friction acts on."""
    parts = [np.zeros(0)]
    if local.stops.size:
        tangent = np.column_stack([-local.n_stop[:, 1], local.n_stop[:, 0]])
        along = np.sum(tangent * displacement[:, local.stops], axis=-1)
        parts.append(np.diff(along, axis=0, prepend=0.0).ravel())
    a, b = local.contact_pairs
    if a.size:
        tangent = np.column_stack([-local.n_contact[:, 1], local.n_contact[:, 0]])
        along = np.sum(tangent * (displacement[:, b] - displacement[:, a]), axis=-1)
        parts.append(np.diff(along, axis=0, prepend=0.0).ravel())
    return np.concatenate(parts)
