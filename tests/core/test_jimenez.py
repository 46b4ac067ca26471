"""Wrinkle maps of Jimenez et al. 2011 (§1.2, §1.2.1, Listing 1.1, Table 1.1): pure NumPy."""

import numpy as np
import pytest

from wrinkle_addon.core.maps import jimenez as wm

FLAT = np.array([0.5, 0.5, 1.0], np.float32)  # encoded (0, 0, 1)
NO_MASK = np.zeros(4, np.float32)


def _normals_in_cone(n, max_slope=0.95, seed=0):
    rng = np.random.default_rng(seed)
    slopes = rng.uniform(-max_slope, max_slope, (n, 2))
    v = np.concatenate([slopes, np.ones((n, 1))], axis=1)
    return (v / np.linalg.norm(v, axis=1, keepdims=True)).astype(np.float32)


def _unit(v):
    v = np.asarray(v, np.float64)
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _mask(zone):
    """(mask_a, mask_b) with only ``zone`` (0-7) set to 1."""
    m = np.zeros(8, np.float32)
    m[zone] = 1.0
    return m[:4], m[4:]


def test_pd_of_the_flat_normal_is_half_grey_with_blue_zero():
    np.testing.assert_array_equal(wm.normal_to_derivative(FLAT), [0.5, 0.5, 0.0])
    np.testing.assert_allclose(wm.derivative_to_normal([0.5, 0.5, 0.0]), FLAT, atol=1e-7)


def test_pd_encoding_of_a_known_normal():
    n = _unit([0.3, -0.6, 1.0])  # slopes (0.3, -0.6)
    pd = wm.normal_to_derivative(wm.encode(n))
    np.testing.assert_allclose(pd, [0.65, 0.2, 0.0], atol=1e-6)


def test_normal_pd_normal_round_trip_inside_the_cone():
    n = _normals_in_cone(500)
    rgb = wm.encode(n)
    back = wm.derivative_to_normal(wm.normal_to_derivative(rgb))
    assert back.shape == (500, 3)
    np.testing.assert_allclose(back, rgb, atol=2e-6)


def test_normals_outside_the_cone_are_clipped_to_its_edge():
    a = np.radians(60.0)
    steep = wm.encode([[np.sin(a), 0.0, np.cos(a)],  # slope tan 60 = 1.73 in x
                       [0.0, -np.sin(a), np.cos(a)],  # -1.73 in y
                       [0.6, 0.0, -0.8]])  # facing away: to the edge on its side
    pd = wm.normal_to_derivative(steep)
    np.testing.assert_allclose(pd, [[1.0, 0.5, 0.0], [0.5, 0.0, 0.0], [1.0, 0.5, 0.0]], atol=1e-6)
    back = wm.derivative_to_normal(pd)
    edge = 0.5 + 0.5 / np.sqrt(2.0)  # encoded component of (1, 0, 1) / sqrt 2
    np.testing.assert_allclose(back[0], [edge, 0.5, edge], atol=1e-6)
    np.testing.assert_allclose(back[1], [0.5, 1.0 - edge, edge], atol=1e-6)


def test_difference_map_of_identical_maps_is_half_grey():
    rgb = wm.encode(_normals_in_cone(50))
    np.testing.assert_array_equal(wm.difference_map(rgb, rgb), np.full((50, 3), 0.5, np.float32))


def test_base_plus_twice_the_decoded_difference_is_the_wrinkle_map():
    b = wm.encode(_normals_in_cone(50, seed=1))
    w = wm.encode(_normals_in_cone(50, seed=2))
    d = wm.difference_map(b, w)
    np.testing.assert_allclose(wm.decode(b) + 2.0 * wm.decode(d), wm.decode(w), atol=1e-6)
    # a concrete pixel: d = 0.5 + 0.5 (w - b)
    np.testing.assert_allclose(wm.difference_map([0.2, 0.5, 1.0], [0.6, 0.4, 0.9]), [0.7, 0.45, 0.45])


@pytest.mark.parametrize("difference", [False, True])
def test_zero_weights_return_the_base_normal(difference):
    base = wm.encode(_normals_in_cone(20, seed=3))
    wrinkle = np.full((20, 3), [0.9, 0.1, 0.3], np.float32)
    ones = np.ones((20, 4), np.float32)
    out = wm.blend(base, [wrinkle, wrinkle], ones, ones, np.zeros((2, 8)), difference=difference)
    np.testing.assert_allclose(out, _unit(wm.decode(base)), atol=1e-6)


@pytest.mark.parametrize("zone", range(8))
def test_one_zone_at_weight_one_on_a_flat_base_gives_the_wrinkle_normal(zone):
    n = _normals_in_cone(30, seed=4)
    a, b = _mask(zone)
    weights = np.zeros(8)
    weights[zone] = 1.0
    pd = wm.normal_to_derivative(wm.encode(n))
    np.testing.assert_allclose(wm.blend(FLAT, [pd], a, b, weights), n, atol=1e-6)
    d = wm.difference_map(FLAT, wm.encode(n))
    np.testing.assert_allclose(wm.blend(FLAT, [d], a, b, weights, difference=True), n, atol=1e-6)
    # the other zones' weights do nothing here
    other = np.where(np.arange(8) == zone, 0.0, 1.0)
    np.testing.assert_allclose(wm.blend(FLAT, [pd], a, b, other), np.tile([0, 0, 1], (30, 1)), atol=1e-7)


def test_half_weight_adds_half_the_slope():
    a, b = _mask(2)
    pd = wm.encode([0.8, -0.4, -1.0])  # slopes (0.8, -0.4); B ignored
    out = wm.blend(FLAT, [pd], a, b, [0, 0, 0.5, 0, 0, 0, 0, 0])
    np.testing.assert_allclose(out, _unit([0.4, -0.2, 1.0]), atol=1e-6)
    out2 = wm.blend(FLAT, [pd], a, b, [0, 0, 0.5, 0, 0, 0, 0, 0], strength=2.0)
    np.testing.assert_allclose(out2, _unit([0.8, -0.4, 1.0]), atol=1e-6)


@pytest.mark.parametrize("difference", [False, True])
def test_zone_weights_are_clamped_to_0_1(difference):
    base = wm.encode(_unit([0.1, 0.2, 1.0]))
    if difference:
        wrinkle = wm.difference_map(base, wm.encode(_unit([0.6, -0.3, 1.0])))
    else:
        wrinkle = wm.encode([0.5, -0.5, 0.0])
    a, b = _mask(5)
    one = wm.blend(base, [wrinkle], a, b, [0, 0, 0, 0, 0, 1.0, 0, 0], difference=difference)
    three = wm.blend(base, [wrinkle], a, b, [0, 0, 0, 0, 0, 3.0, 0, 0], difference=difference)
    negative = wm.blend(base, [wrinkle], a, b, [0, 0, 0, 0, 0, -2.0, 0, 0], difference=difference)
    np.testing.assert_allclose(three, one, atol=1e-7)
    np.testing.assert_allclose(negative, _unit([0.1, 0.2, 1.0]), atol=1e-6)
    assert np.abs(one - negative).max() > 0.1  # weight 1 does change the normal
    if not difference:
        np.testing.assert_allclose(one, _unit([0.6, -0.3, 1.0]), atol=1e-6)


def test_table_1_1_anger_cancels_surprise_on_the_forehead():
    table = np.array([wm.TABLE_1_1["Surprise"], wm.TABLE_1_1["Anger"]])
    both = wm.expression_sums([1.0, 1.0], table)
    # at full strength each, the outer forehead keeps 0.8 - 0.6 = 0.2, the inner cancels
    np.testing.assert_allclose(both, [0.2, 0.2, 0.0, 0.0, 0.8, 0.8, 1.0, 0.0], atol=1e-6)
    # surprise at 0.7 under full anger: every forehead zone sums below 0 and clamps to 0
    sums = wm.expression_sums([0.7, 1.0], table)
    np.testing.assert_allclose(sums, [-0.04, -0.04, -0.24, -0.24, 0.8, 0.8, 1.0, 0.0], atol=1e-6)
    np.testing.assert_array_equal(wm.zone_response(sums)[:4], 0.0)

    base = wm.encode(_normals_in_cone(40, seed=5))
    wrinkle = wm.encode(np.tile([0.9, -0.7, 0.0], (40, 1)))  # a strong PD wrinkle everywhere
    forehead = np.ones((40, 4), np.float32)  # mask A: zones 1-4 at 1, mask B empty
    nothing = np.zeros((40, 4), np.float32)
    out = wm.blend(base, [wrinkle], forehead, nothing, sums)
    np.testing.assert_allclose(out, _unit(wm.decode(base)), atol=1e-6)
    # surprise alone does wrinkle the forehead: zone 1 at 0.8 times the wrinkle slopes
    alone = wm.blend(FLAT, [wrinkle[:1]], [1, 0, 0, 0], NO_MASK, wm.TABLE_1_1["Surprise"])
    np.testing.assert_allclose(alone[0], _unit([0.8 * 0.9, 0.8 * -0.7, 1.0]), atol=1e-6)


def test_pd_and_difference_modes_agree():
    base = wm.encode(_normals_in_cone(60, max_slope=0.4, seed=6))
    ones, zeros = np.ones((60, 4), np.float32), np.zeros((60, 4), np.float32)
    weights = [1.0, 0, 0, 0, 0, 0, 0, 0]
    # the wrinkle map equal to the base: a flat PD detail map and a 0.5 difference map
    flat_pd = np.tile([0.5, 0.5, 0.0], (60, 1)).astype(np.float32)
    pd_out = wm.blend(base, [flat_pd], ones, zeros, weights)
    diff_out = wm.blend(base, [wm.difference_map(base, base)], ones, zeros, weights, difference=True)
    np.testing.assert_allclose(pd_out, _unit(wm.decode(base)), atol=1e-6)
    np.testing.assert_allclose(diff_out, pd_out, atol=1e-6)
    # a different wrinkle map at weight 1: both modes give the wrinkle normal
    w_n = _normals_in_cone(60, max_slope=0.4, seed=7)
    b_slopes = wm.decode(base)[:, :2] / wm.decode(base)[:, 2:]
    w_slopes = w_n[:, :2] / w_n[:, 2:]
    detail = np.concatenate([wm.encode(w_slopes - b_slopes), np.zeros((60, 1))], axis=1)
    pd_out = wm.blend(base, [detail], ones, zeros, weights)
    d = wm.difference_map(base, wm.encode(w_n))
    diff_out = wm.blend(base, [d], ones, zeros, weights, difference=True)
    np.testing.assert_allclose(pd_out, w_n, atol=1e-5)
    np.testing.assert_allclose(diff_out, w_n, atol=1e-5)


def test_two_maps_add_their_slopes():
    a, b = _mask(0)
    m1, m2 = wm.encode([0.2, 0.0, 0.0]), wm.encode([0.0, -0.6, 0.0])
    out = wm.blend(FLAT, [m1, m2], a, b, [[1, 0, 0, 0, 0, 0, 0, 0], [0.5, 0, 0, 0, 0, 0, 0, 0]])
    np.testing.assert_allclose(out, _unit([0.2, -0.3, 1.0]), atol=1e-6)
    with pytest.raises(ValueError, match="2 wrinkle maps but 1 rows"):
        wm.blend(FLAT, [m1, m2], a, b, np.zeros(8))


def test_mask_sum_weights_each_zone_by_its_channel():
    a = np.array([1.0, 0.5, 0.0, 0.25], np.float32)
    b = np.array([0.0, 1.0, 1.0, 0.0], np.float32)
    w = np.array([0.4, 1.0, 0.9, 2.0, 0.7, -1.0, 0.3, 1.0], np.float32)
    # 1*0.4 + 0.5*1 + 0 + 0.25*1 (2 clamped) + 0 + 1*0 (-1 clamped) + 1*0.3 + 0
    assert wm.mask_sum(a, b, w) == pytest.approx(1.45)


def test_zone_response_strength_and_power():
    raw = [-1.0, 0.0, 0.5, 1.0, 3.0, 0.25, 0.81, 0.2]
    np.testing.assert_allclose(wm.zone_response(raw), [0, 0, 0.5, 1, 1, 0.25, 0.81, 0.2], atol=1e-7)
    np.testing.assert_allclose(wm.zone_response(raw, strength=2.0, power=2.0),
                               [0, 0, 0.5, 2, 2, 0.125, 1.3122, 0.08], atol=1e-6)
    np.testing.assert_allclose(wm.zone_response(raw, power=0.5)[[2, 5, 6]], [np.sqrt(0.5), 0.5, 0.9],
                               atol=1e-6)
    strengths = np.array([0, 1, 1, 1, 0.5, 1, 1, 2])
    np.testing.assert_allclose(wm.zone_response(raw, strength=strengths),
                               [0, 0, 0.5, 1, 0.5, 0.25, 0.81, 0.4], atol=1e-7)


def test_zone_tension_is_the_mask_weighted_mean_compression():
    masks = np.zeros((4, 8), np.float32)
    masks[0, 0] = 1.0
    masks[1, 0] = 1.0
    masks[2, 0] = 0.5
    masks[2, 3] = 1.0
    masks[3, 7] = 1.0
    compression = np.array([0.1, 0.3, 0.6, np.nan])  # NaN counts as 0
    # zone 0: (0.1 + 0.3 + 0.5 * 0.6) / 2.5 = 0.28; zone 3: 0.6; zone 7: 0; others empty
    np.testing.assert_allclose(wm.zone_tension(masks, compression), [0.28, 0, 0, 0.6, 0, 0, 0, 0], atol=1e-6)
    np.testing.assert_allclose(wm.zone_tension(masks, compression, gain=2.0), [0.56, 0, 0, 1.0, 0, 0, 0, 0],
                               atol=1e-6)
    assert wm.zone_tension(masks, -np.ones(4)).max() == 0.0  # stretching gives no wrinkles


def test_table_from_expressions():
    expressions = {
        "Surprise": {"FRONTALIS_OUTER": 0.6, "FRONTALIS_MAJOR": 0.5, "FRONTALIS_INNER": 0.9},
        "Frown": {"CORRUGATOR": 1.0, "ZYGOMATICUS_MAJOR": 0.7, "NASALIS": 0.3},
        "Neutral": {},
    }
    table = wm.table_from_expressions(expressions)
    np.testing.assert_allclose(table, [[0.6, 0.6, 0.9, 0.9, 0, 0, 0, 0],
                                       [0, 0, 0, 0, 1.0, 1.0, 0.3, 0],
                                       [0, 0, 0, 0, 0, 0, 0, 0]], atol=1e-7)
    custom = wm.table_from_expressions({"Pout": {"CHIN": 0.4}}, zone_of_role={"CHIN": (7,)})
    np.testing.assert_allclose(custom, [[0, 0, 0, 0, 0, 0, 0, 0.4]], atol=1e-7)


def test_blend_keeps_leading_shapes_and_gives_unit_normals():
    rng = np.random.default_rng(8)
    base = rng.random((5, 7, 3)).astype(np.float32)
    maps = [rng.random((5, 7, 3)).astype(np.float32) for _ in range(3)]
    ma, mb = rng.random((5, 7, 4)), rng.random((5, 7, 4))
    weights = rng.uniform(-1, 2, (3, 8))
    for difference in (False, True):
        out = wm.blend(base, maps, ma, mb, weights, difference=difference)
        assert out.shape == (5, 7, 3) and np.isfinite(out).all()
        np.testing.assert_allclose(np.linalg.norm(out, axis=-1), 1.0, atol=1e-5)


def _tension_face(seed):
    """A grid of 60 x 40 vertices with masks on part of it (NaN on one vertex), posed by a
    random squash: the plan must give what the reference gives at every zone."""
    rng = np.random.default_rng(seed)
    nx, ny = 60, 40
    x, y = np.meshgrid(np.linspace(0, 0.1, nx), np.linspace(0, 0.07, ny))
    rest = np.stack([x.ravel(), y.ravel(), np.zeros(nx * ny)], 1).astype(np.float32)
    idx = np.arange(nx * ny).reshape(ny, nx)
    edges = np.concatenate([np.stack([idx[:, :-1].ravel(), idx[:, 1:].ravel()], 1),
                            np.stack([idx[:-1].ravel(), idx[1:].ravel()], 1),
                            np.stack([idx[:-1, :-1].ravel(), idx[1:, 1:].ravel()], 1)])
    masks = np.zeros((nx * ny, 8), np.float32)
    masks[:, 0] = (rest[:, 0] < 0.04) * rng.random(nx * ny)
    masks[:, 3] = np.clip((rest[:, 1] - 0.03) * 40, 0, 1)
    masks[:, 5] = rest[:, 0] > 0.07
    masks[7, 0] = np.nan
    squash = np.array([1.0 - 0.3 * rng.random(), 1.0 + 0.1 * rng.random(), 1.0], np.float32)
    skin = rest * squash + rng.normal(0, 2e-4, rest.shape).astype(np.float32)
    skin[edges[5]] = skin[edges[5, 0]]  # a collapsed edge
    rest_length = np.linalg.norm(rest[edges[:, 0]] - rest[edges[:, 1]], axis=1)
    return edges, rest_length, masks, skin


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_folded_tension_plan_equals_the_reference(seed):
    edges, rest_length, masks, skin = _tension_face(seed)
    plan = wm.tension_plan(edges, rest_length, masks)
    assert len(plan.edges) < len(edges)  # the edges no mask reaches are left out
    for gain in (1.0, 3.0, float("nan")):
        want = wm.zone_tension(masks, wm.vertex_compression(skin, edges, rest_length), gain)
        got = wm.plan_tension(plan, skin, gain)
        assert got.dtype == np.float32 and got.shape == (8,)
        np.testing.assert_allclose(got, want, rtol=0, atol=2e-6)
    assert wm.plan_tension(plan, skin)[[0, 3]].min() > 0.01  # the squash compresses both zones
    assert wm.plan_tension(plan, np.full_like(skin, np.nan)).max() == 0.0  # no number, no wrinkles
