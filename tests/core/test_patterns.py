"""Pattern functions ("Pattern functions and tears", §3): each height field against its
formula, the damping at the border, the time periodicity and the valid vertices."""

import numpy as np
import pytest

from wrinkle_addon.core.patterns import functions as patterns

RNG = np.random.default_rng(7)
X, Y = RNG.uniform(-2.0, 2.0, 500), RNG.uniform(-2.0, 2.0, 500)


@pytest.mark.parametrize("kind, formula", [
    ("FOREHEAD", lambda x, y, t, a, b, g: a * np.sin(y + b * np.sin(x) - t)),
    ("EYE_CORNER",
     lambda x, y, t, a, b, g: a * np.exp(-b * np.abs(np.hypot(x, y) - t * np.sin(g * np.arctan(y / x))))),
    ("CHEEK", lambda x, y, t, a, b, g: a * np.sin(b * np.hypot(x, y) + t)),
    ("FROWN", lambda x, y, t, a, b, g: a * np.sin(x * y / (b + t))),
    ("DIMPLE", lambda x, y, t, a, b, g: a * (np.log(x * x + y * y + t) - np.log(1 + t))),
    ("EYE_POUCH", lambda x, y, t, a, b, g: np.abs(np.cos(x + a * t) + np.cos(y + b * t)) / g),
])
def test_each_pattern_is_its_formula(kind, formula):
    a, b, g, t = -0.3, 1.7, 2.5, 0.8
    got = patterns.pattern(kind, X, Y, t, a, b, g)
    np.testing.assert_allclose(got, formula(X, Y, t, a, b, g), rtol=1e-12, atol=1e-12)


def test_the_patterns_look_as_described():
    # forehead: straight horizontal furrows with no waviness, bent by it
    x = np.linspace(-2, 2, 9)
    flat = patterns.pattern("FOREHEAD", x, np.full(9, 0.4), 0.0, -1.0, 0.0)
    assert np.ptp(flat) < 1e-12
    assert np.ptp(patterns.pattern("FOREHEAD", x, np.full(9, 0.4), 0.0, -1.0, 0.5)) > 0.1
    # eye corner: the deepest furrows lie on the rose curve rho = t sin(g phi)
    phi = np.radians(30.0)
    rho = 1.0 * np.sin(3.0 * phi)
    on = patterns.pattern("EYE_CORNER", [rho * np.cos(phi)], [rho * np.sin(phi)], 1.0, -1.0, 6.0, 3.0)
    half = 0.5 * rho
    off = patterns.pattern("EYE_CORNER", [half * np.cos(phi)], [half * np.sin(phi)], 1.0, -1.0, 6.0, 3.0)
    assert on[0] == pytest.approx(-1.0) and off[0] > -0.3
    # dimple: deepest at the centre, a log((1 + t) / t) deep, 0 on the unit circle
    centre = patterns.pattern("DIMPLE", [0.0], [0.0], 0.2, 0.1)
    assert centre[0] == pytest.approx(-0.1 * np.log(1.2 / 0.2))
    assert patterns.pattern("DIMPLE", [0.6], [0.8], 0.2, 0.1)[0] == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("kind, params", [
    ("FOREHEAD", (-0.2, 0.4, 0.0)), ("CHEEK", (-0.2, 3.0, 0.0)), ("EYE_POUCH", (1.0, 2.0, 5.0)),
])
def test_running_cycles_repeat_every_two_pi(kind, params):
    for t in (0.0, 0.7, 3.1):
        np.testing.assert_allclose(patterns.pattern(kind, X, Y, t + 2 * np.pi, *params),
                                   patterns.pattern(kind, X, Y, t, *params), atol=1e-9)
    moved = patterns.pattern(kind, X, Y, 1.0, *params) - patterns.pattern(kind, X, Y, 0.0, *params)
    assert np.abs(moved).max() > 0.01


def test_huge_or_degenerate_parameters_give_no_nan():
    for kind in patterns.PATTERNS:
        for a, b, g, t in ((1e300, 1e300, 1e300, 1e300), (0.0, 0.0, 0.0, 0.0), (-1e300, -1.0, 1e-300, -5.0)):
            h = patterns.pattern(kind, np.append(X, 0.0), np.append(Y, 0.0), t, a, b, g)
            assert np.isfinite(h).all(), kind
    with pytest.raises(ValueError, match="unknown pattern"):
        patterns.pattern("SMILE", X, Y, 0.0)


def test_damping_falls_smoothly_to_zero_at_the_border():
    d = np.linspace(0.0, 1.2, 1201)
    damp = patterns.damping_radius(d, 1.0, 0.4)
    assert (damp[d <= 0.6] == 1.0).all() and (damp[d >= 1.0] == 0.0).all()
    slope = np.gradient(damp, d)
    assert abs(slope[np.searchsorted(d, 1.0) - 1]) < 0.05 and abs(slope[np.searchsorted(d, 0.6) + 1]) < 0.05
    assert np.abs(np.diff(slope)).max() < 0.05  # no kink anywhere (C¹)
    assert (np.diff(damp) <= 1e-15).all()
    np.testing.assert_array_equal(patterns.damping_radius(d, 1.0, 0.0), (d <= 1.0).astype(float))
    assert (patterns.damping_radius(d, 0.0, 0.3) <= (d <= 0.0)).all()  # radius 0: nothing
    border = patterns.damping_border(np.array([0.0, 0.1, 0.2, 0.5]), 0.2, weight=np.array([1, 1, 0.5, 1]))
    np.testing.assert_allclose(border, [0.0, 0.5, 0.5, 1.0])


def test_valid_vertices_are_a_seeded_fraction():
    m = patterns.valid_vertices(1000, 0.3, seed=4)
    assert m.sum() == 300
    np.testing.assert_array_equal(m, patterns.valid_vertices(1000, 0.3, seed=4))
    assert (m != patterns.valid_vertices(1000, 0.3, seed=5)).any()
    assert patterns.valid_vertices(10, 1.0, 0).all() and not patterns.valid_vertices(10, 0.0, 0).any()
    assert patterns.valid_vertices(0, 0.5, 0).shape == (0,)
