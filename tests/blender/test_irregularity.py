"""The face's Irregularity and Seed reach the muscles' static plan: the default makes the
furrows irregular, 0 gives Zhang's regular ones back exactly, the pattern is the face's own
(from its name when it is set up, and kept when it is renamed), and a file saved before the
setting existed keeps the regular wrinkles it was saved with."""

import bpy
import numpy as np
import pytest

from tests.blender import scenes
from tests.blender.test_ui_contract import _Layout
from wrinkle_addon.core.muscles import irregularity
from wrinkle_addon.glue.muscles import muscle_objects
from wrinkle_addon.ui import muscles as muscles_ui

# make_face's columns on one side of the midline: the depth and the long waves of the course
# are mirrored across it (both sides alike), so they change slowly right beside it
_X = np.linspace(-scenes.WIDTH / 2, scenes.WIDTH / 2, 70)
CENTRAL = (_X > 0.005) & (_X < 0.045)


def _heights(face, frame=4):
    """The offsets across the patch (its normal is -Y) as a (rows, columns) image."""
    bpy.context.scene.frame_set(frame)
    return scenes.offsets(face)[:, 1].reshape(40, 70).astype(np.float64)


def _column_likeness(h):
    """The smallest correlation between the wrinkled part of a central column and the
    middle one: 1 when every column has the same furrows (scaled by the attenuation)."""
    rows = np.abs(h).max(axis=1) > 1e-6
    cols = h[rows][:, CENTRAL]
    mid = cols[:, cols.shape[1] // 2]
    return min(np.corrcoef(mid, cols[:, j])[0, 1] for j in range(cols.shape[1]))


def _face():
    face, muscle = scenes.wrinkled_face()
    scenes.animate_shape_key(face, [(1, 0.0), (5, 1.0)])
    return face, muscle


def test_a_new_face_gets_the_natural_default_and_a_seed_of_its_own():
    face, muscle = _face()
    s = face.ewrinkles_face
    assert s.irregularity == pytest.approx(irregularity.DEFAULT) and s.is_property_set("irregularity")
    assert s.seed == muscle_objects.name_seed("Face") != 0
    assert muscle.ewrinkles_muscle.irregularity == 1.0
    core = muscle_objects.to_core(muscle, face)
    assert core.irregularity == pytest.approx(irregularity.DEFAULT) and core.seed == s.seed
    s.irregularity, muscle.ewrinkles_muscle.irregularity = 1.5, 0.5
    assert muscle_objects.to_core(muscle, face).irregularity == pytest.approx(0.75)  # face x muscle


def test_the_face_setting_reaches_the_plan_and_zero_gives_regular_furrows():
    face, muscle = _face()
    irregular = _heights(face)
    assert np.abs(irregular).max() > 1e-4
    assert _column_likeness(irregular) < 0.9  # the furrows change from column to column
    face.ewrinkles_face.irregularity = 0.0  # the static plan is rebuilt on the next frame
    regular = _heights(face)
    assert _column_likeness(regular) > 0.9999  # every column has the same furrows
    assert np.abs(regular - irregular).max() > 1e-4
    face.ewrinkles_face.irregularity = irregularity.DEFAULT
    np.testing.assert_array_equal(_heights(face), irregular)  # back to the same, to the bit
    muscle.ewrinkles_muscle.irregularity = 0.0  # the muscle's factor: regular too
    np.testing.assert_allclose(_heights(face), regular, atol=1e-9)
    muscle.ewrinkles_muscle.irregularity = 1.0
    face.ewrinkles_face.seed += 1  # another pattern
    other = _heights(face)
    assert np.abs(other - irregular).max() > 1e-4 and _column_likeness(other) < 0.99


def test_the_pattern_is_the_faces_own_and_survives_renaming():
    face, _muscle = _face()
    before = _heights(face)
    face.name = "Renamed"
    bpy.context.scene.frame_set(2)
    np.testing.assert_array_equal(_heights(face), before)  # the stored seed, not the name
    second = scenes.make_face("Second")
    bpy.ops.wrinkle.enable()
    scenes.add_sheet(second)
    scenes.animate_shape_key(second, [(1, 0.0), (5, 1.0)])
    assert second.ewrinkles_face.seed != face.ewrinkles_face.seed
    assert np.abs(_heights(second) - before).max() > 1e-4  # the same face, another pattern


def test_an_old_file_keeps_its_regular_wrinkles(tmp_path):
    face, _muscle = _face()
    face.ewrinkles_face.irregularity = 0.0
    regular = _heights(face)
    face.ewrinkles_face.property_unset("irregularity")  # as a file saved before the setting existed
    new = scenes.make_face("New")
    bpy.ops.wrinkle.enable()
    scenes.add_sheet(new)
    path = tmp_path / "old.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    bpy.ops.wm.open_mainfile(filepath=str(path))
    face, new = bpy.data.objects["Face"], bpy.data.objects["New"]
    assert face.ewrinkles_face.irregularity == 0.0
    assert new.ewrinkles_face.irregularity == pytest.approx(irregularity.DEFAULT)  # a stored value is kept
    bpy.context.scene.frame_set(2)
    np.testing.assert_allclose(_heights(face), regular, atol=1e-9)


def test_the_panels_show_the_settings():
    face, muscle = _face()
    layout = _Layout()
    muscles_ui.draw_face_muscles(layout, bpy.context, face)
    assert {"irregularity", "seed"} <= set(layout.drawn)
    bpy.context.view_layer.objects.active = muscle
    panel = type("Panel", (), {"layout": _Layout()})()
    muscles_ui.VIEW3D_PT_wrinkle_muscle.draw(panel, bpy.context)
    assert "irregularity" in panel.layout.drawn


def test_a_version_0_2_file_opens_with_regular_wrinkles(tmp_path):
    from tests.blender.test_migration import V02

    path = tmp_path / "v02.blend"
    path.write_bytes(V02.read_bytes())
    bpy.ops.wm.open_mainfile(filepath=str(path))
    s = bpy.data.objects["Face"].ewrinkles_face
    assert s.irregularity == 0.0 and s.is_property_set("irregularity")
    assert muscle_objects.to_core(s.muscles[0].object, bpy.data.objects["Face"]).irregularity == 0.0
