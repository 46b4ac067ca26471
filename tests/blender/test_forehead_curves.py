"""The forehead-lines sample scene (sample_scenes/forehead_curves.py): wrinkle curves (Bando et
al. 2002, §6-7) on the scanned ICT head, placed from its landmarks and raised by its brow
shape keys.  Nothing is rendered.

The scene is built once for the module (about 6 s): the per-test reset is replaced by a
no-op here, and each test sets the frame it looks at.
"""

import addon_utils
import bpy
import numpy as np
import pytest

from sample_scenes import forehead_curves
from tests.blender import conftest as harness
from tests.blender import scenes

pytestmark = pytest.mark.skipif(not forehead_curves.available(),
                                reason=f"{forehead_curves.DATA} not found")

MM = 1e-3


@pytest.fixture(autouse=True)
def factory_reset():
    """Overrides conftest's per-test reset: the tests share the module's scene."""
    yield


@pytest.fixture(scope="module")
def built(wrinkle_addon_enabled):
    from sample_scenes.lib import ict

    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    if not addon_utils.check(harness.ADDON)[1]:  # what conftest's reset does: a test disabled it
        harness.enable_addon()
    face, shots = forehead_curves.build()
    me = face.data
    rest = np.empty((len(me.vertices), 3), np.float32)
    me.attributes["position"].data.foreach_get("vector", rest.ravel())
    normals = np.empty((len(me.vertices), 3), np.float32)
    me.vertex_normals.foreach_get("vector", normals.ravel())
    lm = {k: np.asarray(v, np.float64) for k, v in ict.load_ict(forehead_curves.DATA)["landmarks"].items()}
    yield {"face": face, "shots": shots, "rest": rest.astype(np.float64), "normals": normals, "lm": lm}
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)


def _curves(face):
    return [ref.object for ref in face.ewrinkles_face.wrinkle_curves.items]


def _samples(face):
    """Each curve sampled densely in the face's space, lowest curve first."""
    from wrinkle_addon.glue import curve_objects

    out = [np.concatenate(curve_objects.face_space_samples(ob, face)) for ob in _curves(face)]
    return sorted(out, key=lambda p: p[:, 2].mean())


def _heights(b, frame):
    """The wrinkle heights (N,) along the rest normals on ``frame``."""
    bpy.context.scene.frame_set(frame)
    off = scenes.offsets(b["face"]).astype(np.float64)
    return (off * b["normals"]).sum(axis=1)


def _column(b, x0, half=0.0008):
    """The front vertices within ``half`` of x = x0, between the eyes and the hairline,
    sorted bottom to top."""
    rest, lm = b["rest"], b["lm"]
    sel = np.flatnonzero((np.abs(rest[:, 0] - x0) < half) & (rest[:, 1] < lm["glabella"][1] + 0.03)
                         & (rest[:, 2] > lm["eye_L"][2]) & (rest[:, 2] < lm["hairline_center"][2]))
    return sel[np.argsort(rest[sel, 2])]


def _z_at(samples, x0):
    order = np.argsort(samples[:, 0])
    return float(np.interp(x0, samples[order, 0], samples[order, 2]))


def test_forehead_lines_are_curves_placed_from_the_landmarks(built):
    from wrinkle_addon.glue import status

    face, lm, rest = built["face"], built["lm"], built["rest"]
    obs = _curves(face)
    assert 3 <= len(obs) <= 4 and face.ewrinkles_face.enabled
    for ob in obs:
        p = ob.ewrinkles_curve
        assert p.is_curve and p.enabled and ob.parent == face
        assert p.rest_height == 0.0  # nothing at neutral, as the paper's faces
        assert 1 * MM <= p.depth <= 4 * MM and 2 * MM <= p.width <= 3 * MM
    assert status.get(face, "curves") == ""
    mid, brow, hair = lm["glabella"][0], lm["glabella"][2], lm["hairline_center"][2]
    outer = abs(lm["brow_outer_L"][0] - mid)
    lines = _samples(face)
    for pts in lines:
        # above the brows, below the hairline, not into the temples
        assert pts[:, 2].min() > brow + 3 * MM and pts[:, 2].max() < hair - 8 * MM
        span = pts[:, 0].max() - pts[:, 0].min()
        assert 1.2 * outer < span < 2.0 * outer
        assert abs(0.5 * (pts[:, 0].max() + pts[:, 0].min()) - mid) < 2 * MM  # centred
        # a gentle arch: the ends lower than the middle, never steep
        z_mid = _z_at(pts, mid)
        assert pts[0, 2] < z_mid and pts[-1, 2] < z_mid and np.ptp(pts[:, 2]) < 15 * MM
    for ob in obs:  # the Bézier points lie on the skin (snapped): within an edge of a vertex
        bp = np.array([tuple(p.co) for p in ob.data.splines[0].bezier_points])
        assert np.linalg.norm(rest[:, None, :] - bp[None], axis=2).min(axis=0).max() < 3 * MM
    gaps = np.diff([_z_at(pts, mid) for pts in lines])
    assert np.all((gaps > 8 * MM - 1e-4) & (gaps < 12 * MM))  # real forehead lines: 8-12 mm apart


def test_nothing_at_neutral(built):
    h = _heights(built, built["shots"]["Neutral"])
    assert np.abs(h).max() < 1e-3 * MM  # r = 0: below a micrometre (float32 shrinkage noise)


def test_the_brow_raise_cuts_a_furrow_under_each_line_with_bulges_beside(built):
    b, lm = built, built["lm"]
    h = _heights(b, b["shots"]["Brow raise"])
    rest = b["rest"]
    lines = _samples(b["face"])
    mid = lm["glabella"][0]
    for x0 in (mid - 0.015, mid, mid + 0.015):
        col = _column(b, x0)
        z, hc = rest[col, 2], h[col]
        zs = [_z_at(pts, x0) for pts in lines]
        for k, zc in enumerate(zs):
            near = np.abs(z - zc) < 1.5 * MM
            around = np.abs(z - zc) < 4 * MM
            assert near.any()
            # the furrow: a few tenths of a millimetre deep, and the lowest point is on the line
            assert hc[near].min() < -0.15 * MM, (x0, k, hc[near].min())
            assert hc[near].min() == hc[around].min()
        for lo, hi in zip([zs[0] - 9 * MM] + zs, zs + [zs[-1] + 9 * MM]):
            between = (z > lo + 2 * MM) & (z < hi - 2 * MM)
            assert hc[between].max() > 0.02 * MM, (x0, lo, hi)  # the round bulges
    # the furrows are the curves': along each line the shrinkage across it raised all of it
    # (the middle of every line cut), and away from the lines nothing moved
    far = np.ones(len(rest), bool)
    for pts in lines:
        d = np.linalg.norm(rest[:, None, :] - pts[None, ::2], axis=2).min(axis=1)
        far &= d > 10 * forehead_curves.WIDTH + 2 * MM
    assert np.abs(h[far]).max() < 1e-3 * MM


def test_nothing_on_the_eyelids_or_below_the_brows(built):
    b, lm, rest = built, built["lm"], built["rest"]
    h = _heights(b, b["shots"]["Brow raise"])
    assert h.min() < -0.2 * MM  # the frame does have wrinkles
    for side in ("L", "R"):
        eye = lm[f"eye_{side}"]
        lids = ((np.abs(rest[:, 0] - eye[0]) < 0.016) & (rest[:, 2] > eye[2] - 0.010)
                & (rest[:, 2] < eye[2] + 0.008) & (rest[:, 1] < eye[1] + 0.02))
        assert lids.sum() > 50
        assert np.abs(h[lids]).max() < 1e-3 * MM
    below = (rest[:, 2] < min(lm["brow_inner_L"][2], lm["brow_outer_L"][2]) - 6 * MM) & (rest[:, 1] < 0.0)
    assert np.abs(h[below]).max() < 5e-3 * MM
