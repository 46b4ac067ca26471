"""Sample content: the procedural head, the forehead patch and the ICT loader.

Pure NumPy; nothing here imports bpy.
"""

import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from sample_scenes.lib import headgen, ict  # noqa: E402

ICT_PATH = ict.DEFAULT_PATH
PAIRS = [n[:-2] for n in headgen.LANDMARK_NAMES if n.endswith("_L")]


@pytest.fixture(scope="module")
def head():
    return headgen.make_head()


@pytest.fixture(scope="module")
def patch():
    return headgen.make_forehead_patch()


def face_normals(mesh):
    p = mesh["positions"].astype(np.float64)
    q = mesh["quads"]
    n = np.cross(p[q[:, 2]] - p[q[:, 0]], p[q[:, 3]] - p[q[:, 1]])  # 2 x vector area
    return n, p[q].mean(axis=1)


def edges(quads):
    e = np.concatenate([quads[:, [0, 1]], quads[:, [1, 2]], quads[:, [2, 3]], quads[:, [3, 0]]])
    return np.unique(np.sort(e, axis=1), axis=0, return_counts=True)


def check_mesh(mesh):
    pos, quads, uvs = mesh["positions"], mesh["quads"], mesh["corner_uvs"]
    assert pos.dtype == np.float32 and pos.ndim == 2 and pos.shape[1] == 3
    assert quads.dtype == np.int32 and quads.ndim == 2 and quads.shape[1] == 4
    assert uvs.dtype == np.float32 and uvs.shape == (len(quads), 4, 2)
    assert np.isfinite(pos).all() and np.isfinite(uvs).all()
    assert quads.min() == 0 and quads.max() == len(pos) - 1  # every vertex used
    assert all(len(set(q)) == 4 for q in quads[:: max(1, len(quads) // 2000)])
    assert (np.sort(quads, axis=1)[:, 1:] != np.sort(quads, axis=1)[:, :-1]).all()
    n, _ = face_normals(mesh)
    assert 0.5 * np.linalg.norm(n, axis=1).min() > 1e-9  # no degenerate quad (m^2)
    _, count = edges(quads)
    assert count.max() <= 2  # manifold: no edge shared by three faces
    assert uvs.min() >= 0.0 and uvs.max() <= 1.0


@pytest.mark.parametrize("target", [10_000, 50_000, 200_000])
def test_head_vertex_count_tracks_target(target):
    mesh = headgen.make_head(target)
    assert abs(len(mesh["positions"]) - target) <= 0.25 * target
    check_mesh(mesh)


def test_head_default_mesh(head):
    check_mesh(head)
    assert abs(len(head["positions"]) - 40_000) <= 10_000


def test_head_is_deterministic():
    a, b = headgen.make_head(10_000), headgen.make_head(10_000)
    for key in ("positions", "quads", "corner_uvs"):
        np.testing.assert_array_equal(a[key], b[key])


def test_head_normals_point_out(head):
    n, centres = face_normals(head)
    outward = np.einsum("ij,ij->i", n, centres - head["positions"].mean(axis=0))
    assert outward.mean() > 0
    # Stricter: seen from the centre of the skull (or the neck axis, for the
    # neck), every face is wound counter-clockwise.
    neck_axis = np.column_stack([np.zeros(len(centres)), np.full(len(centres), 0.01), centres[:, 2]])
    axis = np.where(centres[:, 2:3] < -0.02, neck_axis, headgen.ORIGIN)
    assert (np.einsum("ij,ij->i", n, centres - axis) > 0).all()


def test_head_boundary_is_the_neck_ring(head):
    uniq, count = edges(head["quads"])
    border = np.unique(uniq[count == 1])
    z = head["positions"][border, 2]
    assert len(border) > 16
    assert np.ptp(z) < 1e-3 and z.max() < 0.0  # one level ring, below the chin


def test_head_proportions(head):
    p = head["positions"]
    lm = head["landmarks"]
    assert 0.20 < p[:, 2].max() - lm["chin"][2] < 0.26  # chin to crown
    skull = p[np.abs(p[:, 2] - 0.17) < 0.005]
    assert 0.13 < np.ptp(skull[:, 0]) < 0.17  # skull width above the ears
    assert 0.17 < np.ptp(skull[:, 1]) < 0.22  # glabella to the back of the head
    # Head length (glabella to opisthocranion) of an adult, 18-20 cm: a longer
    # cranium dwarfs the face.
    g = lm["glabella"]
    assert 0.18 < p[:, 1].max() - g[1] < 0.20


def test_head_face_resolution(head):
    p = head["positions"].astype(np.float64)
    uniq, _ = edges(head["quads"])
    length = np.linalg.norm(p[uniq[:, 0]] - p[uniq[:, 1]], axis=1)
    mid = 0.5 * (p[uniq[:, 0]] + p[uniq[:, 1]])
    lm = head["landmarks"]
    face = ((np.abs(mid[:, 0]) < 0.05) & (mid[:, 1] < -0.05)
            & (mid[:, 2] > lm["chin"][2]) & (mid[:, 2] < lm["hairline_center"][2]))
    assert 0.0012 < np.median(length[face]) < 0.0021
    back = mid[:, 1] > 0.05
    assert np.median(length[back]) > np.median(length[face])


def test_head_uvs_do_not_flip_or_overlap(head):
    uv = head["corner_uvs"].astype(np.float64)
    a, b = uv[:, 2] - uv[:, 0], uv[:, 3] - uv[:, 1]
    area = 0.5 * (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])
    assert (area > 0).all()  # every quad keeps its orientation in UV space
    # Two islands, the band and the crown disc, stacked in V without overlap:
    # sorted by their lowest V, some face starts above every face before it.
    lo, hi = uv[:, :, 1].min(axis=1), uv[:, :, 1].max(axis=1)
    order = np.argsort(lo)
    split = np.flatnonzero(lo[order][1:] > np.maximum.accumulate(hi[order])[:-1])
    assert len(split) == 1
    assert 1000 < len(lo) - split[0] - 1 < 0.2 * len(lo)  # the crown island
    # The face (in front of y = -6 cm) spans about half of U.
    n, centres = face_normals(head)
    face = (centres[:, 1] < -0.06) & (centres[:, 2] > 0.02) & (centres[:, 2] < 0.19)
    assert np.ptp(uv[face, :, 0]) > 0.45


def test_head_landmarks_on_surface(head):
    pos = head["positions"].astype(np.float64)
    lm = head["landmarks"]
    assert set(lm) == set(headgen.LANDMARK_NAMES)
    for name, point in lm.items():
        assert point.dtype == np.float32 and point.shape == (3,), name
        dist = np.sqrt(np.min(np.sum((pos - point) ** 2, axis=1)))
        assert dist < 0.002, name


@pytest.mark.parametrize("mesh_name", ["head", "ict"])
def test_landmarks_mirror_and_order(mesh_name, head):
    if mesh_name == "ict":
        mesh = ict.load_ict(ICT_PATH)
        tol = 0.004
    else:
        mesh, tol = head, 0.0005
    lm = mesh["landmarks"]
    assert set(lm) == set(headgen.LANDMARK_NAMES)
    for base in PAIRS:
        left, right = lm[base + "_L"], lm[base + "_R"]
        assert left[0] > 0 > right[0], base
        np.testing.assert_allclose(left * (-1, 1, 1), right, atol=tol, err_msg=base)
    z = {k: v[2] for k, v in lm.items()}
    assert z["chin"] < z["lower_lip"] < z["upper_lip"] < z["nose_tip"]
    assert z["lower_lip"] < z["mouth_corner_L"] < z["upper_lip"] + 0.005
    assert z["nose_tip"] < z["nose_bridge"] < z["glabella"] < z["hairline_center"]
    assert z["nose_tip"] < z["eye_L"] < z["brow_mid_L"] < z["hairline_L"]
    assert z["jaw_L"] < z["mouth_corner_L"] < z["cheekbone_L"] < z["eye_L"]
    assert z["nose_ala_L"] < z["nose_tip"] + 0.002
    front = min(lm, key=lambda k: lm[k][1])
    assert front == "nose_tip"
    assert lm["cheek_lateral_L"][1] > lm["mouth_corner_L"][1]  # toward the ear
    assert lm["cheek_lateral_L"][0] > lm["mouth_corner_L"][0]
    inner, mid, outer = lm["brow_inner_L"][0], lm["brow_mid_L"][0], lm["brow_outer_L"][0]
    assert 0 < inner < mid < outer


def test_head_is_star_shaped_from_origin():
    """Every ray from ORIGIN crosses the surface once (above the neck), which
    is what lets the vertices be found by bisection."""
    mesh = headgen.make_head(10_000)
    pos = mesh["positions"].astype(np.float64)
    pos = pos[pos[:, 2] > -0.015]
    dirs = pos - headgen.ORIGIN
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    ts = np.arange(0.001, 0.25, 0.0005)
    inside = np.stack([headgen.head_field(headgen.ORIGIN + t * dirs) < 0 for t in ts])
    crossings = (inside[1:] != inside[:-1]).sum(axis=0)
    assert (crossings == 1).all()


def test_forehead_patch(patch):
    check_mesh(patch)
    assert abs(len(patch["positions"]) - 20_000) <= 5_000
    p = patch["positions"]
    assert np.ptp(p[:, 2]) == pytest.approx(0.08, rel=1e-3)
    assert np.ptp(p[:, 0]) < 0.14 and np.ptp(p[:, 0]) > 0.12  # arc of 0.14 on r = 0.1
    n, _ = face_normals(patch)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    assert (n[:, 1] < -0.7).all()  # faces -Y
    lm = patch["landmarks"]
    assert set(lm) == {"attachment_L", "attachment_R", "insertion_L", "insertion_R"}
    for side in "LR":
        assert lm["attachment_" + side][2] > lm["insertion_" + side][2] + 0.05
    assert lm["attachment_L"][0] > 0 > lm["attachment_R"][0]
    np.testing.assert_allclose(lm["insertion_L"] * (-1, 1, 1), lm["insertion_R"], atol=1e-6)
    uv = patch["corner_uvs"].astype(np.float64)
    a, b = uv[:, 2] - uv[:, 0], uv[:, 3] - uv[:, 1]
    assert (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0] > 0).all()


@pytest.mark.parametrize("target", [2_000, 80_000])
def test_forehead_patch_count(target):
    mesh = headgen.make_forehead_patch(width=0.1, height=0.06, target_verts=target)
    assert abs(len(mesh["positions"]) - target) <= 0.25 * target


def test_ict_loader_orientation():
    data = ict.load_ict(ICT_PATH)
    pos = data["positions"]
    assert pos.dtype == np.float32 and pos.shape[1] == 3
    assert data["quads"].dtype == np.int32 and data["quads"].max() < len(pos)
    assert data["corner_uvs"].shape == data["quads"].shape + (2,)
    names, deltas = data["expression_names"], data["expression_deltas"]
    assert all(isinstance(n, str) for n in names) and len(names) == len(deltas) == 53
    assert deltas.dtype == np.float32 and deltas.shape == (len(names),) + pos.shape
    assert np.abs(deltas).max() < 0.05  # metres: no expression moves skin 5 cm
    assert 0.2 < np.ptp(pos[:, 2]) < 0.4  # Z up, in metres
    lm = data["landmarks"]
    # The face looks toward -Y: the nose is in front of the skull's middle.
    assert lm["nose_tip"][1] < pos[:, 1].mean() - 0.05
    assert lm["nose_tip"][1] <= pos[:, 1].min() + 1e-6
    # Z up: the crown is above the eyes, which are above the chin.
    assert pos[:, 2].max() > lm["eye_L"][2] > lm["chin"][2]
    # browInnerUp_L lifts the character's left (+X) brow, and lifts it up.
    d = deltas[names.index("browInnerUp_L")]
    moved = np.linalg.norm(d, axis=1) > 0.5 * np.linalg.norm(d, axis=1).max()
    assert pos[moved, 0].mean() > 0 and d[moved, 2].mean() > 0


def test_head_adult_proportions(head):
    """Eye line at half the head height, face thirds, eye spacing one eye width,
    nose and mouth widths, the jaw narrower than the cheekbones."""
    p = head["positions"].astype(np.float64)
    lm = head["landmarks"]
    crown = p[:, 2].max()
    midline = np.abs(p[:, 0]) < 0.004
    menton = p[midline & (p[:, 1] < lm["chin"][1] + 0.03), 2].min()  # lowest point of the chin
    eye_z = lm["eye_L"][2]
    assert abs(eye_z - 0.5 * (crown + menton)) < 0.012 * (crown - menton) / 0.1
    # Thirds: hairline-glabella, glabella-subnasale, subnasale-menton within 20 %.
    subnasale = lm["nose_ala_L"][2] - 0.004
    thirds = np.array([lm["hairline_center"][2] - lm["glabella"][2],
                       lm["glabella"][2] - subnasale, subnasale - menton])
    assert thirds.max() / thirds.min() < 1.25, thirds
    # The fissure of one eye spans about the gap between the eyes.
    (xi, _zi), (xo, _zo) = headgen._CANTHUS_IN, headgen._CANTHUS_OUT
    assert 0.8 < (xo - xi) / (2 * xi) < 1.1
    assert 0.055 < 2 * lm["eye_L"][0] < 0.070  # interpupillary distance
    mouth = 2 * lm["mouth_corner_L"][0]
    alae = 2 * lm["nose_ala_L"][0]
    assert 0.045 < mouth < 0.056 and 0.028 < alae < 0.040 and mouth > 1.3 * alae

    def width(z, y_max):
        band = p[(np.abs(p[:, 2] - z) < 0.002) & (p[:, 1] < y_max)]
        return np.ptp(band[:, 0])

    cheeks = width(lm["cheekbone_L"][2], -0.03)
    jaw = width(lm["mouth_corner_L"][2] - 0.015, -0.03)
    assert 0.11 < cheeks < 0.15 and jaw < cheeks


def _profile_y(z, x=0.0):
    """Y of the front surface at (x, z), found by marching along +Y."""
    return headgen._project(np.array([[x, -0.3, z]]), np.array([[0.0, 1.0, 0.0]]),
                            headgen.head_field)[0, 1]


def test_head_profile_has_the_features():
    """Seen in profile: brow ridge over the nasion, a nose that stands out, lips in
    front of the sulcus under them, the chin forward of that sulcus."""
    glabella, nasion = _profile_y(0.130), min(_profile_y(z) for z in (0.119, 0.121, 0.123))
    assert glabella < nasion - 0.001
    nose = min(_profile_y(z) for z in np.arange(0.074, 0.090, 0.002))
    subnasale = max(_profile_y(z) for z in np.arange(0.064, 0.074, 0.002))
    assert subnasale - nose > 0.012  # the nose projects at least 12 mm
    upper, lower = _profile_y(0.051), _profile_y(0.043)
    sulcus, chin = _profile_y(0.033), _profile_y(0.022)
    assert upper < subnasale and lower < sulcus - 0.003 and chin < sulcus - 0.001


def test_head_eyes_open_between_lids():
    """The eyeball shows in the fissure: at the pupil the surface is the cornea; just
    above the upper lid margin and below the lower one the lids stand proud of it."""
    cx, _cy, cz = headgen._EYE_C
    pupil = _profile_y(cz, cx)
    upper_lid = _profile_y(cz + 0.0075, cx)
    lower_lid = _profile_y(cz - 0.0065, cx)
    assert abs(pupil - (headgen._EYE_C[1] - headgen._EYE_R - 0.0004)) < 0.001
    ball = headgen._EYE_C[1] - np.sqrt(headgen._EYE_R ** 2 - 0.0075 ** 2)
    assert upper_lid < ball - 0.0008  # the lid covers the ball there
    assert lower_lid < headgen._EYE_C[1] - np.sqrt(headgen._EYE_R ** 2 - 0.0065 ** 2) - 0.0008


def test_head_ears_stand_out(head):
    p = head["positions"].astype(np.float64)
    lm = head["landmarks"]
    side = p[(p[:, 1] > 0.0) & (p[:, 1] < 0.04)]
    at_ear = side[(side[:, 2] > 0.08) & (side[:, 2] < 0.125)]
    above = side[(side[:, 2] > 0.15) & (side[:, 2] < 0.16)]
    assert np.abs(at_ear[:, 0]).max() > np.abs(above[:, 0]).max() + 0.005
    ear = at_ear[np.argmax(at_ear[:, 0])]
    assert lm["nose_ala_L"][2] < ear[2] < lm["brow_mid_L"][2]  # between brow and nose base


def test_head_landmarks_at_the_features(head):
    """Each landmark is the surface point at its feature (within 1 mm of the surface
    of the field, and where the feature's geometry puts it)."""
    lm = {k: v.astype(np.float64) for k, v in head["landmarks"].items()}
    pts = np.array(list(lm.values()))
    assert np.abs(headgen.head_field(pts)).max() < 0.001
    # The eye landmark is the pupil: on the visual axis of the eyeball.
    eye = lm["eye_L"]
    assert np.hypot(eye[0] - headgen._EYE_C[0], eye[2] - headgen._EYE_C[2]) < 0.001
    assert abs(eye[1] - (headgen._EYE_C[1] - headgen._EYE_R)) < 0.0015
    # The nose tip is the most forward point; the lips are the most forward points of
    # the mouth on the midline, above and below the mouth line.
    assert lm["nose_tip"][1] <= head["positions"][:, 1].min() + 1e-6
    p = head["positions"].astype(np.float64)
    near = (np.abs(p[:, 0]) < 0.002) & (p[:, 1] < -0.09)
    mouth = p[near & (p[:, 2] > 0.036) & (p[:, 2] < 0.060)]
    upper = mouth[mouth[:, 2] > 0.0475]
    lower = mouth[mouth[:, 2] < 0.0475]
    assert lm["upper_lip"][1] < upper[:, 1].min() + 0.0015
    assert lm["lower_lip"][1] < lower[:, 1].min() + 0.0015
    # The mouth corner is where the lips meet at the side: the surface there is
    # recessed from the lips by several millimetres.
    assert lm["mouth_corner_L"][1] > lm["upper_lip"][1] + 0.006
    # The chin in front of the mentolabial sulcus.
    assert lm["chin"][1] < _profile_y(0.033) - 0.001


def _depth_curvature(a, b, n=33):
    """Second derivative (1/m) of the front surface's depth along the segment a-b
    in (x, z), seen from the front: > 0 where it is convex, < 0 in a crease."""
    t = np.linspace(0.0, 1.0, n)[:, None]
    xz = np.asarray(a, float) + t * (np.asarray(b, float) - np.asarray(a, float))
    starts = np.column_stack([xz[:, 0], np.full(n, -0.3), xz[:, 1]])
    y = headgen._project(starts, np.tile([0.0, 1.0, 0.0], (n, 1)), headgen.head_field)[:, 1]
    ds = np.hypot(*(np.asarray(b, float) - np.asarray(a, float))) / (n - 1)
    return np.diff(y, 2) / ds ** 2


def test_head_nose_has_nostrils():
    """Under the tip, either side of the columella, the nostrils sink into the nose:
    behind both the columella and the alae."""
    columella, nostril, ala = (_profile_y(0.0725, x) for x in (0.0, 0.0075, 0.015))
    assert nostril > columella + 0.002
    assert nostril > ala + 0.0015


def test_head_mouth_corners_tuck_in(head):
    """The lips wrap round the teeth: the corners sit well behind the middle of the
    lips (a flat mouth reads as a slit at three-quarter view), the lips stand proud of
    the skin above and below them."""
    lm = head["landmarks"]
    corner = _profile_y(lm["mouth_corner_L"][2], lm["mouth_corner_L"][0])
    upper = _profile_y(lm["upper_lip"][2])
    assert corner > upper + 0.015
    assert _profile_y(lm["lower_lip"][2]) < _profile_y(0.033) - 0.006


def test_head_folds_are_soft():
    """The nasolabial folds are soft: across them the surface bends with a radius
    of several millimetres, not a crease. The cheek turns into the side of the jaw
    gently, so no shading line runs from the mouth to the jaw."""
    a, b = np.array([0.0205, 0.0720]), np.array([0.0330, 0.0400])  # the fold's line
    d = b - a
    normal = np.array([d[1], -d[0]]) / np.hypot(*d)
    for t in (0.2, 0.35, 0.5):
        c = a + t * d
        assert _depth_curvature(c - 0.006 * normal, c + 0.006 * normal).min() > -250, t
    for z in (0.030, 0.035, 0.040):
        assert _depth_curvature((0.028, z), (0.050, z)).max() < 300, z


def test_head_glabella_over_the_nasion(head):
    """The glabella is the most prominent point of the brow on the midline, with the
    nasion's dip below it: the profile's most forward point above the nasion, standing
    out of it by a couple of millimetres (a flat brow puts it wherever the forehead
    happens to lean furthest forward)."""
    lm = head["landmarks"]
    g = lm["glabella"].astype(np.float64)
    zs = np.arange(0.110, 0.160, 0.001)
    y = headgen._front_profile(headgen.head_field, 0.0, zs)
    eyes = (zs > lm["eye_L"][2] - 0.006) & (zs < g[2])
    nasion_z, nasion_y = zs[eyes][np.argmax(y[eyes])], y[eyes].max()
    assert lm["eye_L"][2] < nasion_z < g[2] - 0.006  # a centimetre below the glabella
    assert g[1] < nasion_y - 0.002
    above = (zs > nasion_z) & (zs < nasion_z + 0.03)
    assert abs(zs[above][np.argmin(y[above])] - g[2]) < 0.0015
    # The forehead leans back from there, and the hairline is where it turns into the crown.
    hair = lm["hairline_center"].astype(np.float64)
    assert 0.05 < hair[2] - g[2] < 0.07
    y0, y1 = headgen._front_profile(headgen.head_field, 0.0, np.array([hair[2] - 0.001, hair[2] + 0.001]))
    assert 30.0 < np.degrees(np.arctan((y1 - y0) / 0.002)) < 50.0


def test_head_neck_and_ears_are_adult_sized(head):
    """The neck is 11-12.5 cm wide under the jaw (three quarters of the skull's
    breadth), spreading toward the shoulders; the ears are 5.5-7 cm tall and stand out
    of the side of the head by more than a centimetre and a half at the helix."""
    p = head["positions"].astype(np.float64)
    neck = [np.ptp(p[np.abs(p[:, 2] - z) < 0.003, 0]) for z in (-0.03, -0.02, -0.01)]
    assert 0.11 < min(neck) < 0.125
    skull = p[np.abs(p[:, 2] - 0.15) < 0.003]
    assert 0.7 < min(neck) / np.ptp(skull[:, 0]) < 0.85
    assert np.ptp(p[np.abs(p[:, 2] - headgen._NECK_CUT - 0.004) < 0.003, 0]) > min(neck) + 0.01
    side = p[(np.abs(p[:, 0]) > 0.08) & (p[:, 1] > -0.01) & (p[:, 1] < 0.05)]
    assert 0.055 < np.ptp(side[:, 2]) < 0.07  # only the ear reaches out there
    skull_side = np.abs(p[(np.abs(p[:, 2] - 0.15) < 0.003) & (np.abs(p[:, 1] - 0.02) < 0.005), 0]).max()
    assert np.abs(side[:, 0]).max() > skull_side + 0.015


def test_head_quads_are_even_where_the_rays_graze(head):
    """Under the nose and round the ears the rays from ORIGIN meet the surface at a
    glancing angle; the vertices are slid over the surface there, so those quads are as
    even as the rest of the face (no long slivers) and stay on the surface."""
    p = head["positions"].astype(np.float64)
    q = head["quads"]
    e = np.stack([np.linalg.norm(p[q[:, (i + 1) % 4]] - p[q[:, i]], axis=1) for i in range(4)], 1)
    aspect = e.max(axis=1) / e.min(axis=1)
    c = p[q].mean(axis=1)
    face = (c[:, 1] < -0.05) & (np.abs(c[:, 0]) < 0.05)
    nose_base = (np.abs(c[:, 0]) < 0.02) & (c[:, 2] > 0.06) & (c[:, 2] < 0.085) & (c[:, 1] < -0.09)
    ears = ((np.abs(c[:, 0]) > 0.06) & (c[:, 1] > -0.01) & (c[:, 1] < 0.05)
            & (c[:, 2] > 0.06) & (c[:, 2] < 0.14))
    assert aspect[face].max() < 4.0 and aspect[nose_base].max() < 4.0
    assert np.percentile(aspect[ears], 95) < 4.5 and aspect[ears].max() < 8.0
    assert e[nose_base].max() < 0.006
    assert np.abs(headgen.head_field(p[::7], detail=0.00096)).max() < 2e-4  # on the surface


def test_head_nasolabial_fold_lies_on_the_cheek_fat():
    """Across the upper nasolabial fold (from beside the ala down toward the mouth
    corner) the surface is most concave on the fold's line, and convex on the cheek
    side of it, where the cheek's fat bulges."""
    a, b = np.array([0.0195, 0.0750]), np.array([0.0335, 0.0395])  # the fold's line
    d = b - a
    lateral = -np.array([d[1], -d[0]]) / np.hypot(*d)  # toward the cheek
    s = np.linspace(-0.008, 0.012, 41)[1:-1]  # across the fold, as _depth_curvature samples it
    for t in (0.3, 0.5):
        c = a + t * d
        k = _depth_curvature(c - 0.008 * lateral, c + 0.012 * lateral, n=41)
        assert abs(s[np.argmin(k)]) < 0.004, t
        assert k[(s > 0.004) & (s < 0.010)].max() > 40.0, t


def test_make_head_is_quick():
    """make_head(40000) in well under the two seconds the demos can wait (CPU time, so
    a busy machine does not fail it)."""
    import time

    start = time.process_time()
    headgen.make_head(40000)
    assert time.process_time() - start < 6.0
