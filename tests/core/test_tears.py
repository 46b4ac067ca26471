"""Dripping tears ("Pattern functions and tears", §4.1): the teardrop surface and its timing."""

import numpy as np
import pytest

from wrinkle_addon.core import tears


def _surface(tau, alpha=1.0, beta=0.6, lam=0.5, n=201):
    u, v = np.meshgrid(np.linspace(0, np.pi, n), np.linspace(0, 2 * np.pi, 9), indexing="ij")
    return u, tears.teardrop(u, v, tau, alpha, beta, lam)


def test_the_surface_is_its_formula_and_a_closed_drop_pointed_on_top():
    u, p = _surface(0.0)
    t = tears.T0
    r = np.sin(u) / (t + np.cos(u))
    np.testing.assert_allclose(np.hypot(p[..., 0], p[..., 1]), r, atol=1e-12)
    np.testing.assert_allclose(p[..., 2], 0.6 * t * np.cos(u) - 0.6 * t, atol=1e-12)
    assert np.abs(p[0, :, :2]).max() < 1e-12 and np.abs(p[-1, :, :2]).max() < 1e-12  # closed at both tips
    assert p[0, 0, 2] == pytest.approx(0.0)  # the top starts where it forms
    radius = r[:, 0]
    widest = u[np.argmax(radius), 0]
    assert widest > 0.6 * np.pi  # round at the bottom, pointed at the top


def test_as_it_falls_it_grows_longer_and_thinner_and_moves_down():
    shapes = []
    for tau in (0.0, 0.5, 1.0, 2.0):
        _u, p = _surface(tau)
        height = p[..., 2].max() - p[..., 2].min()
        width = 2 * np.hypot(p[..., 0], p[..., 1]).max()
        shapes.append((height, width, p[..., 2].mean()))
    h, w, z = np.array(shapes).T
    assert (np.diff(h) > 0).all() and (np.diff(w) < 0).all() and (np.diff(z) < 0).all()


def test_a_new_drop_every_period_each_lasting_its_lifetime():
    assert tears.age(-0.1, 0.0, 2.0, 1.5) is None
    assert tears.age(0.5, 0.0, 2.0, 1.5) == pytest.approx(0.5)
    assert tears.age(1.7, 0.0, 2.0, 1.5) is None
    assert tears.age(4.25, 0.0, 2.0, 1.5) == pytest.approx(0.25)
    assert tears.age(1.0, 0.0, 0.0, 1.5) is None


def _on_sphere(R=0.1, k=40, n=9, half_width=0.004, length=0.06):
    """A tear's base along a meridian of a sphere of radius R (a cheek-like curvature)."""
    theta = np.linspace(0.3, 0.3 + length / R, k)
    path = np.stack([np.zeros(k), -R * np.sin(theta), R * np.cos(theta)], 1)
    normals = path / R
    base, arc, w = tears.strip(path, normals, half_width, n)
    base = base / np.linalg.norm(base, axis=1, keepdims=True) * R  # snapped onto the skin
    return base, base / R, arc, w, k


def test_the_strip_runs_along_the_path_across_the_tangent_plane():
    base, normals, arc, w, k = _on_sphere()
    assert base.shape == (k * 9, 3) and arc.shape == w.shape == (k * 9,)
    assert arc[-1] == pytest.approx(0.06, rel=1e-3) and w.min() == -1 and w.max() == 1
    with pytest.raises(ValueError):
        tears.strip(np.zeros((1, 3)), np.zeros((1, 3)), 0.01, 5)
    with pytest.raises(ValueError):
        tears.strip(np.zeros((3, 3)), np.tile([0, 0, 1.0], (3, 1)), 0.01, 5)


def test_the_shell_is_closed_and_never_inside_the_skin():
    R = 0.1
    base, normals, arc, w, k = _on_sphere(R)
    factor = tears.reveal_profile(arc, 0.05, 0.006) * (1 - tears.reveal_profile(arc, 0.004, 0.004))
    rise = tears.rise_noise(np.stack([arc, w * 0.004], 1), 0.2, 0.0003, seed=1, eps=0.002)
    pos, quads = tears.shell(base, normals, w, k, thickness=0.0012, gap=0.0001, rise=rise, factor=factor)
    # closed: every edge is shared by exactly two faces
    e = np.sort(np.stack([quads, np.roll(quads, -1, axis=1)], 2).reshape(-1, 2), axis=1)
    _u, counts = np.unique(e, axis=0, return_counts=True)
    assert (counts == 2).all()
    # never inside the skin (the sphere): vertices, edge midpoints and face centres
    mids = 0.5 * (pos[e[:, 0]] + pos[e[:, 1]])
    centres = pos[quads].mean(axis=1)
    for pts in (pos, mids, centres):
        assert (np.linalg.norm(pts, axis=1) > R).all()
    # the top is never below the bottom, and the head is round: zero thickness ahead of it
    assert len(pos) < 2 * len(base)  # the unrevealed part shares the bottom's vertices
