# SPDX-License-Identifier: GPL-3.0-or-later
"""Wrinkle morph targets (core.morphs): the truncated SVD, K by tolerance, the cap."""

import numpy as np
import pytest

from wrinkle_addon.core import morphs


def _animation(frames=40, verts=500, rank=3, seed=1, noise=0.0):
    """Offsets of ``rank`` wrinkle shapes with smooth weight curves, on part of a mesh."""
    rng = np.random.default_rng(seed)
    shapes = np.zeros((rank, verts, 3))
    shapes[:, : verts // 2] = rng.normal(size=(rank, verts // 2, 3)) * 1e-3
    t = np.linspace(0, 1, frames)
    curves = np.stack([np.clip(np.sin(np.pi * (t * (k + 1) + 0.3 * k)), 0, None) for k in range(rank)], 1)
    d = np.tensordot(curves, shapes, axes=(1, 0))
    return d + rng.normal(size=d.shape) * noise * 1e-3 * (np.abs(d) > 0)


def test_exact_rank_is_found_and_reproduced():
    d = _animation(rank=3)
    m = morphs.fit(d, tolerance=1e-7)
    assert m.components == 3 and m.count == 3 + m.constant
    assert m.within_tolerance and m.max_error < 1e-7
    np.testing.assert_allclose(morphs.reconstruct(m.weights, m.targets), d, atol=1e-7)


def test_the_smallest_k_within_the_tolerance():
    d = _animation(rank=6, noise=0.02)
    for tol in (1e-4, 3e-5, 1e-5):
        m = morphs.fit(d, tolerance=tol, max_targets=41)
        assert m.within_tolerance
        err = np.linalg.norm(morphs.reconstruct(m.weights, m.targets) - d, axis=2)
        assert err.max() <= tol + 1e-9 and abs(err.max() - m.max_error) < 1e-6 * max(tol, 1e-9) + 1e-9
        if m.count:  # one target fewer is not enough
            fewer = morphs.fit(d, tolerance=tol, count=m.components - 1)
            assert fewer.max_error > tol
    assert morphs.fit(d, 1e-4).count < morphs.fit(d, 1e-5, max_targets=41).count


def test_the_cap_and_an_explicit_count():
    d = _animation(rank=8, noise=0.05)
    capped = morphs.fit(d, tolerance=1e-12, max_targets=4)
    assert capped.count == 4 and not capped.within_tolerance and capped.max_error > 1e-12
    assert morphs.fit(d, tolerance=1.0, count=5).components == 5
    assert morphs.fit(d, tolerance=1e-12, count=500).components == 40  # at most one per frame


def test_weights_lie_in_0_1_and_untouched_vertices_stay_zero():
    d = _animation(rank=3)
    m = morphs.fit(d, tolerance=1e-8)
    assert m.weights.min() >= 0.0 and m.weights.max() <= 1.0 + 1e-6
    assert not m.targets[:, 250:].any()  # the second half never moves
    assert m.frame_max_error.shape == (40,)


def test_signed_weights_become_a_constant_target():
    """A wrinkle that changes sign (a furrow that becomes a bulge) needs negative singular
    weights: they are shifted into [0, 1] and the shift becomes one constant target."""
    d = _animation(rank=2)
    d[:, :, 0] += np.linspace(-1, 1, 40)[:, None] * np.where(np.arange(500) < 250, 1e-3, 0.0)
    m = morphs.fit(d, tolerance=1e-7)
    assert m.constant and np.allclose(m.weights[:, -1], 1.0)
    assert m.weights.min() >= -1e-7 and m.weights.max() <= 1.0 + 1e-6
    np.testing.assert_allclose(morphs.reconstruct(m.weights, m.targets), d, atol=1e-7)
    capped = morphs.fit(d, tolerance=1e-12, max_targets=2)
    assert capped.count <= 2  # the constant counts against the cap


def test_no_wrinkles_no_targets():
    m = morphs.fit(np.zeros((5, 10, 3)), tolerance=0.0)
    assert m.count == 0 and m.max_error == 0.0 and m.weights.shape == (5, 0)


@pytest.mark.parametrize("bad", [np.full((2, 3, 3), np.nan), np.zeros((2, 3))])
def test_bad_offsets(bad):
    with pytest.raises(ValueError):
        morphs.fit(bad, tolerance=0.1)


def test_bad_parameters():
    with pytest.raises(ValueError, match="tolerance"):
        morphs.fit(np.zeros((2, 3, 3)), tolerance=-1)
    with pytest.raises(ValueError, match="max_targets"):
        morphs.fit(np.zeros((2, 3, 3)), tolerance=0.1, max_targets=0)


def test_normal_deltas_are_the_least_squares_fit():
    rng = np.random.default_rng(3)
    w = rng.uniform(0, 1, (30, 4))
    truth = rng.normal(size=(4, 50, 3))
    missing = np.tensordot(w, truth, axes=(1, 0))
    np.testing.assert_allclose(morphs.fit_normals(w, missing), truth, atol=1e-5)
    noisy = missing + rng.normal(size=missing.shape) * 0.1
    fitted = morphs.fit_normals(w, noisy)
    err = np.abs(np.tensordot(w, fitted, axes=(1, 0)) - noisy).sum()
    assert err < np.abs(np.tensordot(w, fitted * 1.05, axes=(1, 0)) - noisy).sum()
    assert morphs.fit_normals(np.zeros((3, 0)), np.zeros((3, 5, 3))).shape == (0, 5, 3)
    with pytest.raises(ValueError):
        morphs.fit_normals(w, missing[:5])
