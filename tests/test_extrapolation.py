"""Reduced-rank extrapolation of the LATIN iterates (``LatinOptions(acceleration="rre")``,
``multilatin.latin.extrapolation``): exact on an affine map with few modes, the same
answers as relaxation, fewer iterations."""

from __future__ import annotations

import numpy as np
import pytest

import multilatin as ml
from multilatin.latin import LatinOptions, solve_latin
from multilatin.latin.extrapolation import ReducedRankExtrapolation


class AffineIterates:
    """A stand-in for the field engine: s_{n+1} = A s_n + c on fields of shape
    (1, n_steps, n_points, 2), A with ``modes`` distinct eigenvalues."""

    def __init__(self, n_steps: int, n_points: int, modes: int, seed: int = 0) -> None:
        rng = np.random.default_rng(seed)
        self.shape = (1, n_steps, n_points, 2)
        size = 2 * int(np.prod(self.shape))  # W and F, flat
        basis, _ = np.linalg.qr(rng.normal(size=(size, modes)))
        # A = V diag(λ) Vᵀ, applied through its factors (as a dense matrix, 48 000 values
        # would need 18 GB)
        self.basis, self.eigenvalues = basis, np.linspace(0.5, 0.99, modes)
        self.solution = rng.normal(size=size)
        self.x = self.solution + basis @ rng.normal(size=modes)  # error in the modes
        self.local_stages = 0

    def step(self) -> None:
        error = self.x - self.solution
        self.x = self.solution + self.basis @ (self.eigenvalues * (self.basis.T @ error))

    def fields(self, cases: object = None) -> tuple[np.ndarray, ...]:
        half = self.x.size // 2
        w, f = self.x[:half].reshape(self.shape), self.x[half:].reshape(self.shape)
        return w, f, w, f

    def shift(self, cases: np.ndarray, dw: list[np.ndarray], df: list[np.ndarray]) -> None:
        self.x = self.x + np.concatenate([np.ravel(dw), np.ravel(df)])

    def local_stage(self) -> None:
        self.local_stages += 1


@pytest.mark.parametrize(("n_points", "reduction"), [(30, 1e-4), (4000, 1e-2)])
def test_one_cycle_finds_the_fixed_point_of_an_affine_map_with_few_modes(
        n_points: int, reduction: float) -> None:
    """Exact in exact arithmetic (RRE on an affine map whose error lives in 4 modes, 8
    differences); here to the Gram matrix's conditioning, and to the sketch's where the
    fields are larger than it (n_points = 4000: 48 000 values in 1 024 blocks)."""
    engine = AffineIterates(n_steps=3, n_points=n_points, modes=4)
    weights = np.ones(n_points * 2)
    rre = ReducedRankExtrapolation(8, weights, weights, 1)
    error = np.linalg.norm(engine.x - engine.solution)
    for _ in range(9):  # 9 iterates, 8 differences: one cycle
        moved = rre(np.array([0]), engine)  # type: ignore[arg-type]
        if moved:
            break
        engine.step()
    assert moved == [0] and engine.local_stages == 1
    # iterating alone would leave up to 0.99⁸ = 0.92 of the error
    assert np.linalg.norm(engine.x - engine.solution) < reduction * error


def test_no_step_when_the_iterates_do_not_contract() -> None:
    """A steady drift (every difference the same): no combination reduces it."""
    engine = AffineIterates(n_steps=2, n_points=10, modes=2)
    drift = np.random.default_rng(1).normal(size=engine.x.size)
    weights = np.ones(20)
    rre = ReducedRankExtrapolation(5, weights, weights, 1)
    for _ in range(20):
        assert not rre(np.array([0]), engine)  # type: ignore[arg-type]
        engine.x = engine.x + drift
    assert rre.steps[0] == 0


def test_b0_linear_fewer_iterations_same_answer(b0: ml.Model) -> None:
    plain = b0.solve(options=LatinOptions())
    fast = b0.solve(options=LatinOptions(acceleration="rre"))
    assert fast.iterations < plain.iterations
    tight = b0.solve(options=LatinOptions(acceleration="rre", tol=1e-10, max_iter=5000))
    reference = b0.reference()
    assert tight.qoi["v_tip"] == pytest.approx(reference.qoi["v_tip"], rel=1e-7)


@pytest.mark.parametrize("mu", [(0.3, 0.15), (0.1, 0.3)])
def test_b1_frictional_contact_same_answer_fewer_iterations(mu: tuple[float, float]) -> None:
    assembly = ml.load_model("b1").assemble({"mu1": mu[0], "mu2": mu[1]})
    # with session 14's diagonal direction (corner stiffening): 66 / 100 and 100 / 124;
    # with the two-scale direction (session 15) the relaxed tail is shorter and RRE gains
    # less (75 / 83 at (0.3, 0.15), docs/convergence.md)
    diagonal = LatinOptions(micro_stiffening=1.0, corner_stiffening=1.5)
    plain = solve_latin(assembly, diagonal)
    fast = solve_latin(assembly, LatinOptions(acceleration="rre", micro_stiffening=1.0,
                                              corner_stiffening=1.5))
    assert fast.iterations < 0.85 * plain.iterations
    tight = [solve_latin(assembly, LatinOptions(acceleration=a, tol=1e-10, max_iter=20000))
             for a in ("relaxation", "rre")]
    for name in ("R_stop", "u_A", "p_B"):
        np.testing.assert_allclose(tight[1].qoi[name], tight[0].qoi[name], rtol=1e-7,
                                   atol=1e-9)


def test_command_line(capsys: pytest.CaptureFixture[str]) -> None:
    import json

    from multilatin.cli import main

    args = ["solve", "b1", "--set", "mu1=0.3", "--set", "mu2=0.15", "--json"]
    counts = []
    for extra in ([], ["--acceleration", "rre"]):
        assert main([*args, *extra]) == 0
        counts.append(json.loads(capsys.readouterr().out)["iterations"])
    assert counts[1] < counts[0]
    assert main(args[:-1] + ["--acceleration", "rre"]) == 0  # the text output says so
    assert "R_stop = " in (out := capsys.readouterr().out)
    assert "(error not estimated: acceleration rre)" in out
    with pytest.raises(SystemExit) as refused:  # argparse: not one of the choices
        main([*args, "--acceleration", "aitken"])
    assert refused.value.code == 2
    assert "invalid choice: 'aitken'" in capsys.readouterr().err


@pytest.mark.parametrize("acceleration", ["rre", "anderson"])
def test_no_qoi_error_estimate_and_no_qoi_stopping_without_plain_relaxation(
        acceleration: str) -> None:
    """The estimates read the contraction of relaxed iterations, which RRE's and Anderson's
    steps break (with either as the default, 4 of tests/test_qoi_error.py's 12 tests fail):
    none is given, none can be asked."""
    result = ml.load_model("b1").solve({"mu1": 0.3, "mu2": 0.15},
                                       options=LatinOptions(acceleration=acceleration))
    assert result.converged and result.qoi_error
    assert all(value is None for value in result.qoi_error.values())
    with pytest.raises(ml.ModelError, match=f"qoi_rtol: .* got '{acceleration}'"):
        LatinOptions(acceleration=acceleration, qoi_rtol=1e-3)
