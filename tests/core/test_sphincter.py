"""The sphincter muscle (core/muscles/sphincter.py) and the blend of folds that meet
(core/muscles/system.py, ``blend``)."""

import numpy as np
import pytest

from tests.core.meshes import grid
from wrinkle_addon.core.muscles import sphincter, system
from wrinkle_addon.core.muscles.fields import muscle_field
from wrinkle_addon.core.muscles.muscle import LINEAR, SHEET, SPHINCTER, Muscle

CENTRE = np.array([0.0, 0.0, 0.04])


def ring(**kw):
    """A sphincter round (0, 0.04) in the XZ plane: its axis a 25 mm along +X, b 20 mm up."""
    base = dict(kind=SPHINCTER, attachment=CENTRE[None],
                insertion=CENTRE + np.array([[0.025, 0, 0], [0, 0, 0.02]]),
                length=1.5, spread=np.radians(50), spread_c=np.radians(25), lambda_w=0.4, n_wrinkles=4,
                k0=0.002, alpha=1.0, pull=0.3, depth=0.03)
    base.update(kw)
    return Muscle(**base)


def plane(n=141):
    rest, edges, tris, _q = grid(n, n, width=0.14, height=0.14)
    rest[:, 2] -= 0.03  # centred on z = 0.04
    return rest, edges, tris


def polar(rest):
    rel = rest - CENTRE
    pa, pb = rel[:, 0] / 0.025, rel[:, 2] / 0.02
    return np.sqrt(pa * pa + pb * pb), np.arctan2(pb, pa)


def squeeze_round(rest, c=0.15):
    """Skin drawn together round the centre: every angle shrunk toward 0 (the axis a) by c,
    the radius kept: compression along the fibres only, as a squint gives at the eye corner."""
    rho, theta = polar(rest)
    t = theta * (1.0 - c)
    out = rest.copy()
    out[:, 0] = CENTRE[0] + rho * np.cos(t) * 0.025
    out[:, 2] = CENTRE[2] + rho * np.sin(t) * 0.02
    return out


@pytest.mark.parametrize("kw, why", [
    (dict(insertion=np.array([[0.025, 0, 0.04], [0.05, 0, 0.04]])), "do not span an ellipse"),
    (dict(insertion=CENTRE[None] + np.array([[0.0, 0, 0], [0, 0, 0.02]])), "do not span an ellipse"),
    (dict(length=0.9), "outer reach"),
    (dict(spread=0.0), "angle is 0"),
    (dict(insertion=CENTRE[None] + np.array([[0.025, 0, 0]])), "centre and the ends of its two axes"),
])
def test_a_degenerate_sphincter_says_why(kw, why):
    m = ring(**kw)
    assert why in m.problem()
    f = muscle_field(plane(21)[0], m)
    assert len(f.region) == len(f.aoi) == 0


def test_region_is_the_sector_and_the_band():
    rest, *_ = plane()
    m = ring()
    f = muscle_field(rest, m)
    rho, theta = polar(rest)
    expect = np.flatnonzero((rho >= 0.4 * 1.5) & (rho <= 1.5) & (np.abs(theta) <= np.radians(50)))
    np.testing.assert_array_equal(np.sort(f.region), expect)
    assert m.problem() is None and Muscle(**{**ring().__dict__, "kind": 2}).sanitized().kind == SPHINCTER


def test_fibres_run_round_the_centre():
    rest, *_ = plane(41)
    f = muscle_field(rest, ring())
    rel = rest[f.region] - CENTRE
    # the tangent of the ellipse through the point: perpendicular to the gradient of rho
    grad = np.stack([rel[:, 0] / 0.025**2, np.zeros(len(rel)), rel[:, 2] / 0.02**2], axis=1)
    cos = np.einsum("ij,ij->i", f.contraction_dir, grad) / np.linalg.norm(grad, axis=1)
    np.testing.assert_allclose(cos, 0.0, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(f.contraction_dir, axis=1), 1.0)


def test_squeezed_round_the_centre_it_raises_radial_furrows():
    rest, edges, tris = plane()
    m = ring()
    plan = system.build_plan(rest, edges, tris, [m])
    h = system.heights(plan, squeeze_round(rest).astype(np.float32), [0.0])
    rho, theta = polar(rest)
    assert h.min() < -1e-4
    # the furrows are the cycle ends of eq. 7 round the ring: theta = -Theta + k 2u/|b|
    u = plan.half_cycles[0]
    furrows = -np.radians(50) + np.arange(1, 4) * 2 * u / 0.02
    band = (rho > 0.85) & (rho < 1.15)
    for t in furrows:  # along each furrow's ray the skin is lower than between the furrows
        on = band & (np.abs(theta - t) < np.radians(2))
        between = band & (np.abs(theta - (t + u / 0.02)) < np.radians(2))
        assert h[on].mean() < 0.0 < h[between].mean()
    # a radial line: along the middle furrow the depth changes slowly with rho, it tapers
    # to 0 at both ends of the band
    on = np.abs(theta - furrows[1]) < np.radians(1.5)
    assert np.all(h[on & (rho < 0.6)] == 0.0) and np.all(h[on & (rho > 1.5)] == 0.0)
    assert np.abs(h[on & (rho > 0.6) & (rho < 0.66)]).max() < 0.2 * np.abs(h[on]).max()


def test_stretched_along_the_fibres_no_wrinkle():
    rest, edges, tris = plane()
    plan = system.build_plan(rest, edges, tris, [ring()])
    h = system.heights(plan, squeeze_round(rest, c=-0.15).astype(np.float32), [0.0])
    assert np.all(h == 0.0)


def squeeze_half(rest, c=0.15, upper=True):
    """Skin drawn together round the centre on one half of the sector only (theta > 0, or
    < 0): what the brows coming down do beside the eye, from above."""
    rho, theta = polar(rest)
    side = theta > 0 if upper else theta < 0
    t = np.where(side, theta * (1.0 - c), theta)
    out = rest.copy()
    out[:, 0] = CENTRE[0] + rho * np.cos(t) * 0.025
    out[:, 2] = CENTRE[2] + rho * np.sin(t) * 0.02
    return out


@pytest.mark.parametrize("upper", [True, False])
def test_one_half_squeezed_the_ring_does_not_fold(upper):
    """The ring folds as it shortens all round (system.RING_GATE): squeezed on one half of
    its sector only, no furrow, though that half alone is compressed as much as a full
    squeeze compresses it; squeezed all round, the furrows.  (The grid is moved half a
    cell up, so that no vertex lies on the axis between the halves.)"""
    rest, edges, tris = plane()
    rest[:, 2] += 0.0005
    plan = system.build_plan(rest, edges, tris, [ring()])
    half = system.heights(plan, squeeze_half(rest, upper=upper).astype(np.float32), [0.0])
    full = system.heights(plan, squeeze_round(rest).astype(np.float32), [0.0])
    eps = system.compression(plan, squeeze_half(rest, upper=upper).astype(np.float32).T[:, plan.verts])
    assert eps.max() > 0.1  # the squeezed half is compressed
    assert full.min() < -1e-4
    assert np.abs(half).max() == 0.0


def test_a_weak_squeeze_all_round_fades_in():
    """The gate is a smooth ramp: a squeeze just over its start gives shallower furrows than
    a full one, not none and not all."""
    rest, edges, tris = plane()
    plan = system.build_plan(rest, edges, tris, [ring()])
    depth = [-system.heights(plan, squeeze_round(rest, c=c).astype(np.float32), [0.0]).min()
             for c in (0.0, 0.012, 0.15)]
    assert depth[0] == 0.0 < depth[1] < 0.5 * depth[2]


def test_contracted_it_draws_the_skin_toward_its_centre():
    rest, edges, tris = plane()
    m = ring(k0=0.0)
    plan = system.build_plan(rest, edges, tris, [m])
    off = system.evaluate(plan, rest.astype(np.float32), [1.0])
    rho, _t = polar(rest)
    rel = rest - CENTRE
    inside = (rho > 0.2) & (rho < 0.95)
    # inside the ring every point moves pull x its distance, straight toward the centre
    np.testing.assert_allclose(off[inside], -0.3 * rel[inside], atol=2e-6)
    assert np.all(off[rho > 1.5 + 1e-6] == 0.0)
    mid = (rho > 1.05) & (rho < 1.45)
    assert np.all(np.einsum("ij,ij->i", off[mid], rel[mid]) < 0.0)


def test_pull_profile_is_c1():
    rho = np.linspace(0.0, 2.0, 20001)
    s = sphincter.pull_profile(rho, 1.5)
    ds = np.diff(s) / np.diff(rho)
    assert s[0] == 1.0 and s[-1] == 0.0
    assert np.abs(np.diff(ds)).max() < 1e-2  # no jump in the slope anywhere


def test_keep_out_leaves_the_opening_alone():
    rest, edges, tris = plane()
    rho, _t = polar(rest)
    keep = np.clip((rho - 0.7) / 0.2, 0.0, 1.0)
    plan = system.build_plan(rest, edges, tris, [ring()], keep_out=keep)
    skin = squeeze_round(rest).astype(np.float32)
    h = system.heights(plan, skin, [1.0])
    off = system.evaluate(plan, skin, [1.0]) - 0.0
    assert np.all(h[rho <= 0.7] == 0.0)
    assert np.all(off[rho <= 0.7] == 0.0)


# ----------------------------------------------------------------- folds that meet
def crossing():
    """Two linear muscles over one patch, their fibres at right angles."""
    a = dict(kind=LINEAR, length=0.06, spread=np.radians(40), spread_c=np.radians(20), lambda_w=0.3,
             n_wrinkles=4, k0=0.001, alpha=1.0, pull=0.2)
    along_x = Muscle(attachment=np.array([[-0.04, 0, 0.04]]), insertion=np.array([[0.0, 0, 0.04]]), **a)
    along_z = Muscle(attachment=np.array([[0.0, 0, 0.0]]), insertion=np.array([[0.0, 0, 0.04]]), **a)
    return along_x, along_z


def test_crossing_folds_never_pile_up():
    rest, edges, tris = plane()
    mx, mz = crossing()
    skin = (CENTRE + (rest - CENTRE) * 0.88).astype(np.float32)  # compressed every way
    both = system.build_plan(rest, edges, tris, [mx, mz])
    assert both.blend_rows is not None and len(both.blend_verts) > 100
    h = system.heights(both, skin, [0.0, 0.0])
    alone = [system.heights(system.build_plan(rest, edges, tris, [m]), skin, [0.0]) for m in (mx, mz)]
    summed = alone[0] + alone[1]
    # summed, the two patterns reach deeper and higher than either; blended, never
    assert summed.min() < 1.3 * min(a.min() for a in alone)
    assert h.min() >= min(a.min() for a in alone) - 1e-7
    assert h.max() <= max(a.max() for a in alone) + 1e-7
    # where only one muscle wrinkles, its folds are exactly its own
    only_x = (alone[1] == 0.0) & (alone[0] != 0.0)
    np.testing.assert_array_equal(h[only_x], alone[0][only_x])


def test_the_stronger_compression_wins():
    rest, edges, tris = plane()
    mx, mz = crossing()
    skin = rest.copy()
    skin[:, 0] = CENTRE[0] + (rest[:, 0] - CENTRE[0]) * 0.85  # along x much more than along z
    skin[:, 2] = CENTRE[2] + (rest[:, 2] - CENTRE[2]) * 0.98
    skin = skin.astype(np.float32)
    plan = system.build_plan(rest, edges, tris, [mx, mz])
    h = system.heights(plan, skin, [0.0, 0.0])
    hx = system.heights(system.build_plan(rest, edges, tris, [mx]), skin, [0.0])
    hz = system.heights(system.build_plan(rest, edges, tris, [mz]), skin, [0.0])
    core = plan.verts[plan.height_sum.keys[plan.blend_verts]]
    core = core[np.abs(hx[core]) > 0.3 * np.abs(hx).max()]
    # the folds of the muscle along x run through; the other's are nearly gone
    assert np.corrcoef(h[core], hx[core])[0, 1] > 0.95
    assert np.abs(h[core] - hx[core]).mean() < 0.25 * np.abs(hz[core]).mean()


def test_neighbours_in_phase_are_one_family_and_still_sum():
    """Two sheets side by side sharing one attachment line and one length (the Frontalis
    preset): their folds are one set, and across their border they sum as before."""
    rest, edges, tris = plane()
    base = dict(kind=SHEET, length=0.075, spread=0.06, spread_c=0.015, lambda_w=0.1, n_wrinkles=4,
                k0=0.001, alpha=1.0, pull=0.2, depth=0.03)
    left = Muscle(attachment=np.array([[-0.06, 0, 0.1], [-0.0, 0, 0.1]]),
                  insertion=np.array([[-0.06, 0, 0.03], [0.0, 0, 0.03]]), **base)
    right = Muscle(attachment=np.array([[-0.03, 0, 0.1], [0.03, 0, 0.1]]),
                   insertion=np.array([[-0.03, 0, 0.03], [0.03, 0, 0.03]]), **base)
    fields = [muscle_field(rest, m) for m in (left, right)]
    assert system.families(fields).tolist() == [0, 0]
    plan = system.build_plan(rest, edges, tris, [left, right])
    assert plan.blend_rows is None
    skin = rest.copy()
    skin[:, 2] = 0.1 - (0.1 - rest[:, 2]) * 0.9
    h = system.heights(plan, skin.astype(np.float32), [0.0, 0.0])
    alone = [system.heights(system.build_plan(rest, edges, tris, [m]), skin.astype(np.float32), [0.0])
             for m in (left, right)]
    np.testing.assert_allclose(h, alone[0] + alone[1], atol=1e-7)


def test_crossing_muscles_are_two_families():
    rest, *_ = plane()
    fields = [muscle_field(rest, m) for m in crossing()]
    assert system.families(fields).tolist() == [0, 1]


def test_formed_wrinkles_of_crossing_muscles_blend_like_the_face():
    """A wrinkle map's fully formed wrinkles (A = 1) of two crossing muscles are joined as
    the face joins them: blended where the families meet, never the pile of their sum, and
    each muscle's own folds where it is alone.  One muscle alone is formed_heights."""
    rest, edges, tris = plane()
    mx, mz = crossing()
    plan = system.build_plan(rest, edges, tris, [mx, mz])
    alone = [system.formed_heights(plan, i) for i in (0, 1)]
    together = system.formed_together(plan, [0, 1])
    summed = alone[0] + alone[1]
    assert summed.min() < 1.3 * min(a.min() for a in alone)  # the sum piles up: the test can fail
    assert together.min() >= min(a.min() for a in alone) - 1e-7
    assert together.max() <= max(a.max() for a in alone) + 1e-7
    only_x = (alone[1] == 0.0) & (alone[0] != 0.0)
    np.testing.assert_array_equal(together[only_x], alone[0][only_x])
    np.testing.assert_allclose(system.formed_together(plan, [1]), alone[1], atol=1e-7)
    np.testing.assert_array_equal(system.formed_together(plan, [0, 1], strength=0.0), 0.0)
