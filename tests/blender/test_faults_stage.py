"""Regression tests: modifiers after the Wrinkles stage, and Bake for Farm's paths and names.

* Deformers after the stage (Displace, Smooth, Armature) must keep their effect on viewport
  frames: the in-place fast path writes the stage's output over the final positions, so it
  is only taken when nothing but a final Subdivision Surface follows the stage in the
  viewport.  The stand-in of Bake for Farm must not apply them a second time either.
* Blender's Alembic exporter aborts the whole process when the .blend's path holds ";" or
  "=", so the bake refuses such a file first.  Checked in a subprocess: were the check
  missing, the abort would take pytest down with it.
* A face whose name the exporter rewrites ("/", ":", ".", spaces) still gets a stand-in
  that reads its cache; when no path fits, nothing is left hidden or half made.
"""

import json
import os
import subprocess
import sys
import textwrap

import bpy
import numpy as np
import pytest

from tests.blender import scenes
from wrinkle_addon.glue import farm_bake, pipeline

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DISPLACE = 0.01


def _read(me, name):
    out = np.empty((len(me.vertices), 3), np.float32)
    me.attributes[name].data.foreach_get("vector", out.ravel())
    return out


def _add_rig(face, scene):
    """An armature whose one bone carries the whole face and slides along X over frames 1-4."""
    arm = bpy.data.objects.new("Rig", bpy.data.armatures.new("Rig"))
    scene.collection.objects.link(arm)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    bone = arm.data.edit_bones.new("Head")
    bone.head, bone.tail = (0.0, 0.0, 0.0), (0.0, 0.0, 0.02)
    bpy.ops.object.mode_set(mode="OBJECT")
    bpy.context.view_layer.objects.active = face
    group = face.vertex_groups.new(name="Head")
    group.add(list(range(len(face.data.vertices))), 1.0, "REPLACE")
    pose = arm.pose.bones["Head"]
    for frame, x in ((1, 0.004), (4, 0.016)):
        pose.location = (x, 0.0, 0.0)
        pose.keyframe_insert("location", frame=frame)
    return arm


def _add_after(face, kind, scene):
    """Add a deformer the way a user does once wrinkles are on: at the end, after Wrinkles."""
    if kind == "DISPLACE":  # no texture, mid level 0: every point moves DISPLACE along its normal
        mod = face.modifiers.new("Displace", "DISPLACE")
        mod.strength, mod.mid_level = DISPLACE, 0.0
    elif kind == "SMOOTH":
        mod = face.modifiers.new("Smooth", "SMOOTH")
        mod.factor, mod.iterations = 1.0, 4
    elif kind == "SUBSURF":
        mod = face.modifiers.new("Subdivision", "SUBSURF")
        mod.levels = mod.render_levels = 1
    else:
        mod = face.modifiers.new("Armature", "ARMATURE")
        mod.object = _add_rig(face, scene)
    names = [m.name for m in face.modifiers]
    assert names[-1] == mod.name and "Wrinkles" in names[:-1]
    return mod


def _animated_face():
    scene = bpy.context.scene
    face, muscle = scenes.wrinkled_face(contraction=1.0)
    scenes.animate_shape_key(face, [(1, 0.0), (4, 1.0)])
    scene.frame_start, scene.frame_end = 1, 4
    return scene, face


@pytest.mark.parametrize("kind", ["DISPLACE", "SMOOTH", "ARMATURE", "DISPLACE+SUBSURF"])
def test_deformer_after_the_stage_keeps_its_effect_on_viewport_frames(kind):
    """After frame_set, the evaluated face is what Blender computes with the whole stack:
    the same as after a forced write-back, which makes Blender evaluate everything again."""
    scene, face = _animated_face()
    for part in kind.split("+"):
        _add_after(face, part, scene)
    for f in (1, 3, 2, 3):  # frame 3 twice: a re-visited frame
        scene.frame_set(f)
        dg = bpy.context.evaluated_depsgraph_get()
        ev = face.evaluated_get(dg).data
        shown = _read(ev, "position")
        offset = _read(ev, "wrinkle_offset")
        moved = np.linalg.norm(shown - (_read(ev, "wrinkle_skin") + offset), axis=1)
        assert np.abs(offset).max() > 1e-4, f"frame {f}: no wrinkles to check"
        assert pipeline.update_face(face, dg)  # write-back: Blender evaluates the whole stack
        truth = scenes.evaluated_positions(face).copy()
        np.testing.assert_allclose(shown, truth, atol=1e-6, err_msg=f"{kind} after Wrinkles, frame {f}")
        if kind == "DISPLACE":
            np.testing.assert_allclose(moved, DISPLACE, atol=1e-6, err_msg=f"frame {f}")
        else:
            assert moved.max() > 1e-3, f"frame {f}: the {kind} modifier had no effect"
    assert pipeline.status_of(face) == ""


@pytest.mark.parametrize("after", ["hidden-displace", "final-subsurf-level-0"])
def test_modifiers_that_keep_the_positions_keep_the_in_place_path(after):
    """A modifier after the stage that is off in the viewport changes nothing there, and a
    final Subdivision Surface either subdivides the mesh we write into (on the GPU), or
    adds vertices (on the CPU: the in-place write refuses that mesh), or, at level 0, does
    nothing: frames are still written in place (the original mesh's offsets are left
    alone)."""
    scene, face = _animated_face()
    if after == "hidden-displace":
        _add_after(face, "DISPLACE", scene).show_viewport = False
    else:
        _add_after(face, "SUBSURF", scene).levels = 0
    scene.frame_set(1)
    stored = scenes.stored_offsets(face).copy()
    for f in (2, 4):
        scene.frame_set(f)
        ev = face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
        np.testing.assert_array_equal(_read(ev, "position"), _read(ev, "wrinkle_skin") + scenes.offsets(face))
        np.testing.assert_array_equal(scenes.stored_offsets(face), stored)


def _live_positions(scene, face, frames):
    out = {}
    for f in frames:
        scene.frame_set(f)
        out[f] = scenes.evaluated_positions(face).copy()
    return out


def _bake(face, **kwargs):
    bpy.context.view_layer.objects.active = face
    bpy.ops.wrinkle.bake(frame_start=1, frame_end=3, **kwargs)
    return face.ewrinkles_face.bake_object


def _check_stand_in(scene, face, baked, live):
    assert face.hide_render and baked is not None
    got = _live_positions(scene, baked, live)
    for f, want in live.items():
        assert got[f].shape == want.shape, f"frame {f}"
        np.testing.assert_allclose(got[f], want, atol=1e-6, err_msg=f"stand-in, frame {f}")
    assert np.abs(got[3] - got[1]).max() > 1e-3  # the stand-in does move


@pytest.mark.parametrize("subdivide", [False, True], ids=["displace", "displace+subsurf"])
def test_stand_in_applies_deformers_after_the_stage_once(tmp_path, subdivide):
    """The cache already holds the Displace after the stage; the stand-in only adds the
    final Subdivision Surface that the exporter leaves out."""
    scene, face = _animated_face()
    _add_after(face, "DISPLACE", scene)
    if subdivide:
        sub = face.modifiers.new("Subdivision", "SUBSURF")
        sub.levels = sub.render_levels = 1
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))
    face = bpy.data.objects["Face"]
    live = _live_positions(scene, face, (1, 3))
    baked = _bake(face)
    _check_stand_in(scene, face, baked, live)
    assert [m.type for m in baked.modifiers] == ["MESH_SEQUENCE_CACHE"] + ["SUBSURF"] * subdivide


def test_bake_refuses_a_subdivision_followed_by_other_modifiers(tmp_path):
    """The exporter applies a Subdivision Surface that is not last: the cache would not fit
    the stand-in's vertices."""
    scene, face = _animated_face()
    sub = face.modifiers.new("Subdivision", "SUBSURF")
    sub.levels = sub.render_levels = 1
    _add_after(face, "DISPLACE", scene)
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))
    face = bpy.data.objects["Face"]
    with pytest.raises(RuntimeError, match='"Subdivision" subdivides the face before other modifiers'):
        _bake(face)
    assert not (tmp_path / "wrinkle_bake").exists()
    assert not face.hide_render and face.ewrinkles_face.bake_object is None


# --- The .blend's path: ";" and "=" abort Blender's Alembic exporter --------------------

BAKE_AT_PATH = textwrap.dedent("""
    import json, os, sys
    root, blend, out = sys.argv[-3], sys.argv[-2], sys.argv[-1]
    sys.path.insert(0, root)
    import bpy
    import addon_utils
    addon_utils.enable("wrinkle_addon", default_set=True)
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    from tests.blender import scenes
    face, _muscle = scenes.wrinkled_face(contraction=1.0)
    bpy.ops.wm.save_as_mainfile(filepath=blend)
    face = bpy.data.objects["Face"]
    bpy.context.view_layer.objects.active = face
    error = None
    try:
        bpy.ops.wrinkle.bake(frame_start=1, frame_end=2)
    except RuntimeError as exc:
        error = str(exc)
    folder = os.path.dirname(blend)
    json.dump({"error": error, "files": sorted(os.listdir(folder)), "hidden": face.hide_render,
               "stand_in": face.ewrinkles_face.bake_object is not None,
               "objects": sorted(o.name for o in bpy.data.objects)}, open(out, "w"))
""")


@pytest.mark.parametrize("where", ["a;b/shot.blend", "shots/a=b.blend"],
                         ids=["semicolon-in-folder", "equals-in-name"])
def test_bake_refuses_a_blend_path_alembic_cannot_store(tmp_path, where):
    """Run in a fresh process: without the check the exporter aborts it (exit 134)."""
    blend = tmp_path / where
    blend.parent.mkdir()
    script = tmp_path / "bake_at_path.py"
    script.write_text(BAKE_AT_PATH)
    out = tmp_path / "result.json"
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(tmp_path / "user"))
    run = subprocess.run([sys.executable, str(script), ROOT, str(blend), str(out)], env=env,
                         cwd=str(tmp_path), capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, f"exit {run.returncode}:\n" + run.stdout[-2000:] + run.stderr[-2000:]
    got = json.loads(out.read_text())
    char = ";" if ";" in where else "="
    assert got["error"] is not None and f'contains "{char}"' in got["error"], got["error"]
    assert "Alembic" in got["error"]
    assert got["files"] == [blend.name]  # no wrinkle_bake folder, no .abc
    assert not got["hidden"] and not got["stand_in"]
    assert got["objects"] == ["Face", "Frontalis"]


def test_output_path_with_semicolon_and_equals_bakes(tmp_path):
    """Only the .blend's path matters to the exporter: an .abc path with ";" and "=" is fine."""
    scene, face = _animated_face()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))
    face = bpy.data.objects["Face"]
    live = _live_positions(scene, face, (1, 3))
    baked = _bake(face, filepath=str(tmp_path / "out;a=b" / "Face;1=2.abc"))
    assert (tmp_path / "out;a=b" / "Face;1=2.abc").is_file()
    _check_stand_in(scene, face, baked, live)


# --- Names the exporter rewrites -------------------------------------------------------


@pytest.mark.parametrize("name", ["Face/Left", "Fäce: L.1 é/ü"])
def test_stand_in_of_a_face_with_an_odd_name_follows_the_cache(tmp_path, name):
    scene = bpy.context.scene
    face = scenes.make_face(name)
    bpy.ops.wrinkle.enable()
    scenes.add_sheet(face, contraction=1.0)
    scenes.animate_shape_key(face, [(1, 0.0), (3, 1.0)])
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))
    face = bpy.data.objects[name]
    live = _live_positions(scene, face, (1, 2, 3))
    assert np.abs(live[3] - live[1]).max() > 1e-3
    baked = _bake(face)
    assert baked.name == name + " Baked"
    _check_stand_in(scene, face, baked, live)


def test_cache_without_the_face_mesh_leaves_nothing_behind(tmp_path, monkeypatch):
    """When the written cache holds no single mesh for the face, the bake fails, the face
    still renders and no stand-in, mesh or cache file is left."""
    scene, face = _animated_face()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))
    face = bpy.data.objects["Face"]
    # a cache with two other meshes stands in for a cache the face's path cannot be found in
    others = []
    for x in (0.0, 1.0):
        me = bpy.data.meshes.new("Other")
        me.from_pydata([(x, 0, 0), (x + 1, 0, 0), (x, 0, 1)], [], [(0, 1, 2)])
        ob = bpy.data.objects.new(f"Other{x:.0f}", me)
        scene.collection.objects.link(ob)
        others.append(ob)
    for ob in bpy.context.selected_objects:
        ob.select_set(False)
    for ob in others:
        ob.select_set(True)
    wrong = str(tmp_path / "others.abc")
    bpy.ops.wm.alembic_export(filepath=wrong, start=1, end=1, selected=True, flatten=True,
                              as_background_job=False)
    for ob in others:
        bpy.data.objects.remove(ob)
    real_open = farm_bake._open_cache
    monkeypatch.setattr(farm_bake, "_open_cache", lambda _path: real_open(wrong))
    meshes_before = set(bpy.data.meshes.keys())
    with pytest.raises(RuntimeError, match="holds no single mesh"):
        _bake(face)
    assert not face.hide_render and face.ewrinkles_face.bake_object is None
    assert "Face Baked" not in bpy.data.objects
    assert set(bpy.data.meshes.keys()) == meshes_before
    assert len(bpy.data.cache_files) == 0


def test_free_bake_removes_the_cache_file(tmp_path):
    """The stand-in's modifier holds the CacheFile's only user: Free Bake leaves no orphan
    CacheFile to be saved with the .blend (the .abc on disk is kept)."""
    _scene, face = _animated_face()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))
    face = bpy.data.objects["Face"]
    _bake(face)
    assert [c.users for c in bpy.data.cache_files] == [1]
    bpy.ops.wrinkle.free_bake()
    assert len(bpy.data.cache_files) == 0
    assert (tmp_path / "wrinkle_bake" / "Face.abc").is_file()
