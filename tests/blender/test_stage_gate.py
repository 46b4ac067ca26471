"""Without the add-on, a file renders the wrinkles of the frame it was saved on, and no
wrinkles on any other frame, never another frame's (stale) wrinkles."""

import addon_utils
import bpy
import numpy as np

from tests.blender import scenes
from tests.blender.conftest import ADDON


def _read(me, name):
    out = np.empty((len(me.vertices), 3), np.float32)
    me.attributes[name].data.foreach_get("vector", out.ravel())
    return out


def _shown(face):
    """(evaluated positions, the skin under them) now."""
    ev = face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    return _read(ev, "position"), _read(ev, "wrinkle_skin")


def test_without_the_addon_only_the_saved_frame_has_wrinkles(tmp_path):
    scene = bpy.context.scene
    face, muscle = scenes.wrinkled_face()
    scenes.animate_shape_key(face, [(1, 0.0), (5, 1.0)])
    for frame, value in ((1, 0.0), (5, 1.0)):
        muscle.ewrinkles_muscle.contraction = value
        muscle.keyframe_insert("ewrinkles_muscle.contraction", frame=frame)
    scene.frame_set(3)
    pos3, skin3 = _shown(face)
    assert np.abs(pos3 - skin3).max() > 1e-4  # wrinkled on frame 3
    path = tmp_path / "shot.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))

    addon_utils.disable(ADDON, default_set=True)
    try:
        bpy.ops.wm.open_mainfile(filepath=str(path))
        face = bpy.data.objects["Face"]
        assert not any("wrinkle" in getattr(h, "__module__", "") for h in bpy.app.handlers.frame_change_post)
        scene = bpy.context.scene
        scene.frame_set(5)
        pos5, skin5 = _shown(face)
        np.testing.assert_array_equal(pos5, skin5)  # no wrinkles: not frame 3's on frame 5's skin
        scene.frame_set(3)
        pos, skin = _shown(face)
        np.testing.assert_allclose(pos, pos3, atol=1e-7)  # the saved frame keeps its wrinkles
    finally:
        bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
        addon_utils.enable(ADDON, default_set=True)
