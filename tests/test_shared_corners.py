"""A node whose displacement component two boundary conditions prescribe (the corner of a
clamped face and a held one): its reaction is shared between them in proportion to their
lengths there, in LATIN (its boundary points at the node carry one traction density) and
in the monolithic reference, so that the supports' reactions add up to the load. The
reference counted the whole reaction in each of them (R_held 129.2 N against LATIN's
120.1 N at the first step of the model below)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_held_stops import assert_qois_equal

import multilatin as ml
from multilatin.latin import LatinOptions

MODEL = Path(__file__).parent / "data" / "block_pushed_beside_a_held_foundation.toml"


def _corner_force(result: ml.SolveResult) -> np.ndarray:
    """F̂ of the contact pair at (0, 10), per step (the foundation's point: the first of
    the pair's two)."""
    assert result.interface is not None
    fields = result.interface
    contact = [i for i, itf in enumerate(result.assembly.interfaces) if itf.kind == "contact"]
    corner = np.flatnonzero(np.isin(fields.interface, contact)
                            & np.all(fields.coords == [0.0, 10.0], axis=1))
    assert corner.size == 2  # the foundation's point and the block's
    force: np.ndarray = fields.force_hat[:, corner[0]]
    return force


@pytest.fixture(scope="module")
def model() -> ml.Model:
    return ml.Model(ml.ModelSpec.from_toml(MODEL))


def test_the_supports_reactions_add_up_to_the_load(model) -> None:
    """No load along x: the x reactions of all supports sum to zero at every step."""
    reference = model.reference()
    total = sum(np.asarray(reference.reactions[name])[:, 0] for name in reference.reactions)
    scale = np.abs(np.asarray(reference.reactions["push"])[:, 0]).max()
    np.testing.assert_allclose(total, 0.0, atol=1e-9 * scale)


@pytest.mark.parametrize("kappa", [0.5, 2.0])
def test_latin_shares_a_corner_reaction_as_the_reference(model, kappa) -> None:
    reference = model.reference()
    result = model.solve(options=LatinOptions(kappa=kappa, tol=1e-10, max_iter=3000))
    assert_qois_equal(result, reference)


def test_a_corner_between_moving_holders_slides_at_the_cone(model) -> None:
    """The contact pair at (0, 10) is held on both sides: by the foundation's held face and
    by the block's pushed one. Where the push moves (steps 2, 3, 5) the pair slides and
    its friction is at the cone (it kept its previous value before: the push force 7 %
    low, 185.8 N against 198.9 N at step 2); where it stays (step 4), the corner keeps
    step 3's force (its normal force unchanged: still at the cone)."""
    result = model.solve(options=LatinOptions(tol=1e-10, max_iter=3000))
    force = _corner_force(result)
    tangential, normal = np.abs(force[:, 0]), np.abs(force[:, 1])
    np.testing.assert_allclose(tangential[[1, 2, 4]], 0.3 * normal[[1, 2, 4]], rtol=1e-6)
    assert tangential[3] == pytest.approx(tangential[2], rel=1e-6)


def test_a_corner_held_by_a_stop_slides_where_the_other_holder_moves() -> None:
    """The foundation's corner node is driven sideways while the block's, above it, is held
    by a rigid stop: the pair slides (at the cone) where the drive moves, keeps its force
    where it stays, and LATIN equals the reference (before, both kept the pair frozen: the
    drive's reaction 167.2 N instead of 180.6 N at step 2)."""
    model = ml.Model(ml.ModelSpec.from_toml(
        Path(__file__).parent / "data" / "block_against_a_stop_on_a_driven_foundation.toml"))
    reference = model.reference()
    result = model.solve(options=LatinOptions(tol=1e-10, max_iter=3000))
    assert_qois_equal(result, reference)
    force = _corner_force(result)
    np.testing.assert_allclose(np.abs(force[[1, 2, 4], 0]), 0.3 * np.abs(force[[1, 2, 4], 1]),
                               rtol=1e-6)
    assert force[3, 0] == pytest.approx(force[2, 0], rel=1e-6)
