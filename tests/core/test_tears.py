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
