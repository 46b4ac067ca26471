"""Fine-scale wrinkle furrows carved along a direction field (Bando, Kuratate & Nishita
2002, §5.2 - §5.4): ``wrinkle_addon.core.bando.carve``."""

import numpy as np
import pytest

from wrinkle_addon.core.bando import carve as bc

TOL_END = 1.5  # px: an end stopped on another furrow lies this close to its line (a pixel diagonal)


# --------------------------------------------------------------------------- meshes
def grid_mesh(n, u0=0.0, u1=1.0, v0=0.0, v1=1.0):
    """An n x n vertex grid over [u0, u1] x [v0, v1]: uv (U, 2), tris (T, 3)."""
    u, v = np.meshgrid(np.linspace(u0, u1, n), np.linspace(v0, v1, n))
    uv = np.stack([u.ravel(), v.ravel()], 1)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    return uv, np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])


def rotating_field(uv, m=0.5, turn=1.0):
    """Magnitude ``m`` everywhere, the direction turning slowly across the square."""
    ang = turn * (uv[:, 0] + 0.5 * uv[:, 1])
    return m * np.stack([np.cos(ang), np.sin(ang)], 1)


def face_mesh(n=41):
    """A face-like UV layout: an oval island with holes for the eyes and the mouth, plus a
    separate small island (an ear); the field runs across the forehead and bends around
    the cheeks, its magnitude growing from 0.25 at the chin to 0.75 at the top."""
    uv, tris = grid_mesh(n, 0.02, 0.98, 0.02, 0.98)
    cen = uv[tris].mean(axis=1)

    def inside(c, x, y, a, b):
        return ((c[:, 0] - x) / a) ** 2 + ((c[:, 1] - y) / b) ** 2 < 1.0

    keep = inside(cen, 0.45, 0.5, 0.36, 0.46)
    for x, y, a, b in ((0.32, 0.58, 0.08, 0.04), (0.58, 0.58, 0.08, 0.04), (0.45, 0.25, 0.12, 0.04)):
        keep &= ~inside(cen, x, y, a, b)
    keep |= inside(cen, 0.9, 0.5, 0.06, 0.14)  # the ear island
    tris = tris[keep]
    ang = 0.7 * np.sin(2.5 * (uv[:, 0] - 0.45)) * (1.0 - uv[:, 1])
    m = 0.25 + 0.5 * uv[:, 1]
    return uv, tris, m[:, None] * np.stack([np.cos(ang), np.sin(ang)], 1)


# --------------------------------------------------------------------------- geometry
def _orient(p, q, r):
    """Twice the signed area of the triangles p q r (..., 2)."""
    return ((q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1])
            - (q[..., 1] - p[..., 1]) * (r[..., 0] - p[..., 0]))


def _point_segment_distance(p, a, b):
    e = b - a
    v = p - a
    t = np.clip((v * e).sum(-1) / np.maximum((e * e).sum(-1), 1e-300), 0.0, 1.0)
    w = v - t[..., None] * e
    return np.sqrt((w * w).sum(-1))


def near_pairs(seg_a, seg_b):
    """Index pairs (i, j) of the segments (pixel units) of ``seg_a`` and ``seg_b`` whose
    midpoints lie in neighbouring cells of a grid as coarse as the longest segment plus
    2 px: a superset of the pairs that cross or come within ``TOL_END``."""
    length = max(np.linalg.norm(s[:, 1] - s[:, 0], axis=1).max(initial=0.0) for s in (seg_a, seg_b))
    g = length + 2.0 * TOL_END + 1.0
    ca = np.floor(seg_a.mean(axis=1) / g).astype(np.int64)
    cb = np.floor(seg_b.mean(axis=1) / g).astype(np.int64)
    w = int(max(ca.max(initial=0), cb.max(initial=0))) + 3
    key_b = (cb[:, 1] + 1) * w + cb[:, 0] + 1
    order = np.argsort(key_b, kind="stable")
    sorted_b = key_b[order]
    out_i, out_j = [], []
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            key = (ca[:, 1] + 1 + dy) * w + ca[:, 0] + 1 + dx
            lo = np.searchsorted(sorted_b, key, "left")
            n = np.searchsorted(sorted_b, key, "right") - lo
            i = np.repeat(np.arange(len(seg_a)), n)
            k = np.arange(int(n.sum())) - np.repeat(np.cumsum(n) - n, n)
            out_i.append(i)
            out_j.append(order[np.repeat(lo, n) + k])
    return np.concatenate(out_i), np.concatenate(out_j)


def proper_crossings(seg_a, fid_a, seg_b, fid_b):
    """Pairs (i, j) of segments (pixel units) of different furrows that cross properly,
    each with the smallest distance from an end point of one to the other segment."""
    i, j = near_pairs(seg_a, seg_b)
    p, q, b0, b1 = seg_a[i, 0], seg_a[i, 1], seg_b[j, 0], seg_b[j, 1]
    cross = ((_orient(p, q, b0) * _orient(p, q, b1) < 0) & (_orient(b0, b1, p) * _orient(b0, b1, q) < 0)
             & (fid_a[i] != fid_b[j]))
    i, j = i[cross], j[cross]
    d = np.minimum.reduce([
        _point_segment_distance(seg_a[i, 0], seg_b[j, 0], seg_b[j, 1]),
        _point_segment_distance(seg_a[i, 1], seg_b[j, 0], seg_b[j, 1]),
        _point_segment_distance(seg_b[j, 0], seg_a[i, 0], seg_a[i, 1]),
        _point_segment_distance(seg_b[j, 1], seg_a[i, 0], seg_a[i, 1]),
    ])
    return i, j, d


def ends_touching(seg_a, fid_a, seg_b, fid_b, tol=TOL_END):
    """How many segment end points of ``seg_a`` lie within ``tol`` of a segment of
    another furrow in ``seg_b``."""
    i, j = near_pairs(seg_a, seg_b)
    d = _point_segment_distance(seg_a[i, 1], seg_b[j, 0], seg_b[j, 1])
    return len(np.unique(i[(d < tol) & (fid_a[i] != fid_b[j])]))


def test_near_pairs_find_every_crossing():
    """The grid prefilter of the crossing test misses no crossing (against all pairs)."""
    rng = np.random.default_rng(0)
    p = rng.random((400, 2)) * 100
    seg = np.stack([p, p + rng.normal(size=(400, 2)) * 4], axis=1)
    fid = np.arange(400)
    a0, a1, b0, b1 = seg[:, None, 0], seg[:, None, 1], seg[None, :, 0], seg[None, :, 1]
    brute = (_orient(a0, a1, b0) * _orient(a0, a1, b1) < 0) & (_orient(b0, b1, a0) * _orient(b0, b1, a1) < 0)
    i, j, _d = proper_crossings(seg, fid, seg, fid)
    assert brute.sum() > 20
    assert set(zip(i.tolist(), j.tolist())) == set(zip(*np.nonzero(brute)))


def px(res):
    return res.segments * res.height.shape[0]


# --------------------------------------------------------------------------- Equation 1
def test_parameters_equation_1():
    p = bc.parameters([0.0, 0.5, 1.0])
    np.testing.assert_array_equal(p.N, [30, 20, 10])
    np.testing.assert_allclose(p.theta_max, [0.5, 0.3, 0.1])
    np.testing.assert_allclose(p.D, [4.0, 5.0, 6.0])
    np.testing.assert_allclose(p.I, [1.0, 0.75, 0.0])
    np.testing.assert_allclose(p.W_h, [0.0, 1.0, 2.0])
    np.testing.assert_allclose(p.W_o, [1.0, 7.0, 13.0])
    q = bc.parameters([0.0, 0.5, 1.0], scale=2.0)  # only the lengths follow the pixel unit
    np.testing.assert_array_equal(q.N, p.N)
    np.testing.assert_allclose(q.theta_max, p.theta_max)
    np.testing.assert_allclose(q.I, p.I)
    np.testing.assert_allclose(q.D, 2 * p.D)
    np.testing.assert_allclose(q.W_h, 2 * p.W_h)
    np.testing.assert_allclose(q.W_o, 2 * p.W_o)
    assert bc.parameters(0.45).N == 21  # floor(21.0), not 20 from rounding
    clipped = bc.parameters([-0.5, 1.5])
    np.testing.assert_array_equal(clipped.N, [30, 10])
    # the height profile is W_h wide at half depth, and never thinner than the minimum
    r = bc.profile_radius(4.0)
    assert (1.0 - 2.0 / r) ** 2 == pytest.approx(0.5)
    assert bc.profile_radius(0.0) == bc.MIN_PROFILE_RADIUS


# --------------------------------------------------------------------------- no crossings
@pytest.mark.parametrize("case", ["random0", "random1", "random2", "random3", "swirl", "face"])
def test_furrows_never_cross(case):
    """No two segments of different furrows cross, except where one ends on the other.

    Random per-vertex fields on a coarse grid make furrows meet at every angle, head on
    too, and so exercise both the label-image test against earlier rounds and the
    conflicts between segments grown in the same round (turning the latter off makes
    these fields cross)."""
    if case == "face":
        uv, tris, field = face_mesh()
    else:
        uv, tris = grid_mesh(9)
        if case == "swirl":
            w = uv - 0.5
            field = 1.4 * np.stack([-w[:, 1], w[:, 0]], 1)
        else:
            field = 0.5 * np.random.default_rng(int(case[-1])).normal(size=uv.shape)
    res = bc.carve(uv, tris, field, 256, seed=11, scale=1.0)
    assert res.furrows > 100
    s = px(res)
    i, j, d = proper_crossings(s, res.segment_furrow, s, res.segment_furrow)
    bad = d > TOL_END
    assert not bad.any(), f"{bad.sum()} crossings, e.g. {s[i[bad][0]]} x {s[j[bad][0]]}"
    # not vacuous: many furrows stopped on others (T junctions)
    assert ends_touching(s, res.segment_furrow, s, res.segment_furrow) > 50
    # the label image holds the lines: every pixel a segment passes through is labelled
    # with its furrow, but for its last pixel, where it may end on another furrow's line
    ix, iy, _t, count = bc._supercover(s[:, 0], s[:, 1])
    k = np.arange(ix.shape[1])[None, :]
    lab = res.labels[np.clip(iy, 0, 255), np.clip(ix, 0, 255)]
    wrong = (k < count[:, None] - 1) & (lab != res.segment_furrow[:, None])
    assert not wrong.any(), f"{wrong.any(axis=1).sum()} segments pass pixels of other furrows"
    assert set(np.unique(res.labels[res.labels >= 0])) <= set(res.furrow_ids.tolist())


def test_same_round_conflicts_lowest_id_wins():
    """Within one round, where ends of different furrows claim one pixel the lower id keeps
    it; cuts are repeated until stable, so a furrow cut early gives back the pixels it no
    longer reaches."""
    uv, tris = grid_mesh(2)
    c = bc._Carver(uv, tris, rotating_field(uv), 16, 1.0, 0, None)
    cells = np.array([[5, 6, 7, 8],      # end 0, furrow 0
                      [20, 7, 9, 10],    # end 1, furrow 1: loses pixel 7 to furrow 0 at k=1
                      [9, 11, 12, 13],   # end 2, furrow 2: would lose 9 to furrow 1, which never gets there
                      [30, 31, 8, 32]])  # end 3, furrow 3: loses 8 to furrow 0 at k=2
    fid = np.array([0, 1, 2, 3])
    kb, win = c._resolve(cells, fid, np.array([4, 4, 4, 4]))
    np.testing.assert_array_equal(kb, [4, 1, 4, 2])
    np.testing.assert_array_equal(win, [-1, 0, -1, 0])
    assert (c.scratch == bc._BIG).all()  # the scratch image is left clean
    kb, win = c._resolve(cells, np.array([0, 0, 2, 3]), np.array([4, 4, 4, 4]))  # one furrow's two ends
    np.testing.assert_array_equal(kb, [4, 4, 0, 2])


# --------------------------------------------------------------------------- spacing
@pytest.mark.parametrize("scale", [0.5, 1.0])
def test_start_spacing(scale):
    """What §5.2 guarantees is about START points: a furrow may only start on a pixel
    whose occupancy is 0, and a segment's occupancy is a line of width W_o, i.e. every
    pixel centre within W_o / 2 of it (step 6).  Furrows grow on through occupied pixels,
    so two furrows may come closer than that further along (they converge, only centre
    lines stop them); no distance between whole furrows is guaranteed.  Hence:

    * a start lies at least W_o / 2 from every furrow of an earlier batch (less the
      1/sqrt(2) px between a random start and its pixel centre);
    * starts of one batch lie outside each other's thinning box (|along| < (N + 1) D and
      |across| < W_o / 2 in the direction of either), as if the first had grown first.

    With a constant field (m = 0.5, W_o = 7 scale) every segment has the same W_o."""
    uv, tris = grid_mesh(2)
    d = np.array([np.cos(0.3), np.sin(0.3)])
    field = np.tile(0.5 * d, (len(uv), 1))
    res = bc.carve(uv, tris, field, 256, seed=5, scale=scale)
    prm = bc.parameters(0.5, scale)
    half = float(prm.W_o) / 2.0
    R = 256
    seg = px(res)
    batch_of = dict(zip(res.furrow_ids.tolist(), res.batches.tolist()))
    seg_batch = np.array([batch_of[f] for f in res.segment_furrow])
    starts = res.starts * R
    assert res.batches.max() >= 3
    worst = np.inf
    for b in range(1, res.batches.max() + 1):
        p = starts[res.batches == b]
        older = seg[seg_batch < b]
        dist = _point_segment_distance(p[:, None], older[None, :, 0], older[None, :, 1]).min(axis=1)
        worst = min(worst, dist.min())
    assert worst >= half - 2 ** -0.5 - 1e-9, (worst, half)
    assert worst < half + 1.0  # the fill phase packs starts right at the band's edge
    # within a batch: outside each other's box
    reach = float((prm.N + 1) * prm.D)
    box_half = max(half, bc.MIN_BOX)
    for b in range(res.batches.max() + 1):
        p = starts[res.batches == b]
        v = p[None] - p[:, None]
        along = np.abs(v @ d)
        across = np.abs(v[..., 1] * d[0] - v[..., 0] * d[1])
        inside = (along < reach) & (across < box_half)
        np.fill_diagonal(inside, False)
        assert not inside.any()


# --------------------------------------------------------------------------- determinism
def test_same_seed_same_images():
    uv, tris, field = face_mesh()
    a = bc.carve(uv, tris, field, 192, seed=7)
    b = bc.carve(uv, tris, field, 192, seed=7)
    c = bc.carve(uv, tris, field, 192, seed=8)
    assert a.height.dtype == np.float32 and a.occupancy.dtype == bool
    assert a.height.tobytes() == b.height.tobytes()
    assert a.occupancy.tobytes() == b.occupancy.tobytes()
    assert a.labels.tobytes() == b.labels.tobytes()
    assert a.segments.tobytes() == b.segments.tobytes()
    assert not np.array_equal(a.height, c.height)
    assert not np.array_equal(a.labels, c.labels)


def test_global_generator_untouched():
    uv, tris, field = face_mesh(11)
    np.random.seed(3)
    before = np.random.random(3)
    np.random.seed(3)
    bc.carve(uv, tris, field, 64, seed=1)
    assert np.array_equal(np.random.random(3), before)


# --------------------------------------------------------------------------- coverage
def test_coverage():
    uv, tris = grid_mesh(2)
    res = bc.carve(uv, tris, rotating_field(uv, 0.5), 256, seed=2)
    assert res.scale == 0.5  # the default: 256 / 512
    assert 0.5 < res.coverage <= 1.0
    assert res.coverage == pytest.approx(float((res.height < 1.0).mean()))
    assert 0.75 <= res.height.min() < 0.76  # m = 0.5: grey level I = 0.75 on the centre line
    assert res.height.max() == 1.0
    assert res.occupancy.all()  # the fill phase leaves no free pixel
    assert res.furrows == len(res.lines) == len(res.furrow_ids) > 100
    # a stronger field carves deeper (I = 1 - m^2) with longer segments
    strong = bc.carve(uv, tris, rotating_field(uv, 0.9), 256, seed=2)
    assert 0.19 <= strong.height.min() < 0.2


def test_zero_field_carves_nothing():
    uv, tris = grid_mesh(2)
    res = bc.carve(uv, tris, np.zeros_like(uv), 64, seed=0)
    assert res.furrows == 0 and res.coverage == 0.0
    assert (res.height == 1.0).all() and (res.labels == -1).all()


def test_lines_are_the_segments():
    uv, tris, field = face_mesh(21)
    res = bc.carve(uv, tris, field, 128, seed=4)
    total = 0
    for f in res.lines:
        seg = res.segments[res.segment_furrow == f.id]
        total += len(seg)
        assert len(f.points) == len(seg) + 1
        assert np.isin(f.start, f.points).all()
        # consecutive points are segments of the furrow
        pairs = {tuple(np.round(s.ravel(), 12)) for s in seg}
        for p, q in zip(f.points[:-1], f.points[1:]):
            assert (tuple(np.round(np.concatenate([p, q]), 12)) in pairs
                    or tuple(np.round(np.concatenate([q, p]), 12)) in pairs)
    assert total == len(res.segments)


# --------------------------------------------------------------------------- mesh coverage
def test_uncovered_pixels_never_carved():
    uv, tris, field = face_mesh()
    res = bc.carve(uv, tris, field, 256, seed=3)
    out = ~res.covered
    assert out.any() and res.covered.any()
    assert (res.height[out] == 1.0).all()
    assert (res.labels[out] == -1).all()
    assert res.occupancy[out].all()
    assert (res.height[res.covered] < 1.0).any()
    # every segment runs over covered pixels (its end may touch an uncovered pixel's edge)
    s = px(res)
    t = np.linspace(0.0, 0.999, 16)[None, :, None]
    pts = s[:, None, 0] + t * (s[:, None, 1] - s[:, None, 0])
    ix, iy = np.floor(pts[..., 0]).astype(int), np.floor(pts[..., 1]).astype(int)
    assert res.covered[iy, ix].all()


# --------------------------------------------------------------------------- §5.4
def test_initial_state_keeps_lines_and_stops_new_furrows():
    """§5.4: a second part starts from the first part's images over the shared region: its
    lines stay, its occupied pixels start nothing, and new furrows stop on its lines."""
    R = 192
    uv_a, tris_a = grid_mesh(5, 0.0, 0.5)
    a = bc.carve(uv_a, tris_a, rotating_field(uv_a, 0.5, 2.5), R, seed=1, scale=1.0)
    init = bc.CarveState(height=a.height, occupancy=a.occupancy & a.covered, labels=a.labels)
    uv_b, tris_b = grid_mesh(9)
    field_b = rotating_field(uv_b, 0.5, 2.5) + 0.3 * np.random.default_rng(0).normal(size=uv_b.shape)
    b = bc.carve(uv_b, tris_b, field_b, R, seed=2, scale=1.0, initial=init)
    lab = a.labels >= 0
    np.testing.assert_array_equal(b.labels[lab], a.labels[lab])
    assert (b.height <= a.height).all()
    assert b.furrow_ids.min() > a.furrow_ids.max()
    # nothing starts on the first part's occupied pixels
    st = np.floor(b.starts * R).astype(int)
    assert not init.occupancy[st[:, 1], st[:, 0]].any()
    # no new segment crosses an old one; many new ends stop on old lines
    sa, sb = px(a), px(b)
    i, j, d = proper_crossings(sb, b.segment_furrow, sa, a.segment_furrow)
    assert (d <= TOL_END).all(), d.max()
    assert ends_touching(sb, b.segment_furrow, sa, a.segment_furrow) > 20
    assert (b.occupancy | ~b.covered).all()


def test_initial_state_of_a_result():
    """A CarveResult serves as an initial state (carving again keeps everything)."""
    uv, tris, field = face_mesh(21)
    a = bc.carve(uv, tris, field, 96, seed=1)
    b = bc.carve(uv, tris, field, 96, seed=2, initial=a)
    assert b.furrows == 0  # nothing was free
    assert np.array_equal(a.height, b.height) and np.array_equal(a.labels, b.labels)


# --------------------------------------------------------------------------- bad input
def test_magnitudes_above_one_are_clipped():
    uv, tris = grid_mesh(3)
    unit = rotating_field(uv, 1.0)
    a = bc.carve(uv, tris, unit, 96, seed=1)
    b = bc.carve(uv, tris, 3.0 * unit, 96, seed=1)
    assert np.array_equal(a.height, b.height) and np.array_equal(a.labels, b.labels)


@pytest.mark.parametrize("kwargs, match", [
    (dict(resolution=0), "resolution"),
    (dict(resolution=8193), "resolution"),
    (dict(resolution=-4), "resolution"),
    (dict(resolution=32.5), "resolution"),
    (dict(resolution="big"), "resolution"),
    (dict(field="nan"), "NaN"),
    (dict(field="short"), "field must be"),
    (dict(uv="3d"), "uv must be"),
    (dict(tris="bad_index"), "tris index"),
    (dict(tris="float"), "integer"),
    (dict(tris="flat"), "tris must be"),
    (dict(scale=0.0), "scale"),
    (dict(scale=float("nan")), "scale"),
    (dict(seed=-1), "seed"),
    (dict(seed=1.5), "seed"),
    (dict(initial="wrong_shape"), "initial"),
])
def test_bad_input(kwargs, match):
    uv, tris = grid_mesh(3)
    field = rotating_field(uv)
    args = dict(uv=uv, tris=tris, field=field, resolution=32, seed=0, scale=None, initial=None)
    args.update(kwargs)
    if args["field"] is not None and isinstance(args["field"], str):
        args["field"] = {"nan": np.where(np.arange(len(uv))[:, None] == 4, np.nan, field),
                         "short": field[:-1]}[args["field"]]
    if isinstance(args["uv"], str):
        args["uv"] = np.zeros((len(uv), 3))
    if isinstance(args["tris"], str):
        args["tris"] = {"bad_index": np.where(tris == 0, len(uv), tris), "float": tris.astype(float),
                        "flat": tris.ravel()}[args["tris"]]
    if isinstance(args["initial"], str):
        args["initial"] = bc.CarveState(np.ones((16, 16)), np.zeros((16, 16), bool), np.full((16, 16), -1))
    with pytest.raises(ValueError, match=match):
        bc.carve(args.pop("uv"), args.pop("tris"), args.pop("field"), args.pop("resolution"), **args)
