"""Zhang 2005 eqs. 5-12 and 15: the properties the paper states."""

import numpy as np
import pytest

from wrinkle_addon.core.muscles import zhang


@pytest.mark.parametrize("alpha", [-1.0, -0.5, 0.0, 0.5, 1.0, 2.0, 3.5])
@pytest.mark.parametrize("k0", [0.3, 1.0, 2.5])
def test_shape_function_has_zero_integral(alpha, k0):
    """Eq. 8: the furrow's volume goes into the bulge; d comes from the closed form."""
    u = 0.7
    w = np.linspace(0.0, 2 * u, 200_001)
    h = zhang.shape_function(w, u, k0, alpha)
    assert abs(np.trapezoid(h, w) if hasattr(np, "trapezoid") else np.trapz(h, w)) < 1e-6 * k0


def test_bulge_height_closed_form_values():
    assert zhang.bulge_height(1.0, 1.0) == pytest.approx(0.75)
    assert zhang.bulge_height(1.0, 0.0) == pytest.approx(0.5)
    assert zhang.bulge_height(2.0, -1.0) == pytest.approx(np.log(2.0))


def test_furrow_sharp_bulge_round():
    """Furrows at the cycle ends are deeper and steeper than the bulge mid-cycle."""
    u, k0, alpha = 1.0, 1.0, 1.0
    h = lambda w: zhang.shape_function(np.asarray(w), u, k0, alpha)  # noqa: E731
    assert h(u) == pytest.approx(zhang.bulge_height(k0, alpha))  # bulge top = d
    assert h(0.0) == pytest.approx(h(2 * u))
    assert h(0.0) < -abs(h(u))  # the furrow is deeper than the bulge is high
    step = 1e-4
    furrow_slope = (h(2 * u) - h(2 * u - step)) / step
    bulge_slope = (h(u + step) - h(u)) / step
    assert abs(furrow_slope) > 3.5 * abs(bulge_slope)


def test_shape_is_symmetric_within_a_cycle():
    w = np.linspace(0, 1, 101)
    np.testing.assert_allclose(zhang.shape_function(w, 1.0, 1.3, 0.7),
                               zhang.shape_function(2 - w, 1.0, 1.3, 0.7), atol=1e-12)


def test_half_cycle_and_cycle_position():
    u = zhang.half_cycle(0.1, 0.4, 3)
    assert u == pytest.approx(0.6 * 0.1 / 6)
    l = np.linspace(0.0401, 0.0999, 1000)
    w = zhang.cycle_position(l, 0.4, 0.1, u)
    assert w.min() >= 0 and w.max() < 2 * u
    # exactly n_w cycles across the wrinkling region: w wraps n_w - 1 times inside it
    assert np.sum(np.diff(w) < 0) == 2


def test_half_cycle_never_divides_by_zero():
    assert np.isfinite(zhang.half_cycle(0.1, 0.4, 0))


def test_anisotropic_function():
    eps = np.array([-0.5, 0.0, 0.25, 0.5, 1.0, 1.5])
    a = zhang.anisotropic(eps)
    np.testing.assert_allclose(a[:2], 0.0, atol=1e-12)  # stretch and rest: no wrinkle
    assert a[4] == pytest.approx(1.0)
    assert a[5] == pytest.approx(1.0)
    assert np.all(np.diff(a[1:5]) > 0)


def test_anisotropic_is_continuous_at_zero():
    assert zhang.anisotropic(np.array([1e-9]))[0] < 1e-8


@pytest.mark.parametrize("xc,xmax", [(0.0, 1.0), (0.3, 0.9), (10.0, 20.0)])
def test_attenuation_profile(xc, xmax):
    x = np.linspace(xc - 1, xmax + 1, 2001)
    at = zhang.attenuation(x, xc, xmax)
    assert np.all(at[x <= xc] == 1.0)
    assert np.all(at[x > xmax] == 0.0)
    assert zhang.attenuation(xmax, xc, xmax) == pytest.approx(0.0, abs=1e-12)
    assert np.all(np.diff(at) <= 1e-12)  # monotone
    assert np.max(np.abs(np.diff(at))) < 0.01  # continuous: no jump at either end


def test_edge_fade_reaches_zero_at_both_ends():
    l = np.linspace(0.4, 1.0, 601)
    f = zhang.edge_fade(l, 0.4, 1.0, 0.05)
    assert f[0] == pytest.approx(0.0, abs=1e-12) and f[-1] == pytest.approx(0.0, abs=1e-12)
    assert np.all(f[(l > 0.45) & (l < 0.95)] == 1.0)


def test_edge_shrinkage():
    tau = zhang.edge_shrinkage(np.array([1.0, 2.0, 0.0]), np.array([0.5, 3.0, 1.0]))
    np.testing.assert_allclose(tau, [0.5, -0.5, 0.0])


def test_furrow_width_is_where_the_shape_is_below_zero():
    # alpha = 1: d = 0.75 k0, and H < 0 where |t| (1 + t^2) > 0.75, i.e. |t| > t0
    t0 = np.roots([1.0, 0.0, 1.0, -0.75])
    t0 = float(t0[np.abs(t0.imag) < 1e-12].real[0])
    assert zhang.furrow_width(1.0) == pytest.approx(2.0 * (1.0 - t0), abs=1e-3)
    assert zhang.furrow_width(0.0) == pytest.approx(1.0, abs=1e-3)  # a triangle wave: half below
    # a sharper shape has a narrower furrow
    assert zhang.furrow_width(2.0) < zhang.furrow_width(1.0) < zhang.furrow_width(0.0)


def test_soft_fold_limits_only_the_deep_furrows():
    cap = 1.0
    h = np.linspace(-5.0, 1.0, 6001)
    out = zhang.soft_fold(h, cap)
    shallow = h >= -zhang.FOLD_KNEE * cap
    np.testing.assert_array_equal(out[shallow], h[shallow])  # bulges and shallow furrows as they were
    assert out.min() > -cap  # never deeper than the cap
    assert np.all(np.diff(out) >= 0.0)  # the order of depths is kept
    slope = np.diff(out) / np.diff(h)
    assert np.abs(np.diff(slope)).max() < 1e-2  # C1: no kink at the knee
    np.testing.assert_array_equal(zhang.soft_fold(h, 0.0), h)  # cap 0: no limit
    # one cap per height
    caps = np.array([1.0, 2.0])
    assert np.all(zhang.soft_fold(np.array([-3.0, -3.0]), caps) > -caps)
    assert zhang.fold_cap(4.0, 1.0) == pytest.approx(zhang.furrow_width(1.0) * 4.0 / zhang.FOLD_RATIO)
