"""benchmarks/realism_measures.py on synthetic height fields whose answers are known."""

import numpy as np
import pytest

from benchmarks import realism_measures as rm

STEP = 0.5


def furrow_field(positions, width=100.0, height=60.0, tilt_deg=0.0, depth=0.6, bulge=0.3,
                 present=None, step=STEP):
    """Horizontal furrows at the heights ``positions`` (mm, at x = 0, the field's centre),
    tilted by ``tilt_deg``: each a sharp cusp -depth exp(-|s|/0.6) with a round bulge
    bulge exp(-(s/2)^2) halfway to the next.  ``present(x)``: where the furrows exist."""
    xs = -0.5 * width + step * np.arange(int(width / step) + 1)
    zs = step * np.arange(int(height / step) + 1)
    X, Z = np.meshgrid(xs, zs)
    s0 = Z - np.tan(np.radians(tilt_deg)) * X
    h = np.zeros_like(X)
    positions = sorted(positions)
    for k, p in enumerate(positions):
        cusp = -depth * np.exp(-np.abs(s0 - p) / 0.6)
        if present is not None:
            cusp = cusp * present(X)
        h += cusp
        if k + 1 < len(positions):
            mid = 0.5 * (p + positions[k + 1])
            h += bulge * np.exp(-(((s0 - mid) / 2.0) ** 2))
    return rm.Grid.of(h, step, x0=xs[0], z0=0.0)


def test_parallel_furrows_counted_continuous_level_even():
    got = rm.forehead(furrow_field([10, 22, 34, 46]))
    assert got["furrows"] == 4
    assert got["continuity"] == pytest.approx(1.0)
    assert got["angle_deg"] == pytest.approx(0.0, abs=0.2)
    assert got["spacing_cv"] == pytest.approx(0.0, abs=0.02)
    # the cusp is 0.6 deep, the bulge 0.3 high (plus the cusps' tails)
    assert got["furrow_bulge_ratio"] == pytest.approx(2.0, rel=0.1)


@pytest.mark.parametrize("tilt", [6.0, 12.0, -20.0])
def test_tilted_furrows_give_their_angle(tilt):
    got = rm.forehead(furrow_field([20, 32, 44], height=100.0, tilt_deg=tilt).crop((-30, 30), (0, 100)))
    assert got["furrows"] == 3
    assert got["angle_deg"] == pytest.approx(abs(tilt), abs=0.5)
    # against a brow line tilted the same way, the furrows are parallel to it
    same = rm.forehead(furrow_field([20, 32, 44], height=100.0, tilt_deg=tilt).crop((-30, 30), (0, 100)),
                       brow_angle_deg=tilt)
    assert same["angle_deg"] == pytest.approx(0.0, abs=0.5)


def test_broken_furrows_have_low_continuity_but_count_once():
    # each furrow: 15 mm present, 10 mm missing, over the 100 mm width
    def present(x):
        return (np.mod(x + 50.0, 25.0) < 15.0).astype(float)

    got = rm.forehead(furrow_field([10, 22, 34, 46], present=present))
    assert got["furrows"] == 4
    assert got["continuity"] == pytest.approx(0.15, abs=0.02)


def test_furrow_broken_at_the_midline_is_one_furrow_of_half_the_width():
    got = rm.forehead(furrow_field([10, 22, 34, 46], present=lambda x: (np.abs(x) > 3.0).astype(float)))
    assert got["furrows"] == 4
    assert got["continuity"] == pytest.approx(0.47, abs=0.02)


def test_furrows_stepped_at_the_midline_are_one_row_each():
    # the right half's furrows 2.5 mm higher than the left's: a kink, not new furrows
    left = furrow_field([10, 22, 34, 46], present=lambda x: (x < -1.0).astype(float))
    right = furrow_field([12.5, 24.5, 36.5, 48.5], present=lambda x: (x > 1.0).astype(float))
    got = rm.forehead(rm.Grid.of(left.h + right.h, STEP, x0=left.xs[0]))
    assert got["furrows"] == 4
    assert got["continuity"] == pytest.approx(0.49, abs=0.02)


def test_uneven_spacing_gives_its_coefficient_of_variation():
    positions = [10, 16, 30, 36]  # gaps 6, 14, 6: mean 8.67, standard deviation 3.77
    got = rm.forehead(furrow_field(positions))
    gaps = np.diff(positions)
    assert got["furrows"] == 4
    assert got["spacing_cv"] == pytest.approx(np.std(gaps) / np.mean(gaps), abs=0.02)
    assert got["spacing_cv"] > 0.35


def test_bulge_dominated_profile_has_ratio_below_one():
    got = rm.forehead(furrow_field([10, 22, 34, 46], depth=0.2, bulge=0.6))
    assert got["furrows"] == 4
    assert got["furrow_bulge_ratio"] < 1.0


def test_fewer_than_three_furrows_have_no_spacing_cv():
    got = rm.forehead(furrow_field([20, 35]))
    assert got["furrows"] == 2
    assert got["spacing_cv"] is None


def test_zero_field_has_no_furrows():
    got = rm.forehead(rm.Grid.of(np.zeros((120, 200))))
    assert got == {"furrows": 0, "continuity": 0.0, "angle_deg": None, "spacing_cv": None,
                   "furrow_bulge_ratio": None}


def test_short_dimples_are_not_furrows():
    # 5 mm long dashes every 20 mm: under a tenth of the 100 mm width
    def present(x):
        return (np.mod(x + 50.0, 20.0) < 5.0).astype(float)

    got = rm.forehead(furrow_field([10, 22, 34], present=present))
    assert got["furrows"] == 0


def glabella_field(grooves, width=40.0, height=40.0, step=STEP):
    """Grooves (x at z = 0 (mm), angle from vertical (deg), z from, z to, depth), each a
    cusp across x; the midline at x = 0, the field's centre."""
    xs = -0.5 * width + step * np.arange(int(width / step) + 1)
    zs = -0.5 * height + step * np.arange(int(height / step) + 1)
    X, Z = np.meshgrid(xs, zs)
    h = np.zeros_like(X)
    for x0, angle, z0, z1, depth in grooves:
        s = X - x0 - np.tan(np.radians(angle)) * Z
        h += -depth * np.exp(-np.abs(s) / 0.6) * ((Z >= z0) & (Z <= z1))
    return rm.Grid.of(h, step, x0=xs[0], z0=zs[0])


def test_vertical_glabella_furrows_found_with_length_and_depth():
    got = rm.glabella(glabella_field([(-7, 10.0, -8, 6, 0.5), (7, -10.0, -6, 10, 0.8)]), 0.0)
    assert got["glabella_furrows_per_side"] == 1
    # the shorter side: 14 mm of z at 10 degrees from vertical
    assert got["glabella_length_mm"] == pytest.approx(14.0 / np.cos(np.radians(10.0)), abs=0.6)
    assert got["glabella_depth_mm"] == pytest.approx(0.5, abs=0.02)


def test_glabella_counts_the_weaker_side():
    one_side = rm.glabella(glabella_field([(-7, 0.0, -8, 8, 0.5), (-12, 0.0, -8, 8, 0.5)]), 0.0)
    assert one_side["glabella_furrows_per_side"] == 0
    assert one_side["glabella_length_mm"] == 0.0
    two_each = rm.glabella(glabella_field([(-6, 0.0, -8, 8, 0.5), (-12, 0.0, -8, 8, 0.5),
                                           (6, 0.0, -8, 8, 0.5), (12, 0.0, -8, 8, 0.5)]), 0.0)
    assert two_each["glabella_furrows_per_side"] == 2


@pytest.mark.parametrize("groove, why", [
    ((7, 0.0, -3, 3, 0.5), "too short"),
    ((7, 0.0, -8, 8, 0.2), "too shallow"),
    ((7, 45.0, -8, 8, 0.5), "too far from vertical"),
])
def test_glabella_rejects(groove, why):
    got = rm.glabella(glabella_field([(-7, 0.0, -8, 8, 0.5), groove]), 0.0)
    assert got["glabella_furrows_per_side"] == 0, why


def test_glabella_depth_follows_the_shallower_side():
    got = rm.glabella(glabella_field([(-7, 0.0, -8, 8, 0.5), (7, 0.0, -8, 8, 0.2)]), 0.0)
    assert got["glabella_length_mm"] == 0.0  # nowhere 0.3 mm deep on the x > 0 side
    assert got["glabella_depth_mm"] == pytest.approx(0.2, abs=0.02)


def test_glabella_length_is_measured_in_3d():
    # a 16 mm groove on a surface sloping back 45 degrees: 16 sqrt(2) along the skin
    g = glabella_field([(-7, 0.0, -8, 8, 0.5), (7, 0.0, -8, 8, 0.5)])
    g = rm.Grid.of(g.h, g.step, x0=g.xs[0], z0=g.zs[0], y=np.broadcast_to(g.zs[:, None], g.h.shape))
    got = rm.glabella(g, 0.0)
    assert got["glabella_length_mm"] == pytest.approx(16.0 * np.sqrt(2.0), abs=0.6)


def test_zero_glabella():
    got = rm.glabella(rm.Grid.of(np.zeros((80, 80))), 20.0)
    found = (got["glabella_furrows_per_side"], got["glabella_length_mm"], got["glabella_depth_mm"])
    assert found == (0, 0.0, 0.0)


def test_nasolabial_deepest():
    xs = np.arange(-40.0, 40.5, 0.5)
    zs = np.arange(0.0, 50.5, 0.5)
    X, Z = np.meshgrid(xs, zs)
    grid = rm.Grid.of(np.zeros_like(X), 0.5, x0=xs[0], z0=zs[0])
    band = rm.segment_band(grid, (15.0, 40.0), (25.0, 10.0), 4.0)
    assert band[np.searchsorted(zs, 25.0), np.searchsorted(xs, 20.0)]
    assert not band[np.searchsorted(zs, 25.0), np.searchsorted(xs, 0.0)]
    fold = -0.8 * np.exp(-np.abs(X - (25.0 - (Z - 10.0) / 3.0)) / 0.8) * ((Z > 12) & (Z < 38))
    grid.h[:] = fold
    assert rm.deepest_in_band(grid, band)[0]
    # a deeper crease outside the band (under the eye) takes over
    grid.h[:] = fold - 1.2 * np.exp(-np.abs(Z - 48.0) / 0.8) * (np.abs(X) < 10)
    hit, low, other = rm.deepest_in_band(grid, band)
    assert not hit and low == pytest.approx(-1.2, abs=0.05) and other == low
    grid.h[:] = 0.0  # no furrow at all
    assert not rm.deepest_in_band(grid, band)[0]


def test_front_grid_interpolates_linearly_and_keeps_the_nearest_surface():
    # two squares facing -Y: the near one (y = -5) over the left half of the far one (y = 0)
    def square(x0, x1, y, base):
        p = np.array([[x0, y, 0.0], [x1, y, 0.0], [x1, y, 20.0], [x0, y, 20.0]])
        return p, np.array([[0, 1, 2], [0, 2, 3]]) + base  # wound to face -Y

    far, ft = square(0.0, 20.0, 0.0, 0)
    near, nt = square(0.0, 10.0, -5.0, 4)
    points = np.vstack([far, near])
    heights = np.concatenate([0.1 * far[:, 0] + 0.05 * far[:, 2], np.full(4, 9.0)])
    grid = rm.front_grid(points, np.vstack([nt, ft]), heights, (0.0, 20.0), (0.0, 20.0), step=0.5)
    X, Z = np.meshgrid(grid.xs, grid.zs)
    right = (X > 10.5) & (X < 19.5) & (Z > 0.5) & (Z < 19.5)
    left = (X < 9.5) & (X > 0.5) & (Z > 0.5) & (Z < 19.5)
    assert np.allclose(grid.h[right], 0.1 * X[right] + 0.05 * Z[right], atol=1e-5)
    assert np.allclose(grid.h[left], 9.0) and np.allclose(grid.y[left], -5.0)
    # a triangle facing away (+Y) is not drawn
    back = rm.front_grid(points, np.vstack([ft[:, ::-1]]), heights, (0.0, 20.0), (0.0, 20.0), step=0.5)
    assert not back.valid.any()


def test_max_abs():
    assert rm.max_abs([0.1, -0.7, 0.3], [True, True, False]) == pytest.approx(0.7)
    assert rm.max_abs([0.1, -0.7], [False, False]) == 0.0
