"""Skin Age on a face in Blender: the neutral default leaves every method as published (and
files saved before the setting look as they did); it reaches the muscles' plan (deeper
furrows when old, shallower when young) and the fine wrinkles' node inputs (their rest
height and depth, so a farm renders them with no add-on); the sample head starts young;
the setting survives saving and reopening."""

import bpy
import numpy as np
import pytest

from tests.blender import scenes
from tests.blender.test_curves import uv_face
from tests.blender.test_ui_contract import _Layout
from wrinkle_addon.core import skin_age
from wrinkle_addon.glue.bando import fine as fine_glue
from wrinkle_addon.glue.muscles import muscle_objects
from wrinkle_addon.ui import bando as bando_ui
from wrinkle_addon.ui import panels


def _heights(face, frame=4):
    bpy.context.scene.frame_set(frame)
    return scenes.offsets(face)[:, 1].astype(np.float64)


def _face():
    face, muscle = scenes.wrinkled_face()
    scenes.animate_shape_key(face, [(1, 0.0), (5, 1.0)])
    return face, muscle


def test_the_default_is_neutral_and_the_core_muscle_scales_with_age():
    face, muscle = _face()
    s = face.ewrinkles_face
    assert s.skin_age == skin_age.NEUTRAL
    neutral = muscle_objects.to_core(muscle, face)
    assert neutral.k0 == pytest.approx(muscle.ewrinkles_muscle.k0 / muscle_objects.face_scale(face))
    s.skin_age = 1.0
    old = muscle_objects.to_core(muscle, face)
    assert old.k0 == pytest.approx(1.4 * neutral.k0)
    assert old.irregularity == pytest.approx(1.5 * neutral.irregularity)
    s.skin_age = 0.0
    young = muscle_objects.to_core(muscle, face)
    assert young.k0 == pytest.approx(0.6 * neutral.k0)
    assert young.irregularity == pytest.approx(0.5 * neutral.irregularity)


def test_old_skin_folds_deeper_than_young_and_neutral_is_unchanged_to_the_bit():
    face, _muscle = _face()
    neutral = _heights(face)
    assert np.abs(neutral).max() > 1e-4
    face.ewrinkles_face.skin_age = 1.0  # the static plan is rebuilt on the next frame
    old = _heights(face)
    face.ewrinkles_face.skin_age = 0.0
    young = _heights(face)
    depth = [float(np.abs(h).max()) for h in (young, neutral, old)]
    assert depth[0] < depth[1] < depth[2]
    assert depth[2] > 1.6 * depth[0]
    face.ewrinkles_face.skin_age = skin_age.NEUTRAL
    np.testing.assert_array_equal(_heights(face), neutral)


def test_the_fine_wrinkles_node_reads_the_aged_rest_height_and_depth(tmp_blend):
    face = uv_face()
    fs = face.ewrinkles_face.fine_wrinkles
    fs.resolution = "512"
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.carve_fine() == {"FINISHED"}
    node = fs.material.node_tree.nodes[fine_glue.GROUP_NODE]

    def inputs():
        return node.inputs["Rest Height"].default_value, node.inputs["Distance"].default_value

    assert inputs() == pytest.approx((fs.rest_height, fs.distance))  # neutral: as published
    face.ewrinkles_face.skin_age = 0.0
    assert inputs() == pytest.approx((0.0, 0.6 * fs.distance))  # young: no fine crackle at rest
    face.ewrinkles_face.skin_age = 1.0
    assert inputs() == pytest.approx((1.0, 1.4 * fs.distance))
    face.ewrinkles_face.skin_age = 0.25
    fs.rest_height = 0.4  # the face's own r, aged
    assert inputs() == pytest.approx((0.2, 0.8 * fs.distance))
    layout = _Layout()
    bando_ui.draw_face_fine(layout, bpy.context, face)  # the panel's note on the aged values
    assert "rest_height" in layout.drawn
    path = str(tmp_blend("aged"))
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    face = bpy.data.objects["Face"]
    assert face.ewrinkles_face.skin_age == pytest.approx(0.25)
    node = face.ewrinkles_face.fine_wrinkles.material.node_tree.nodes[fine_glue.GROUP_NODE]
    assert node.inputs["Rest Height"].default_value == pytest.approx(0.2)


def test_the_sample_head_starts_young_and_the_panel_shows_the_setting():
    assert bpy.ops.wrinkle.add_sample_head(parts=False) == {"FINISHED"}
    skin = bpy.context.active_object
    assert skin.ewrinkles_face.skin_age == pytest.approx(skin_age.YOUNG)
    layout = _Layout()
    panels.VIEW3D_PT_wrinkle_face.draw(type("P", (), {"layout": layout})(), bpy.context)
    assert "skin_age" in layout.drawn
