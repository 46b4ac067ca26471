"""A file saved by version 0.2 opens with everything kept.

``data/wrinkles_v0_2.blend`` was written by version 0.2 itself (``data/make_v0_2_blend.py``
run against that version): it stored ``Object.wrinkles`` and ``Object.wrinkle_muscle``,
keyed a contraction, drove another from a shape key and bound a wrinkle-map expression
to a muscle, all through the old names.  It was saved on frame 3, so its mesh holds the
offsets version 0.2 computed for frame 3.
"""

from pathlib import Path

import bpy
import numpy as np
import pytest

from tests.blender import scenes
from wrinkle_addon.glue.maps import nodegroups
from wrinkle_addon.props import migrate

V02 = Path(__file__).with_name("data") / "wrinkles_v0_2.blend"


def _open_v02(tmp_path):
    path = tmp_path / "old.blend"
    path.write_bytes(V02.read_bytes())
    bpy.ops.wm.open_mainfile(filepath=str(path))
    return bpy.data.objects["Face"]


def test_settings_muscles_and_table_are_kept(tmp_path):
    face = _open_v02(tmp_path)
    for ob in bpy.data.objects:
        assert "wrinkles" not in ob.keys() and "wrinkle_muscle" not in ob.keys(), ob.name
    s = face.ewrinkles_face
    assert s.enabled and s.strength == pytest.approx(1.25)
    names = [r.object.name for r in s.muscles]
    assert names == ["Frontalis", "Corrugator"]
    sheet, linear = (bpy.data.objects[n] for n in names)
    assert sheet.ewrinkles_muscle.is_muscle and sheet.ewrinkles_muscle.kind == "SHEET"
    assert sheet.ewrinkles_muscle.lambda_w == pytest.approx(0.35) and sheet.ewrinkles_muscle.n_wrinkles == 5
    assert linear.ewrinkles_muscle.kind == "LINEAR" and linear.ewrinkles_muscle.wrinkles_only
    assert (linear.ewrinkles_muscle.role, linear.ewrinkles_muscle.side) == ("CORRUGATOR", "L")
    maps = s.maps
    assert maps.tension_gain == pytest.approx(7.0) and maps.strength == pytest.approx(0.9)
    assert [ex.name for ex in maps.expressions] == ["Raise", "Brows"]
    assert maps.expressions[0].source == "MUSCLE" and maps.expressions[0].muscle == sheet
    assert maps.expressions[1].shape_key == "BrowsUp"
    assert list(maps.expressions[1].weights) == pytest.approx([0, 0, 0, 0, 0.5, 0.5, 0, 0])
    assert maps.material is not None and maps.weights_group is not None


def test_animation_and_drivers_follow_the_new_names(tmp_path):
    face = _open_v02(tmp_path)
    scene = bpy.context.scene
    sheet, linear = bpy.data.objects["Frontalis"], bpy.data.objects["Corrugator"]
    drivers = [fc for ob in (sheet, linear) if ob.animation_data for fc in ob.animation_data.drivers]
    assert [fc.data_path for fc in drivers] == ["ewrinkles_muscle.contraction"]
    assert drivers[0].driver.is_valid
    ng = face.ewrinkles_face.maps.weights_group
    paths = [t.data_path for fc in ng.animation_data.drivers for v in fc.driver.variables for t in v.targets]
    assert "ewrinkles_muscle.contraction" in paths and not any(p.startswith("wrinkle_muscle") for p in paths)
    assert all(fc.driver.is_valid for fc in ng.animation_data.drivers)
    for frame, want in ((1, 0.0), (5, 1.0)):
        scene.frame_set(frame)
        assert sheet.ewrinkles_muscle.contraction == pytest.approx(want)  # the keyframes
        assert linear.ewrinkles_muscle.contraction == pytest.approx(0.8 * want)  # the driver
        node = ng.nodes[nodegroups.expr_node(0)]
        assert node.outputs[0].default_value == pytest.approx(want)  # the map row's driver


def test_the_wrinkles_are_those_version_0_2_computed(tmp_path):
    """The model has been refined since version 0.2 (C¹ fall-offs, A(eps) smoothed over half
    a cycle), so the offsets are no longer equal to the bit; with every setting carried
    over they are still the same wrinkles and the same pull (a lost or renamed setting
    moves or rescales them far beyond these bounds)."""
    face = _open_v02(tmp_path)
    saved = scenes.stored_offsets(face).copy()  # frame 3, written by version 0.2
    assert np.abs(saved).max() > 1e-4
    bpy.context.scene.frame_set(5)
    assert np.abs(scenes.offsets(face) - saved).max() > 1e-4  # the wrinkles are live
    bpy.context.scene.frame_set(3)
    now = scenes.offsets(face)
    assert np.corrcoef(now.ravel(), saved.ravel())[0, 1] > 0.95
    assert np.abs(now).max() == pytest.approx(np.abs(saved).max(), rel=0.05)


def test_migration_is_idempotent_and_leaves_new_files_alone(tmp_path):
    _open_v02(tmp_path)
    assert migrate.migrate() == 0
    face = scenes.make_face()
    face.ewrinkles_face.strength = 2.0
    assert migrate.migrate() == 0 and face.ewrinkles_face.strength == 2.0


def test_crafted_old_values_do_not_stop_the_migration(tmp_path):
    face = _open_v02(tmp_path)
    odd = scenes.make_face("Odd", shape_key=False)
    odd["wrinkles"] = 5  # not a group: dropped, and the other objects still migrate
    odd["wrinkle_muscle"] = "text"
    face["wrinkles"] = {"strength": 0.5}
    face.ewrinkles_face.strength = 2.0  # already migrated: the new value wins
    assert migrate.migrate() == 3
    assert "wrinkles" not in odd.keys() and "wrinkle_muscle" not in odd.keys()
    assert face.ewrinkles_face.strength == 2.0
