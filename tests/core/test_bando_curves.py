"""Bando et al. 2002, §6-8: the large-scale wrinkle profile, curves, footprints and plan."""

import numpy as np
import pytest

from tests.core.meshes import uv_grid
from wrinkle_addon.core.bando import curves
from wrinkle_addon.core.bezier import bezier

_trapz = np.trapezoid if hasattr(np, "trapezoid") else np.trapz
SCALE = 0.2  # metres per UV unit on the flat test grids
D, W = 0.002, 0.004  # 2 mm deep, 4 mm wide (the paper's face wrinkles: 2-12 mm)


def _flat(n=201, sx=SCALE, sy=SCALE):
    """An n x n grid over the UV square, flat in 3-D with ``x = u sx``, ``y = v sy``."""
    uv, tris = uv_grid(n)
    pos = np.stack([uv[:, 0] * sx, uv[:, 1] * sy, np.zeros(len(uv))], 1)
    return uv, tris, pos


def _segment_distance(p, a, b):
    """Reference distance (N,) from 3-D points to the segment ab."""
    e = b - a
    t = np.clip(((p - a) @ e) / (e @ e), 0.0, 1.0)
    return np.linalg.norm(p - (a + t[:, None] * e), axis=1)


def _line(a, b, k=50):
    return np.linspace(a, b, k)


def _de_casteljau(ctrl, t):
    pts = np.array(ctrl, float)
    while len(pts) > 1:
        pts = (1 - t) * pts[:-1] + t * pts[1:]
    return pts[0]


# --------------------------------------------------------------------------- profile (eqs. 2-3)
def test_profile_has_zero_integral():
    """Eq. 3: the volume pushed down at the furrow makes up the bulge."""
    for d, w in [(1.0, 1.0), (0.002, 0.004), (0.012, 0.003)]:
        l = np.linspace(0.0, 50 * w, 2_000_001)
        assert abs(_trapz(curves.profile(l, d, w), l)) / (d * w) < 1e-6


def test_windowed_profile_integral_is_small_and_as_documented():
    d, w = 0.003, 0.005
    l = np.linspace(0.0, 50 * w, 2_000_001)
    s = curves.profile(l, d, w) * curves.window(l, w)
    integral = _trapz(s, l) / (d * w)
    assert abs(integral) < 1.5e-3
    assert integral == pytest.approx(curves.WINDOWED_INTEGRAL, abs=1e-6)
    assert np.all(s[l >= curves.CUTOFF * w] == 0.0)
    np.testing.assert_array_equal(s[l <= curves.WINDOW_START * w],
                                  curves.profile(l, d, w)[l <= curves.WINDOW_START * w])
    # the cut-off is where |S| is below 1e-3 d
    assert abs(curves.profile(9 * w, d, w)) < 1e-3 * d


def test_profile_furrow_and_bulge():
    d, w = 0.002, 0.004
    assert curves.profile(0.0, d, w) == pytest.approx(-d)
    l = np.linspace(0.0, 20 * w, 400_001)
    s = curves.profile(l, d, w)
    assert s.min() == s[0] == pytest.approx(-d)
    assert l[np.argmax(s)] == pytest.approx(2 * w, rel=1e-4)
    assert s.max() == pytest.approx(d * np.exp(-2.0), rel=1e-9)
    assert curves.profile(w, d, w) == 0.0  # the furrow's edge


def test_furrow_is_sharp_and_bulge_round():
    d, w, h = 0.002, 0.004, 1e-8
    slope0 = (curves.profile(h, d, w) - curves.profile(0.0, d, w)) / h
    assert slope0 == pytest.approx(2 * d / w, rel=1e-5)
    slope_bulge = (curves.profile(2 * w + h, d, w) - curves.profile(2 * w - h, d, w)) / (2 * h)
    assert abs(slope_bulge) < 1e-6 * abs(slope0)


# --------------------------------------------------------------------------- taper
@pytest.mark.parametrize("ramp", [0.1, 0.5, 0.8])  # 0.8 is clamped to half the length
def test_taper_is_c1_one_in_middle_zero_at_ends(ramp):
    L = 1.0
    u = np.linspace(-0.2, 1.2, 140_001)
    h = u[1] - u[0]
    f = curves.taper(u, L, ramp)
    assert f[np.argmin(np.abs(u - 0.5))] == pytest.approx(1.0)
    assert np.all(f[(u <= 0) | (u >= L)] == 0.0)
    assert np.all((f >= 0) & (f <= 1))
    if ramp < 0.5:
        assert np.all(f[(u >= ramp) & (u <= L - ramp)] == 1.0)
    r = min(ramp, 0.5 * L)
    df = np.diff(f) / h
    assert np.abs(df).max() <= 1.5 / r + 1e-6  # smoothstep's steepest slope
    # C1: the slope changes by at most |f''| h = 6 h / r^2 per step; a kink would jump ~1 / r
    assert np.abs(np.diff(df)).max() < 1.01 * 6 * h / r**2
    assert abs(df[np.argmin(np.abs(u))]) < 10 * h / r**2  # zero slope at the ends (3 h / r^2 one step in)


def test_taper_zero_is_a_step():
    f = curves.taper(np.array([-0.1, 0.0, 0.01, 0.5, 0.99, 1.0]), 1.0, 0.0)
    np.testing.assert_array_equal(f, [0, 0, 1, 1, 1, 0])


# --------------------------------------------------------------------------- bezier, resample
def test_straight_bezier_is_collinear_and_ends_exact():
    a, b, c = np.array([0.1, 0.2]), np.array([0.5, 0.4]), np.array([0.9, 0.6])
    pts = np.stack([a, b, c])
    dirn = (c - a) / np.linalg.norm(c - a)
    hl = pts - 0.1 * dirn
    hr = pts + 0.13 * dirn
    s = bezier(pts, hl, hr, 16)
    assert s.shape == (33, 2)
    rel = s - a
    cross = rel[:, 0] * dirn[1] - rel[:, 1] * dirn[0]
    assert np.abs(cross).max() < 1e-15
    np.testing.assert_array_equal(s[0], a)
    np.testing.assert_array_equal(s[-1], c)
    np.testing.assert_allclose(s[16], b, atol=1e-15)


@pytest.mark.parametrize("dim", [2, 3])
def test_bezier_matches_de_casteljau(dim):
    rng = np.random.default_rng(7)
    pts, hl, hr = rng.normal(size=(3, 4, dim))
    n = 997
    s = bezier(pts, hl, hr, n)
    assert s.shape == (3 * n + 1, dim)
    for _ in range(20):
        i, j = rng.integers(0, 3), rng.integers(0, n)
        want = _de_casteljau([pts[i], hr[i], hl[i + 1], pts[i + 1]], j / n)
        np.testing.assert_allclose(s[i * n + j], want, atol=1e-12)
    cyc = bezier(pts, hl, hr, 8, cyclic=True)
    assert cyc.shape == (4 * 8 + 1, dim)
    np.testing.assert_allclose(cyc[-1], pts[0])
    np.testing.assert_allclose(cyc[3 * 8 + 4], _de_casteljau([pts[3], hr[3], hl[0], pts[0]], 0.5))


def test_bezier_refuses_bad_input():
    p = np.zeros((1, 2))
    with pytest.raises(ValueError, match="at least 2"):
        bezier(p, p, p, 4)
    p = np.array([[0.0, 0.0], [1.0, np.nan]])
    with pytest.raises(ValueError, match="finite"):
        bezier(p, p, p, 4)


def test_resample_by_arc_length():
    poly = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [1.0, 2.0]])  # a repeated point
    r = curves.resample(poly, 0.25)
    assert len(r) == 13
    step = np.linalg.norm(np.diff(r, axis=0), axis=1)
    np.testing.assert_allclose(step, 0.25)
    np.testing.assert_array_equal(r[[0, -1]], poly[[0, -1]])
    assert len(curves.resample(poly, 0.7)) == 6  # ceil(3 / 0.7) = 5 steps of 0.6
    with pytest.raises(ValueError, match="zero length"):
        curves.resample(np.ones((3, 2)), 0.1)


# --------------------------------------------------------------------------- chain_order
def test_chain_order_open_path():
    path = [7, 3, 9, 1, 4]
    edges = np.array([[path[i + 1], path[i]] if i % 2 else [path[i], path[i + 1]] for i in range(4)])
    order = curves.chain_order(edges[[2, 0, 3, 1]])
    assert order.tolist() == path[::-1]  # starts at the lower-index end (4)
    assert curves.chain_order([[5, 2]]).tolist() == [2, 5]


def test_chain_order_closed_loop():
    loop = [10, 4, 8, 2, 6]
    edges = np.array([[loop[i], loop[(i + 1) % 5]] for i in range(5)])
    order = curves.chain_order(edges[::-1])
    assert order.tolist() == [2, 6, 10, 4, 8, 2]  # starts at 2, towards the lower neighbour


@pytest.mark.parametrize("edges, message", [
    ([[0, 1], [1, 2], [1, 3]], "branch"),
    ([[0, 1], [2, 3]], "several pieces"),
    ([[0, 1], [1, 2], [2, 0], [3, 4], [4, 5], [5, 3]], "several pieces"),
    ([[0, 1], [1, 2], [2, 0], [5, 6]], "several pieces"),
    (np.zeros((0, 2), int), "at least one edge"),
    ([[3, 3]], "itself"),
])
def test_chain_order_refuses_bad_selections(edges, message):
    with pytest.raises(ValueError, match=message):
        curves.chain_order(edges)


# --------------------------------------------------------------------------- curve_plan
def _straight_plan(taper=0.02):
    uv, tris, pos = _flat()
    a, b = np.array([0.2, 0.5]), np.array([0.8, 0.5])
    c = curves.Curve(_line(a, b), D, W, taper)
    return uv, tris, pos, a, b, curves.curve_plan(uv, tris, pos, [c])


def test_straight_curve_distances_heights_and_cutoff():
    uv, tris, pos, a, b, plan = _straight_plan()
    L = 0.6 * SCALE
    assert plan.lengths[0] == pytest.approx(L, rel=1e-12)
    # l is the perpendicular distance in metres wherever the foot is on the curve
    inside = (plan.u >= 0) & (plan.u <= L)
    assert inside.sum() > 1000
    dist = np.abs(uv[plan.verts, 1] - 0.5) * SCALE
    np.testing.assert_allclose(plan.l[inside], dist[inside], atol=1e-12)
    np.testing.assert_allclose(plan.u[inside], (uv[plan.verts[inside], 0] - 0.2) * SCALE, atol=1e-12)
    np.testing.assert_allclose(np.abs(plan.tangent[:, 0]), 1.0)
    # the middle (beyond the taper ramps): the height is S(l) (windowed)
    h = curves.curve_heights(plan)
    x = uv[:, 0] * SCALE
    mid = (x > 0.2 * SCALE + 0.02) & (x < 0.8 * SCALE - 0.02)
    y = np.abs(uv[:, 1] - 0.5) * SCALE
    want = curves.profile(y, D, W) * curves.window(y, W)
    np.testing.assert_allclose(h[mid], want[mid], atol=1e-15)
    close = mid & (y <= curves.WINDOW_START * W)
    np.testing.assert_allclose(h[close], curves.profile(y[close], D, W), atol=1e-15)
    assert h[mid & (y < 1e-12)].min() == pytest.approx(-D)  # the furrow
    # beyond the cut-off nothing is touched
    true = _segment_distance(pos, np.r_[a * SCALE, 0], np.r_[b * SCALE, 0])
    far = true >= curves.CUTOFF * W
    assert np.all(h[far] == 0.0)
    assert not np.isin(np.flatnonzero(far), plan.footprint).any()
    assert np.isin(np.flatnonzero(mid & (y < curves.WINDOW_START * W)), plan.footprint).all()


def test_ends_fade_smoothly_to_zero():
    taper_len = 0.02
    uv, tris, pos, a, b, plan = _straight_plan(taper_len)
    h = curves.curve_heights(plan)
    x, y = pos[:, 0], np.abs(pos[:, 1] - 0.5 * SCALE)
    x0, x1 = a[0] * SCALE, b[0] * SCALE
    # heights everywhere are S(l) window(l) taper(u), u extended along the curve's line
    u = x - x0
    l = np.where(u < 0, np.hypot(u, y), np.where(x > x1, np.hypot(x - x1, y), y))
    want = curves.profile(l, D, W) * curves.window(l, W) * curves.taper(u, x1 - x0, taper_len)
    np.testing.assert_allclose(h, want, atol=1e-15)
    assert np.all(h[(x <= x0) | (x >= x1)] == 0.0)  # nothing at and beyond the ends
    # along the furrow the height goes from 0 to -d without a jump (smoothstep, C1)
    row = np.flatnonzero(np.isclose(pos[:, 1], 0.5 * SCALE))
    line = h[row[np.argsort(x[row])]]
    assert line.min() == pytest.approx(-D)
    h_grid = SCALE / 200
    step = np.abs(np.diff(line)).max()
    assert step <= 1.01 * 1.5 * D * h_grid / taper_len  # smoothstep's steepest slope
    # no kink: second differences within smoothstep's curvature (a kink would be ~ step)
    assert np.abs(np.diff(line, 2)).max() < 1.01 * 6 * D * h_grid**2 / taper_len**2 < 0.25 * step


def test_circular_arc_distance_is_radius_difference():
    uv, tris, pos = _flat()
    R, c0, k = 0.25, np.array([0.5, 0.5]), 0.5522847498
    ang = np.array([0.0, 0.5 * np.pi, np.pi])  # a half circle: two quarter-circle segments
    pts = c0 + R * np.stack([np.cos(ang), np.sin(ang)], 1)
    tang = np.stack([-np.sin(ang), np.cos(ang)], 1) * k * R
    poly = bezier(pts, pts - tang, pts + tang, 64)
    plan = curves.curve_plan(uv, tris, pos, [{"polyline_uv": poly, "d": D, "w": W, "taper": 0.01}])
    rel = uv[plan.verts] - c0
    r = np.linalg.norm(rel, axis=1)
    theta = np.arctan2(rel[:, 1], rel[:, 0])
    ok = (theta > 0.2) & (theta < np.pi - 0.2) & (np.abs(r - R) < 0.5 * R)
    assert ok.sum() > 1000
    np.testing.assert_allclose(plan.l[ok], np.abs(R - r[ok]) * SCALE, atol=3e-5)  # 0.75 % of w
    # the Bezier circle bulges out by up to 2.7e-4 R
    assert plan.lengths[0] == pytest.approx(np.pi * R * SCALE, rel=3e-4)
    radial = rel[ok] / r[ok, None]
    assert np.abs((plan.tangent[ok] * radial).sum(axis=1)).max() < 0.05  # tangent ⟂ radius


@pytest.mark.parametrize("curve_dir", ["along", "diagonal"])
def test_nonuniform_uv_scaling_gives_3d_distances(curve_dir):
    """uv = (x, 2y): a UV unit is twice as long in u as in v on the skin."""
    uv, tris, pos = _flat(sx=SCALE, sy=SCALE / 2)
    a, b = (np.array([0.2, 0.5]), np.array([0.8, 0.5])) if curve_dir == "along" else \
        (np.array([0.25, 0.2]), np.array([0.75, 0.8]))
    plan = curves.curve_plan(uv, tris, pos, [(_line(a, b), D, W, 0.01)])
    a3, b3 = np.r_[a * [SCALE, SCALE / 2], 0], np.r_[b * [SCALE, SCALE / 2], 0]
    assert plan.lengths[0] == pytest.approx(np.linalg.norm(b3 - a3), rel=1e-12)
    inside = (plan.u > 0) & (plan.u < plan.lengths[0])
    assert inside.sum() > 500
    true = _segment_distance(pos[plan.verts], a3, b3)
    np.testing.assert_allclose(plan.l[inside], true[inside], atol=1e-12)
    # and no vertex within the cut-off is missed
    near = _segment_distance(pos, a3, b3) < 0.99 * curves.CUTOFF * W
    near &= (pos[:, :2] - a3[:2]) @ (b3 - a3)[:2] > 0.05 * np.dot(b3 - a3, b3 - a3)
    near &= (pos[:, :2] - b3[:2]) @ (a3 - b3)[:2] > 0.05 * np.dot(b3 - a3, b3 - a3)
    assert np.isin(np.flatnonzero(near), plan.footprint).all()


def test_very_dense_polylines_give_the_same_wrinkle():
    """A polyline much denser than w / 8 is resampled; the wrinkle does not change."""
    uv, tris, pos = _flat(121)
    coarse = curves.curve_plan(uv, tris, pos, [(_line([0.2, 0.5], [0.8, 0.5], 2), D, W, 0.02)])
    fine = curves.curve_plan(uv, tris, pos, [(_line([0.2, 0.5], [0.8, 0.5], 20_000), D, W, 0.02)])
    np.testing.assert_array_equal(fine.verts, coarse.verts)
    np.testing.assert_allclose(fine.static, coarse.static, atol=1e-15)
    np.testing.assert_allclose(fine.l, coarse.l, atol=1e-12)


def test_wiggly_curve_matches_brute_force_nearest_point():
    """The branch-and-bound search finds the same nearest point as trying every segment."""
    uv, tris, pos = _flat(161, sx=SCALE, sy=1.5 * SCALE)
    rng = np.random.default_rng(3)
    pts = np.stack([np.linspace(0.2, 0.8, 5), 0.5 + 0.15 * rng.uniform(-1, 1, 5)], 1)
    hl, hr = pts + 0.1 * rng.normal(size=(2, 5, 2))
    poly = bezier(pts, hl, hr, 40)
    w = 0.003
    plan = curves.curve_plan(uv, tris, pos, [(poly, D, w, 0.0)])
    scale = np.array([SCALE, 1.5 * SCALE])
    a, b = poly[:-1] * scale, poly[1:] * scale  # the polyline's segments on the skin
    p = pos[:, :2]
    e = b - a
    t = np.clip(np.einsum("vsk,sk->vs", p[:, None] - a, e) / (e * e).sum(1), 0, 1)
    dist = np.linalg.norm(p[:, None] - a - t[..., None] * e, axis=2).min(axis=1)
    np.testing.assert_allclose(plan.l, dist[plan.verts], rtol=1e-12, atol=1e-15)
    inside = (plan.u > w) & (plan.u < plan.lengths[0] - w)
    want = np.flatnonzero(dist < 0.999 * curves.CUTOFF * w)
    got = plan.verts
    missing = np.setdiff1d(want, got)
    # anything missing is beyond the ends (u outside the curve), never beside the curve
    assert inside.sum() > 1000
    assert len(missing) < 0.2 * len(want)
    ends = np.concatenate([poly[[0]], poly[[-1]]]) * scale
    assert np.all(np.linalg.norm(p[missing, None] - ends, axis=2).min(axis=1) < curves.CUTOFF * w * 1.01)


def test_two_curves_heights_sum():
    uv, tris, pos = _flat()
    c1 = curves.Curve(_line([0.2, 0.45], [0.8, 0.45]), D, W, 0.02)
    c2 = {"polyline_uv": _line([0.3, 0.3], [0.7, 0.62]), "d": 1.5 * D, "w": 0.7 * W, "taper": 0.01}
    both = curves.curve_plan(uv, tris, pos, [c1, c2])
    h1 = curves.curve_heights(curves.curve_plan(uv, tris, pos, [c1]))
    h2 = curves.curve_heights(curves.curve_plan(uv, tris, pos, [c2]))
    overlap = (h1 != 0) & (h2 != 0)
    assert overlap.sum() > 100
    np.testing.assert_allclose(curves.curve_heights(both), h1 + h2, atol=1e-16)
    # the plan's bookkeeping: entries grouped by curve, footprint the union
    assert np.all(both.curve[both.entries(0)] == 0) and np.all(both.curve[both.entries(1)] == 1)
    np.testing.assert_array_equal(both.footprint, np.flatnonzero((h1 != 0) | (h2 != 0)))
    # per-frame modulation: M per entry scales each curve separately
    m = np.where(both.curve == 0, 0.5, 2.0)
    np.testing.assert_allclose(curves.curve_heights(both, m), 0.5 * h1 + 2.0 * h2, atol=1e-16)
    np.testing.assert_allclose(curves.curve_heights(both, 0.0), 0.0)


def test_surface_reuse_and_merged_plans_match_one_plan():
    uv, tris, pos = _flat(121)
    c1 = (_line([0.2, 0.45], [0.8, 0.45]), D, W, 0.02)
    c2 = (_line([0.3, 0.3], [0.7, 0.62]), 1.5 * D, 0.7 * W, 0.01)
    both = curves.curve_plan(uv, tris, pos, [c1, c2])
    surf = curves.curve_surface(uv, tris, pos)
    merged = curves.merge_plans([curves.curve_plan(uv, tris, pos, [c], surface=surf) for c in (c1, c2)])
    for name in ("verts", "curve", "static", "tangent", "foot", "l", "u", "offsets", "lengths", "footprint"):
        np.testing.assert_array_equal(getattr(merged, name), getattr(both, name), err_msg=name)
    with pytest.raises(ValueError, match="does not belong"):
        curves.curve_plan(uv[:-1], tris, pos[:-1], [c1], surface=surf)


def test_on_a_cylinder_l_is_the_distance_along_the_skin():
    """UV unrolls a cylinder of radius 5 cm: l and the arc length are geodesic, not chords."""
    n, radius = 201, 0.05
    uv, tris, _pos = _flat(n)
    theta = (uv[:, 0] - 0.5) * 2.0  # radians: the UV square covers 2 rad of the cylinder
    pos = np.stack([radius * np.sin(theta), radius * np.cos(theta), uv[:, 1] * 0.1], 1)
    w = 0.002
    along = curves.curve_plan(uv, tris, pos, [(_line([0.5, 0.1], [0.5, 0.9]), D, w, 0.005)])
    mid = (along.u > 0.01) & (along.u < along.lengths[0] - 0.01)
    geodesic = np.abs(theta[along.verts]) * radius
    np.testing.assert_allclose(along.l[mid], geodesic[mid], rtol=2e-4, atol=1e-9)
    assert along.lengths[0] == pytest.approx(0.08, rel=1e-9)
    around = curves.curve_plan(uv, tris, pos, [(_line([0.25, 0.5], [0.75, 0.5], 200), D, w, 0.005)])
    assert around.lengths[0] == pytest.approx(1.0 * radius, rel=1e-4)  # 1 rad of arc, not the chord


def test_vertices_without_a_metric_are_untouched():
    uv, tris, pos = _flat(41)
    uv = np.concatenate([uv, [[0.5, 0.501]]])  # a vertex on the furrow but in no triangle
    pos = np.concatenate([pos, [[0.1, 0.1, 0.0]]])
    plan = curves.curve_plan(uv, tris, pos, [(_line([0.2, 0.5], [0.8, 0.5]), D, W, 0.0)])
    assert len(plan.verts) > 0 and len(uv) - 1 not in plan.footprint
    assert curves.curve_heights(plan).shape == (len(uv),)


def test_plan_with_no_curves_is_empty():
    uv, tris, pos = _flat(11)
    plan = curves.curve_plan(uv, tris, pos, [])
    assert len(plan.verts) == 0 and len(plan.footprint) == 0
    np.testing.assert_array_equal(curves.curve_heights(plan), np.zeros(len(uv)))


# --------------------------------------------------------------------------- bad input
_GOOD = _line([0.2, 0.5], [0.8, 0.5])


@pytest.mark.parametrize("curve, message", [
    ((np.tile([0.4, 0.5], (5, 1)), D, W, 0.0), "zero length"),
    ((_GOOD[:1], D, W, 0.0), "at least 2 samples"),
    ((_GOOD, D, 0.0, 0.0), "width"),
    ((_GOOD, D, -W, 0.0), "width"),
    ((_GOOD, np.nan, W, 0.0), "depth"),
    ((_GOOD, np.inf, W, 0.0), "depth"),
    ((_GOOD + 1.5, D, W, 0.0), "outside the UV square"),
    ((np.where(np.arange(50)[:, None] == 3, np.nan, _GOOD), D, W, 0.0), "NaN"),
    ((_GOOD, D, W, -1.0), "taper"),
    ((_GOOD, D, "wide", 0.0), "numbers"),
    ({"d": D, "w": W}, "polyline_uv"),
])
def test_bad_curves_are_refused_with_a_message(curve, message):
    uv, tris, pos = _flat(11)
    with pytest.raises(ValueError, match=message) as err:
        curves.curve_plan(uv, tris, pos, [curves.Curve(*curve) if isinstance(curve, tuple) else curve])
    assert "Wrinkle curve 1" in str(err.value) or "polyline_uv" in str(err.value)


def test_nan_in_the_mesh_is_refused():
    uv, tris, pos = _flat(11)
    uv[5, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        curves.curve_plan(uv, tris, pos, [(_GOOD, D, W, 0.0)])


# --------------------------------------------------------------------------- pigment (eq. 6)
def test_pigment_is_eq6_clipped():
    base = np.array([0.9, 0.7, 0.6])
    a_m, a_h = np.array([0.3, 0.4, 0.5]), np.array([0.05, 0.3, 0.25])
    c = curves.pigment(base, np.array([0.0, 0.5, 4.0]), np.array([0.2, 0.1, 0.0]), a_m, a_h)
    assert c.shape == (3, 3)
    np.testing.assert_allclose(c[0], base - 0.2 * a_h)
    np.testing.assert_allclose(c[1], base - 0.5 * a_m - 0.1 * a_h)
    np.testing.assert_allclose(c[2], [0.0, 0.0, 0.0])  # clipped
    np.testing.assert_allclose(curves.pigment([0.5, 2.0, 0.5], 0.0, 0.0, a_m, a_h), [0.5, 1.0, 0.5])


def test_refinement_limits_follow_the_curve():
    n = 41
    x, y = np.meshgrid(np.linspace(0, 0.1, n), np.linspace(0, 0.1, n))
    pos = np.stack([x.ravel(), y.ravel(), np.zeros(n * n)], 1)
    idx = np.arange(n * n).reshape(n, n)
    edges = np.concatenate([np.stack([idx[:, :-1].ravel(), idx[:, 1:].ravel()], 1),
                            np.stack([idx[:-1].ravel(), idx[1:].ravel()], 1)])
    w = 0.002
    line = np.stack([np.linspace(0.02, 0.08, 200), np.full(200, 0.05), np.zeros(200)], 1)
    limit = curves.edge_limits(pos, edges, [line], [w])
    mid = pos[edges].mean(axis=1)
    dist = np.abs(mid[:, 1] - 0.05)
    inside = (mid[:, 0] > 0.03) & (mid[:, 0] < 0.07)
    np.testing.assert_allclose(limit[inside & (dist < 0.001)], curves.REFINE_NEAR * w)
    assert np.all(np.isinf(limit[dist > curves.CUTOFF * w + 0.003]))
    assert np.all(limit[inside & (dist > 0.009) & (dist < 0.017)] == curves.REFINE_FAR * w)
    assert np.isinf(curves.edge_limits(pos, edges, [line], [0.0])).all()  # w = 0: nothing
