"""Discretisation and solver choices of the LATIN iteration: ``LatinOptions`` (arguments,
not model parameters, as pyMOR keeps them apart)."""

from __future__ import annotations

import re
from dataclasses import dataclass

from ..decomposition.interfaces import INTERFACE_ELEMENTS
from ..errors import ModelError

__all__ = ["ACCELERATIONS", "BACKENDS", "KAPPA_RANGE", "SEARCH_MODULI", "STUDY_QOI_RTOL",
           "LatinOptions"]

#: studies stop each case on its QoIs' estimated errors at this relative tolerance (or at
#: η < tol before); chosen from ``benchmarks/qoi_stopping.py`` (docs/tolerance.md)
STUDY_QOI_RTOL = 1e-3

#: admissible κ: beyond, k is so far from the stiffness that the linear stage loses the
#: digits the answer needs (and the macro problem turns singular in floating point)
KAPPA_RANGE = (1e-3, 1e3)
SEARCH_MODULI = ("mean", "neighbour", "own")
#: accelerations of the fixed point (``LatinOptions.acceleration``)
ACCELERATIONS = ("relaxation", "anderson", "rre")
#: array backends of the iteration (``engine``): NumPy (with Numba) is the reference
BACKENDS = ("numpy", "torch")

@dataclass(frozen=True)
class LatinOptions:
    """Discretisation and solver choices (arguments, not model parameters).

    kappa: search direction k = κ E / L per interface side (see ``search_modulus``; L: the
        smaller side of a body, so that splitting a body into more substructures keeps the
        same k, measured best in ``benchmarks/b1_search_direction.py``); the converged
        answer does not depend on it.
    search_modulus: whose E and L set k on each side of an interface between two
        substructures. ``"own"`` (default): each side its own substructure's;
        ``"neighbour"``: the substructure on the other side (LMT's scills rule: E−
        stands for the rest of the structure); ``"mean"``: both sides the mean E of the
        two and the L of the first side's body (the rule before issue 15). All three are
        the same for equal materials and body sizes (every bundled B model). On a block
        against a 1 000 times stiffer foundation (``benchmarks/slide.py``) "own" converges
        in 59–346 iterations from κ 0.1 to 2, "mean" not in 1 000 at κ ≥ 0.5
        (docs/convergence.md).
    held_nodes: at a node held on one side only by a prescribed displacement (or a closed
        stop, for contact) — an interface ending on a clamped or pushed face — the pair's
        force comes from the free side alone, against the held motion
        (``held_nodes.held_corners``): only the sum of the pair's and the holder's forces
        is determined there, and the split was an almost neutral mode that η hardly sees
        (a block on a 1 000 times stiffer foundation stopped 3.7 % off). False: the
        earlier two-sided rule, for side-by-side benchmarks.
    tol: stop when the indicator η (paper §4.3) drops below ``tol``. The default is the
        loosest of ``benchmarks/b1_tolerance.py``'s ladder at which R_stop is within 0.1 %
        of its tightly converged value on all 3 × 169 cold cases of the B1 grids (b1,
        b1-4, b1-9) with the default search direction (docs/tolerance.md).
    max_iter: iteration cap; reaching it without η < tol is a failure, not an answer.
    relaxation: ω in s ← ω s_new + (1 − ω) s_old after each linear stage (method.md §4:
        without it, statically determined clusters give an eigenvalue −1).
    stagnation_window: every so many iterations, a case whose smallest η of the window is
        not below ``stagnation_ratio`` times that of the window before (the fixed point
        cycles between contact statuses, measured on one of the 21 125 B3 cases at ω = 0.9
        before issue 15's held-node rule; or ω is too close to 1 for a statically held
        body) has its relaxation lowered by 0.1, down to 0.5. A slow
        but converging tail (0.97–0.99 per iteration) gains a factor 0.2–0.4 per 100
        iterations and is left alone. The converged answer does not depend on ω. With
        Anderson mixing the check is off (its damping stays ω). A case whose η alternates
        while s goes back and forth has ω lowered within 20 iterations (``oscillation``).
    acceleration: ``"relaxation"`` alone; ``"anderson"``: Anderson mixing of the last
        ``anderson_depth`` iterates of the fixed point s ↦ linear(local(s)), damped by ω
        (combinations of admissible fields stay admissible); ``"rre"``: relaxation, and
        every ``rre_cycle`` iterations a reduced-rank extrapolation of the last ones
        (``extrapolation``: restarted GMRES on the fixed point where it is affine, at
        a fraction of Anderson's cost; 22–48 % fewer iterations on b1, b1-4, b3, as
        accurate on the B1 grids, docs/convergence.md). With Anderson or RRE, results
        carry no QoI error estimate (``SolveResult.qoi_error`` None: the estimate reads
        the contraction of relaxed iterations, which their steps break — measured, 4 of
        the 12 tests of tests/test_qoi_error.py fail with either) and cannot stop on
        them (``qoi_rtol`` refused).
    extrapolate_sliding: a case whose fields move by the same increment window after window
        while an open stop or contact closes — a body sliding freely toward it, resisted by
        the search direction alone — jumps ahead to that closing (``sliding``); with
        relaxation only (Anderson keeps its own history). The fixed point is unchanged.
    rigid_balance: after every local stage, the rigid motions each free cluster of
        substructures can make are solved for so that ŝ is in equilibrium on them
        (``rigid_balance``): a body's rigid slide, held back by the search direction alone,
        no longer decays by a fraction per iteration. The fixed point is unchanged. Cold
        B1-family solves under the studies' QoI rule take up to 40 % fewer iterations, the
        B1 13 × 13 study 25 % fewer, but each iteration costs 1.4–2.4 times as much (local
        stages of its trials), so it is off by default (docs/convergence.md, session 36).
        NumPy backend and relaxation only.
    tangential_ratio: k_T / k_N on contact interfaces and stops (separate normal and
        tangential search directions).
    corner_stiffening: k times this factor at *corner nodes* — a substructure's node where
        two of its interfaces meet (an interface ending on a stop, a loaded or clamped face,
        another interface) — falling linearly to 1 at ``corner_reach`` × L from it (L: the
        body's smaller side, as in k = κ E / L), on every interface point
        (``operators.corner_factors``; not on macro-only interfaces, whose local stage takes
        one k per side). The tail's slow modes sit there (forces at single
        nodes, docs/convergence.md). 1: k alike everywhere. The fixed point does not depend
        on k.
    micro_stiffening: a *two-scale* search direction H (``multilatin.latin.two_scale``): k
        times this factor on interfaces between substructures and on stops, except — on
        contact interfaces and stops — on each side's macro part (constant and linear
        functions per component), which keeps k: mesh-scale modes (the slow tail) want a
        stiff direction, a body sliding over a contact a soft one (docs/convergence.md).
        The contact local stage then couples a side's points (an inner iteration). 1: the
        diagonal k of the paper. The fixed point does not depend on it.
    macro: solve the macro problem (eq. [14]–[15]); False gives the one-scale LATIN.
    interface_elements: see ``multilatin.interfaces``.
    qoi_rtol: also stop a case, before η < tol, once the estimated error of every quantity
        of interest at every step it reports (a QoI with ``step``: that step alone;
        ``multilatin.latin.tracking``) is below ``qoi_rtol``
        times its value, or times 1 % of the largest magnitude it took at its steps over
        the last ``iteration.RECENT`` iterations
        for a QoI near zero, or times 1 % of its terms' size (``iteration.CANCELLED``)
        for a QoI that is a small rest of its terms, and the state's own remaining change
        η / (1 − ρ) (ρ: η's rate) is below ``qoi_rtol`` too (``iteration.state_settled``:
        a QoI that stalls while the state still moves stops nothing); looked at after
        ``tracking.WINDOW`` + 5 iterations. From then
        on η < tol alone no longer stops a case whose estimates have not settled, only η <
        tol / 10 does (``solver.ETA_STOP_UNDER``). None: η alone. Such a case is converged
        on its QoIs (``SolveResult.stopped_on_qoi``).
    dirichlet_stiffening: factor on k for prescribed-displacement components.
    backend: the array library of the iteration's field work (``multilatin.latin.engine``):
        ``"numpy"`` (default, with the Numba kernels when installed: the reference) or
        ``"torch"`` (PyTorch, extra ``gpu``; the same formulas in fp64, on ``device``).
        The operators are built with SciPy either way; the answers agree to rounding.
    device: where the torch backend works: ``"cpu"``, ``"cuda"`` or ``"cuda:N"``. The
        NumPy backend works on the CPU only.
    fuse: torch backend: compile the local stage with ``torch.compile`` (fused kernels;
        docs/gpu.md). Measured on the CPU build: 3.3 times faster on 64 b3 cases after a
        compilation of about 3 minutes (13 s from PyTorch's cache in a later process), and
        again for a batch of one case; not measured on a GPU.
    settled_steps: a case's leading load steps whose own share of η, ‖s_t − ŝ_t‖ over the
        case's ½(‖s‖ + ‖ŝ‖), has stayed below ``settled_steps`` × ``tol`` for three
        iterations are no longer iterated, from the first step on (``engine.NumpyFields.
        settle``): a step's fields depend on the earlier steps' alone, so the rest converge
        as before, and a warm start, whose first steps are often its neighbour's, iterates
        only the steps it changes (the main job's study: a third of its rows, −15 % of its
        time, docs/performance.md). 0: every step every iteration. At 0.1 the answers moved
        by up to 1e-8 relative at tol 1e-10 and 18 of B1's 142 QoI estimates fell below
        their error (tests/test_qoi_error.py); at 0.01 neither, for the same saving. NumPy
        backend with Numba and relaxation (elsewhere ignored: torch iterates every step).
    recover_displacements: recover every substructure's interior displacements from the
        converged interface fields (``SolveResult.displacements``; the QoIs evaluated on
        them). False, what a study does (it keeps the QoIs alone): no interior recovery and
        no contact pressures (``SolveResult.contact``); the QoIs from the interface fields
        by their functionals (``tracking.qoi_functionals``: the same linear maps, equal to
        rounding, tests/test_batch.py).
    """

    kappa: float = 0.5
    tol: float = 1e-6
    max_iter: int = 1000
    relaxation: float = 0.9
    macro: bool = True
    interface_elements: str = "nodal"
    dirichlet_stiffening: float = 10.0
    acceleration: str = "relaxation"
    anderson_depth: int = 3
    rre_cycle: int = 10
    extrapolate_sliding: bool = True
    rigid_balance: bool = False
    tangential_ratio: float = 1.0
    corner_stiffening: float = 1.0
    corner_reach: float = 0.2
    micro_stiffening: float = 4.0
    search_modulus: str = "own"
    held_nodes: bool = True
    stagnation_window: int = 100
    stagnation_ratio: float = 0.7
    qoi_rtol: float | None = None
    backend: str = "numpy"
    device: str = "cpu"
    fuse: bool = False
    recover_displacements: bool = True
    settled_steps: float = 0.01

    def __post_init__(self) -> None:
        if self.qoi_rtol is not None and not 0 < self.qoi_rtol < 1:
            raise ModelError(f"qoi_rtol: must lie in (0, 1), got {self.qoi_rtol!r}")
        if not KAPPA_RANGE[0] <= self.kappa <= KAPPA_RANGE[1]:
            raise ModelError(f"kappa: the search direction k = κ E / L needs κ in "
                             f"[{KAPPA_RANGE[0]:g}, {KAPPA_RANGE[1]:g}] (useful: 0.1 to 2), "
                             f"got {self.kappa!r}")
        if not 0 < self.tol < 1:
            raise ModelError(f"tol: must lie in (0, 1), got {self.tol!r}")
        if self.max_iter < 1:
            raise ModelError(f"max_iter: must be >= 1, got {self.max_iter!r}")
        if not 0 < self.relaxation <= 1:
            raise ModelError(f"relaxation: must lie in (0, 1], got {self.relaxation!r}")
        if self.interface_elements not in INTERFACE_ELEMENTS:
            raise ModelError(
                f"interface_elements: expected one of {INTERFACE_ELEMENTS}, "
                f"got {self.interface_elements!r}"
            )
        if self.acceleration not in ACCELERATIONS:
            raise ModelError(f"acceleration: expected one of {ACCELERATIONS}, "
                             f"got {self.acceleration!r}")
        if self.qoi_rtol is not None and self.acceleration != "relaxation":
            raise ModelError(f"qoi_rtol: stopping on the QoIs' estimated errors needs "
                             f"acceleration 'relaxation', got {self.acceleration!r} (the "
                             f"estimates read the contraction of relaxed iterations, which "
                             f"mixing and extrapolation steps break: tests/test_qoi_error.py "
                             f"fails with them); stop on η alone with qoi_rtol=None "
                             f"(`--qoi-rtol none`)")
        if not 0 <= self.settled_steps < 1:
            raise ModelError(f"settled_steps: must lie in [0, 1), got {self.settled_steps!r}")
        if self.rre_cycle < 2:
            raise ModelError(f"rre_cycle: must be >= 2, got {self.rre_cycle!r}")
        if self.search_modulus not in SEARCH_MODULI:
            raise ModelError(f"search_modulus: expected one of {SEARCH_MODULI}, "
                             f"got {self.search_modulus!r}")
        if not 1.0 <= self.corner_stiffening <= 1e3:
            raise ModelError(f"corner_stiffening: must lie in [1, 1000], got "
                             f"{self.corner_stiffening!r}")
        if not 1.0 <= self.micro_stiffening <= 1e3:
            raise ModelError(f"micro_stiffening: must lie in [1, 1000], got "
                             f"{self.micro_stiffening!r}")
        if not 0.0 < self.corner_reach <= 10.0:
            raise ModelError(f"corner_reach: must lie in (0, 10], got {self.corner_reach!r}")
        if not self.tangential_ratio > 0:
            raise ModelError(f"tangential_ratio: must be > 0, got {self.tangential_ratio!r}")
        if self.stagnation_window < 2:
            raise ModelError(f"stagnation_window: must be >= 2, got {self.stagnation_window!r}")
        if not 0 < self.stagnation_ratio <= 1:
            raise ModelError(f"stagnation_ratio: must lie in (0, 1], got "
                             f"{self.stagnation_ratio!r}")
        if self.anderson_depth < 1:
            raise ModelError(f"anderson_depth: must be >= 1, got {self.anderson_depth!r}")
        if self.rigid_balance and (self.backend != "numpy"
                                   or self.acceleration != "relaxation"):
            raise ModelError(f"rigid_balance: built for the numpy backend with acceleration "
                             f"'relaxation', got backend {self.backend!r} and acceleration "
                             f"{self.acceleration!r}")
        if self.backend not in BACKENDS:
            raise ModelError(f"backend: expected one of {BACKENDS}, got {self.backend!r}")
        if not (self.device == "cpu" or re.fullmatch(r"cuda(:\d+)?", str(self.device))):
            raise ModelError(f"device: expected 'cpu', 'cuda' or 'cuda:N', got {self.device!r}")
        if self.fuse and self.backend != "torch":
            raise ModelError("fuse: compiles the torch backend's local stage (the numpy "
                             "backend's is compiled by Numba already); use backend 'torch'")
        if self.backend == "numpy" and self.device != "cpu":
            raise ModelError(f"device: the numpy backend works on the CPU only, got "
                             f"{self.device!r} (use backend 'torch' for a GPU)")
        if not self.dirichlet_stiffening >= 1:
            raise ModelError(
                f"dirichlet_stiffening: must be >= 1, got {self.dirichlet_stiffening!r}"
            )
