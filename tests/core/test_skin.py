"""core.skin: the skin's regions from the landmarks, the eyes' frames, the lash cards.

The regions are checked on the sample head and on a second face (the sample head scaled,
stretched and moved, as in the landmark tests): the T-zone is oilier than the cheeks and
the neck, the cheeks, nose tip and lids redder than the forehead, the lips in the lip zone;
everything in [0, 1]."""

from pathlib import Path

import numpy as np
import pytest

from wrinkle_addon.core import landmark_finder, skin, zones

NPZ = Path(__file__).resolve().parents[2] / "wrinkle_addon" / "data" / "ict_head.npz"


def _blender(a):
    a = np.asarray(a, np.float64)
    return np.stack([a[..., 0], -a[..., 2], a[..., 1]], axis=-1) * 0.01


@pytest.fixture(scope="module", params=["sample", "variant"])
def face(request):
    with np.load(NPZ) as d:
        p, quads = _blender(d["positions"]), d["quads"]
    if request.param == "variant":
        p = p * (1.12, 0.95, 1.05) + (0.3, -0.2, 1.4)
    found, _method, _msg = landmark_finder.find_landmarks(p, quads)
    return p, found


def _nearest(p, point):
    return int(np.argmin(np.linalg.norm(p - point, axis=1)))


def test_regions_follow_the_face(face):
    p, lm = face
    w = skin.regions(p, lm)
    assert w.shape == (len(p), 3) and w.dtype == np.float32
    assert w.min() >= 0.0 and w.max() <= 1.0
    oil, red, lip = w.T
    e = 2.0 * abs(lm["eye_L"][0] - lm["glabella"][0])
    up = np.array([0.0, 0.0, 1.0])
    forehead = _nearest(p, lm["glabella"] + 0.7 * e * up)
    nose = _nearest(p, lm["nose_tip"])
    cheek = _nearest(p, 0.55 * lm["cheekbone_L"] + 0.45 * lm["mouth_corner_L"])
    neck = int(np.argmin(p[:, 2]))
    assert oil[forehead] > 0.9 and oil[nose] > 0.5
    assert oil[cheek] < 0.2 and oil[neck] == 0.0
    assert red[nose] > 0.8 and red[cheek] > 0.5 and red[forehead] < 0.1
    mid_lip = 0.5 * (lm["mouth_corner_L"] + lm["mouth_corner_L"] * (-1, 1, 1) + (2 * lm["glabella"][0], 0, 0))
    r = zones.face_zones(p, lm).lip_radius  # the lip zone is r <= 1; its edge is soft
    assert (r <= 0.9).any() and lip[r <= 0.9].min() > 0.99 and lip[r >= 1.1].max() == 0.0
    assert lip[forehead] == 0.0 and lip[nose] == 0.0
    assert lip[_nearest(p, mid_lip)] > 0.9


def _sphere(n=2000, seed=0):
    v = np.random.default_rng(seed).normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_sphere_centre_ignores_crowding():
    pts = _sphere()
    pts = np.concatenate([pts] + [pts[pts[:, 1] < -0.8]] * 4)  # crowded toward the front
    pts = 0.012 * pts + (0.03, -0.09, 0.035)
    assert np.allclose(skin.sphere_centre(pts), (0.03, -0.09, 0.035), atol=1e-9)
    assert np.linalg.norm(pts.mean(axis=0) - (0.03, -0.09, 0.035)) > 1e-3  # the mean would not


def test_cornea_apex_and_eye_frame():
    d = _sphere()
    gaze = np.array([0.1, -1.0, 0.05]) / np.linalg.norm([0.1, -1.0, 0.05])
    bulge = 1.0 + 0.15 * np.clip(d @ gaze - 0.8, 0.0, None) / 0.2  # the cornea
    shell = 0.013 * d * bulge[:, None] + (0.03, -0.09, 0.035)
    apex = skin.cornea_apex(shell)
    to_apex = (apex - (0.03, -0.09, 0.035)) / np.linalg.norm(apex - (0.03, -0.09, 0.035))
    assert np.degrees(np.arccos(to_apex @ gaze)) < 3
    ball = 0.012 * d + (0.03, -0.09, 0.035)
    e = skin.eye_directions(ball, apex)
    assert np.allclose(np.linalg.norm(e, axis=1), 1.0, atol=1e-5)
    front = int(np.argmax(d @ gaze))
    assert e[front, 2] > 0.99 and e[int(np.argmin(d @ gaze)), 2] < -0.99


def test_components_and_moving():
    # two quads sharing an edge, and a separate triangle
    sizes = np.array([4, 4, 3])
    corners = np.array([0, 1, 2, 3, 1, 4, 5, 2, 6, 7, 8])
    assert skin.components(9, sizes, corners).tolist() == [0, 0, 0, 0, 0, 0, 1, 1, 1]
    deltas = np.zeros((3, 5, 3), np.float32)
    deltas[1, 2, 0] = 1e-3
    assert skin.moving(deltas, 1e-5).tolist() == [1]
