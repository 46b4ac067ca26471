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


# --------------------------------------------------------------------------- shapes that read as wrinkles
# Measures of shape on the height in the frame, in frame units, with each type's default frame
# (core.patterns.functions.FRAMES) and parameters; the paper's readings fail them, so they can fail.
def _defaults(kind, shape="FACE"):
    spec = patterns.spec(kind, shape)
    return spec.time, tuple(p.default for p in spec.params) + (0.0,) * (3 - len(spec.params))


def _damped(kind, x, y, t, params, shape="FACE"):
    f = patterns.FRAMES[kind]
    radius = f["radius"] / f["unit"]
    h = patterns.pattern(kind, x, y, t, *params, shape=shape)
    return h * patterns.damping_radius(np.hypot(x, y), radius, 0.4 * radius)


def _polar(kind, rho, phi, t, params, shape="FACE"):
    r, p = np.meshgrid(rho, phi, indexing="ij")
    return _damped(kind, (r * np.cos(p)).ravel(), (r * np.sin(p)).ravel(), t, params, shape).reshape(r.shape)


def _sign_changes(v, tol):
    s = np.sign(np.where(np.abs(v) < tol, 0.0, v))
    s = s[s != 0]
    return int(np.sum(s[1:] != s[:-1]))


def _furrow_angles(h, rho, phi):
    """The angle (degrees) between each furrow and the radial direction: the furrows are the
    deep local minima of ``h`` along each arc, each followed to the nearest on the next arc."""
    out = []
    for i in range(len(rho) - 1):
        found = []
        for row in h[i], h[i + 1]:
            inner = row[1:-1]
            deep = (inner < row[:-2]) & (inner <= row[2:]) & (inner < 0.3 * row.min())
            found.append(np.flatnonzero(deep) + 1)
        for j in found[0]:
            if len(found[1]):
                k = found[1][np.argmin(np.abs(found[1] - j))]
                out.append(np.degrees(np.arctan2(abs(phi[k] - phi[j]) * rho[i], rho[i + 1] - rho[i])))
    return np.array(out)


SPAN = np.radians(40.0)  # the fan's half-angle the measures look at


def _crows_feet_measures(shape, t, params):
    rho, phi = np.linspace(0.35, 0.95, 121), np.linspace(-SPAN, SPAN, 161)
    h = _polar("EYE_CORNER", rho, phi, t, params, shape)
    dev = h - h.mean(axis=1, keepdims=True)  # against the arc's mean: furrow (-) or bulge (+)
    tol = 0.05 * np.abs(dev).max()
    arcs = min(_sign_changes(dev[i], 0.05 * np.abs(dev[i]).max()) for i in range(20, 100))
    rays = max(_sign_changes(dev[:, j], tol) for j in range(len(phi)))
    rho2 = np.linspace(0.25, 1.0, 76)
    angles = _furrow_angles(_polar("EYE_CORNER", rho2, np.linspace(-SPAN, SPAN, 321), t, params, shape),
                            rho2, np.linspace(-SPAN, SPAN, 321))
    return arcs, rays, angles


def test_crows_feet_fan_out_from_the_corner_as_distinct_furrows():
    t, params = _defaults("EYE_CORNER")
    arcs, rays, angles = _crows_feet_measures("FACE", t, params)
    count = int(params[2])
    assert 2 <= count <= 5
    assert arcs >= 2 * (count - 1)  # along every arc: furrow, bulge, furrow ...: distinct furrows
    assert rays == 0  # along every ray the height keeps to furrow or bulge: no loop crosses it
    assert len(angles) > 50 and np.percentile(angles, 90) < 5.0  # the furrows radiate
    # lateral only (+x), fading out: nothing behind the corner, nothing beyond the length t
    x = np.linspace(-1.2, 1.2, 241)
    assert np.abs(patterns.pattern("EYE_CORNER", -np.abs(x), 0.3 * x, t, *params, shape="FACE")).max() == 0
    far = patterns.pattern("EYE_CORNER", [1.12 * t], [0.0], t, *params, shape="FACE")
    near = patterns.pattern("EYE_CORNER", [0.4 * t], [0.0], t, *params, shape="FACE")
    assert far[0] == 0.0 and near[0] < 0.5 * params[0]
    # the fan spans 30-90 degrees: the outer furrows' angle between them
    assert 30.0 <= np.degrees((count - 1) * patterns.FAN_PITCH) + 24.0 <= 90.0
    # each furrow is sharp, its bulges round: the furrow deeper than the bulges are high
    across = np.linspace(-0.3, 0.3, 601)
    profile = patterns.pattern("EYE_CORNER", np.full(601, 0.5), across, t, -1.0, params[1], 1.0, shape="FACE")
    assert -profile.min() > 3.0 * profile.max() > 0.0


@pytest.mark.parametrize("params", [(-0.12, 6.0, 3.0), (-0.07, 10.0, 3.0), (-0.04, 16.0, 3.0)])
def test_the_papers_crows_feet_are_petal_loops_that_fail_the_measures(params):
    """The rose ``rho = t sin(g phi)`` with t the furrows' length: its furrows turn across the
    rays toward the petals' tips (the loops), and the arcs do not alternate."""
    arcs, rays, angles = _crows_feet_measures("PAPER", 1.0, params)
    assert np.percentile(angles, 90) > 30.0
    assert rays >= 1 and arcs < 2 * (int(params[2]) - 1)


def test_near_the_corner_of_its_rose_the_papers_crows_feet_are_rays_through_the_corner():
    # t far beyond the region: radiating furrows, but on both sides of the corner and unfaded
    _arcs, _rays, angles = _crows_feet_measures("PAPER", 20.0, (-0.04, 16.0, 3.0))
    assert np.percentile(angles, 90) < 5.0
    h = patterns.pattern("EYE_CORNER", [-0.5, 0.5], [0.0, 0.0], 20.0, -0.04, 16.0, 3.0)
    assert h[0] == pytest.approx(h[1])  # behind the corner, on the eyelid, as deep


def _frown_measures(shape, params):
    g = np.linspace(-1.4, 1.4, 281)
    x, y = np.meshgrid(g, g, indexing="ij")
    h = _damped("FROWN", x.ravel(), y.ravel(), 0.0, params, shape).reshape(x.shape)
    dx, dy = np.gradient(h, g, g)
    horizontal = (dx ** 2).sum() / (dx ** 2 + dy ** 2).sum()
    asymmetry = np.abs(h - h[::-1]).max() / np.abs(h).max()
    return g, h, horizontal, asymmetry


def test_frown_lines_are_vertical_and_symmetric_about_the_midline():
    _t, params = _defaults("FROWN")
    g, h, horizontal, asymmetry = _frown_measures("FACE", params)
    assert horizontal > 0.9  # the height changes across, not along: the lines are vertical
    assert asymmetry < 1e-9
    row = h[:, np.searchsorted(g, 0.0)]  # across, at the origin's height
    inner = row[1:-1]
    minima = g[1:-1][(inner < row[:-2]) & (inner <= row[2:]) & (inner < 0.5 * row.min())]
    np.testing.assert_allclose(np.sort(minima), [-0.5 * params[1], 0.5 * params[1]], atol=0.02)
    column = h[np.searchsorted(g, 0.5 * params[1]), :]
    long = g[column < 0.5 * column.min()]
    assert 1.0 < np.ptp(long) < 2.2  # 10-20 mm long on a frame of about 10 mm
    assert -row.min() > 3.0 * row.max() > 0.0  # sharp furrows, rounder bulges


@pytest.mark.parametrize("params", [(-0.12, 0.3), (-0.2, 0.45), (-0.08, 1.0)])
def test_the_papers_frown_hyperbolas_fail_the_measures(params):
    _g, _h, horizontal, asymmetry = _frown_measures("PAPER", params)
    assert horizontal < 0.7 and asymmetry > 1.0  # oblique hyperbolas, a furrow facing a ridge


def test_the_cheek_fold_is_one_crease_with_the_cheek_bulging_beside_it():
    _t, params = _defaults("CHEEK")
    x = np.linspace(-1.0, 1.0, 801)
    for y in (-0.6, 0.0, 0.6):
        h = _damped("CHEEK", x, np.full_like(x, y), 0.0, params)
        inner = h[1:-1]
        minima = x[1:-1][(inner < h[:-2]) & (inner <= h[2:]) & (inner < 0.3 * h.min())]
        assert len(minima) == 1  # one crease
        on_arc = np.sqrt(patterns.FOLD_RADIUS ** 2 - y * y) - patterns.FOLD_RADIUS
        assert minima[0] == pytest.approx(on_arc, abs=0.02)
        lateral, medial = h[x > minima[0]].max(), h[x < minima[0]].max()
        assert lateral > 2.0 * medial > 0.0  # the cheek bulges beside the fold, not the lip
    # the paper's rings: many creases across
    h = patterns.pattern("CHEEK", x, np.zeros_like(x), 0.0, -0.08, 6.0)
    inner = h[1:-1]
    assert ((inner < h[:-2]) & (inner <= h[2:]) & (inner < 0.3 * h.min())).sum() > 1


def _pits(h):
    """The local minima of a grid ``h`` deeper than a third of its deepest."""
    c = h[1:-1, 1:-1]
    low = c < 0.3 * h.min()
    for dx, dy in ((0, 1), (2, 1), (1, 0), (1, 2), (0, 0), (2, 2), (0, 2), (2, 0)):
        low &= c <= h[dx:dx + c.shape[0], dy:dy + c.shape[1]]
    return np.argwhere(low)


def test_the_dimple_is_a_single_round_pit():
    t, params = _defaults("DIMPLE", "PAPER")
    g = np.linspace(-2.0, 2.0, 201)
    x, y = np.meshgrid(g, g, indexing="ij")
    h = _damped("DIMPLE", x.ravel(), y.ravel(), t, params, "PAPER").reshape(x.shape)
    pits = _pits(h)
    assert len(pits) == 1 and np.allclose(g[pits[0] + 1], 0.0)
    assert -h.min() > 5.0 * h.max()  # a pit with at most a low rim
    # the measure can fail: the paper's cheek rings are no pit
    rings = patterns.pattern("CHEEK", x.ravel(), y.ravel(), 1.0, -0.08, 6.0).reshape(x.shape)
    assert len(_pits(rings)) != 1


def test_each_variant_is_beside_its_papers_reading_and_layers_keep_their_shape():
    for kind in patterns.VARIANTS:
        assert patterns.spec(kind, "PAPER") is patterns.PATTERNS[kind]
        assert patterns.spec(kind, "FACE") is patterns.VARIANTS[kind]
    assert patterns.spec("DIMPLE", "FACE") is patterns.PATTERNS["DIMPLE"]  # a paper that works
    local = np.column_stack([X, Y, np.zeros_like(X)])
    lay = patterns.layer("EYE_CORNER", local, local, np.zeros((0, 2)), np.ones(len(X)), shape="FACE")
    h = patterns.heights(patterns.plan([lay]), [(1.0, 1.0, -0.04, 16.0, 3.0)])
    np.testing.assert_allclose(h, patterns.pattern("EYE_CORNER", X, Y, 1.0, -0.04, 16.0, 3.0, shape="FACE"))
    old = patterns.layer("EYE_CORNER", local, local, np.zeros((0, 2)), np.ones(len(X)))
    assert old.shape == "PAPER"


def test_the_places_come_from_the_landmarks_and_scale_with_the_face():
    marks = {"eye_L": [0.0317, -0.079, 0.1166], "mouth_corner_L": [0.0248, -0.094, 0.0474],
             "nose_tip": [0.0, -0.12, 0.081], "glabella": [0.0, -0.097, 0.1313]}
    at = patterns.places(marks)
    e = 2 * 0.0317
    assert at["EYE_CORNER"][0][0] == pytest.approx(0.0317 + 0.22 * e)
    assert at["FROWN"][0][0] == 0.0 and at["DIMPLE"][0][0] > 0.0248 + 0.25 * e
    top, bottom = patterns.fold_ends(marks)
    assert top[2] > 0.0474 > bottom[2] and top[0] < 0.0248 < bottom[0]  # nose wing down past the mouth
    np.testing.assert_allclose(at["CHEEK"][1], (top - bottom) / np.linalg.norm(top - bottom))
    big = {k: 2.0 * np.asarray(v) for k, v in marks.items()}
    np.testing.assert_allclose(patterns.places(big)["CHEEK"][0], 2.0 * at["CHEEK"][0])


@pytest.mark.parametrize("alpha", [-0.04, -0.08, -0.2])
def test_the_frown_lines_are_soft_valleys_not_slits(alpha):
    """The anatomical frown's two lines: each a valley at least 3 times as wide (between its
    zero crossings) as it is deep, whatever its depth, with a bulge beside it."""
    x = np.linspace(0.0, 1.5, 30001)
    h = patterns.lines(x, np.zeros_like(x), 0.0, alpha, 1.0)
    line = int(np.argmin(h))
    depth = -h[line]
    assert depth == pytest.approx(abs(alpha), rel=1e-3)
    above = np.flatnonzero(h >= 0.0)
    left, right = above[above < line].max(), above[above > line].min()
    width = x[right] - x[left]
    assert width >= 3.0 * depth
    assert h[right:].max() > 0.0  # the skin bunched beside it
