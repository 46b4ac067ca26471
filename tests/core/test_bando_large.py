"""Large-scale wrinkles per frame (Bando et al. 2002, §6-7): the curve's profile, modulated by
the shrinkage across it, on a flat grid with analytic deformations."""

import numpy as np
import pytest

from wrinkle_addon.core.bando import curves, large, mapped

SIZE = 0.1  # metres: the grid is SIZE x SIZE, UV = position / SIZE


def _grid(n=81):
    x, y = np.meshgrid(np.linspace(0, SIZE, n), np.linspace(0, SIZE, n))
    rest = np.stack([x.ravel(), y.ravel(), np.zeros(n * n)], 1)
    i = np.arange(n - 1)
    a = (i[:, None] * n + i[None, :]).ravel()
    tris = np.concatenate([np.stack([a, a + 1, a + n + 1], 1), np.stack([a, a + n + 1, a + n], 1)])
    uv = rest[:, :2][tris] / SIZE
    return rest, tris, mapped.mapped_mesh(tris, uv, len(rest))


def _curve(y=0.5, d=0.001, w=0.002):
    return curves.Curve(np.array([[0.2, y], [0.8, y]]), d, w, 0.01)


def _heights(plan, m, skin):
    return large.heights(plan, skin.astype(np.float32))


def test_rest_heights_are_r_times_the_profile():
    rest, _tris, m = _grid()
    plan = large.build(m, rest, [_curve()], [0.4])
    h = _heights(plan, m, rest)
    mid = (np.abs(rest[plan.footprint, 0] - 0.05) < 1e-9)  # the middle of the curve, x = 0.05
    l = np.abs(rest[plan.footprint, 1] - 0.05)
    np.testing.assert_allclose(h[mid], 0.4 * curves.profile(l[mid], 0.001, 0.002)
                               * curves.window(l[mid], 0.002), atol=1e-7)
    assert h.min() == pytest.approx(-0.4 * 0.001, rel=1e-4)


def test_compression_across_the_curve_deepens_it_and_along_it_does_not():
    rest, _tris, m = _grid()
    plan = large.build(m, rest, [_curve()], [0.0])
    assert np.abs(_heights(plan, m, rest)).max() < 1e-9  # r = 0: nothing at rest (float32 rounding)
    across = rest * [1.0, 0.8, 1.0]  # the skin shrinks by 20 % across the (horizontal) curve
    s = large.shrinkage_at(plan, across.astype(np.float32))
    np.testing.assert_allclose(s, 0.2, atol=1e-5)
    h = _heights(plan, m, across)
    assert h.min() == pytest.approx(-0.2 * 0.001, rel=1e-3)  # M(0.2) = 0.2 for r = 0
    along = rest * [0.8, 1.0, 1.0]
    assert np.abs(_heights(plan, m, along)).max() < 1e-9
    stretched = rest * [1.0, 1.2, 1.0]
    assert np.abs(_heights(plan, m, stretched)).max() < 1e-9


def test_two_crossing_curves_sum_each_with_its_own_shrinkage():
    rest, _tris, m = _grid()
    horizontal = _curve()
    vertical = curves.Curve(np.array([[0.5, 0.2], [0.5, 0.8]]), 0.001, 0.002, 0.01)
    plan = large.build(m, rest, [horizontal, vertical], [0.0, 0.0])
    squeeze_y = (rest * [1.0, 0.8, 1.0]).astype(np.float32)
    h = _heights(plan, m, squeeze_y)
    only_h = _heights(large.build(m, rest, [horizontal], [0.0]), m, squeeze_y)
    plan_h = large.build(m, rest, [horizontal], [0.0])
    both = dict(zip(plan.footprint, h))
    for v, value in zip(plan_h.footprint, only_h):
        assert both[v] == pytest.approx(value, abs=1e-9)  # the vertical curve adds nothing
    centre = np.argmin(np.linalg.norm(rest - [0.05, 0.05, 0], axis=1))
    squeeze_both = (rest * [0.8, 0.8, 1.0]).astype(np.float32)
    assert dict(zip(plan.footprint, _heights(plan, m, squeeze_both)))[centre] == pytest.approx(
        -2 * 0.2 * 0.001, rel=1e-3)


def test_a_seam_vertex_gets_the_average_of_its_copies():
    rest, tris, _m = _grid(21)
    uv = rest[:, :2][tris] / SIZE
    right = uv[:, :, 0].mean(1) > 0.5
    uv[right] += 1e-7  # the right half is its own island, touching the left (a seam at x = 0.5)
    m = mapped.mapped_mesh(tris, uv, len(rest))
    plan = large.build(m, rest, [curves.Curve(np.array([[0.2, 0.5], [0.8, 0.5]]), 0.001, 0.005, 0.01)], [1.0])
    h = dict(zip(plan.footprint, _heights(plan, m, rest)))
    seam = np.flatnonzero((np.abs(rest[:, 0] - 0.05) < 1e-9) & (np.abs(rest[:, 1] - 0.05) < 1e-9))[0]
    assert h[seam] == pytest.approx(-0.001, rel=1e-3)  # not -0.002: the two copies are averaged


@pytest.mark.parametrize("r", [0.0, 0.25, 0.5, 1.0])
@pytest.mark.parametrize("factor", [0.7, 1.0, 1.3])
def test_the_frame_modulation_is_eq5(r, factor):
    from wrinkle_addon.core.bando import field

    rest, _tris, m = _grid(41)
    plan = large.build(m, rest, [_curve()], [r])
    skin = (rest * [1.0, factor, 1.0]).astype(np.float32)
    s = large.shrinkage_at(plan, skin)
    expected = np.bincount(plan.entry_slot, weights=plan.static * field.modulation(s.astype(np.float64), r),
                           minlength=len(plan.footprint))
    np.testing.assert_allclose(large.heights(plan, skin), expected, atol=1e-9)
