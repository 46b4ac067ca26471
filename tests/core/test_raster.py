"""UV-space baking: rasteriser, padding, PD slopes, zone masks."""

import tracemalloc

import numpy as np
import pytest

from tests.core.meshes import grid, uv_grid
from wrinkle_addon.core import mesh
from wrinkle_addon.core import raster as uvbake
from wrinkle_addon.core.maps import jimenez as wrinkle_maps
from wrinkle_addon.core.maps import uvmaps


def _pixel_centres(R):
    c = (np.arange(R) + 0.5) / R
    u, v = np.meshgrid(c, c)  # row j = v, column i = u
    return u, v


def _inside(u, v, tri):
    """Reference point-in-triangle test (strict interior) on pixel centres."""
    (x0, y0), (x1, y1), (x2, y2) = tri
    d0 = (x1 - x0) * (v - y0) - (y1 - y0) * (u - x0)
    d1 = (x2 - x1) * (v - y1) - (y2 - y1) * (u - x1)
    d2 = (x0 - x2) * (v - y2) - (y0 - y2) * (u - x2)
    return ((d0 > 0) & (d1 > 0) & (d2 > 0)) | ((d0 < 0) & (d1 < 0) & (d2 < 0))


def test_single_triangle_covers_exactly_the_pixels_whose_centres_are_inside():
    R = 32
    tri = np.array([[0.11, 0.07], [0.83, 0.31], [0.37, 0.92]])
    _img, cov = uvbake.rasterize(tri[None], None, R)
    u, v = _pixel_centres(R)
    inside = _inside(u, v, tri)
    assert cov.sum() > 100
    np.testing.assert_array_equal(cov, inside)  # no centre lies exactly on an edge here
    # row 0 is v near 0: the rows covered are those of v in [0.07, 0.92]
    rows = np.flatnonzero(cov.any(axis=1))
    assert rows.min() in (2, 3) and rows.max() == 28


def test_interpolation_is_exact_for_linear_functions():
    R = 64
    rng = np.random.default_rng(1)
    tri = np.array([[0.05, 0.1], [0.95, 0.2], [0.4, 0.97]])
    a, b, c = rng.normal(size=(3, 3))

    def f(p):
        return a + b * p[..., :1] + c * p[..., 1:2]

    img, cov = uvbake.rasterize(tri[None], f(tri)[None], R)
    u, v = _pixel_centres(R)
    expected = f(np.stack([u, v], -1))
    np.testing.assert_allclose(img[cov], expected[cov], atol=1e-5)
    assert np.all(img[~cov] == 0)


def test_a_mesh_is_covered_without_gaps_or_double_coverage():
    R = 128
    rng = np.random.default_rng(7)
    uv, tris = uv_grid(9)
    inner = (uv > 0) & (uv < 1)
    uv = uv + np.where(inner, rng.uniform(-0.04, 0.04, uv.shape), 0.0)  # jittered, shared edges
    corners = uv[tris]
    ones = np.ones((len(tris), 3, 1))
    # accumulate: every pixel must be drawn by exactly one triangle
    count = np.zeros((R, R))
    for t in range(len(tris)):
        _img, cov = uvbake.rasterize(corners[t:t + 1], None, R)
        count += cov
    assert count.min() == 1 and count.max() == 1
    img, cov, index = uvbake.rasterize(corners, ones, R, index=True)
    assert cov.all() and (index >= 0).all() and np.all(img == 1)
    # two triangles sharing one edge, with pixel centres exactly on it
    pair = np.array([[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], [[1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]])
    c0 = uvbake.rasterize(pair[:1], None, 16)[1]
    c1 = uvbake.rasterize(pair[1:], None, 16)[1]
    assert not (c0 & c1).any() and (c0 | c1).all()


def test_chunking_gives_the_same_image():
    uv, tris = uv_grid(12)
    vals = np.stack([uv[:, 0] * 3, uv[:, 1] - 1], 1)[tris]
    big = uvbake.rasterize(uv[tris], vals, 96)
    small = uvbake.rasterize(uv[tris], vals, 96, chunk_pixels=37)
    np.testing.assert_array_equal(big[0], small[0])
    np.testing.assert_array_equal(big[1], small[1])


def test_degenerate_and_outside_triangles_draw_nothing_and_never_fail():
    tris = np.array([
        [[0.2, 0.2], [0.4, 0.4], [0.6, 0.6]],  # no area
        [[1.5, 1.5], [1.9, 1.5], [1.5, 1.9]],  # outside the unit square (another UDIM tile)
        [[np.nan, 0.0], [0.5, 0.5], [0.0, 0.5]],  # not finite
    ])
    img, cov = uvbake.rasterize(tris, np.ones((3, 3, 2)), 32)
    assert not cov.any() and not img.any()
    img, cov = uvbake.rasterize(np.zeros((0, 3, 2)), np.zeros((0, 3, 1)), 8)
    assert img.shape == (8, 8, 1) and not cov.any()


def test_padding_fills_a_seam_band_with_island_values():
    R = 64
    # two islands with a gap between them (a seam), background elsewhere
    left = np.array([[[0.05, 0.05], [0.45, 0.05], [0.45, 0.95]], [[0.05, 0.05], [0.45, 0.95], [0.05, 0.95]]])
    right = left + [0.5, 0.0]
    uv = np.concatenate([left, right])
    vals = np.concatenate([np.full((2, 3, 1), 2.0), np.full((2, 3, 1), 4.0)])
    img, cov = uvbake.rasterize(uv, vals, R)
    gap = (slice(10, 50), slice(29, 35))  # the columns between the islands
    assert not cov[gap].any()
    padded, grown = uvbake.pad(img.copy(), cov, pixels=4)
    assert grown[gap].all() and grown.sum() > cov.sum()
    g = padded[gap][..., 0]
    assert np.all((g >= 2.0 - 1e-6) & (g <= 4.0 + 1e-6))  # island values, never the black background
    assert np.all(padded[cov] == img[cov])  # the islands themselves are untouched
    far = uvbake.pad(img.copy(), cov, pixels=2)[1]
    assert cov.sum() < far.sum() < grown.sum()  # one ring of pixels per iteration


def _plane(n=257, size=0.2):
    """A flat square of side ``size`` with the UV square mapped onto it (x = u size,
    y = v size, normal +Z): tangent = +X, bitangent = +Y."""
    uv, tris = uv_grid(n)
    pos = np.stack([uv[:, 0] * size, uv[:, 1] * size, np.zeros(len(uv))], 1)
    return uv, pos, tris


def test_sine_height_gives_the_analytic_slopes_with_the_right_sign():
    size, amp, wavelength = 0.2, 0.002, 0.5  # wavelength in UV units
    uv, pos, tris = _plane(size=size)
    h = amp * np.sin(2 * np.pi * uv[:, 0] / wavelength)
    R = 256
    s, cov = uvbake.slopes(uv[tris], pos[tris], h[tris], R, padding=0)
    u, v = _pixel_centres(R)
    dh_dx = amp * 2 * np.pi / wavelength * np.cos(2 * np.pi * u / wavelength) / size
    peak = np.abs(dh_dx).max()
    assert 0.1 < peak < 1  # inside the PD cone: no clipping in this test
    assert cov.all()
    np.testing.assert_allclose(s[..., 0], -dh_dx, atol=0.03 * peak)  # n'_x = -dh/dx
    assert np.abs(s[..., 1]).max() < 1e-3 * peak  # no slope along v
    # the normal tilts toward -u where the height increases with u
    rising = dh_dx > 0.5 * peak
    assert np.all(s[..., 0][rising] < 0)
    # smooth slopes (vertex gradients interpolated): the same field, more accurate
    smooth, _cov = uvbake.slopes(uv[tris], pos[tris], h[tris], R, smooth=True, verts=tris, padding=0)
    np.testing.assert_allclose(smooth[..., 0], -dh_dx, atol=0.01 * peak)
    assert np.abs(smooth[..., 1]).max() < 1e-3 * peak
    assert np.all(smooth[..., 0][rising] < 0)
    pd = uvmaps.pd_map(uv[tris], pos[tris], h[tris], R, padding=0)
    assert pd.shape == (R, R, 4) and pd.dtype == np.float32
    np.testing.assert_allclose(wrinkle_maps.decode(pd[..., 0]), s[..., 0], atol=1e-6)
    assert np.all(pd[..., 2] == 0) and np.all(pd[..., 3] == 1)
    normals = wrinkle_maps.normals_of_derivatives(wrinkle_maps.decode(pd[..., :2]))
    assert np.all(normals[..., 0][rising] < 0)


def test_slopes_use_world_length_per_uv_unit_along_v_and_for_sheared_uvs():
    size, amp = 0.2, 0.001
    uv, pos, tris = _plane(n=129, size=size)
    pos[:, 1] *= 3.0  # v spans 3x the length of u: slopes along v are 3x smaller
    h = amp * np.sin(2 * np.pi * uv[:, 1])
    s, _cov = uvbake.slopes(uv[tris], pos[tris], h[tris], 128, padding=0)
    u, v = _pixel_centres(128)
    expected = -amp * 2 * np.pi * np.cos(2 * np.pi * v) / (3 * size)
    np.testing.assert_allclose(s[..., 1], expected, atol=0.03 * np.abs(expected).max())
    # a sheared layout (x = u + 0.5 v): a height varying with x only tilts along the tangent
    uv, pos, tris = _plane(n=129, size=size)
    pos[:, 0] = size * (uv[:, 0] + 0.5 * uv[:, 1])
    h = amp * pos[:, 0] / size * 10
    s, _cov = uvbake.slopes(uv[tris], pos[tris], h[tris], 128, padding=0)
    inner = (slice(4, -4), slice(4, -4))
    np.testing.assert_allclose(s[inner][..., 0], -amp * 10 / size, rtol=1e-3)
    assert np.abs(s[inner][..., 1]).max() < 1e-3 * amp * 10 / size
    s, _cov = uvbake.slopes(uv[tris], pos[tris], h[tris], 128, smooth=True, verts=tris, padding=0)
    np.testing.assert_allclose(s[..., 0], -amp * 10 / size, rtol=1e-6)
    assert np.abs(s[..., 1]).max() < 1e-6 * amp * 10 / size


def test_weighted_height_fields_meet_without_a_streak():
    """Two zones with different wrinkles (sines out of phase) meeting at u = 1/2.  Cutting
    the heights together leaves a step, whose slope is a streak along the border; each
    vertex weighting the two fields' gradients passes smoothly from one to the other."""
    size, amp = 0.2, 0.002
    uv, pos, tris = _plane(n=129, size=size)
    fields = np.stack([amp * np.sin(6 * np.pi * uv[:, 1]), amp * np.cos(6 * np.pi * uv[:, 1])], 1)
    layer = (uv[:, 0] > 0.5).astype(int)
    one_hot = (layer[:, None] == np.arange(2)).astype(float)
    peak = amp * 6 * np.pi / size  # the largest slope of either field
    cut = np.take_along_axis(fields, layer[:, None], 1)[:, 0]
    R = 128
    s_cut = uvbake.slopes(uv[tris], pos[tris], cut[tris], R, smooth=True, verts=tris, padding=0)[0]
    assert np.abs(s_cut).max() > 2 * peak  # the streak
    sides = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    edges = np.unique(np.sort(sides, axis=1), axis=0)
    soft = uvbake.soften(one_hot, edges, uvbake.diffusion_time(0.02, size / 128))
    np.testing.assert_allclose(soft.sum(axis=1), 1.0, atol=1e-5)
    s = uvbake.slopes(uv[tris], pos[tris], fields[tris], R, smooth=True, verts=tris, padding=0,
                      weights=soft)[0]
    assert np.abs(s).max() < 1.05 * peak
    u, v = _pixel_centres(R)
    left, right = u < 0.3, u > 0.7  # away from the border each side shows its own field
    np.testing.assert_allclose(s[..., 1][left], -amp * 6 * np.pi / size * np.cos(6 * np.pi * v[left]),
                               atol=0.05 * peak)
    np.testing.assert_allclose(s[..., 1][right], amp * 6 * np.pi / size * np.sin(6 * np.pi * v[right]),
                               atol=0.05 * peak)
    # a single field with weights 1 is the unweighted bake
    one = uvbake.slopes(uv[tris], pos[tris], fields[tris, 0][..., None], R, smooth=True, verts=tris,
                        padding=0, weights=np.ones((len(uv), 1)))[0]
    plain = uvbake.slopes(uv[tris], pos[tris], fields[tris, 0], R, smooth=True, verts=tris, padding=0)[0]
    np.testing.assert_allclose(one, plain, atol=1e-12)
    with pytest.raises(ValueError, match="smooth"):
        uvbake.slopes(uv[tris], pos[tris], fields[tris], R, weights=soft)


def test_a_non_uniform_scale_changes_the_slopes_and_a_uniform_one_does_not():
    size, amp = 0.2, 0.002
    uv, pos, tris = _plane(n=65, size=size)  # normal +Z
    h = amp * np.sin(2 * np.pi * uv[:, 0])

    def bake(matrix):
        p, hh = uvbake.to_world(pos, tris, h, matrix)
        return uvbake.slopes(uv[tris], p[tris], hh[tris], 64, smooth=True, verts=tris, padding=0)[0]

    plain = bake(np.eye(3))
    assert np.abs(plain).max() > 0.01
    np.testing.assert_allclose(bake(np.diag([3.0, 3.0, 3.0])), plain, atol=1e-6)
    rot = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    np.testing.assert_allclose(bake(rot), plain, atol=1e-6)  # slopes live in tangent space
    np.testing.assert_allclose(bake(np.diag([2.0, 1.0, 1.0])), plain / 2, atol=1e-6)  # u runs 2x longer
    np.testing.assert_allclose(bake(np.diag([1.0, 1.0, 3.0])), plain * 3, atol=1e-6)  # heights 3x taller
    with pytest.raises(ValueError, match="zero"):
        uvbake.to_world(pos, tris, h, np.diag([1.0, 0.0, 1.0]))


def test_smooth_slopes_are_continuous_where_per_pixel_slopes_are_faceted():
    uv, pos, tris = _plane(n=9, size=0.1)
    h = 0.004 * np.sin(2 * np.pi * uv[:, 0]) * np.cos(2 * np.pi * uv[:, 1])
    R = 128
    faceted = uvbake.slopes(uv[tris], pos[tris], h[tris], R, padding=0)[0]
    smooth = uvbake.slopes(uv[tris], pos[tris], h[tris], R, smooth=True, verts=tris, padding=0)[0]
    jump_f = np.abs(np.diff(faceted[..., 0], axis=1)).max()
    jump_s = np.abs(np.diff(smooth[..., 0], axis=1)).max()
    assert jump_s < 0.25 * jump_f  # no steps at the triangle edges
    with pytest.raises(ValueError, match="verts"):
        uvbake.slopes(uv[tris], pos[tris], h[tris], R, smooth=True)


def test_islands_that_touch_in_uv_do_not_mix_their_heights():
    # two islands side by side in UV, touching along u = 0.5, with different constant heights
    left = np.array([[[0.0, 0.0], [0.5, 0.0], [0.5, 1.0]], [[0.0, 0.0], [0.5, 1.0], [0.0, 1.0]]])
    right = left + [0.5, 0.0]
    uv = np.concatenate([left, right])
    right_pos = np.concatenate([right, np.zeros((2, 3, 1))], -1) + [0.0, 0.0, 5.0]  # elsewhere on the mesh
    pos = np.concatenate([np.concatenate([left, np.zeros((2, 3, 1))], -1), right_pos])
    h = np.concatenate([np.zeros((2, 3)), np.full((2, 3), 0.01)])
    verts = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])  # no mesh vertex in common
    islands = uvbake.uv_islands(uv, verts)
    assert len(np.unique(islands)) == 2
    assert len(np.unique(uvbake.uv_islands(uv))) == 1  # by UV alone they touch: one island
    s, _cov = uvbake.slopes(uv, pos, h, 32, islands=islands, padding=0)
    assert np.abs(s).max() == 0.0  # each island is flat
    joined = uvbake.slopes(uv, pos, h, 32, islands=np.zeros(4, int), padding=0)[0]
    assert np.abs(joined).max() > 0  # the same seam read as one island would make a cliff


def test_uv_islands_of_a_grid_and_two_copies():
    uv, tris = uv_grid(6)
    a = uvbake.uv_islands(uv[tris])
    assert len(np.unique(a)) == 1
    both = np.concatenate([uv[tris] * 0.4, uv[tris] * 0.4 + 0.5])
    ids = uvbake.uv_islands(both)
    assert len(np.unique(ids)) == 2 and len(np.unique(ids[: len(tris)])) == 1


def test_soft_borders_are_monotone_and_masks_sum_to_at_most_one():
    rest, edges, tris, _q = grid(81, 21, 0.2, 0.05)  # edge length 2.5 mm
    x = rest[:, 0]
    m = np.zeros((len(rest), 8))
    m[:, 0] = x < 0.0  # zone 1: the left half
    m[:, 4] = x > -0.02  # zone 5 overlaps it on a band
    m[:, 7] = 0.5
    edge_len = np.median(mesh.edge_lengths(rest, edges))
    softness = 0.03
    t = uvbake.diffusion_time(softness, edge_len)
    assert t > 1
    soft = uvbake.soften(m, edges, t)
    assert soft.shape == (len(rest), 8) and soft.dtype == np.float32
    assert soft.sum(axis=1).max() <= 1.0 + 1e-6
    assert soft.min() >= 0.0
    # zone 1 alone (no overlap normalisation): a monotone ramp across its border
    alone = uvbake.soften(m[:, :1], edges, t)[:, 0]
    row = np.flatnonzero(np.isclose(rest[:, 2], rest[len(rest) // 2, 2]))
    order = np.argsort(x[row])
    profile, xs = alone[row][order], x[row][order]
    assert np.all(np.diff(profile) <= 1e-5)
    assert profile[0] > 0.99 and profile[-1] < 0.01
    # the ramp from 84 % to 16 % is about ``softness`` wide
    width = np.interp(0.16, profile[::-1], xs[::-1]) - np.interp(0.84, profile[::-1], xs[::-1])
    assert 0.6 * softness < width < 1.4 * softness, width
    sharp = uvbake.soften(m[:, :1], edges, 0.0)[:, 0]
    assert set(np.unique(sharp)) <= {0.0, 1.0}
    # rasterised and packed
    uv = np.stack([(x + 0.1) / 0.2, rest[:, 2] / 0.05], 1)
    a, b = uvmaps.mask_images(uv[tris], soft[tris], 64)
    assert a.shape == b.shape == (64, 64, 4)
    total = a.sum(-1) + b.sum(-1)
    assert total.max() <= 1.0 + 1e-5
    assert a[32, 2, 0] > 0.3 and a[32, -3, 0] < 0.01  # zone 1 is on the left (low u) in R of mask A
    assert b[32, -3, 0] > 0.3 and b[32, 2, 0] < 0.05  # zone 5 in R of mask B
    assert np.all(b[..., 3] > 0.2)  # zone 8 everywhere, in A of mask B


def test_a_small_zone_is_softened_but_not_dimmed():
    rest, edges, _t, _q = grid(41, 41, 0.1, 0.1)
    m = np.zeros((len(rest), 8))
    spot = np.hypot(rest[:, 0], rest[:, 2] - 0.05) < 0.006  # a few vertices
    m[spot, 6] = 1.0
    edge = np.median(mesh.edge_lengths(rest, edges))
    soft = uvbake.soften(m, edges, uvbake.diffusion_time(0.02, edge))
    assert soft[:, 6].max() == pytest.approx(1.0)
    assert (soft[:, 6] > 0.1).sum() > 3 * spot.sum()  # the border spread out


def test_diffusion_keeps_values_in_range_and_handles_isolated_vertices():
    edges = np.array([[0, 1], [1, 2], [2, 2]])  # and a loop edge
    x = np.array([1.0, 0.0, 0.0, 0.7])  # vertex 3 has no edge
    y = uvbake.diffuse(x, edges, 10.0)
    assert y[3] == pytest.approx(0.7) and -1e-6 <= y.min() and y.max() <= 1 + 1e-6
    assert y[0] > y[1] > y[2]
    assert y[:3].sum() == pytest.approx(1.0)  # (I + tL) conserves the total
    assert uvbake.diffusion_time(0.0, 0.01) == 0 and uvbake.diffusion_time(0.01, 0.0) == 0
    assert uvbake.diffusion_time(0.02, 0.01) == pytest.approx(0.5)
    grown = uvbake.dilate_max(np.array([0.0, 1.0, 0.0, 0.0]), np.array([[0, 1], [1, 2], [2, 3]]), 1)
    np.testing.assert_array_equal(grown, [1, 1, 1, 0])
    kept = uvbake.dilate_max(np.array([0.0, 1.0, 0.0, 0.0]), np.array([[0, 1], [1, 2], [2, 3]]), 5,
                             inside=np.array([False, True, True, True]))
    np.testing.assert_array_equal(kept, [0, 1, 1, 1])


def test_4096_on_a_small_mesh_with_bounded_memory():
    uv, pos, tris = _plane(n=17, size=0.1)
    h = 0.001 * np.sin(6 * uv[:, 0])
    tracemalloc.start()  # NumPy reports its buffers to tracemalloc
    try:
        pd = uvmaps.pd_map(uv[tris], pos[tris], h[tris], 4096, smooth=True, verts=tris)
        peak_mb = tracemalloc.get_traced_memory()[1] / 2**20
    finally:
        tracemalloc.stop()
    assert pd.shape == (4096, 4096, 4)
    assert 0.0 <= pd.min() and pd.max() <= 1.0
    # the output alone is 256 MB; the working memory stays about as much again (measured 528)
    assert peak_mb < 700, f"peak {peak_mb:.0f} MB"


@pytest.mark.parametrize("R", [1, 3])
def test_tiny_resolutions(R):
    uv, pos, tris = _plane(n=5)
    pd = uvmaps.pd_map(uv[tris], pos[tris], np.zeros((len(tris), 3)), R)
    assert pd.shape == (R, R, 4) and np.allclose(pd[..., :2], 0.5)
