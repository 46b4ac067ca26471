"""Fine wrinkles over two body parts (Bando et al. 2002, §5.4): the shared portion found,
the field and heights copied, and the second part carved on from them."""

import numpy as np
import pytest

from wrinkle_addon.core.bando import carve, parts

STEP = 1.0 / 40.0


def _grid(x0, x1):
    """A flat strip of the plane z = 0 from x0 to x1 (y in [0, 0.4]), on the global grid
    of step STEP: positions (N, 3) and triangles (T, 3)."""
    xs = np.arange(round(x0 / STEP), round(x1 / STEP) + 1) * STEP
    ys = np.arange(0, round(0.4 / STEP) + 1) * STEP
    nx, ny = len(xs), len(ys)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    pos = np.stack([X.ravel(), Y.ravel(), np.zeros(X.size)], 1)
    i, j = np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), indexing="ij")
    a = (i * ny + j).ravel()
    b, c, d = a + ny, a + ny + 1, a + 1
    tris = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    return pos, tris


def _part_a():
    pos, tris = _grid(0.0, 0.6)
    uv = np.stack([0.05 + 0.9 * pos[:, 0] / 0.6, 0.05 + 0.9 * pos[:, 1] / 0.6], 1)
    return pos, tris, uv


def _part_b():
    # another unwrap: turned by -90 degrees and scaled, its triangles listed in another order
    pos, tris = _grid(0.4, 1.0)
    tris = tris[::-1][:, [1, 2, 0]]
    uv = np.stack([0.05 + 0.9 * pos[:, 1] / 0.6, 0.05 + 0.9 * (1.0 - pos[:, 0]) / 0.6], 1)
    return pos, tris, uv


def test_match_points_finds_moved_copies_and_nothing_else():
    rng = np.random.default_rng(3)
    a = rng.random((500, 3))
    perm = rng.permutation(500)
    b = a[perm] + rng.uniform(-4e-7, 4e-7, (500, 3))
    b = np.concatenate([b, rng.random((50, 3)) + 2.0])  # 50 points far from every point of a
    got = parts.match_points(a, b, 1e-6)
    np.testing.assert_array_equal(got[:500], perm)
    assert (got[500:] == -1).all()
    assert (parts.match_points(a, np.zeros((0, 3)), 1e-6) == -1).all()
    with pytest.raises(ValueError):
        parts.match_points(a, b, 0.0)


def test_shared_portion_is_the_overlap_with_corners_matched():
    pa, ta, _ = _part_a()
    pb, tb, _ = _part_b()
    sa, sb, corner = parts.shared_portion(pa, ta, pb, tb, 1e-6)
    # the overlap x in [0.4, 0.6] is 8 x 16 quads, 2 triangles each
    assert len(sa) == len(sb) == 8 * 16 * 2
    np.testing.assert_allclose(pa[ta[sa][np.arange(len(sa))[:, None], corner]], pb[tb[sb]], atol=1e-12)
    centres = pb[tb[sb]].mean(axis=1)
    assert (centres[:, 0] > 0.4).all() and (centres[:, 0] < 0.6).all()
    none = parts.shared_portion(pa, ta, pb + 5.0, tb, 1e-6)
    assert all(len(x) == 0 for x in none)


def test_copy_field_turns_directions_and_keeps_lengths():
    pa, ta, ua = _part_a()
    pb, tb, ub = _part_b()
    sa, sb, corner = parts.shared_portion(pa, ta, pb, tb, 1e-6)
    src_uv = ua[ta[sa][np.arange(len(sa))[:, None], corner]]
    dst_uv = ub[tb[sb]]
    # along the skin's x with magnitude 0.6: (0.6, 0) in A's UV, (0, -0.6) in B's
    f = np.broadcast_to([0.6, 0.0], src_uv.shape)
    got = parts.copy_field(src_uv, dst_uv, f)
    np.testing.assert_allclose(got, np.broadcast_to([0.0, -0.6], got.shape), atol=1e-12)
    degenerate = src_uv.copy()
    degenerate[0] = degenerate[0, 0]
    assert (parts.copy_field(degenerate, dst_uv, f)[0] == 0).all()


def test_sample_bilinear_is_exact_for_linear_images():
    R = 16
    j, i = np.mgrid[0:R, 0:R]
    img = 0.3 + 0.01 * i + 0.02 * j  # a linear function of the pixel centres
    uv = np.array([[0.5, 0.5], [0.2, 0.7], [(3 + 0.5) / R, (5 + 0.5) / R]])
    want = 0.3 + 0.01 * (uv[:, 0] * R - 0.5) + 0.02 * (uv[:, 1] * R - 0.5)
    np.testing.assert_allclose(parts.sample_bilinear(img, uv), want, atol=1e-12)


def _two_parts(R, copy):
    """Carve part A, then part B from A's shared portion (``copy``) or on its own.  Returns
    both results and the corner UVs of the shared triangles in A and in B."""
    pa, ta, ua = _part_a()
    pb, tb, ub = _part_b()
    sa, sb, corner = parts.shared_portion(pa, ta, pb, tb, 1e-6)
    src_uv = ua[ta[sa][np.arange(len(sa))[:, None], corner]]
    dst_uv = ub[tb[sb]]
    # one skin direction: diagonal in x, y with magnitude 0.8; each part's own UV vectors
    fa = np.broadcast_to([0.8 * 0.6, 0.8 * 0.8], ua.shape)
    fb = np.broadcast_to([0.8 * 0.8, -0.8 * 0.6], ub.shape)
    a = carve.carve(ua, ta, fa, R, seed=1)
    initial = parts.copy_heights(a.height, src_uv, dst_uv, R) if copy else None
    b = carve.carve(ub, tb, fb, R, seed=2, initial=initial)
    return a, b, (pa, ta, ua), (pb, tb, ub), initial


def _heights_at(result, uv):
    return parts.sample_bilinear(result.height, uv)


def _band_points(lo, hi, n=4000, seed=0):
    rng = np.random.default_rng(seed)
    return np.stack([rng.uniform(lo, hi, n), rng.uniform(0.02, 0.38, n), np.zeros(n)], 1)


def _uv_a(p):
    return np.stack([0.05 + 0.9 * p[:, 0] / 0.6, 0.05 + 0.9 * p[:, 1] / 0.6], 1)


def _uv_b(p):
    return np.stack([0.05 + 0.9 * p[:, 1] / 0.6, 0.05 + 0.9 * (1.0 - p[:, 0]) / 0.6], 1)


def test_second_part_carries_on_the_first_parts_furrows():
    R = 256
    a, b, _A, _B, initial = _two_parts(R, copy=True)
    # the copied state: the whole shared portion occupied, the copied furrows labelled 0
    # (the band x in [0.4, 0.6] is u in [0.05, 0.65], v in [0.65, 0.95] of B's texture)
    assert abs(initial.occupancy.sum() / (0.6 * 0.3 * R * R) - 1.0) < 0.03
    assert (initial.labels[initial.height < 1] == 0).all()
    # inside the shared portion B shows A's furrows at the same points of the skin, but for
    # resampling (A's image read bilinearly at B's pixels, B's read again here: about 4 %)
    p = _band_points(0.43, 0.57)
    ha, hb = _heights_at(a, _uv_a(p)), _heights_at(b, _uv_b(p))
    assert (ha < 0.9).mean() > 0.3  # A has furrows there
    same = np.abs(ha - hb).mean()
    # carved on their own, the two parts disagree there: the test can fail
    _a2, b_alone, _A, _B, _ = _two_parts(R, copy=False)
    alone = np.abs(ha - _heights_at(b_alone, _uv_b(p))).mean()
    assert same < 0.06 and same < 0.4 * alone, (same, alone)
    # B's new furrows start outside the shared portion only
    starts_x = 1.0 - (b.starts[:, 1] - 0.05) / 0.9 * 0.6
    assert (starts_x > 0.6 - 1.5 / R * 0.6 / 0.9).all()


def test_second_part_furrows_stop_on_the_copied_ones():
    R = 256
    _a, b, _A, _B, initial = _two_parts(R, copy=True)
    # B's furrows grow into the shared portion only until they meet a copied furrow: the
    # copied heights stay but for a few pixels, and every copied furrow pixel keeps label 0
    band = initial.occupancy
    changed = np.abs(b.height - initial.height) > 1e-6
    assert changed[band].mean() < 0.02
    assert (b.labels[initial.labels == 0] == 0).all()
    assert (b.height <= initial.height + 1e-6).all()  # new furrows take the minimum


def test_copy_heights_checks_its_input():
    with pytest.raises(ValueError):
        parts.copy_heights(np.ones((8, 8)), np.zeros((2, 3, 2)), np.zeros((3, 3, 2)), 8)
    state = parts.copy_heights(np.ones((8, 8)), np.zeros((0, 3, 2)), np.zeros((0, 3, 2)), 8)
    assert not state.occupancy.any() and (state.height == 1).all() and (state.labels == -1).all()
