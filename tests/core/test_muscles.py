"""Muscle coordinates (Zhang eqs. 1-3, 13-14), Waters' pull, and the per-frame system."""

from dataclasses import replace

import numpy as np
import pytest

from tests.core.meshes import grid, squash_vertical
from wrinkle_addon.core import mesh
from wrinkle_addon.core.muscles import system, zhang
from wrinkle_addon.core.muscles.fields import muscle_field
from wrinkle_addon.core.muscles.muscle import LINEAR, SHEET, Muscle
from wrinkle_addon.core.muscles.waters import radial_falloff


def sheet(**kw):
    base = dict(kind=SHEET, attachment=np.array([[-0.05, 0, 0.08], [0.05, 0, 0.08]]),
                insertion=np.array([[-0.05, 0, 0.01], [0.05, 0, 0.01]]), length=0.075,
                spread=0.1, spread_c=0.03, lambda_w=0.3, n_wrinkles=4, k0=0.001, alpha=1.0,
                pull=0.2, depth=0.03)
    base.update(kw)
    return Muscle(**base)


def linear(**kw):
    base = dict(kind=LINEAR, attachment=np.array([[0.0, 0, 0.04]]), insertion=np.array([[0.04, 0, 0.04]]),
                length=0.055, spread=np.radians(35), spread_c=np.radians(15), lambda_w=0.2,
                n_wrinkles=3, k0=0.001, alpha=1.0, pull=0.2)
    base.update(kw)
    return Muscle(**base)


def test_linear_region_matches_equations_1_to_3():
    rest, *_ = grid()
    m = linear()
    f = muscle_field(rest, m)
    rel = rest - m.attachment[0]
    fibre = np.array([1.0, 0, 0])
    dist = np.linalg.norm(rel, axis=1)
    phi = np.arccos(np.clip(rel @ fibre / np.maximum(dist, 1e-12), -1, 1))
    lam = dist * np.cos(phi) / m.length
    expect = np.flatnonzero((lam >= m.lambda_w) & (lam <= 1) & (phi / m.spread <= 1))
    np.testing.assert_array_equal(np.sort(f.region), expect)


def test_sheet_region_matches_equations_13_14():
    rest, *_ = grid()
    m = sheet()
    f = muscle_field(rest, m)
    l = 0.08 - rest[:, 2]  # attachment line at z = 0.08, fibres point down
    h = np.abs(rest[:, 0])
    expect = np.flatnonzero((l / m.length >= m.lambda_w) & (l / m.length <= 1) & (2 * h / m.spread <= 1))
    np.testing.assert_array_equal(np.sort(f.region), expect)


def test_attenuation_reaches_zero_at_region_border():
    rest, *_ = grid(120, 80)
    f = muscle_field(rest, sheet(fade_ends=False))
    h = np.abs(rest[f.region, 0])
    near_edge = h > 0.0495
    assert np.all(np.abs(f.amplitude[near_edge]) < 2e-3 * 0.001 * 4)


def test_radial_falloff():
    d = np.linspace(0, 2, 2001)
    r = radial_falloff(d, 1.0, 1.5)
    assert r[0] == 0.0 and r[1000] == pytest.approx(1.0) and np.all(r[d > 1.5] == 0)
    assert np.max(np.abs(np.diff(r))) < 0.01
    # degenerate: Rs >= Rf, or both zero, stays finite
    assert np.all(np.isfinite(radial_falloff(d, 2.0, 1.0)))
    assert np.all(np.isfinite(radial_falloff(d, 0.0, 0.0)))


def _system(rest, edges, tris, muscles):
    return system.build_plan(rest, edges, tris, muscles)


def test_contraction_pulls_toward_attachment_without_overshoot():
    rest, edges, tris, _ = grid()
    m = linear(pull=0.6)
    plan = _system(rest, edges, tris, [m])
    off = system.evaluate(plan, rest.astype(np.float32), [1.0])
    moved = np.flatnonzero(np.abs(off[:, 0]) > 1e-7)
    assert len(moved)
    to_att = m.attachment[0] - rest[moved]
    # the in-plane pull points toward the attachment
    cos = np.einsum("ij,ij->i", off[moved][:, [0, 2]], to_att[:, [0, 2]])
    assert np.all(cos > 0)
    assert np.all(np.linalg.norm(off[moved][:, [0, 2]], axis=1) < np.linalg.norm(to_att, axis=1))


def test_sheet_contraction_compresses_and_wrinkles():
    rest, edges, tris, _ = grid(120, 80)
    plan = _system(rest, edges, tris, [sheet()])
    relaxed = system.evaluate(plan, rest.astype(np.float32), [0.0])
    assert np.all(relaxed == 0.0)  # no contraction, no compression: nothing moves
    off = system.evaluate(plan, rest.astype(np.float32), [1.0])
    assert off[:, 2].max() > 0.005  # brows pulled up toward the hairline
    assert np.abs(off[:, 1]).max() > 1e-4  # and wrinkles along the normal (the Y axis)


def test_wrinkles_from_shape_key_compression_alone():
    """Wrinkles-only muscle, no contraction: the skin compressed by a 'shape key' wrinkles."""
    rest, edges, tris, _ = grid(120, 80)
    plan = _system(rest, edges, tris, [sheet(wrinkles_only=True)])
    skin = squash_vertical(rest, 0.7).astype(np.float32)
    off = system.evaluate(plan, skin, [1.0])
    assert np.all(off[:, [0, 2]] == 0)  # no pull
    col = off.reshape(80, 120, 3)[:, 60, 1]
    # furrows and bulges alternate along the fibre: several sign changes
    signs = np.sign(col[np.abs(col) > 1e-6])
    assert np.sum(signs[1:] != signs[:-1]) >= 6
    # stretching instead gives nothing (A(eps) = 0 for eps < 0)
    stretched = squash_vertical(rest, 1.2).astype(np.float32)
    assert np.abs(system.evaluate(plan, stretched, [0.0])).max() == 0.0


def test_direction_weighting_ignores_perpendicular_compression():
    """Squeezing across the fibres (|cos theta| = 0 edges) raises no wrinkles."""
    rest, edges, tris, _ = grid(120, 80)
    plan = _system(rest, edges, tris, [sheet(wrinkles_only=True)])
    skin = rest.copy()
    skin[:, 0] *= 0.7
    assert np.abs(system.evaluate(plan, skin.astype(np.float32), [0.0])).max() < 1e-4 * 0.001


def test_wrinkle_amplitude_grows_with_compression():
    rest, edges, tris, _ = grid(120, 80)
    plan = _system(rest, edges, tris, [sheet(wrinkles_only=True)])
    amps = [np.abs(system.evaluate(plan, squash_vertical(rest, f).astype(np.float32), [0])).max()
            for f in (0.95, 0.85, 0.7)]
    assert amps[0] < amps[1] < amps[2]


def test_heights_bounded_by_shape_function():
    rest, edges, tris, _ = grid(120, 80)
    m = sheet(wrinkles_only=True, k0=0.002, alpha=1.0)
    plan = _system(rest, edges, tris, [m])
    off = system.evaluate(plan, squash_vertical(rest, 0.5).astype(np.float32), [0])
    assert np.abs(off).max() <= 0.002 * 2.0 + 1e-6  # |H| <= k0 2^alpha - d < k0 2^alpha


def test_plan_is_deterministic():
    rest, edges, tris, _ = grid()
    a = _system(rest, edges, tris, [sheet(), linear()])
    b = _system(rest, edges, tris, [sheet(), linear()])
    skin = squash_vertical(rest, 0.8).astype(np.float32)
    np.testing.assert_array_equal(system.evaluate(a, skin, [0.5, 0.3]), system.evaluate(b, skin, [0.5, 0.3]))


@pytest.mark.parametrize("bad", [
    dict(insertion=np.array([[0.0, 0, 0.04]])),  # attachment == insertion
    dict(length=0.0),  # R = 0
    dict(spread=0.0),
    dict(n_wrinkles=0), dict(n_wrinkles=1000),
    dict(k0=float("nan")), dict(alpha=float("inf")), dict(lambda_w=float("nan")),
    dict(attachment=np.array([[np.nan, 0, 0]])),
])
def test_bad_linear_parameters_never_produce_nan(bad):
    rest, edges, tris, _ = grid()
    plan = _system(rest, edges, tris, [linear(**bad)])
    off = system.evaluate(plan, squash_vertical(rest, 0.8).astype(np.float32), [1.0])
    assert np.all(np.isfinite(off))
    assert np.abs(off).max() < 0.05


@pytest.mark.parametrize("bad", [
    dict(length=0.0), dict(spread=0.0), dict(n_wrinkles=0), dict(n_wrinkles=1000),
    dict(insertion=np.array([[-0.05, 0, 0.08], [0.05, 0, 0.08]])),  # lines coincide
    dict(depth=float("nan")),
])
def test_bad_sheet_parameters_never_produce_nan(bad):
    rest, edges, tris, _ = grid()
    plan = _system(rest, edges, tris, [sheet(**bad)])
    off = system.evaluate(plan, squash_vertical(rest, 0.8).astype(np.float32), [1.0])
    assert np.all(np.isfinite(off))


def test_problem_messages():
    assert "attachment equals" in linear(insertion=np.array([[0.0, 0, 0.04]])).problem()
    assert "R is 0" in linear(length=0).problem()
    assert "Ls is 0" in sheet(length=0).problem()
    assert linear().problem() is None and sheet().problem() is None


def test_degenerate_mesh_inputs():
    """Loose vertices, zero-length edges, degenerate triangles and NaN skin stay finite."""
    rest, edges, tris, _ = grid(30, 20)
    rest = np.concatenate([rest, [[0.0, 0.0, 0.05], [0.01, 0.0, 0.05]]])  # two loose vertices
    rest[5] = rest[6]  # a zero-length edge and degenerate triangles
    plan = _system(rest, edges, tris, [sheet(), linear()])
    skin = squash_vertical(rest, 0.8).astype(np.float32)
    skin[7] = np.nan
    off = system.evaluate(plan, skin, [1.0, 1.0])
    assert np.all(np.isfinite(off))
    assert np.all(off[7] == 0)


def test_ngons_and_empty_meshes():
    tris = mesh.fan_triangles(np.arange(6), np.array([0]), np.array([6]))
    assert tris.tolist() == [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]]
    assert len(mesh.fan_triangles(np.arange(2), np.array([0]), np.array([2]))) == 0
    plan = system.build_plan(np.zeros((0, 3)), np.zeros((0, 2)), np.zeros((0, 3)), [sheet()])
    assert system.evaluate(plan, np.zeros((0, 3), np.float32), [1.0]).shape == (0, 3)


def test_fuzz_random_meshes_and_parameters():
    rng = np.random.default_rng(1234)
    for _ in range(40):
        n = int(rng.integers(3, 400))
        rest = rng.normal(size=(n, 3)) * 0.05
        edges = rng.integers(0, n, size=(int(rng.integers(0, 3 * n)), 2))
        tris = rng.integers(0, n, size=(int(rng.integers(0, 2 * n)), 3))
        muscles = []
        for _k in range(int(rng.integers(0, 4))):
            kind = int(rng.integers(0, 2))
            pts = rng.normal(size=(2, 3)) * 0.05
            muscles.append(Muscle(
                kind=kind, attachment=pts[:kind + 1],
                insertion=pts[::-1][:kind + 1] + rng.normal(size=3) * 0.02,
                length=float(rng.uniform(-0.01, 0.2)), spread=float(rng.uniform(-0.1, 2.0)),
                spread_c=float(rng.uniform(0, 1)), lambda_w=float(rng.uniform(-0.5, 1.5)),
                n_wrinkles=float(rng.integers(0, 50)), k0=float(rng.normal() * 0.01),
                alpha=float(rng.uniform(-3, 3)), pull=float(rng.uniform(0, 1)),
                depth=float(rng.uniform(0, 0.1)), wrinkles_only=bool(rng.integers(0, 2))))
        plan = system.build_plan(rest, edges, tris, muscles)
        skin = (rest + rng.normal(size=rest.shape) * 0.01).astype(np.float32)
        off = system.evaluate(plan, skin, rng.uniform(0, 1, len(muscles)))
        assert np.all(np.isfinite(off))
        assert np.abs(off).max(initial=0) < 1.0


def test_refine_edges_selects_long_edges_in_region_only():
    from wrinkle_addon.core.muscles import resolution

    rest, edges, tris, _ = grid(30, 20)
    m = sheet(n_wrinkles=6)
    split = resolution.refine_edges(rest, edges, [m], factor=4)
    assert len(split)
    f = muscle_field(rest, m)
    region = set(f.region.tolist())
    assert all(edges[i, 0] in region or edges[i, 1] in region for i in split)
    fine_rest, fine_edges, *_ = grid(400, 260)
    assert len(resolution.refine_edges(fine_rest, fine_edges, [m], factor=4)) == 0


def test_formed_heights_are_the_wrinkle_at_full_amplitude():
    """formed_heights = H(w) At (A = 1): the per-frame heights of the same muscle are that
    field scaled by A(eps) in [0, 1] at each vertex, and grow toward it with compression."""
    rest, edges, tris, _ = grid(120, 80)
    plan = _system(rest, edges, tris, [sheet(wrinkles_only=True)])
    formed = system.formed_heights(plan, 0)
    assert np.abs(formed).max() > 1e-4 and system.formed_heights(plan, 1).max() == 0.0
    for squash, lo in ((0.9, 0.0), (0.6, 0.3)):
        h = system.heights(plan, squash_vertical(rest, squash).astype(np.float32), [0.0])
        lit = np.abs(formed) > 1e-5
        ratio = h[lit] / formed[lit]
        assert ratio.min() >= -1e-6 and ratio.max() <= 1.0 + 1e-6
        assert np.median(ratio) > lo
    assert np.all(h[formed == 0.0] == 0.0)  # nothing outside the region


def test_deep_folds_are_limited_by_their_width():
    """A fold is never deeper than its width allows (zhang.soft_fold): the cap is the
    muscle's furrow width over FOLD_RATIO, narrowed with the skin's compression; shallow
    folds are exactly the model's."""
    rest, edges, tris, _ = grid(120, 80)
    m = sheet(wrinkles_only=True)
    plan = _system(rest, edges, tris, [m])
    free = replace(plan, fold_weight=np.zeros_like(plan.fold_weight))
    mild = squash_vertical(rest, 0.95).astype(np.float32)
    np.testing.assert_array_equal(system.heights(plan, mild, [0.0]), system.heights(free, mild, [0.0]))

    u = plan.half_cycles[0]
    deep = sheet(wrinkles_only=True, k0=0.6 * u)  # a fold as deep as it is wide
    plan = _system(rest, edges, tris, [deep])
    free = replace(plan, fold_weight=np.zeros_like(plan.fold_weight))
    squashed = squash_vertical(rest, 0.6).astype(np.float32)
    h, h_free = system.heights(plan, squashed, [0.0]), system.heights(free, squashed, [0.0])
    cap = zhang.fold_cap(u, 1.0)
    assert -h_free.min() > cap  # the model alone cuts deeper than the cap
    eps = system.compression(plan, squashed[plan.verts].T.copy())
    assert -h.min() <= cap * (1.0 - eps.min()) + 1e-9
    assert np.all(h >= h_free - 1e-9)  # only made shallower
    np.testing.assert_array_equal(h[h_free > 0], h_free[h_free > 0])  # bulges untouched


def test_sheet_region_ends_at_region_end():
    """``region_end``: the wrinkling region stops at that fraction of Ls, the pull still
    reaches Ls, and the furrows before the end stay where they were."""
    rest, *_ = grid(120, 80)
    full, short = sheet(), sheet(region_end=0.6)
    f_full, f_short = muscle_field(rest, full), muscle_field(rest, short)
    l = 0.08 - rest[:, 2]
    assert l[f_short.region].max() <= 0.6 * short.length + 1e-12
    assert l[f_full.region].max() > 0.9 * full.length
    np.testing.assert_array_equal(np.sort(f_short.aoi), np.sort(f_full.aoi))  # the pull is the same
    # away from the new end's fade (one half cycle), the amplitude is the same
    u = f_full.half_cycle
    same = np.flatnonzero(l[f_short.region] < 0.6 * short.length - u)
    amp_full = dict(zip(f_full.region.tolist(), f_full.amplitude))
    expect = [amp_full[v] for v in f_short.region[same]]
    np.testing.assert_allclose(f_short.amplitude[same], expect, atol=1e-15)
    # 1 (and a value that is not a number) is Zhang's region
    for value in (1.0, float("nan")):
        f = muscle_field(rest, sheet(region_end=value))
        np.testing.assert_array_equal(f.region, f_full.region)
        np.testing.assert_array_equal(f.amplitude, f_full.amplitude)
