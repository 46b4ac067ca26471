"""The Frontalis preset moves the forehead as raised brows do (3D skin-displacement studies):
the lower forehead up, the upper forehead down, meeting on a horizontal line at 61 ± 10 % of
the forehead's height above the brows."""

import bpy
import numpy as np
import pytest

from sample_scenes.lib import headgen, rigging, scene_setup


@pytest.fixture(scope="module")
def head_data():
    return headgen.make_head(20000)


def _pull(face):
    """Each vertex's displacement by the pull alone (Strength 0: no wrinkle heights)."""
    ev = face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    n = len(face.data.vertices)
    pos = np.empty(n * 3, np.float32)
    ev.attributes["position"].data.foreach_get("vector", pos)
    rest = np.array([v.co for v in face.data.vertices])
    return rest, pos.reshape(-1, 3) - rest


@pytest.mark.parametrize("x", [0.0, 0.012, 0.03])
def test_surprise_converges_on_one_line(head_data, x):
    data = head_data
    face = scene_setup.mesh_object_from_arrays("Head", data["positions"], data["quads"], data["corner_uvs"])
    rigging.wrinkle_face(face, data["landmarks"], refine=False)
    rigging.key_expressions(face, {1: "NEUTRAL", 10: "SURPRISE"})
    face.ewrinkles_face.strength = 0.0
    bpy.context.scene.frame_set(9)
    bpy.context.scene.frame_set(10)
    rest, moved = _pull(face)
    lm = data["landmarks"]
    brow, hair = lm["brow_mid_L"][2], lm["hairline_center"][2]
    front = rest[:, 1] < lm["glabella"][1] + 0.03
    column = front & (np.abs(rest[:, 0] - x) < 0.003) & (rest[:, 2] > brow) & (rest[:, 2] < hair)
    z, dz = rest[column, 2], moved[column, 2]
    order = np.argsort(z)
    z, dz = z[order], dz[order]
    assert len(z) > 10
    fraction = (z - brow) / (hair - brow)
    assert dz[fraction < 0.3].min() > 0.5e-3  # the lower forehead and the brows move up
    upper = dz[fraction > 0.75]
    assert upper.max() <= 0.0 and upper.min() < -0.5e-3  # the upper forehead moves down
    crossing = np.flatnonzero((dz[:-1] > 0) & (dz[1:] <= 0))
    assert len(crossing) == 1, dz  # one line of convergence
    i = crossing[0]
    at = fraction[i] + (fraction[i + 1] - fraction[i]) * dz[i] / (dz[i] - dz[i + 1])
    assert 0.51 <= at <= 0.71, at
