"""The per-frame stage: frame accuracy, exact restore, survival, drivers (docs/architecture.md)."""

import bpy
import numpy as np
import pytest

from tests.blender import scenes
from wrinkle_addon.glue import pipeline


def _static_copy_render(scene, face, path):
    """Render the current evaluated face as a plain static mesh: the ground truth."""
    dg = bpy.context.evaluated_depsgraph_get()
    me = bpy.data.meshes.new_from_object(face.evaluated_get(dg))
    copy = bpy.data.objects.new("Truth", me)
    scene.collection.objects.link(copy)
    face.hide_render = True
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    face.hide_render = False
    bpy.data.objects.remove(copy)
    bpy.data.meshes.remove(me)
    return scenes.load_png(path)


@pytest.fixture
def animated_scene():
    return scenes.animated_render_scene(4)


@pytest.mark.render
def test_background_renders_are_frame_accurate(animated_scene, tmp_path):
    scene, face = animated_scene
    truth = {}
    for f in (1, 2, 3, 4):
        scene.frame_set(f)
        truth[f] = _static_copy_render(scene, face, tmp_path / f"truth_{f}.png")
    # the frames really differ, so a render one frame behind would be caught
    for f in (2, 3, 4):
        assert np.abs(truth[f] - truth[f - 1]).max() > 0.02

    scene.render.filepath = str(tmp_path / "anim_####")
    bpy.ops.render.render(animation=True)
    for f in (1, 2, 3, 4):
        got = scenes.load_png(tmp_path / f"anim_{f:04d}.png")
        assert np.abs(got - truth[f]).max() < 2e-3, f"render(animation=True) frame {f}"

    for f in (3, 1, 4, 2):  # out of order on purpose
        scene.frame_set(f)
        scene.render.filepath = str(tmp_path / f"still_{f}.png")
        bpy.ops.render.render(write_still=True)
        got = scenes.load_png(tmp_path / f"still_{f}.png")
        assert np.abs(got - truth[f]).max() < 2e-3, f"frame_set({f}) + render()"


def test_offsets_follow_frames_exactly(animated_scene):
    """Evaluating frame N always gives the same offsets, whatever frame came before."""
    scene, face = animated_scene
    ref = {}
    for f in (1, 2, 3, 4):
        scene.frame_set(f)
        ref[f] = scenes.offsets(face).copy()
    assert np.abs(ref[1]).max() == 0.0 and np.abs(ref[4]).max() > 1e-3
    for f in (4, 2, 1, 3, 3):
        scene.frame_set(f)
        np.testing.assert_array_equal(scenes.offsets(face), ref[f])


def test_wrinkles_do_not_feed_back(animated_scene):
    scene, face = animated_scene
    scene.frame_set(3)
    first = scenes.offsets(face).copy()
    for _ in range(3):  # re-evaluating the same frame must not drift
        scene.frame_set(3)
    np.testing.assert_array_equal(scenes.offsets(face), first)


def _user_state(face):
    me = face.data
    keys = {k.name: np.array([p.co[:] for p in k.data]) for k in me.shape_keys.key_blocks}
    co = np.array([v.co[:] for v in me.vertices])
    return co, keys, sorted(a.name for a in me.attributes), [m.name for m in face.modifiers]


@pytest.mark.parametrize("remove_muscles", [False, True])
def test_exact_restore(remove_muscles):
    scene = bpy.context.scene
    face = scenes.make_face()
    face.data.shape_keys.key_blocks["BrowsUp"].value = 0.6
    before_eval = scenes.evaluated_positions(face).copy()
    before = _user_state(face)
    bpy.ops.wrinkle.enable()
    muscle = scenes.add_sheet(face)
    muscle.ewrinkles_muscle.contraction = 0.8
    scene.frame_set(1)
    assert np.abs(scenes.evaluated_positions(face) - before_eval).max() > 1e-3
    bpy.context.view_layer.objects.active = face
    bpy.ops.wrinkle.disable(remove_muscles=remove_muscles)
    scene.frame_set(2)
    np.testing.assert_array_equal(scenes.evaluated_positions(face), before_eval)
    after = _user_state(face)
    np.testing.assert_array_equal(after[0], before[0])
    for name, co in before[1].items():
        np.testing.assert_array_equal(after[1][name], co)
    assert after[2:] == before[2:]
    assert ("Frontalis" in bpy.data.objects) != remove_muscles


def test_enable_sets_lock_interface():
    scene = bpy.context.scene
    scene.render.use_lock_interface = False
    scenes.make_face()
    bpy.ops.wrinkle.enable()
    assert scene.render.use_lock_interface


def test_survives_undo():
    scene = bpy.context.scene
    face, muscle = scenes.wrinkled_face()
    face_name, muscle_name = face.name, muscle.name
    bpy.ops.ed.undo_push(message="muscle added")
    muscle.ewrinkles_muscle.contraction = 1.0
    scene.frame_set(2)
    bpy.ops.ed.undo_push(message="contracted")
    contracted = scenes.offsets(face).copy()
    bpy.ops.ed.undo()
    face = bpy.data.objects[face_name]
    scene = bpy.context.scene
    scene.frame_set(3)
    assert bpy.data.objects[muscle_name].ewrinkles_muscle.contraction == 0.0
    assert np.abs(scenes.offsets(face)).max() == 0.0
    assert pipeline.status_of(face) == ""
    bpy.ops.ed.redo()
    face = bpy.data.objects[face_name]
    bpy.context.scene.frame_set(2)
    np.testing.assert_allclose(scenes.offsets(face), contracted, atol=1e-7)


def _read(me, name):
    out = np.empty((len(me.vertices), 3), np.float32)
    me.attributes[name].data.foreach_get("vector", out.ravel())
    return out


def test_viewport_frames_are_written_in_place(animated_scene):
    """frame_set in the viewport depsgraph: the evaluated mesh shows skin + offset, the
    original mesh is not written (so Blender does not evaluate the stack a second time),
    and the offsets are exactly those that write-back (renders) computes."""
    scene, face = animated_scene
    scene.frame_set(1)
    stored = scenes.stored_offsets(face).copy()
    for f in (2, 4, 3):
        scene.frame_set(f)
        dg = bpy.context.evaluated_depsgraph_get()
        ev = face.evaluated_get(dg).data
        shown = scenes.offsets(face).copy()
        assert np.abs(shown).max() > 1e-4
        np.testing.assert_array_equal(_read(ev, "position"), _read(ev, "wrinkle_skin") + shown)
        np.testing.assert_array_equal(scenes.stored_offsets(face), stored)
        assert pipeline.update_face(face, dg)  # write-back, as a render frame does
        np.testing.assert_array_equal(scenes.stored_offsets(face), shown)
        stored = shown


def test_in_place_frames_refresh_the_normals(animated_scene):
    """Normals cached before our in-place write must not survive it (they shade the wrinkles)."""
    scene, face = animated_scene

    def cache_normals(scn, depsgraph=None):  # runs before ours, as any other add-on might
        if depsgraph is not None:
            ev = face.evaluated_get(depsgraph).data
            ev.vertex_normals.foreach_get("vector", np.empty(len(ev.vertices) * 3, np.float32))

    scene.frame_set(2)  # the original mesh now holds offsets of another frame than 3
    handlers = bpy.app.handlers.frame_change_post
    handlers.insert(0, cache_normals)
    try:
        scene.frame_set(3)
    finally:
        handlers.remove(cache_normals)
    ev = face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    got = np.empty((len(ev.vertices), 3), np.float32)
    ev.vertex_normals.foreach_get("vector", got.ravel())

    def normals_of(positions):
        me = bpy.data.meshes.new("probe")
        me.from_pydata(positions.tolist(), [], [tuple(p.vertices) for p in face.data.polygons])
        out = np.empty((len(me.vertices), 3), np.float32)
        me.vertex_normals.foreach_get("vector", out.ravel())
        bpy.data.meshes.remove(me)
        return out

    want = normals_of(_read(ev, "position"))
    unwrinkled = normals_of(_read(ev, "wrinkle_skin"))
    assert np.abs(want - unwrinkled).max() > 1e-2  # the wrinkles do tilt the normals
    np.testing.assert_allclose(got, want, atol=1e-5)


def test_muscle_only_animation_updates_the_viewport():
    """The face itself is static, only a contraction is keyed.  The stage's frame gate (the
    offsets apply on the frame they were computed for) makes the face depend on time, so
    Blender re-evaluates it each frame and every frame shows that frame's wrinkles."""
    scene = bpy.context.scene
    face, muscle = scenes.wrinkled_face()
    for frame, value in ((1, 0.0), (3, 1.0)):
        muscle.ewrinkles_muscle.contraction = value
        muscle.keyframe_insert("ewrinkles_muscle.contraction", frame=frame)
    seen = {}
    for f in (1, 3, 2, 1, 3):
        scene.frame_set(f)
        ev = face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
        off = scenes.offsets(face).copy()
        assert (np.abs(off).max() > 1e-4) == (f > 1), f
        np.testing.assert_array_equal(_read(ev, "position"), _read(ev, "wrinkle_skin") + off)
        np.testing.assert_array_equal(off, seen.setdefault(f, off))


def test_survives_save_and_reload(tmp_path):
    scene = bpy.context.scene
    face, muscle = scenes.wrinkled_face()
    scenes.animate_shape_key(face, [(1, 0.0), (5, 1.0)])
    scene.frame_set(4)
    expected = scenes.offsets(face).copy()
    assert np.abs(expected).max() > 1e-4
    path = tmp_path / "saved.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    bpy.ops.wm.open_mainfile(filepath=str(path))
    face = bpy.data.objects["Face"]
    np.testing.assert_array_equal(scenes.offsets(face), expected)  # stored in the file
    bpy.context.scene.frame_set(2)
    bpy.context.scene.frame_set(4)
    np.testing.assert_allclose(scenes.offsets(face), expected, atol=1e-7)
    assert face.ewrinkles_face.enabled and len(face.ewrinkles_face.muscles) == 1


@pytest.mark.parametrize("how", ["remove", "operator"])
def test_survives_deleted_muscle(how):
    scene = bpy.context.scene
    face, muscle = scenes.wrinkled_face(contraction=1.0)
    scene.frame_set(1)
    assert np.abs(scenes.offsets(face)).max() > 0
    if how == "remove":
        bpy.data.objects.remove(muscle)
    else:
        for ob in bpy.context.selected_objects:
            ob.select_set(False)
        muscle.select_set(True)
        bpy.context.view_layer.objects.active = muscle
        bpy.ops.object.delete()
    scene.frame_set(2)
    assert np.abs(scenes.offsets(face)).max() == 0.0
    assert "Internal error" not in pipeline.status_of(face)


def test_survives_edit_mode_topology_change():
    scene = bpy.context.scene
    face, muscle = scenes.wrinkled_face(contraction=1.0)
    scene.frame_set(1)
    n = len(face.data.vertices)
    bpy.context.view_layer.objects.active = face
    bpy.ops.object.mode_set(mode="EDIT")
    scene.frame_set(2)  # paused while editing, no crash
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.subdivide(number_cuts=1)
    bpy.ops.object.mode_set(mode="OBJECT")
    scene.frame_set(3)
    assert len(face.data.vertices) > n
    off = scenes.offsets(face)
    assert off.shape[0] == len(face.data.vertices)
    assert np.isfinite(off).all() and np.abs(off).max() > 0
    assert pipeline.status_of(face) == ""


def test_subdivision_surface_after_the_stage():
    scene = bpy.context.scene
    face, muscle = scenes.wrinkled_face(contraction=1.0)
    scene.frame_set(1)
    expected = scenes.offsets(face).copy()
    sub = face.modifiers.new("Subdivision", "SUBSURF")
    sub.levels = 1
    scene.frame_set(2)
    scene.frame_set(1)
    assert pipeline.status_of(face) == ""
    np.testing.assert_allclose(scenes.offsets(face), expected, atol=1e-7)


def test_topology_modifier_before_the_stage_is_refused():
    scene = bpy.context.scene
    face, _muscle = scenes.wrinkled_face(contraction=1.0)
    sub = face.modifiers.new("Subdivision", "SUBSURF")
    face.modifiers.move(len(face.modifiers) - 1, 0)
    scene.frame_set(2)
    assert "before Wrinkles" in pipeline.status_of(face)
    assert sub.name in pipeline.status_of(face)


def _all_drivers():
    for coll in (bpy.data.objects, bpy.data.meshes, bpy.data.shape_keys, bpy.data.materials):
        for idb in coll:
            ad = idb.animation_data
            if ad is not None:
                yield from ad.drivers


def test_drivers_are_simple_expressions(tmp_path):
    face, muscle = scenes.wrinkled_face()
    bpy.context.view_layer.objects.active = muscle
    bpy.ops.wrinkle.drive_contraction(shape_key="BrowsUp", gain=0.8)
    drivers = list(_all_drivers())
    assert drivers
    for fc in drivers:
        assert fc.driver.type != "SCRIPTED" or fc.driver.is_simple_expression, fc.driver.expression
    # and they evaluate in a file opened with Python auto-run off
    path = tmp_path / "drivers.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    prefs = bpy.context.preferences.filepaths
    old = prefs.use_scripts_auto_execute
    prefs.use_scripts_auto_execute = False
    try:
        bpy.ops.wm.open_mainfile(filepath=str(path))
        face = bpy.data.objects["Face"]
        face.data.shape_keys.key_blocks["BrowsUp"].value = 1.0
        bpy.context.scene.frame_set(1)
        assert bpy.data.objects["Frontalis"].ewrinkles_muscle.contraction == pytest.approx(0.8)
    finally:
        prefs.use_scripts_auto_execute = old


def test_bones_compressing_the_skin_raise_wrinkles():
    """A wrinkles-only muscle, no contraction: an armature squashing the skin wrinkles it."""
    scene = bpy.context.scene
    face, muscle = scenes.wrinkled_face(wrinkles_only=True)
    arm = bpy.data.objects.new("Rig", bpy.data.armatures.new("Rig"))
    scene.collection.objects.link(arm)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    bone = arm.data.edit_bones.new("Brow")
    bone.head, bone.tail = (0.0, 0.0, scenes.HEIGHT), (0.0, 0.0, scenes.HEIGHT + 0.02)
    anchor = arm.data.edit_bones.new("Anchor")
    anchor.head, anchor.tail = (0.0, 0.0, -0.02), (0.0, 0.0, 0.0)
    bpy.ops.object.mode_set(mode="OBJECT")
    # the brow bone's weight falls from the top edge to the bottom, the still anchor takes
    # the rest (armature weights are normalised): the skin is squashed toward the bottom
    brow, still = face.vertex_groups.new(name="Brow"), face.vertex_groups.new(name="Anchor")
    co = np.array([v.co[2] for v in face.data.vertices])
    for i, z in enumerate(co):
        w = float(np.clip(z / scenes.HEIGHT, 0.0, 1.0))
        brow.add([i], w, "REPLACE")
        still.add([i], 1.0 - w, "REPLACE")
    mod = face.modifiers.new("Armature", "ARMATURE")
    mod.object = arm
    face.modifiers.move(len(face.modifiers) - 1, 0)  # deformers before the Wrinkles stage
    scene.frame_set(1)
    assert np.abs(scenes.offsets(face)).max() == 0.0
    arm.pose.bones["Brow"].location = (0.0, -0.025, 0.0)  # the bone moves the skin down (bone Y)
    arm.pose.bones["Brow"].keyframe_insert("location", frame=2)
    arm.pose.bones["Brow"].location = (0.0, 0.0, 0.0)
    arm.pose.bones["Brow"].keyframe_insert("location", frame=1)
    scene.frame_set(2)
    off = scenes.offsets(face)
    assert pipeline.status_of(face) == ""
    assert np.abs(off[:, 1]).max() > 1e-4  # wrinkles along the normal
    assert np.all(off[:, [0, 2]] == 0)  # and no pull: the bone did the deforming


@pytest.mark.parametrize("animated", ["location", "lambda_w", "face_location"])
def test_playback_follows_animated_static_parameters(animated):
    """Viewport frames skip the static checks of muscles Blender did not update; a muscle
    whose placement or parameters are animated (or a moving face) is updated every frame
    and must be followed exactly as a full re-evaluation does."""
    scene = bpy.context.scene
    face, muscle = scenes.wrinkled_face(contraction=1.0)
    owner, path, values = {
        "location": (muscle, "location", ((0.0, 0.0, 0.0), (0.0, 0.0, 0.01))),
        "lambda_w": (muscle, "ewrinkles_muscle.lambda_w", (0.2, 0.6)),
        "face_location": (face, "location", ((0.0, 0.0, 0.0), (0.02, 0.0, 0.0))),
    }[animated]
    target, attr = (owner.ewrinkles_muscle, "lambda_w") if "." in path else (owner, path)
    for frame, value in zip((1, 5), values):
        setattr(target, attr, value)
        owner.keyframe_insert(path, frame=frame)
    for f in (1, 2, 4, 3, 5):
        scene.frame_set(f)
        shown = scenes.offsets(face).copy()
        pipeline._cache.clear()  # a full re-evaluation from scratch, written back
        assert pipeline.update_face(face, bpy.context.evaluated_depsgraph_get())
        np.testing.assert_allclose(shown, scenes.stored_offsets(face), atol=1e-7, err_msg=f"frame {f}")
