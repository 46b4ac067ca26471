"""Dripping tears ("Pattern functions and tears", §4.1): the teardrop surface and its timing."""

import numpy as np
import pytest

from wrinkle_addon.core.patterns import tears


def _surface(tau, alpha=1.0, beta=0.6, lam=0.5, n=201):
    u, v = np.meshgrid(np.linspace(0, np.pi, n), np.linspace(0, 2 * np.pi, 9), indexing="ij")
    return u, tears.teardrop(u, v, tau, alpha, beta, lam)


def test_the_surface_is_its_formula_and_a_closed_drop_pointed_on_top():
    u, p = _surface(0.0)
    t = tears.T0
    r = np.sin(u) / (t + np.cos(u))
    np.testing.assert_allclose(np.hypot(p[..., 0], p[..., 1]), r, atol=1e-12)
    np.testing.assert_allclose(p[..., 2], 0.6 * t * np.cos(u) - 0.6 * t, atol=1e-12)
    assert np.abs(p[0, :, :2]).max() < 1e-12 and np.abs(p[-1, :, :2]).max() < 1e-12  # closed at both tips
    assert p[0, 0, 2] == pytest.approx(0.0)  # the top starts where it forms
    radius = r[:, 0]
    widest = u[np.argmax(radius), 0]
    assert widest > 0.6 * np.pi  # round at the bottom, pointed at the top


def test_as_it_falls_it_grows_longer_and_thinner_and_moves_down():
    shapes = []
    for tau in (0.0, 0.5, 1.0, 2.0):
        _u, p = _surface(tau)
        height = p[..., 2].max() - p[..., 2].min()
        width = 2 * np.hypot(p[..., 0], p[..., 1]).max()
        shapes.append((height, width, p[..., 2].mean()))
    h, w, z = np.array(shapes).T
    assert (np.diff(h) > 0).all() and (np.diff(w) < 0).all() and (np.diff(z) < 0).all()


def test_a_new_drop_every_period_each_lasting_its_lifetime():
    assert tears.age(-0.1, 0.0, 2.0, 1.5) is None
    assert tears.age(0.5, 0.0, 2.0, 1.5) == pytest.approx(0.5)
    assert tears.age(1.7, 0.0, 2.0, 1.5) is None
    assert tears.age(4.25, 0.0, 2.0, 1.5) == pytest.approx(0.25)
    assert tears.age(1.0, 0.0, 0.0, 1.5) is None


def _on_sphere(R=0.1, k=40, n=9, half_width=0.004, length=0.06):
    """A tear's base along a meridian of a sphere of radius R (a cheek-like curvature)."""
    theta = np.linspace(0.3, 0.3 + length / R, k)
    path = np.stack([np.zeros(k), -R * np.sin(theta), R * np.cos(theta)], 1)
    normals = path / R
    base, arc, w = tears.strip(path, normals, half_width, n)
    base = base / np.linalg.norm(base, axis=1, keepdims=True) * R  # snapped onto the skin
    return base, base / R, arc, w, k


def test_the_strip_runs_along_the_path_across_the_tangent_plane():
    base, normals, arc, w, k = _on_sphere()
    assert base.shape == (k * 9, 3) and arc.shape == w.shape == (k * 9,)
    assert arc[-1] == pytest.approx(0.06, rel=1e-3) and w.min() == -1 and w.max() == 1
    with pytest.raises(ValueError):
        tears.strip(np.zeros((1, 3)), np.zeros((1, 3)), 0.01, 5)
    with pytest.raises(ValueError):
        tears.strip(np.zeros((3, 3)), np.tile([0, 0, 1.0], (3, 1)), 0.01, 5)


def test_the_shell_is_closed_and_never_inside_the_skin():
    R = 0.1
    base, normals, arc, w, k = _on_sphere(R)
    factor = tears.reveal_profile(arc, 0.05, 0.006) * (1 - tears.reveal_profile(arc, 0.004, 0.004))
    rise = tears.rise_noise(np.stack([arc, w * 0.004], 1), 0.2, 0.0003, seed=1, eps=0.002)
    pos, quads, partner = tears.shell(base, normals, w, k, thickness=0.0012, gap=0.0001, rise=rise,
                                      factor=factor)
    # closed: every edge is shared by exactly two faces
    e = np.sort(np.stack([quads, np.roll(quads, -1, axis=1)], 2).reshape(-1, 2), axis=1)
    _u, counts = np.unique(e, axis=0, return_counts=True)
    assert (counts == 2).all()
    # never inside the skin (the sphere): vertices, edge midpoints and face centres
    mids = 0.5 * (pos[e[:, 0]] + pos[e[:, 1]])
    centres = pos[quads].mean(axis=1)
    for pts in (pos, mids, centres):
        assert (np.linalg.norm(pts, axis=1) > R).all()
    # the top is never below the bottom, and the head is round: zero thickness ahead of it
    assert len(pos) < 2 * len(base)  # the unrevealed part shares the bottom's vertices


def test_resample_keeps_the_ends_and_steps_evenly():
    path = np.array([[0, 0, 0], [0, 0, 0], [0.01, 0, 0], [0.01, 0, 0.03]], float)
    out = tears.resample(path, 0.004)
    np.testing.assert_allclose(out[[0, -1]], path[[0, -1]])
    steps = np.linalg.norm(np.diff(out, axis=0), axis=1)
    assert steps.max() <= 0.004 + 1e-12 and steps.min() > 0
    assert len(out) == 11  # 0.04 long in steps of at most 0.004
    for bad in (np.zeros((1, 3)), np.zeros((4, 3))):
        with pytest.raises(ValueError, match="two distinct"):
            tears.resample(bad, 0.004)


def test_the_spine_of_a_band_of_faces_runs_along_it():
    rng = np.random.default_rng(3)
    along, across = rng.uniform(0, 0.05, 2000), rng.uniform(-0.002, 0.002, 2000)
    turn = np.array([[np.cos(0.4), np.sin(0.4)], [-np.sin(0.4), np.cos(0.4)]])
    xz = np.stack([along, across], 1) @ turn
    pts = np.stack([xz[:, 0], np.full(2000, 0.1), xz[:, 1]], 1)
    path, half = tears.spine(pts, 0.002)
    assert half == pytest.approx(0.002, rel=0.05)
    direction = (path[-1] - path[0]) / np.linalg.norm(path[-1] - path[0])
    assert abs(direction @ np.array([turn[0, 0], 0, turn[0, 1]])) > 0.999  # along the band
    assert np.linalg.norm(path[-1] - path[0]) == pytest.approx(0.05, rel=0.1)
    with pytest.raises(ValueError, match="no length"):
        tears.spine(np.ones((5, 3)), 0.002)


def test_the_outline_rounds_both_ends_to_a_small_tip():
    arc = np.linspace(0, 0.05, 501)
    g = tears.outline(arc, 0.05, 0.004)
    assert g[0] == pytest.approx(tears.OUTLINE_TIP) and g[-1] == pytest.approx(tears.OUTLINE_TIP)
    assert (g[(arc >= 0.004) & (arc <= 0.046)] == 1).all()
    assert (np.diff(g[arc <= 0.004]) >= 0).all() and (np.diff(g[arc >= 0.046]) <= 0).all()
    # a quarter circle: at half the head the width is sqrt(3)/2
    assert tears.outline([0.002], 0.05, 0.004)[0] == pytest.approx(np.sqrt(0.75))


def test_a_tears_top_stands_on_its_partner_and_its_rows_have_a_centre():
    R = 0.1
    theta = np.linspace(0.3, 0.9, 40)
    path = np.stack([np.zeros(40), -R * np.sin(theta), R * np.cos(theta)], 1)
    base, arc, w = tears.strip(path, path / R, 0.002, 9, head=0.004)
    base = base / np.linalg.norm(base, axis=1, keepdims=True) * R
    t = tears.Tear(base, base / R, w, arc, 40, 0.002, 0.0006, 0.00008, roughness=0.4, seed=2, head=0.004)
    nb = len(base)
    top = np.arange(len(t.positions)) >= nb
    assert (t.partner[~top] == np.arange(nb)).all() and (t.partner[top] < nb).all()
    lift = t.positions[top] - t.positions[t.partner[top]]
    normal = t.positions[t.partner[top]] / np.linalg.norm(t.positions[t.partner[top]], axis=1, keepdims=True)
    assert (np.einsum("ij,ij->i", lift, normal) > 0).all()  # straight up from its partner
    np.testing.assert_allclose(np.linalg.norm(np.cross(lift, normal), axis=1), 0, atol=1e-12)
    np.testing.assert_allclose(t.arc, arc[t.partner])
    # each vertex's centre: the middle of its own row, on its own sheet (the bottom's where
    # the two sheets meet there, at the rounded ends)
    assert (np.abs(w[t.partner[t.centre]]) < 1e-12).all()
    assert (t.partner[t.centre] // 9 == t.partner // 9).all()
    assert (t.centre[~top] < nb).all()
    meets = t.centre[top] < nb
    at = t.arc[top][meets]
    assert meets.sum() < 0.1 * top.sum() and ((at < 0.004) | (at > arc.max() - 0.004)).all()
    # the ends are rounded in plan: the first and last rows are narrower than the middle
    rows = base.reshape(40, 9, 3)
    width = np.linalg.norm(rows[:, 0] - rows[:, -1], axis=1)
    assert width[0] < 0.5 * width[20] and width[-1] < 0.5 * width[20]
    # the rise never sinks: every top vertex at least as high as the taper alone makes it
    plain = tears.Tear(base, base / R, w, arc, 40, 0.002, 0.0006, 0.00008, roughness=0.0, head=0.004)
    assert len(plain.positions) == len(t.positions)
    h_rough = np.linalg.norm(t.positions[top], axis=1)
    h_plain = np.linalg.norm(plain.positions[top], axis=1)
    assert (h_rough >= h_plain - 1e-12).all() and (h_rough > h_plain + 1e-6).any()


def test_a_bound_point_comes_back_and_moves_rigidly_with_its_triangle():
    rng = np.random.default_rng(5)
    a, b, c = (rng.normal(size=(50, 3)) for _ in range(3))
    p = (a + b + c) / 3 + rng.normal(scale=0.5, size=(50, 3))  # some beyond the edges
    weights, lift = tears.bind(p, a, b, c)
    np.testing.assert_allclose(weights.sum(axis=1), 1.0)
    np.testing.assert_allclose(tears.bound(weights, lift, a, b, c), p, atol=1e-12)
    q, _r = np.linalg.qr(rng.normal(size=(3, 3)))
    q *= np.sign(np.linalg.det(q))  # a rotation
    move = np.array([0.3, -1.0, 2.0])
    np.testing.assert_allclose(tears.bound(weights, lift, a @ q.T + move, b @ q.T + move, c @ q.T + move),
                               p @ q.T + move, atol=1e-12)
    # stretched along the triangle's plane, the height over it stays
    flat = np.zeros((1, 3))
    w1, h1 = tears.bind([[0.2, 0.3, 0.05]], flat, [[1.0, 0, 0]], [[0, 1.0, 0]])
    np.testing.assert_allclose(tears.bound(w1, h1, flat, [[2.0, 0, 0]], [[0, 2.0, 0]]), [[0.4, 0.6, 0.05]])


def test_the_running_head_is_a_bead_with_a_round_front():
    arc = np.linspace(0.0, 0.05, 5001)
    length, head = 0.04, 0.004
    f = tears.bead_profile(arc, length, head)
    assert (f[arc <= length - head - 1e-9] == 1.0).all() and (f[arc >= length + 1e-9] == 0.0).all()
    x = (arc - (length - head)) / head
    assert f.max() > 2.0  # the water gathered at the front, about twice the trail
    peak = arc[f.argmax()]
    assert length - 0.7 * head < peak < length - 0.3 * head
    inside = (x > 0) & (x < 1)
    slope = np.gradient(f, arc)
    assert abs(slope[np.searchsorted(arc, length - head) + 1]) * head < 0.1  # leaves the trail smoothly (C¹)
    assert (slope[inside & (arc > peak)] < 0).all()  # falls to the front
    assert -slope[inside][-1] * head > 5.0  # steeply: a round front on the skin
    plain = tears.bead_profile(arc, length, head, bead=0.0)  # no bead: a quarter circle
    np.testing.assert_allclose(plain[inside], np.sqrt(1.0 - x[inside] ** 2), atol=1e-12)
    assert plain.max() == 1.0
