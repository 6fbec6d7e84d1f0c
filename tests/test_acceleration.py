"""Anderson mixing with ring buffers and an incremental Gram matrix gives the iterates of the
textbook algorithm (the history rebuilt at every step), ring wrap-around and cases leaving
a batch included."""

from __future__ import annotations

import numpy as np

from multilatin.latin.acceleration import Anderson


def _textbook(xs: list[np.ndarray], rs: list[np.ndarray], depth: int, damping: float,
              scale: np.ndarray) -> np.ndarray:
    """One case: γ = argmin ‖r − ΔR γ‖ over the last ``depth`` differences (scaled norm)."""
    x, r = xs[-1], rs[-1]
    if len(xs) == 1:
        return x + damping * r
    d_x = np.diff(np.array(xs[-depth - 1:]), axis=0)
    d_r = np.diff(np.array(rs[-depth - 1:]), axis=0)
    gamma = np.linalg.lstsq((d_r * scale).T, r * scale, rcond=None)[0]
    return x - gamma @ d_x + damping * (r - gamma @ d_r)


def test_ring_buffer_anderson_equals_the_textbook_algorithm() -> None:
    rng = np.random.default_rng(15)
    n_cases, shape, depth, damping = 3, (2, 5, 2), 4, 0.9
    size = 2 * int(np.prod(shape))
    # an affine contraction per case, slow modes near 0.97
    maps = []
    for _ in range(n_cases):
        q, _ = np.linalg.qr(rng.normal(size=(size, size)))
        maps.append((q @ np.diag(rng.uniform(0.3, 0.97, size)) @ q.T, rng.normal(size=size)))
    w_scale = rng.uniform(0.5, 2.0, shape[1:])
    f_scale = rng.uniform(0.5, 2.0, shape[1:])
    scale = np.concatenate([np.broadcast_to(w_scale, shape).ravel(),
                            np.broadcast_to(f_scale, shape).ravel()])
    mixer = Anderson(depth, damping, w_scale, f_scale)
    x = rng.normal(size=(n_cases, size))
    histories: list[tuple[list[np.ndarray], list[np.ndarray]]] = [([], []) for _ in maps]
    active = list(range(n_cases))
    for step in range(25):  # the rings wrap around several times
        if step == 12:  # case 1 leaves the batch
            keep = np.array([0, 2])
            mixer.subset(keep)
            x = x[keep]
            active = [active[k] for k in keep]
        g = np.stack([maps[c][0] @ x[i] + maps[c][1] for i, c in enumerate(active)])
        half = size // 2
        w, f = x[:, :half].reshape(-1, *shape), x[:, half:].reshape(-1, *shape)
        w_new, f_new = g[:, :half].reshape(w.shape), g[:, half:].reshape(f.shape)
        out_w, out_f = mixer(w, f, w_new, f_new)
        got = np.concatenate([out_w.reshape(len(active), -1), out_f.reshape(len(active), -1)],
                             axis=1)
        for i, c in enumerate(active):
            histories[c][0].append(x[i].copy())
            histories[c][1].append(g[i] - x[i])
            expected = _textbook(*histories[c], depth, damping, scale)
            # normal equations (the mixer) against QR (here): rounding only
            np.testing.assert_allclose(got[i], expected, rtol=1e-6, atol=1e-8)
        x = got
