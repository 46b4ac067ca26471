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
    # even depth all along; every furrow runs out of the field at both ends: no end to judge
    assert got["depth_cv_along"] == pytest.approx(0.0, abs=1e-6)
    assert got["taper_mm"] is None


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
                   "furrow_bulge_ratio": None, "depth_cv_along": None, "taper_mm": None}


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
    ((7, 0.0, -1, 1, 0.5), "too short: a dimple"),
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


# --------------------------------------------------------------------------- brow raise: depth and taper
@pytest.mark.parametrize("a", [0.2, 0.4])
def test_depth_varying_along_gives_its_coefficient_of_variation(a):
    # depth 0.6 (1 + a sin(2 pi x / 20)) over five whole periods: CV = a / sqrt(2)
    got = rm.forehead(furrow_field([10, 22, 34], present=lambda x: 1.0 + a * np.sin(2 * np.pi * x / 20.0)))
    assert got["furrows"] == 3
    assert got["depth_cv_along"] == pytest.approx(a / np.sqrt(2.0), rel=0.05)


def test_slanting_even_furrow_has_even_depth():
    # the parabola's vertex follows the cusp between grid lines: no false variation
    got = rm.forehead(furrow_field([20, 32, 44], height=100.0, tilt_deg=8.0).crop((-30, 30), (0, 100)))
    assert got["furrows"] == 3
    assert got["depth_cv_along"] < 0.1


def ramp(x, x0, x1, length):
    """1 between x0 + length and x1 - length, falling linearly to 0 at x0 and x1."""
    return np.clip((x - x0) / length, 0.0, 1.0) * np.clip((x1 - x) / length, 0.0, 1.0)


@pytest.mark.parametrize("length", [4.0, 10.0, 15.0])
def test_linear_taper_gives_its_length(length):
    # from 0.1 mm (the detection threshold) to the plateau's 0.6: length (1 - 0.1 / 0.6)
    got = rm.forehead(furrow_field([10, 22, 34], present=lambda x: ramp(x, -42.0, 42.0, length)))
    assert got["furrows"] == 3
    assert got["taper_mm"] == pytest.approx(length * (1.0 - 0.1 / 0.6), abs=0.6)


def test_furrow_running_out_of_the_region_has_no_end_there():
    # fades over 12 mm on the left, runs on past the field's right edge: only the left end counts
    got = rm.forehead(furrow_field([10, 22, 34], present=lambda x: np.clip((x + 42.0) / 12.0, 0.0, 1.0)))
    assert got["taper_mm"] == pytest.approx(12.0 * (1.0 - 0.1 / 0.6), abs=0.6)
    # ... also when it runs into cells no triangle covers (NaN) inside the field
    g = furrow_field([10, 22, 34], present=lambda x: np.clip((x + 42.0) / 12.0, 0.0, 1.0))
    g.h[:, g.xs > 40.0] = np.nan
    assert rm.forehead(g)["taper_mm"] == pytest.approx(12.0 * (1.0 - 0.1 / 0.6), abs=0.6)


def test_abrupt_furrow_end_has_a_short_taper():
    got = rm.forehead(furrow_field([10, 22, 34], present=lambda x: (np.abs(x) < 40.0).astype(float)))
    assert got["furrows"] == 3
    assert got["taper_mm"] < 1.0


def test_faint_furrow_has_no_taper_to_judge():
    # 0.15 mm deep, cut short at both ends: barely above the 0.1 mm threshold, all fade
    got = rm.forehead(furrow_field([10, 22, 34], depth=0.15, bulge=0.05,
                                   present=lambda x: (np.abs(x) < 40.0).astype(float)))
    assert got["furrows"] == 3
    assert got["taper_mm"] is None


# --------------------------------------------------------------------------- brow down
def test_glabella_counts_deep_lines_of_any_useful_length():
    # 6 mm long and 0.5 mm deep: a frown line now (the length is glabella_length_mm's business)
    got = rm.glabella(glabella_field([(-7, 0.0, -8, 8, 0.5), (7, 0.0, -3, 3, 0.5)]), 0.0)
    assert got["glabella_furrows_per_side"] == 1
    assert got["glabella_length_mm"] == pytest.approx(6.0, abs=0.6)
    assert got["glabella_separation_mm"] is None  # no side has two


@pytest.mark.parametrize("d", [3.0, 4.5, 7.0])
def test_glabella_separation_of_two_lines_on_a_side(d):
    grooves = [(-5, 0.0, -8, 8, 0.6), (-5 - d, 0.0, -8, 8, 0.6), (6, 0.0, -8, 8, 0.6)]
    got = rm.glabella(glabella_field(grooves), 0.0)
    assert got["glabella_furrows_per_side"] == 1
    assert got["glabella_separation_mm"] == pytest.approx(d, abs=0.1)
    both = rm.glabella(glabella_field(grooves + [(6 + d + 1, 0.0, -8, 8, 0.6)]), 0.0)
    assert both["glabella_furrows_per_side"] == 2
    assert both["glabella_separation_mm"] == pytest.approx(d, abs=0.1)  # the smaller side's pair


def test_glabella_separation_of_lines_one_above_the_other():
    # two lines on the same x, one above the other: their nearest points are 4 mm apart
    grooves = [(-6, 0.0, -10, -2, 0.6), (-6, 0.0, 2, 10, 0.6), (6, 0.0, -8, 8, 0.6)]
    got = rm.glabella(glabella_field(grooves), 0.0)
    assert got["glabella_separation_mm"] == pytest.approx(4.0, abs=0.6)


# --------------------------------------------------------------------------- anger: procerus line
def nose_root_field(angle_deg, x_half, depth, z0=8.0, width=32.0, height=22.0, step=STEP):
    """A groove at height z0 through x = 0, ``angle_deg`` from horizontal, from -x_half to
    x_half (mm along x), with a cusp profile of ``depth``."""
    xs = -0.5 * width + step * np.arange(int(width / step) + 1)
    zs = step * np.arange(int(height / step) + 1)
    X, Z = np.meshgrid(xs, zs)
    s = Z - z0 - np.tan(np.radians(angle_deg)) * X
    h = -depth * np.exp(-np.abs(s) / 0.6) * (np.abs(X) <= x_half)
    return rm.Grid.of(h, step, x0=xs[0], z0=0.0)


def test_horizontal_line_at_the_nose_root():
    got = rm.procerus(nose_root_field(0.0, 5.0, 0.4))
    assert got["procerus_line"] is True
    assert rm.procerus(nose_root_field(20.0, 5.0, 0.4))["procerus_line"] is True


@pytest.mark.parametrize("field, why", [
    (lambda: nose_root_field(0.0, 1.5, 0.4), "3 mm: too short"),
    (lambda: nose_root_field(0.0, 5.0, 0.15), "too shallow"),
    (lambda: nose_root_field(50.0, 8.0, 0.4), "too steep"),
    (lambda: rm.Grid.of(np.zeros((45, 65))), "no furrow"),
])
def test_no_procerus_line(field, why):
    assert rm.procerus(field())["procerus_line"] is False, why


def test_vertical_frown_lines_are_no_procerus_line():
    g = glabella_field([(-4, 0.0, -10, 10, 0.8), (4, 0.0, -10, 10, 0.8)], width=32.0, height=22.0)
    assert rm.procerus(g)["procerus_line"] is False


# --------------------------------------------------------------------------- squint: crow's feet
E = 60.0  # interocular distance of the synthetic faces (mm)


def fan_field(rays, outward=1.0, width=50.0, height=60.0, step=STEP, corner=(0.0, 0.0)):
    """Radial grooves from ``corner``: each (direction deg from the outward horizontal, inner
    radius, outer radius, depth), a Gaussian profile across of half-width 0.8 mm."""
    x0 = corner[0] - (width if outward < 0 else 0.0)
    xs = x0 + step * np.arange(int(width / step) + 1)
    zs = corner[1] - 0.5 * height + step * np.arange(int(height / step) + 1)
    X, Z = np.meshgrid(xs, zs)
    u, v = outward * (X - corner[0]), Z - corner[1]
    h = np.zeros_like(X)
    for angle, r0, r1, depth in rays:
        c, s = np.cos(np.radians(angle)), np.sin(np.radians(angle))
        along, across = u * c + v * s, -u * s + v * c
        h += -depth * np.exp(-((across / 0.8) ** 2)) * ((along >= r0) & (along <= r1))
    return rm.Grid.of(h, step, x0=xs[0], z0=zs[0])


RAYS = [(-40.0, 8.0, 28.0, 0.5), (-15.0, 8.0, 28.0, 0.5), (10.0, 8.0, 28.0, 0.5), (35.0, 8.0, 24.0, 0.4)]


@pytest.mark.parametrize("outward", [1.0, -1.0])
def test_fan_of_radial_grooves(outward):
    got = rm.crows_feet_side(fan_field(RAYS, outward), (0.0, 0.0), outward, E)
    assert got["count"] == 4
    assert got["fan_deg"] == pytest.approx(75.0, abs=2.0)
    assert sorted(got["lengths"]) == pytest.approx([16.0, 20.0, 20.0, 20.0], abs=1.0)
    assert got["depth"] == pytest.approx(0.5, abs=0.03)
    both = rm.crows_feet([got, rm.crows_feet_side(fan_field(RAYS[:2], outward), (0.0, 0.0), outward, E)])
    assert both["crows_feet_per_side"] == 2
    assert both["crows_feet_fan_deg"] == pytest.approx(75.0, abs=2.0)
    assert both["crows_feet_length_mm"] == pytest.approx(16.0, abs=1.0)
    assert both["crows_feet_depth_mm"] == pytest.approx(0.5, abs=0.03)


def test_crows_feet_corner_anywhere():
    got = rm.crows_feet_side(fan_field(RAYS, 1.0, corner=(47.0, 35.0)), (47.0, 35.0), 1.0, E)
    assert got["count"] == 4
    assert got["fan_deg"] == pytest.approx(75.0, abs=2.0)


def test_crows_feet_rejects_dimples_and_shallow_lines():
    rays = [(0.0, 10.0, 12.5, 0.5), (30.0, 8.0, 28.0, 0.15), (-30.0, 8.0, 28.0, 0.5)]
    got = rm.crows_feet_side(fan_field(rays), (0.0, 0.0), 1.0, E)
    assert got["count"] == 1  # the 2.5 mm dimple and the 0.15 mm line are no crow's feet
    assert got["fan_deg"] == 0.0
    empty = rm.crows_feet([rm.crows_feet_side(fan_field([]), (0.0, 0.0), 1.0, E)] * 2)
    assert empty == {"crows_feet_per_side": 0, "crows_feet_fan_deg": None, "crows_feet_length_mm": None,
                     "crows_feet_depth_mm": 0.0}


def test_crows_feet_are_measured_inside_the_region():
    # a groove from 3 to 50 mm: only the part from 0.1 E (6 mm) to 0.6 E (36 mm) outward counts
    got = rm.crows_feet_side(fan_field([(0.0, 3.0, 50.0, 0.5)], width=60.0), (0.0, 0.0), 1.0, E)
    assert got["count"] == 1
    assert got["lengths"][0] == pytest.approx(30.0, abs=1.0)


def test_crows_feet_length_is_measured_in_3d():
    g = fan_field([(0.0, 8.0, 28.0, 0.5)])
    sloped = rm.Grid.of(g.h, g.step, x0=g.xs[0], z0=g.zs[0], y=np.broadcast_to(g.xs[None, :], g.h.shape))
    got = rm.crows_feet_side(sloped, (0.0, 0.0), 1.0, E)  # the skin turns away at 45 degrees
    assert got["lengths"][0] == pytest.approx(20.0 * np.sqrt(2.0), abs=1.0)


# --------------------------------------------------------------------------- smile: knots
def smile_field(nub=None, step=STEP):
    """Below the eye, 60 x 50 mm: a clean nasolabial fold (cusp 0.8 mm deep, its round bulge
    0.35 mm high 4 mm above it) slanting at -50 degrees, and four shallow creases (0.25 mm)
    with their bulges.  ``nub``: (offset across the fold (mm, + above), height, half-width):
    a narrow bump 6 mm long beside the fold's lower part."""
    xs = step * np.arange(int(60 / step) + 1)
    zs = step * np.arange(int(50 / step) + 1)
    X, Z = np.meshgrid(xs, zs)
    c, s = np.cos(np.radians(-50.0)), np.sin(np.radians(-50.0))
    along, across = (X - 30.0) * c + (Z - 25.0) * s, -(X - 30.0) * s + (Z - 25.0) * c
    inside = np.abs(along) <= 18.0
    h = (-0.8 * np.exp(-np.abs(across) / 0.8) + 0.35 * np.exp(-(((across - 4.0) / 2.5) ** 2))) * inside
    for z0 in (8.0, 16.0, 34.0, 42.0):  # the creases, level, away from the fold
        cusp = -0.25 * np.exp(-np.abs(Z - z0) / 0.6) + 0.12 * np.exp(-(((Z - z0 - 3.0) / 1.5) ** 2))
        h += cusp * (np.abs(X - (10.0 if z0 > 25 else 50.0)) <= 8.0)
    if nub is not None:
        offset, height, half = nub
        h += height * np.exp(-(((across - offset) / half) ** 2)) * (np.abs(along - 8.0) <= 3.0)
    return rm.Grid.of(h, step)


def test_clean_fold_has_no_knot():
    got = rm.knots(smile_field())
    assert got["knots"] == 0
    assert rm.knots(furrow_field([10, 22, 34, 46]))["knots"] == 0  # even furrows either
    assert rm.knots(rm.Grid.of(np.zeros((40, 40))))["knots"] == 0


def test_slit_beside_a_nub_is_a_knot():
    got = rm.knots(smile_field(nub=(-1.8, 0.6, 0.7)))
    assert got["knots"] == 1
    x, z, height, dist = got["where"][0]
    assert height == pytest.approx(0.6, abs=0.1) and dist <= 2.5
    # the knot is where the nub is: 8 mm down the fold from its middle, 1.8 mm below it
    c, s = np.cos(np.radians(-50.0)), np.sin(np.radians(-50.0))
    assert (x, z) == pytest.approx((30.0 + 8.0 * c + 1.8 * s, 25.0 + 8.0 * s - 1.8 * c), abs=0.8)


@pytest.mark.parametrize("nub, why", [
    ((-7.0, 0.6, 0.7), "a sharp bump far from the fold"),
    ((4.0, 0.25, 3.0), "the fold's bulge higher, but round"),
    ((-1.8, 0.15, 0.7), "a low bump"),
])
def test_no_knot(nub, why):
    assert rm.knots(smile_field(nub=nub))["knots"] == 0, why


# ------------------------------------------------------------------------- brow down: the frown line's offset
def test_glabella_offset_from_the_inner_brows():
    got = rm.glabella(glabella_field([(-7, 0.0, -8, 8, 0.5), (8, 0.0, -8, 8, 0.6)]), 0.0)
    off = rm.glabella_offset(got["lines"], {"L": 9.5, "R": -10.0})
    assert off["sides"]["R"] == pytest.approx((-7.0, -10.0, 3.0), abs=0.1)
    assert off["sides"]["L"] == pytest.approx((8.0, 9.5, 1.5), abs=0.1)
    assert off["glabella_offset_mm"] == pytest.approx(3.0, abs=0.1)  # the larger side
    # the deepest frown line of a side counts; its centre is the mean x of its deep stretch
    two = rm.glabella(glabella_field([(-7, 0.0, -8, 8, 0.5), (-13, 0.0, -8, 8, 0.9), (8, 0.0, -8, 8, 0.6)]),
                      0.0)
    right = rm.glabella_offset(two["lines"], {"L": 9.5, "R": -10.0})["sides"]["R"]
    assert right[0] == pytest.approx(-13.0, abs=0.1)
    # ... only the part at least 0.3 mm deep: a line 20 degrees from vertical through x = 6 at z = 0,
    # 0.6 mm deep below z = 0 and 0.2 mm above: its deep stretch's mean x is 6 - 4 tan 20
    slant = glabella_field([(-7, 0.0, -8, 8, 0.5), (6, 20.0, -8, -0.25, 0.6), (6, 20.0, 0, 8, 0.2)])
    got = rm.glabella(slant, 0.0)
    assert len(got["lines"]["L"]) == 1
    centre = rm.glabella_offset(got["lines"], {"L": 9.5, "R": -10.0})["sides"]["L"][0]
    assert centre == pytest.approx(6.0 - 4.0 * np.tan(np.radians(20.0)), abs=0.2)
    one = rm.glabella(glabella_field([(-7, 0.0, -8, 8, 0.5)]), 0.0)
    none = rm.glabella_offset(one["lines"], {"L": 9.5, "R": -10.0})
    assert none["glabella_offset_mm"] is None and none["sides"]["L"] is None


# --------------------------------------------------------------------------- compression
def sheet(n=8, size=10.0):
    """A flat n x n vertex sheet in the x-z plane (y = 0), two triangles per square."""
    u = np.linspace(0.0, size, n)
    X, Z = np.meshgrid(u, u)
    pts = np.stack([X.ravel(), np.zeros(X.size), Z.ravel()], 1)
    k = np.arange(n * n).reshape(n, n)
    a, b, c, d = k[:-1, :-1].ravel(), k[:-1, 1:].ravel(), k[1:, 1:].ravel(), k[1:, :-1].ravel()
    return pts, np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def rotation(axis, deg):
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    i, j = [(1, 2), (0, 2), (0, 1)][axis]
    r = np.eye(3)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


@pytest.mark.parametrize("sx, sz, want", [(0.8, 1.0, 0.2), (0.7, 1.2, 0.3), (1.0, 1.0, 0.0), (1.1, 1.3, 0.0),
                                          (0.9, 0.6, 0.4)])
def test_uniform_compression_of_a_sheet(sx, sz, want):
    rest, tris = sheet()
    posed = rest * (sx, 1.0, sz)
    posed = posed @ rotation(0, 35.0).T @ rotation(2, -20.0).T + (3.0, -4.0, 1.0)  # moved and turned in 3D
    c, area = rm.triangle_compression(rest, posed, tris)
    assert np.allclose(c, want, atol=1e-9)
    assert np.allclose(area, (10.0 / 7) ** 2 / 2)
    assert np.allclose(rm.vertex_compression(rest, posed, tris), want, atol=1e-9)


def test_vertex_compression_is_the_area_weighted_mean():
    rest = np.array([[0.0, 0, 0], [1, 0, 0], [0, 0, 1], [-2, 0, 0], [5, 0, 5]])
    tris = np.array([[0, 1, 2], [0, 2, 3]])  # areas 0.5 and 1.0; vertex 4 on none
    posed = rest.copy()
    posed[1, 0] = 0.5  # the first triangle squeezed to half across x
    c = rm.vertex_compression(rest, posed, tris)
    assert c[1] == pytest.approx(0.5)
    assert c[3] == pytest.approx(0.0)
    assert c[0] == pytest.approx(0.5 * 0.5 / 1.5) and c[2] == pytest.approx(0.5 * 0.5 / 1.5)
    assert c[4] == 0.0


def test_pearson():
    rng = np.random.default_rng(1)
    a = rng.normal(size=200)
    assert rm.pearson(a, 2.0 * a + 1.0) == pytest.approx(1.0)
    assert rm.pearson(a, -a) == pytest.approx(-1.0)
    noisy = rm.pearson(a, a + rng.normal(size=200))
    assert 0.5 < noisy < 0.9  # 1 / sqrt(2) expected
    assert rm.pearson(a[:19], a[:19]) is None  # too few
    assert rm.pearson(a, np.full(200, 0.3)) is None  # no variance
    assert rm.pearson(a, 0.3 + 1e-8 * a) is None  # ... but round-off
    b = a.copy()
    b[:190] = np.nan
    assert rm.pearson(a, b) is None  # only 10 finite pairs


def test_vertex_normals_of_a_sheet_face_minus_y():
    rest, tris = sheet()
    assert np.allclose(rm.vertex_normals(rest, tris), (0.0, -1.0, 0.0))


# --------------------------------------------------------------------------- brow down: the eye corners
def test_corner_max_abs_lateral_near_and_outside_the_lids():
    pts = np.array([[40.0, 0, 0], [45, 0, 0], [35, 0, 0], [49, 0, 3], [60, 0, 0], [44, 0, 1]])
    h = np.array([0.01, -0.2, -0.9, 0.3, -2.0, -0.5])
    lids = np.array([False, False, False, False, False, True])
    # corner at x 40 going +x, radius 10: points 0, 1, 3 (2 is medial, 4 too far, 5 on the lid)
    assert rm.corner_max_abs(pts, h, (40.0, 0, 0), 1.0, 10.0, lids) == (pytest.approx(0.3), 3)
    assert rm.corner_max_abs(pts, h, (40.0, 0, 0), -1.0, 10.0, lids) == (pytest.approx(0.9), 2)
    assert rm.corner_max_abs(pts, h, (40.0, 0, 0), 1.0, 10.0)[0] == pytest.approx(0.5)


# --------------------------------------------------------------------------- left/right balance
def test_lr_ratio():
    assert rm.lr_ratio(0.5, 0.5) == 1.0
    assert rm.lr_ratio(0.4, 0.6) == pytest.approx(1.5) and rm.lr_ratio(0.6, 0.4) == pytest.approx(1.5)
    assert rm.lr_ratio(None, 0.5) is None and rm.lr_ratio(0.5, 0.0) is None
    got = rm.lr_balance({"L": 0.3, "R": 0.6}, {"L": 2, "R": 3})
    assert got == {"ratio": pytest.approx(2.0), "counts": [2, 3]}


def test_forehead_sides_of_a_mirrored_field_balance():
    sides = rm.forehead_sides(furrow_field([10, 22, 34, 46]), 0.0)
    assert sides["L"] == pytest.approx(sides["R"]) and sides["L"][1] == 4
    got = rm.lr_balance({s: v[0] for s, v in sides.items()}, {s: v[1] for s, v in sides.items()})
    assert got == {"ratio": pytest.approx(1.0), "counts": [4, 4]}


def test_forehead_sides_deeper_on_one_side():
    # the right half (x < 0) at 0.6 mm, the left at 0.3 mm; one furrow only on the right
    g = furrow_field([10, 22, 34, 46], present=lambda x: np.where(x < 0, 1.0, 0.5))
    extra = furrow_field([55], height=60.0, bulge=0.0, present=lambda x: (x < -5).astype(float))
    g = rm.Grid.of(g.h + extra.h, STEP, x0=g.xs[0])
    sides = rm.forehead_sides(g, 0.0)
    assert sides["R"][0] / sides["L"][0] == pytest.approx(2.0, rel=0.05)
    assert (sides["L"][1], sides["R"][1]) == (4, 5)
    # a ridge-line that barely crosses the split is not counted on the far side
    short = furrow_field([20], present=lambda x: (x < 5.0).astype(float))
    assert rm.forehead_sides(short, 0.0)["L"][1] == 0 and rm.forehead_sides(short, 0.0)["R"][1] == 1
    empty = rm.forehead_sides(rm.Grid.of(np.zeros((40, 40))), 10.0)
    assert rm.lr_ratio(empty["L"][0], empty["R"][0]) is None


def test_band_deepest():
    g = rm.Grid.of(np.array([[0.1, -0.4], [-0.9, np.nan]]))
    assert rm.band_deepest(g, [[True, True], [False, True]]) == pytest.approx(0.4)
    assert rm.band_deepest(g, [[False, False], [False, True]]) is None


# --------------------------------------------------------------------------- ridge curvature
def crease(sigma, depth=0.5, step=STEP):
    """A vertical Gaussian crease -depth exp(-x^2 / (2 sigma^2)) at x = 0 on a 30 x 20 mm grid."""
    xs = -15.0 + step * np.arange(int(30 / step) + 1)
    zs = step * np.arange(int(20 / step) + 1)
    X, _Z = np.meshgrid(xs, zs)
    return rm.Grid.of(-depth * np.exp(-0.5 * (X / sigma) ** 2), step, x0=xs[0])


def test_ridge_curvature_max_of_a_gaussian_crease():
    narrow, wide = rm.ridge_curvature_max(crease(0.5)), rm.ridge_curvature_max(crease(1.5))
    assert narrow["ridge_curvature_max"] > 2.0 * wide["ridge_curvature_max"]
    # blurred with sigma 0.5 the crease is a Gaussian of s^2 = sigma^2 + 0.25 and depth 0.5 sigma / s:
    # its curvature at the bottom 0.5 sigma / s^3
    s = np.sqrt(1.5 ** 2 + 0.25)
    assert wide["ridge_curvature_max"] == pytest.approx(0.5 * 1.5 / s ** 3, rel=0.15)
    assert wide["where"][0] == pytest.approx(0.0, abs=0.3)
    assert wide["where"][2] == pytest.approx(-0.5, abs=0.01)
    # a bulge (a crest) as sharp as the crease reads the same
    crest = crease(1.5)
    crest.h = -crest.h
    assert rm.ridge_curvature_max(crest)["ridge_curvature_max"] == pytest.approx(wide["ridge_curvature_max"])
    # nothing 0.1 mm deep or high: no crease
    assert rm.ridge_curvature_max(crease(0.5, depth=0.08)) == {"ridge_curvature_max": 0.0, "where": None}


# --------------------------------------------------------------------------- slits
def groove(profile, across="x", step=STEP):
    """A straight groove with the height profile ``profile(s)`` (s mm across it) at s = 0:
    vertical (across x) on a 30 x 20 mm grid, or horizontal (across z) on a 20 x 30 mm one."""
    a = -15.0 + step * np.arange(int(30 / step) + 1)
    b = step * np.arange(int(20 / step) + 1)
    if across == "x":
        X, _Z = np.meshgrid(a, b)
        return rm.Grid.of(profile(X), step, x0=a[0], z0=b[0])
    _X, Z = np.meshgrid(b, a)
    return rm.Grid.of(profile(Z), step, x0=b[0], z0=a[0])


def v_groove(s):  # 0.5 mm deep, crossing zero at +-0.6 mm, a shoulder beyond
    return np.minimum(-0.5 + 0.5 * np.abs(s) / 0.6, 0.5)


def valley(s):  # 0.5 mm deep, smooth, crossing zero at +-3 mm
    return np.minimum(-0.5 * (1.0 - (s / 3.0) ** 2), 0.3)


@pytest.mark.parametrize("across", ["x", "z"])
def test_narrow_v_groove_is_a_slit_and_a_wide_valley_is_not(across):
    got = rm.slits(groove(v_groove, across), across)
    assert got["slit_count"] == 1
    x, z, width, depth = got["slits"][0]
    assert width == pytest.approx(1.2, abs=0.05) and depth == pytest.approx(0.5, abs=0.01)
    assert (x if across == "x" else z) == pytest.approx(0.0, abs=0.3)
    wide = rm.slits(groove(valley, across), across)
    assert wide["slit_count"] == 0
    assert len(wide["lines"]) == 1 and wide["lines"][0][2] == pytest.approx(6.0, abs=0.1)
    assert wide["lines"][0][4] == pytest.approx(12.0, rel=0.05)


def test_slit_ratio_threshold_and_unknown_widths():
    # a V crossing zero at +-0.8: width 1.6, depth 0.5, ratio 3.2: not a slit at 3, a slit at 3.5
    g = groove(lambda s: np.minimum(-0.5 + 0.5 * np.abs(s) / 0.8, 0.5))
    assert rm.slits(g, "x")["slit_count"] == 0
    assert rm.slits(g, "x", ratio=3.5)["slit_count"] == 1
    # a groove in a field that never comes back to zero: no width known, no slit
    low = rm.slits(groove(lambda s: np.minimum(v_groove(s), -0.05)), "x")
    assert low["slit_count"] == 0 and low["lines"][0][2] is None
    # ... nor when the walk meets an invalid cell first
    g = groove(v_groove)
    g.h[:, np.abs(g.xs - 0.5) < 0.1] = np.nan
    assert rm.slits(g, "x")["slit_count"] == 0
    # a shallow groove (under 0.1 mm) is not looked at
    assert rm.slits(groove(lambda s: 0.15 * v_groove(s)), "x")["lines"] == []
