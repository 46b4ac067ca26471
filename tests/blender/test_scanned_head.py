"""The scanned ICT head (the add-on's sample head): wrinkles from measured compression alone.
"""

from pathlib import Path

import bpy
import numpy as np
import pytest

from tests.blender import scenes

DATA = Path(__file__).resolve().parents[2] / "wrinkle_addon" / "data" / "ict_head.npz"

BROWS_UP = ("browInnerUp_L", "browInnerUp_R", "browOuterUp_L", "browOuterUp_R")


@pytest.fixture
def ict_face():
    from sample_scenes.lib import ict, rigging

    data = ict.load_ict(DATA)
    face = ict.ict_object(data, name="ICTHead")
    rigging.wrinkle_face(face, data["landmarks"], wrinkles_only=True, refine=True)
    return face, data["landmarks"]


def _heights(face):
    """Signed wrinkle height along the rest normal (the offset is purely normal here)."""
    me = face.data
    rest = np.empty((len(me.vertices), 3), np.float32)
    me.attributes["position"].data.foreach_get("vector", rest.ravel())
    off = scenes.offsets(face)
    return rest, -off[:, 1]  # the forehead looks toward -Y: outward is -Y


def test_brow_raise_wrinkles_the_forehead_from_compression_alone(ict_face):
    face, lm = ict_face
    scene = bpy.context.scene
    muscles = [r.object for r in face.ewrinkles_face.muscles]
    assert all(m.ewrinkles_muscle.wrinkles_only for m in muscles)
    assert all(m.ewrinkles_muscle.contraction == 0.0 for m in muscles)
    scene.frame_set(1)
    assert np.abs(scenes.offsets(face)).max() == 0.0  # neutral: nothing compressed
    keys = face.data.shape_keys.key_blocks
    for name in BROWS_UP:
        keys[name].value = 1.0
    scene.frame_set(2)
    rest, h = _heights(face)
    g, hair = lm["glabella"], lm["hairline_center"]
    forehead = ((rest[:, 2] > g[2] + 0.01) & (rest[:, 2] < hair[2]) & (np.abs(rest[:, 0] - g[0]) < 0.03)
                & (rest[:, 1] < g[1] + 0.02))
    assert forehead.sum() > 100
    assert np.abs(h[forehead]).max() > 5e-4  # furrows of half a millimetre or more
    # horizontal furrows: walking up the forehead the height changes sign repeatedly
    column = forehead & (np.abs(rest[:, 0] - g[0] - 0.012) < 0.002)
    order = np.argsort(rest[column, 2])
    profile = h[column][order]
    strong = profile[np.abs(profile) > 0.1 * np.abs(profile).max()]
    assert np.sum(np.sign(strong[1:]) != np.sign(strong[:-1])) >= 3  # two furrows or more
    # while a horizontal walk across the forehead stays in phase (few sign changes)
    z0 = rest[column][order][np.argmax(np.abs(profile)), 2]
    row = forehead & (np.abs(rest[:, 2] - z0) < 0.0015) & (np.abs(rest[:, 0] - g[0] - 0.012) < 0.006)
    across = h[row][np.argsort(rest[row, 0])]
    assert np.mean(np.sign(across) == np.sign(across[np.argmax(np.abs(across))])) > 0.7
    # and the lower face, which the brows do not compress, stays smooth
    lower = rest[:, 2] < lm["nose_tip"][2]
    assert np.abs(h[lower]).max() < 0.2 * np.abs(h[forehead]).max()


def test_brow_down_wrinkles_between_the_brows(ict_face):
    face, lm = ict_face
    keys = face.data.shape_keys.key_blocks
    keys["browDown_L"].value = keys["browDown_R"].value = 1.0
    bpy.context.scene.frame_set(3)
    rest, h = _heights(face)
    g = lm["glabella"]
    between = ((np.abs(rest[:, 2] - g[2]) < 0.01) & (np.abs(rest[:, 0] - g[0]) < 0.02)
               & (rest[:, 1] < g[1] + 0.01))
    assert np.abs(h[between]).max() > 2e-4


def test_a_squint_raises_crows_feet_from_the_rig_alone(ict_face):
    """eyeSquint + cheekSquint, no contraction keyed: the Orbicularis Oculi's furrows fan out
    from each outer eye corner, across the fibres that run round the eye; the lids stay smooth."""
    from wrinkle_addon.core import zones

    face, lm = ict_face
    keys = face.data.shape_keys.key_blocks
    for name in ("eyeSquint_L", "eyeSquint_R", "cheekSquint_L", "cheekSquint_R"):
        keys[name].value = 1.0
    bpy.context.scene.frame_set(4)
    me = face.data
    rest = np.empty((len(me.vertices), 3), np.float32)
    me.attributes["position"].data.foreach_get("vector", rest.ravel())
    off = scenes.offsets(face)
    h = np.linalg.norm(off, axis=1)  # wrinkles only: every offset is a height along the normal
    lids = zones.face_zones(rest, lm).eyelid
    assert h[lids].max() == 0.0
    g = lm["glabella"]
    e = 2.0 * abs(lm["eye_L"][0] - g[0])
    for s in (1.0, -1.0):
        eye = np.array([g[0] + s * (lm["eye_L"][0] - g[0]), lm["eye_L"][2]])
        dx, dz = s * (rest[:, 0] - eye[0]), rest[:, 2] - eye[1]
        rho = np.hypot(dx / (0.4 * e), dz / (0.33 * e))
        theta = np.degrees(np.arctan2(dz / (0.33 * e), dx / (0.4 * e)))
        front = rest[:, 1] < g[1] + 0.05
        corner = front & (rho > 0.75) & (rho < 1.4) & (np.abs(theta) < 45)
        assert h[corner].max() > 2e-4  # deeper than 0.2 mm
        # round the eye the height rises and falls: several furrows across the angle
        ring = corner & (np.abs(rho - 1.0) < 0.05)
        outward = rest[ring] - rest.mean(axis=0)  # the head's inside lies behind the skin
        signed = np.sign(np.einsum("ij,ij->i", off[ring], outward)) * h[ring]
        profile = signed[np.argsort(theta[ring])]
        strong = profile[np.abs(profile) > 0.2 * np.abs(profile).max()]
        assert np.sum(np.sign(strong[1:]) != np.sign(strong[:-1])) >= 4, s
