"""Hostile parameters at the core's entry points: huge and tiny values, the infinities, NaN
and huge counts either give finite results or a ValueError with a message, never another
exception and never an allocation beyond a fixed multiple of the input (seeded fuzz)."""

import math
import tracemalloc

import numpy as np
import pytest

from tests.core.meshes import grid, squash_vertical
from wrinkle_addon.core import raster
from wrinkle_addon.core.bando import curves, field, fine, mapped
from wrinkle_addon.core.muscles import system
from wrinkle_addon.core.muscles.muscle import LINEAR, SHEET, Muscle
from wrinkle_addon.core.patterns import mls, tears

HOSTILE = [0.0, -1.0, 1e-300, 1e-163, 5e-324, 1e300, 1.7e308, math.inf, -math.inf, math.nan, 1e12, 3]
PEAK_MB = 200


def _survives(fn, *args, **kwargs):
    """``fn(*args, **kwargs)`` returns finite values or raises ValueError, within ``PEAK_MB``."""
    tracemalloc.start()
    try:
        out = fn(*args, **kwargs)
    except ValueError as exc:
        assert str(exc), "a ValueError must carry a message"
        out = None
    finally:
        peak = tracemalloc.get_traced_memory()[1] / 1e6
        tracemalloc.stop()
    assert peak < PEAK_MB, f"{peak:.0f} MB"
    if out is not None:
        assert np.all(np.isfinite(np.asarray(out, np.float64))), out
    return out


def _pick(rng, n):
    return [HOSTILE[i] for i in rng.integers(0, len(HOSTILE), n)]


# --- the faults as reported -----------------------------------------------------------
def test_mls_fit_refuses_a_huge_eps_instead_of_overflowing():
    p = np.random.default_rng(0).uniform(size=(20, 2))
    with pytest.raises(ValueError, match="eps"):
        mls.fit(p, p[:, 0], p, eps=math.inf)
    out = mls.fit(p, p[:, 0], p, eps=1e200)  # every point alike: the least-squares plane
    np.testing.assert_allclose(out, p[:, 0], atol=1e-9)  # which holds x exactly


def test_rise_noise_refuses_an_infinite_height():
    c = np.random.default_rng(1).uniform(size=(30, 2))
    with pytest.raises(ValueError, match="height"):
        tears.rise_noise(c, 0.2, math.inf, 0, 0.1)
    with pytest.raises(ValueError, match="seed"):
        tears.rise_noise(c, 0.2, 0.1, math.inf, 0.1)


def test_resample_refuses_a_spacing_that_needs_more_samples_than_memory():
    with pytest.raises(ValueError, match="samples"):
        curves.resample(np.array([[0.0, 0.0], [1.0, 0.0]]), 1e-300)
    with pytest.raises(ValueError, match="samples"):
        tears.resample(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]), 1e-300)


def test_diffusion_time_refuses_an_edge_length_too_small_to_square():
    with pytest.raises(ValueError, match="edges"):
        raster.diffusion_time(0.02, 1e-163)
    with pytest.raises(ValueError, match="softness"):
        raster.diffusion_time(math.nan, 0.01)
    assert raster.diffusion_time(0.02, 0.01) == pytest.approx(0.5)


# --- 4: the muscles' work is bounded by the mesh ----------------------------------------
def _linear(**kw):
    base = dict(kind=LINEAR, attachment=np.array([[0.0, 0, 0.04]]), insertion=np.array([[0.03, 0, 0.04]]),
                length=0.06, spread=math.pi, spread_c=0.2, lambda_w=0.9, n_wrinkles=100, k0=0.001,
                alpha=1.0, pull=0.2)
    base.update(kw)
    return Muscle(**base)


def test_the_smoothing_grid_has_at_most_four_cells_a_row():
    rest, edges, tris, _q = grid(70, 40)
    plan = system.build_plan(rest, edges, tris, [_linear()])
    assert len(plan.row_vert) > 0
    # a grid over the region's bounding box had 725,696 cells for these 120 rows
    assert plan.smooth_size <= 4 * len(plan.row_vert)


def test_more_wrinkles_than_the_mesh_can_show_are_bounded_and_reported():
    rest, edges, tris, _q = grid(70, 40)  # edges of 2 mm
    plan = system.build_plan(rest, edges, tris, [_linear(lambda_w=0.2, n_wrinkles=1000)])
    (i, asked, built), = plan.limits
    # the region is 0.8 R = 48 mm long: one wrinkle per two edges is about 12
    assert (i, asked) == (0, 1000) and 8 <= built <= 14
    assert plan.half_cycles[0] >= 0.002 * 0.99
    fair = system.build_plan(rest, edges, tris, [_linear(lambda_w=0.2, n_wrinkles=4)])
    assert fair.limits == [] and fair.half_cycles[0] == pytest.approx(0.8 * 0.06 / 8)


def test_hostile_muscle_parameters_build_bounded_plans():
    rest, edges, tris, _q = grid(40, 24)
    skin = squash_vertical(rest, 0.7).astype(np.float32)
    rng = np.random.default_rng(4)
    names = ["length", "spread", "spread_c", "lambda_w", "n_wrinkles", "k0", "alpha", "pull", "depth",
             "back_reach", "region_end"]
    for trial in range(60):
        kind = SHEET if trial % 2 else LINEAR
        values = dict(zip(names, _pick(rng, len(names))))
        if kind == SHEET:
            m = Muscle(kind=SHEET, attachment=np.array([[-0.05, 0, 0.08], [0.05, 0, 0.08]]),
                       insertion=np.array([[-0.05, 0, 0.01], [0.05, 0, 0.01]]), **values)
        else:
            m = _linear(**values)
        full = system.build_plan(rest, edges, tris, [m])
        assert full.smooth_size <= 4 * max(len(full.row_vert), 1)
        _survives(system.evaluate, full, skin, [1.0])
        assert _survives(lambda plan: plan.half_cycles, full) is not None


# --- 13: layouts without area, and bow-ties -----------------------------------------------
def test_shrinkage_plan_of_a_collapsed_layout_gives_zero_instead_of_an_index_error():
    rest, _edges, tris, _q = grid(6, 5)
    uv = np.full((len(rest), 2), 0.5)
    plan = field.shrinkage_plan(uv, tris, np.tile([1.0, 0.0], (len(rest), 1)), rest)
    assert (field.shrinkage(plan, squash_vertical(rest, 0.5)) == 0).all()
    m = mapped.mapped_mesh(tris, uv[tris], len(rest))
    d = np.tile([1.0, 0.0], (len(m.uv), 1))
    s = fine.shrinkages(fine.plan(m, rest, d, d), squash_vertical(rest, 0.5).astype(np.float32))
    assert (s == 0).all()
    assert mapped.degenerate_uv(uv[tris]).all()


def test_bow_tie_vertices_are_found():
    rest, _edges, tris, _q = grid(6, 5)
    n = len(rest)
    assert len(mapped.bowtie_vertices(tris, n)) == 0
    hanging = np.vstack([tris, [[0, n, n + 1]]])  # a triangle on a corner: a bow-tie
    np.testing.assert_array_equal(mapped.bowtie_vertices(hanging, n + 2), [0])
    tetra = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]])  # closed: none
    assert len(mapped.bowtie_vertices(tetra, 4)) == 0


# --- 16: seeded fuzz over the entry points that take a user's parameters -----------------
def test_fuzz_mls_fit():
    rng = np.random.default_rng(11)
    p = rng.uniform(size=(25, 2))
    f = rng.uniform(size=25)
    for _ in range(120):
        degree, eps, scale, value, coord = _pick(rng, 5)
        pts = p.copy()
        vals = f.copy()
        if rng.random() < 0.3:
            pts[rng.integers(25), rng.integers(2)] = coord
        if rng.random() < 0.3:
            vals[rng.integers(25)] = value
        _survives(mls.fit, pts, vals, p[:5], degree=degree, eps=eps, scale=scale)
    for degree in (1e6, 10**9, 2.5, -1):
        with pytest.raises(ValueError, match="degree"):
            mls.fit(p, f, p, degree=degree)
    with pytest.raises(ValueError, match="monomials"):
        mls.fit(rng.uniform(size=(200, 40)), rng.uniform(size=200), rng.uniform(size=(1, 40)), degree=3)


def test_fuzz_rise_noise():
    rng = np.random.default_rng(12)
    c = rng.uniform(size=(40, 2))
    for _ in range(120):
        fraction, amplitude, seed, eps, coord = _pick(rng, 5)
        coords = c.copy()
        if rng.random() < 0.3:
            coords[rng.integers(40), rng.integers(2)] = coord
        _survives(tears.rise_noise, coords, fraction, amplitude, seed, eps)


def test_fuzz_resample():
    rng = np.random.default_rng(13)
    for _ in range(150):
        spacing, coord, scale = _pick(rng, 3)
        poly = np.cumsum(rng.uniform(size=(6, 2)), axis=0)
        with np.errstate(all="ignore"):
            if rng.random() < 0.5:
                poly = poly * scale
            if rng.random() < 0.3:
                poly[rng.integers(6), rng.integers(2)] = coord
        _survives(curves.resample, poly, spacing)
        _survives(tears.resample, np.c_[poly, np.zeros(len(poly))], spacing)


def test_fuzz_diffusion_time_and_soften():
    rng = np.random.default_rng(14)
    _rest, edges, _tris, _q = grid(8, 6)
    values = rng.uniform(size=(48, 2))
    for _ in range(150):
        softness, edge = _pick(rng, 2)
        t = _survives(raster.diffusion_time, softness, edge)
        if t is not None:
            _survives(raster.soften, values, edges, t)
