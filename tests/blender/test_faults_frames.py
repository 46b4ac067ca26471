"""Regression tests: the frame stage's handlers, its attributes and one source's failure.

* Our attributes (``wrinkle_offset``, ``wrinkle_skin``, ``wrinkle_frame``) found with another
  type or domain in a file are replaced or reported, never an internal error every frame.
* A file saved on a frame whose wrinkles do not change from frame to frame (written in
  place since the last write-back) opens with the wrinkles of that frame, with the add-on
  and without it; so do the fine wrinkles' shrinkage attributes of a face without the stage.
* A muscle or wrinkle curve moved, rotated or scaled, then evaluated before the next frame
  change (``view_layer.update()`` in a script), is picked up by that frame change.
* ``render(animation=True)`` and Bake for Farm started on the current frame use the keyed
  contraction there, not a value typed over it since the last frame change.
* With time remapping (Frame Map Old/New) the tree applies the offsets on their frame.
* A source that raises (a wrinkle map whose UV map is gone, a broken source) reports its
  problem on its own channel; the other sources' wrinkles are still written.
"""

import json
import textwrap

import bpy
import numpy as np
import pytest

from tests.blender import mapscenes, scenes
from tests.blender.test_curves import add_curve, uv_face
from wrinkle_addon import sources
from wrinkle_addon.core import combine
from wrinkle_addon.glue import pipeline, stage, status
from wrinkle_addon.glue.bando import fine_tree
from wrinkle_addon.glue.errors import WrinkleError
from wrinkle_addon.glue.maps import map_material, nodegroups
from wrinkle_addon.glue.registry import WrinkleSource


def _skin(face):
    ev = face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    out = np.empty((len(ev.vertices), 3), np.float32)
    ev.attributes["wrinkle_skin"].data.foreach_get("vector", out.ravel())
    return out


def _animated_face(contraction=1.0):
    scene = bpy.context.scene
    face, muscle = scenes.wrinkled_face(contraction=contraction)
    scenes.animate_shape_key(face, [(1, 0.0), (4, 1.0)])
    scene.frame_start, scene.frame_end = 1, 4
    return scene, face, muscle


def _truth(face):
    """The positions a full evaluation from scratch gives on this frame (write-back)."""
    pipeline.forget(face)
    assert pipeline.update_face(face, bpy.context.evaluated_depsgraph_get())
    return scenes.evaluated_positions(face).copy()


# --- 5: our attributes with another type or domain ---------------------------------------

@pytest.mark.parametrize("name, data_type, domain", [
    ("wrinkle_offset", "FLOAT", "FACE"),
    ("wrinkle_offset", "FLOAT_VECTOR", "CORNER"),
    ("wrinkle_offset", "FLOAT_COLOR", "POINT"),
    ("wrinkle_frame", "FLOAT_VECTOR", "FACE"),
])
def test_our_attributes_of_another_type_in_a_file_are_replaced(name, data_type, domain, tmp_blend):
    scene, face, _muscle = _animated_face()
    scene.frame_set(2)
    me = face.data
    me.attributes.remove(me.attributes[name])
    me.attributes.new(name, data_type, domain)
    path = str(tmp_blend("crafted"))
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    scene, face = bpy.context.scene, bpy.data.objects["Face"]
    for f in (3, 2, 3):
        scene.frame_set(f)
        assert pipeline.status_of(face) == "", f"frame {f}"
    shown = scenes.evaluated_positions(face).copy()
    assert np.abs(shown - _skin(face)).max() > 1e-4, "no wrinkles"
    np.testing.assert_allclose(shown, _truth(face), atol=1e-6)
    att = face.data.attributes[name]
    assert (att.domain, att.data_type) == ("POINT", "FLOAT" if name == "wrinkle_frame" else "FLOAT_VECTOR")


def test_a_wrinkle_skin_of_another_type_reads_as_a_disabled_stage():
    """The modifier off: the evaluated mesh holds the original's ``wrinkle_skin``, here a float
    on the faces, which is not the stage's output."""
    scene, face, _muscle = _animated_face()
    face.data.attributes.new("wrinkle_skin", "FLOAT", "FACE")
    stage.find_modifier(face).show_viewport = False
    scene.frame_set(2)
    assert pipeline.status_of(face) == "The Wrinkles modifier is disabled or not evaluated"


# --- 6: a saved file holds the wrinkles of its frame --------------------------------------

NO_ADDON = textwrap.dedent("""
    import json, sys
    import bpy
    import numpy as np
    blend, out = sys.argv[-2], sys.argv[-1]
    bpy.ops.wm.open_mainfile(filepath=blend)
    assert "wrinkle_addon" not in sys.modules
    ev = bpy.data.objects["Face"].evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    got = {}
    for name in ("position", "wrinkle_skin"):
        co = np.empty(len(ev.vertices) * 3, np.float32)
        ev.attributes[name].data.foreach_get("vector", co)
        got[name] = co.tolist()
    got["frame"] = bpy.context.scene.frame_current
    json.dump(got, open(out + "/opened.json", "w"))
    bpy.ops.wm.read_factory_settings(use_empty=True)
""")


def test_a_file_saved_on_a_frame_of_unchanging_wrinkles_opens_with_them(tmp_path):
    """A constant contraction and nothing animated: every frame after the first is written
    in place, and the original mesh keeps the first frame's offsets and stamp."""
    scene = bpy.context.scene
    face, _muscle = scenes.wrinkled_face(contraction=1.0)
    for f in range(1, 6):
        scene.frame_set(f)
    want = scenes.evaluated_positions(face).copy()
    assert np.abs(want - _skin(face)).max() > 1e-4, "no wrinkles"
    assert face.data.attributes["wrinkle_frame"].data[0].value != 5.0, "frame 5 was not written in place"
    blend = tmp_path / "saved.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))

    scenes.run_on_farm(NO_ADDON, blend, tmp_path)
    opened = json.loads((tmp_path / "opened.json").read_text())
    assert opened["frame"] == 5
    np.testing.assert_allclose(np.array(opened["position"], np.float32).reshape(-1, 3), want, atol=1e-6,
                               err_msg="opened without the add-on")

    bpy.ops.wm.open_mainfile(filepath=str(blend))
    np.testing.assert_allclose(scenes.evaluated_positions(bpy.data.objects["Face"]), want, atol=1e-6,
                               err_msg="opened with the add-on")


FINE_NO_ADDON = textwrap.dedent("""
    import json, sys
    import bpy
    import numpy as np
    blend, out = sys.argv[-2], sys.argv[-1]
    bpy.ops.wm.open_mainfile(filepath=blend)
    assert "wrinkle_addon" not in sys.modules
    got = {}
    for f in (1, 3, 5):
        bpy.context.scene.frame_set(f)
        ev = bpy.data.objects["Face"].evaluated_get(bpy.context.evaluated_depsgraph_get()).data
        att = ev.attributes["ewrinkles_fine_shrinkage"]
        v = np.empty(len(att.data) * 2, np.float32)
        att.data.foreach_get("vector", v)
        got[f] = v.tolist()
    json.dump(got, open(out + "/opened.json", "w"))
    bpy.ops.wm.read_factory_settings(use_empty=True)
""")


def test_a_saved_file_holds_the_fine_wrinkles_of_every_frame(tmp_blend, tmp_path):
    """Fine wrinkles alone (no Enable Wrinkles): Blender computes their shrinkage itself, so
    the saved file shows that of every frame with no add-on, as the live face does."""
    scene = bpy.context.scene
    face = uv_face(enable=False)
    scenes.animate_shape_key(face, [(1, 0.0), (5, 1.0)])
    face.ewrinkles_face.fine_wrinkles.resolution = "512"
    assert bpy.ops.wrinkle.carve_fine() == {"FINISHED"}

    def corners():
        att = face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data.attributes[
            fine_tree.SHRINKAGE_ATTR]
        v = np.empty(len(att.data) * 2, np.float32)
        att.data.foreach_get("vector", v)
        return v

    live = {}
    for f in (1, 3, 5):
        scene.frame_set(f)
        live[f] = corners()
    assert live[5].max() > 0.1 and np.abs(live[1]).max() < 1e-4
    blend = tmp_blend("fine")
    scene.frame_set(3)
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    scenes.run_on_farm(FINE_NO_ADDON, blend, tmp_path)
    opened = json.loads((tmp_path / "opened.json").read_text())
    for f in (1, 3, 5):
        np.testing.assert_array_equal(np.array(opened[str(f)], np.float32), live[f], err_msg=f"frame {f}")


# --- 7: changes evaluated between frame changes -------------------------------------------

def _move(ob, how):
    if how == "location":
        ob.location.z += 0.004
    elif how == "rotation":
        ob.rotation_euler.y += np.radians(8)
    else:
        ob.scale = tuple(1.15 * s for s in ob.scale)


@pytest.mark.parametrize("how", ["location", "rotation", "scale"])
@pytest.mark.parametrize("what", ["muscle", "curve"])
def test_a_move_evaluated_before_the_next_frame_change_is_picked_up(what, how, tmp_path):
    scene = bpy.context.scene
    if what == "muscle":
        scene, face, ob = _animated_face()
    else:
        face = uv_face()
        ob = add_curve(face)
        scenes.animate_shape_key(face, [(1, 0.0), (4, 1.0)])
    for f in (1, 2):
        scene.frame_set(f)
    before = scenes.evaluated_positions(face).copy()
    _move(ob, how)
    bpy.context.view_layer.update()  # a script's evaluation: it consumes the move's update
    scene.frame_set(3)
    shown = scenes.evaluated_positions(face).copy()
    scene.frame_set(4)
    shown4 = scenes.evaluated_positions(face).copy()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "moved.blend"))
    saved = scenes.stored_offsets(face).copy()
    truth4 = _truth(face)
    np.testing.assert_allclose(shown4, truth4, atol=1e-6, err_msg="frame 4")
    np.testing.assert_allclose(saved, scenes.stored_offsets(face), atol=1e-6, err_msg="what the save stored")
    scene.frame_set(3)
    np.testing.assert_allclose(shown, _truth(face), atol=1e-6, err_msg="frame 3")
    assert np.abs(shown - before).max() > 1e-4


# --- 8: a keyed value typed over, renders and Bake for Farm from the current frame ---------

def _typed_over_scene():
    """A constant skin and a contraction keyed 0.2 -> 1 over frames 1-3, typed over with 0.9
    on frame 1 (not keyed): a frame change brings back 0.2."""
    scene = bpy.context.scene
    face, muscle = scenes.wrinkled_face()
    for f, value in ((1, 0.2), (3, 1.0)):
        muscle.ewrinkles_muscle.contraction = value
        muscle.keyframe_insert("ewrinkles_muscle.contraction", frame=f)
    scene.frame_start, scene.frame_end = 1, 2
    scene.frame_set(1)
    muscle.ewrinkles_muscle.contraction = 0.9
    bpy.context.view_layer.update()
    return scene, face, muscle


def _keyed_truth(scene, face, frame):
    scene.frame_set(frame)
    return scenes.evaluated_positions(face).copy()


@pytest.mark.render
def test_render_animation_from_the_current_frame_uses_the_keyed_value(tmp_path):
    scene, face, _muscle = _typed_over_scene()
    scenes.add_camera_and_light(scene)
    scenes.setup_cycles(scene, size=8, samples=1)
    scene.render.filepath = str(tmp_path / "anim_")
    written = {}

    def record(sc, depsgraph=None):  # after ours: what the render's frame re-evaluates with
        if depsgraph is not None and depsgraph.mode == "RENDER":
            written.setdefault(sc.frame_current, scenes.stored_offsets(face).copy())

    bpy.app.handlers.frame_change_post.append(record)
    try:
        bpy.ops.render.render(animation=True)
    finally:
        bpy.app.handlers.frame_change_post.remove(record)
    assert sorted(written) == [1, 2]
    for f in (1, 2):
        scene.frame_set(f)
        assert pipeline.update_face(face, bpy.context.evaluated_depsgraph_get())
        np.testing.assert_allclose(written[f], scenes.stored_offsets(face), atol=1e-7, err_msg=f"frame {f}")


def test_bake_for_farm_from_the_current_frame_uses_the_keyed_value(tmp_path):
    scene, face, _muscle = _typed_over_scene()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.bake(frame_start=1, frame_end=2) == {"FINISHED"}
    baked = bpy.data.objects["Face Baked"]
    for f in (1, 2):
        want = _keyed_truth(scene, face, f)
        np.testing.assert_allclose(scenes.evaluated_positions(baked), want, atol=1e-6, err_msg=f"frame {f}")


# --- 9: time remapping -------------------------------------------------------------------

def _remapped_face(old=100, new=200):
    scene = bpy.context.scene
    scene.render.frame_map_old, scene.render.frame_map_new = old, new  # Scene Time: new / old x frame
    face, _muscle = scenes.wrinkled_face(contraction=1.0)
    return scene, face


@pytest.mark.parametrize("old, new, frame", [(100, 200, 3), (3, 2, 100000)])
def test_time_remapping_applies_the_offsets_on_their_frame(old, new, frame):
    """Twice the speed, and 2/3 of it far into the shot: a Scene Time between two frames."""
    scene, face = _remapped_face(old, new)
    scene.frame_set(frame)
    dg = bpy.context.evaluated_depsgraph_get()
    assert pipeline.update_face(face, dg)  # as renders write
    shown = scenes.evaluated_positions(face)
    offsets = scenes.stored_offsets(face)
    assert np.abs(offsets).max() > 1e-4
    np.testing.assert_allclose(shown, _skin(face) + offsets, atol=1e-6)
    # the original mesh holds this frame's offsets: an edit or a save need not write them again
    assert not pipeline.update_face(face, bpy.context.evaluated_depsgraph_get(), only_if_changed=True)


@pytest.mark.render
def test_time_remapping_renders_the_wrinkles(tmp_path):
    """Nothing is animated: the remapped render of frame 2 is the plain one."""
    scene, face = _remapped_face()
    scenes.add_camera_and_light(scene)
    scenes.setup_cycles(scene)
    images = {}
    for remap in (200, 100):
        scene.render.frame_map_new = remap
        scene.frame_set(2)
        scene.render.filepath = str(tmp_path / f"remap_{remap}.png")
        bpy.ops.render.render(write_still=True)
        images[remap] = scenes.load_png(tmp_path / f"remap_{remap}.png")
    assert np.abs(images[200] - images[100]).max() < 2e-3


# --- 11: one source's problem stays its own ---------------------------------------------

class Broken(WrinkleSource):
    """A bump on a few vertices whose method ``where`` raises ``error``."""

    name = "test_broken"
    label = "Broken"
    where, error = "", RuntimeError

    def _maybe_raise(self, where):
        if where == self.where:
            raise self.error(f"broken in {where}")

    def active(self, face):
        return True

    def static_key(self, face, in_scene):
        self._maybe_raise("static_key")
        return 1

    def build(self, face, mesh, in_scene):
        self._maybe_raise("build")
        return type("Static", (), {"footprint": combine.Footprint(height_verts=np.arange(20))})

    def inputs(self, face, static):
        self._maybe_raise("inputs")
        return ()

    def contribute(self, face, static, skin, inputs):
        self._maybe_raise("contribute")
        return combine.Contribution(height=np.full(20, 0.001, np.float32))

    def problems(self, face, static):
        self._maybe_raise("problems")
        return ""


@pytest.mark.parametrize("error", [RuntimeError, WrinkleError])
@pytest.mark.parametrize("where", ["static_key", "build", "inputs", "contribute", "problems"])
def test_a_source_that_raises_leaves_the_others_wrinkles(where, error):
    scene, face, _muscle = _animated_face()
    scene.frame_set(3)
    want = scenes.evaluated_positions(face).copy()
    source = Broken()
    source.where, source.error = where, error
    sources.add(source)
    try:
        pipeline.forget(face)
        scene.frame_set(2)
        scene.frame_set(3)
        got = scenes.evaluated_positions(face).copy()
        message = status.get(face, Broken.name)
    finally:
        sources.remove(source)
    assert status.get(face, pipeline.CHANNEL) == ""
    assert f"broken in {where}" in message
    assert message.startswith("Internal error") == (error is RuntimeError)
    if where != "problems":  # else the bump is there, and nothing else is wrong
        np.testing.assert_allclose(got, want, atol=1e-6)


def _maps_face():
    face = uv_face()
    scenes.add_sheet(face, contraction=1.0)
    scenes.animate_shape_key(face, [(1, 0.0), (4, 1.0)])
    face.data.materials.append(mapscenes.node_material("Skin"))
    maps = face.ewrinkles_face.maps
    mask = np.zeros((8, 8, 4), np.float32)
    mask[:, :, 0] = 1.0
    maps.mask_a = mapscenes.data_image("Mask A", mask)
    maps.mask_b = mapscenes.data_image("Mask B", np.zeros((8, 8, 4), np.float32))
    pd = mapscenes.random_normal_map(np.random.default_rng(3), 8, 0.3)
    maps.map_a = mapscenes.data_image("Wrinkle PD", pd)
    maps.weight_mode = "TENSION"
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    return face


def test_removing_the_uv_map_pauses_only_the_wrinkle_maps():
    face = _maps_face()
    scene = bpy.context.scene
    scene.frame_set(3)
    want = scenes.evaluated_positions(face).copy()
    tension = nodegroups.read_tension(face.ewrinkles_face.maps.weights_group)
    assert tension[0] > 0.0
    assert np.abs(want - _skin(face)).max() > 1e-4, "no wrinkles"
    scene.frame_set(2)
    face.data.uv_layers.remove(face.data.uv_layers[0])
    scene.frame_set(3)
    np.testing.assert_allclose(scenes.evaluated_positions(face), want, atol=1e-6)
    assert status.get(face, pipeline.CHANNEL) == ""
    message = status.get(face, map_material.CHANNEL)
    assert "wrinkle maps" in message.lower() and "no UV map" in message  # the maps' own report


def test_a_muscle_linked_into_the_scene_again_wrinkles_again_on_the_next_frame():
    """Viewport frames keep the muscles' static data while nothing that it reads changed; a
    muscle unlinked from the scene leaves it, and one linked back must come back into it
    (not only on a full check)."""
    scene = bpy.context.scene
    face, muscle = scenes.wrinkled_face(contraction=1.0)
    scene.frame_set(1)
    scene.frame_set(2)

    def shown():  # what the face shows: its positions over its skin
        return np.abs(scenes.evaluated_positions(face) - _skin(face)).max()

    assert shown() > 1e-4
    homes = list(muscle.users_collection)
    for coll in homes:
        coll.objects.unlink(muscle)
    scene.frame_set(3)
    scene.frame_set(4)
    assert shown() == 0.0
    for coll in homes:
        coll.objects.link(muscle)
    scene.frame_set(5)
    assert shown() > 1e-4, "the muscle linked again is left out"
