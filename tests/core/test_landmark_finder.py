"""The landmark finder (core.landmark_finder): each rule on its own and in order,
against references placed independently of it, and the bounding-box fallback.

References:

* the procedural head (sample_scenes/lib/headgen.py): the generator's own analytic
  landmarks, surface points at fixed (x, z) in its model;
* the ICT scan (the add-on's sample head, wrinkle_addon/data/ict_head.npz): vertex indices picked
  by inspecting the scan in front and side views (a rendered check, once): the nose tip,
  the left mouth corner, the two corners of the left eye (the eye is their midpoint), and
  the frontal vertices at the glabella, the front of the chin, the middle of the hairline
  (where the forehead turns into the crown) and the most prominent point of the left
  cheekbone; the brow's outer end is ICT-FaceKit's own (iBUG point 26 of
  ict_head_landmarks.json: the vertex first picked here, 2737, was 12 mm short of it, on
  the brow ridge above the eye's outer corner).  tests/core/test_landmark_reference.py
  compares every landmark with a counterpart among ICT's 68 landmarks.
"""

from pathlib import Path

import numpy as np
import pytest

from sample_scenes.lib import headgen
from wrinkle_addon.core import landmark_finder as lf

ICT = Path(__file__).resolve().parents[2] / "wrinkle_addon" / "data" / "ict_head.npz"
ICT_REFERENCE = {  # name -> ICT vertex indices (mean of them)
    "hairline_center": [8254],
    "glabella": [1398],
    "brow_outer_L": [2509],  # iBUG 26 of ICT's own landmarks (test_landmark_reference.py)
    "eye_L": [6548, 6588],
    "nose_tip": [4841],
    "mouth_corner_L": [6684],
    "chin": [968],
    "cheekbone_L": [3374],
}
TOLERANCE = 0.005  # metres
NAMES = [k for k, _l, _d in lf.LANDMARKS]


def _to_blender(a):
    a = np.asarray(a, np.float64)
    return np.stack([a[..., 0], -a[..., 2], a[..., 1]], axis=-1) * 0.01


@pytest.fixture(scope="module")
def ict():
    with np.load(ICT) as data:
        pos = _to_blender(data["positions"])
        keys = {str(n): pos + _to_blender(d)
                for n, d in zip(data["expression_names"], data["expression_deltas"])}
        quads = np.asarray(data["quads"], np.int64)
    ref = {k: pos[v].mean(axis=0) for k, v in ICT_REFERENCE.items()}
    return pos, quads, keys, ref


@pytest.fixture(scope="module")
def head():
    return headgen.make_head()


def _distances(found, ref):
    return {k: float(np.linalg.norm(np.asarray(found[k]) - np.asarray(ref[k], np.float64))) for k in NAMES}


def _check(found, ref):
    assert set(found) == set(NAMES)
    dist = _distances(found, ref)
    far = {k: round(d * 1000, 1) for k, d in dist.items() if d > TOLERANCE}
    assert not far, f"landmarks farther than 5 mm from the reference (mm): {far}"


def test_ict_with_shape_keys_uses_the_openings(ict):
    pos, quads, keys, ref = ict
    found, method, message = lf.find_landmarks(pos, quads, keys)
    assert (method, message) == ("openings", "")
    _check(found, ref)


def test_ict_without_shape_keys_uses_the_openings(ict):
    pos, quads, _keys, ref = ict
    found, method, _m = lf.find_landmarks(pos, quads)
    assert method == "openings"
    _check(found, ref)


def test_ict_rig_rule_alone(ict):
    pos, quads, keys, ref = ict
    found, method, _m = lf.find_landmarks(pos, quads, keys, rules=("rig",))
    assert method == "rig"
    _check(found, ref)


def test_ict_rig_rule_with_left_right_names(ict):
    pos, quads, keys, ref = ict
    renamed = {n.replace("_L", "Left").replace("_R", "Right"): v for n, v in keys.items()}
    found, method, _m = lf.find_landmarks(pos, quads, renamed, rules=("rig",))
    assert method == "rig"
    _check(found, ref)


def test_ict_rig_comes_before_geometry_when_openings_are_ignored(ict):
    pos, quads, keys, _ref = ict
    assert lf.find_landmarks(pos, quads, keys, rules=("rig", "geometry"))[1] == "rig"
    assert lf.find_landmarks(pos, quads, None, rules=("rig", "geometry"))[1] == "geometry"


def test_ict_geometry_rule_alone(ict):
    pos, quads, _keys, ref = ict
    found, method, _m = lf.find_landmarks(pos, quads, rules=("geometry",))
    assert method == "geometry"
    _check(found, ref)


def test_procedural_head_within_5mm(head):
    found, _method, _message = lf.find_landmarks(head["positions"], head["quads"])
    _check(found, head["landmarks"])


def test_procedural_head_uses_the_geometry(head):
    # closed eyelids and mouth line, no shape keys: neither openings nor rig fit
    found, method, message = lf.find_landmarks(head["positions"], head["quads"])
    assert (method, message) == ("geometry", "")
    dist = _distances(found, head["landmarks"])
    assert max(dist[k] for k in ("nose_tip", "glabella", "chin")) < TOLERANCE


def test_polygon_tuple_input_gives_the_same(head):
    q = head["quads"].astype(np.int64)
    polys = (q.ravel(), np.arange(len(q)) * 4, np.full(len(q), 4))
    a = lf.find_landmarks(head["positions"], q)[0]
    b = lf.find_landmarks(head["positions"], polys)[0]
    for k in NAMES:
        np.testing.assert_allclose(a[k], b[k])


# --------------------------------------------------------------------------
# Robustness of the geometry rule: the same face with other ears, at another size,
# turned a little or meshed more coarsely gives the same landmarks.
# --------------------------------------------------------------------------
STABLE = 0.004  # metres: how far a landmark may move under a perturbation that leaves the face as it is
EAR_Z = (0.055, 0.15)  # z span of the procedural head's ears (sample_scenes/lib/headgen.py)


def _ears_scaled(pos, factor):
    """The ears pushed out (factor > 1) or in: the vertices beside and behind the face,
    beyond the side of the skull, moved in x by ``factor`` times their distance past it."""
    p = pos.astype(np.float64)
    ax = np.abs(p[:, 0])
    skull = 0.055
    w = np.clip((ax - skull) / 0.01, 0.0, 1.0) * (p[:, 1] > -0.01)
    w *= np.clip(1.0 - np.abs(p[:, 2] - 0.102) / 0.05, 0.0, 1.0) ** 0.5
    p[:, 0] = np.sign(p[:, 0]) * (ax + (factor - 1.0) * w * (ax - skull))
    return p


def _ears_cut(pos):
    """The ears cut off flush with the side of the head."""
    p = pos.astype(np.float64)
    ear = (p[:, 1] > -0.005) & (p[:, 2] > EAR_Z[0]) & (p[:, 2] < EAR_Z[1])
    p[ear, 0] = np.clip(p[ear, 0], -0.074, 0.074)
    return p


def _yaw(degrees):
    a = np.radians(degrees)
    return np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])


@pytest.fixture(scope="module")
def head_found(head):
    found, method, _m = lf.find_landmarks(head["positions"], head["quads"])
    assert method == "geometry"
    return found


def _check_stable(found, base, ref, skip_ref=("hairline_center",)):
    assert set(found) == set(NAMES)
    moved = {k: round(float(np.linalg.norm(found[k] - base[k])) * 1000, 1) for k in NAMES}
    assert max(moved.values()) < STABLE * 1000, f"landmarks moved (mm): {moved}"
    dist = _distances(found, ref)
    far = {k: round(d * 1000, 1) for k, d in dist.items() if d > TOLERANCE and k not in skip_ref}
    assert not far, f"landmarks farther than 5 mm from the reference (mm): {far}"


@pytest.mark.parametrize("perturb", ["ears 0.8", "ears 1.2", "ears 1.4", "no ears"])
def test_geometry_rule_does_not_depend_on_the_ears(head, head_found, perturb):
    if perturb == "no ears":
        pos = _ears_cut(head["positions"])
    else:
        pos = _ears_scaled(head["positions"], float(perturb.split()[1]))
    assert np.abs(pos - head["positions"]).max() > 0.001  # the ears did change
    found, method, _m = lf.find_landmarks(pos, head["quads"])
    assert method == "geometry"
    _check_stable(found, head_found, head["landmarks"])


@pytest.mark.parametrize("factor", [0.9, 1.15])
def test_geometry_rule_scales_with_the_head(head, head_found, factor):
    found, method, _m = lf.find_landmarks(head["positions"] * factor, head["quads"])
    assert method == "geometry"
    base = {k: v * factor for k, v in head_found.items()}
    ref = {k: np.asarray(v, np.float64) * factor for k, v in head["landmarks"].items()}
    _check_stable(found, base, ref)


@pytest.mark.parametrize("degrees", [3.0, -3.0])
def test_geometry_rule_under_a_small_yaw(head, head_found, degrees):
    rot = _yaw(degrees)
    found, method, _m = lf.find_landmarks(head["positions"] @ rot.T, head["quads"])
    assert method == "geometry"
    base = {k: rot @ v for k, v in head_found.items()}
    ref = {k: rot @ np.asarray(v, np.float64) for k, v in head["landmarks"].items()}
    _check_stable(found, base, ref)


def test_geometry_rule_on_a_coarser_mesh(head_found):
    coarse = headgen.make_head(15000)
    found, method, _m = lf.find_landmarks(coarse["positions"], coarse["quads"])
    assert method == "geometry"
    _check_stable(found, head_found, coarse["landmarks"])


def _sphere(n=48):
    u, v = np.meshgrid(np.linspace(0, 2 * np.pi, n, endpoint=False), np.linspace(-1.4, 1.4, n // 2))
    pos = 0.1 * np.stack([np.cos(v) * np.cos(u), np.cos(v) * np.sin(u), np.sin(v)], -1).reshape(-1, 3)
    idx = np.arange(pos.shape[0]).reshape(n // 2, n)
    quads = np.stack([idx[:-1], np.roll(idx[:-1], -1, 1), np.roll(idx[1:], -1, 1), idx[1:]], -1)
    return pos, quads.reshape(-1, 4)


def test_sphere_falls_back_to_the_bounding_box_with_a_message():
    pos, quads = _sphere()
    found, method, message = lf.find_landmarks(pos, quads, {"eyeBlink_L": pos})
    assert method == lf.FALLBACK and "bounding box" in message
    expected = lf.estimate_landmarks(pos.min(axis=0), pos.max(axis=0))
    for k in NAMES:
        np.testing.assert_allclose(found[k], expected[k])


def test_empty_mesh_falls_back():
    found, method, message = lf.find_landmarks(np.zeros((0, 3)), np.zeros((0, 4), int))
    assert method == lf.FALLBACK and message and set(found) == set(NAMES)


def test_boundary_loops_of_a_grid_with_two_holes():
    n = 12
    idx = np.arange(n * n).reshape(n, n)
    quads = np.stack([idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]], -1)
    keep = np.ones((n - 1, n - 1), bool)
    keep[2:4, 2:4] = False
    keep[6:9, 6:8] = False
    loops = lf.boundary_loops(*lf.polygons(quads[keep]))
    assert [len(v) for v in loops] == [4 * (n - 1), 10, 8]
