# SPDX-License-Identifier: GPL-3.0-or-later
"""USD export of the animated, wrinkled face (glue/export/usd.py), read back with usd-core.

usd-core's ``pxr`` runs in a child process (tests/tools/usd_points.py): Blender's bundled USD
and usd-core must not meet in one interpreter.
"""

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import bpy
import numpy as np
import pytest

from tests.blender import scenes
from wrinkle_addon.glue.errors import WrinkleError
from wrinkle_addon.glue.export import usd

READER = Path(__file__).resolve().parents[1] / "tools" / "usd_points.py"
LAST = 12
CHECKED = (1, 6, LAST)  # first, middle, last

# Blender's Z-up axes from a Y-up stage's: the exporter's Y-up conversion (forward -Z, up Y)
# writes Blender's (x, y, z) as (x, z, -y)
_FROM_UP = {"Z": np.eye(3), "Y": np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])}


def read_usd(path, frames):
    """What tests/tools/usd_points.py reads at ``frames``, in a fresh interpreter."""
    run = subprocess.run([sys.executable, str(READER), str(path), *map(str, frames)],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    return json.loads(run.stdout)


def points(data, frame, key="points"):
    return np.asarray(data["frames"][str(frame)][key], np.float64).reshape(-1, 3)


def wrinkle_skin(face):
    """The evaluated skin before any wrinkle (what the stage stores as ``wrinkle_skin``)."""
    ev = face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    out = np.empty((len(ev.vertices), 3), np.float32)
    ev.attributes["wrinkle_skin"].data.foreach_get("vector", out.ravel())
    return out


def animated_face():
    """The forehead patch with its Frontalis sheet; shape key and contraction ramp 0 -> 1 over
    frames 1..LAST.  Moved and turned, so that object and world space differ."""
    face, muscle = scenes.wrinkled_face()
    scenes.animate_shape_key(face, [(1, 0.0), (LAST, 1.0)])
    for frame, value in ((1, 0.0), (LAST, 1.0)):
        muscle.ewrinkles_muscle.contraction = value
        muscle.keyframe_insert("ewrinkles_muscle.contraction", frame=frame)
    face.data.uv_layers.new(name="UVMap")
    face.data.materials.append(bpy.data.materials.new("Skin"))
    face.location = (0.3, -0.2, 1.5)
    face.rotation_euler = (0.0, 0.0, math.radians(30))
    bpy.context.view_layer.update()
    return face, muscle


def test_usd_holds_every_frame_of_the_wrinkled_face(tmp_path):
    scene = bpy.context.scene
    face, muscle = animated_face()
    size = float(np.linalg.norm(np.ptp(scenes.evaluated_positions(face), axis=0)))
    tol = 1e-5 * size
    # the export must leave the scene as it found it: another range, frame and selection, and
    # on the current frame a keyed value typed over (the contraction), which the export evaluates
    scene.frame_start, scene.frame_end = 20, 40
    scene.frame_set(7)
    muscle.ewrinkles_muscle.contraction = 0.0
    for ob in scene.objects:
        ob.select_set(ob == muscle)
    bpy.context.view_layer.objects.active = muscle
    calls = []

    out = usd.export(bpy.context, face, str(tmp_path / "usd" / "face.usdc"), 1, LAST,
                     progress=lambda fraction, message: calls.append((fraction, message)))

    assert out["file"] == str(tmp_path / "usd" / "face.usdc") and os.path.isfile(out["file"])
    assert out["frames"] == LAST and out["wrinkled_frames"] == LAST
    assert out["points"] == len(face.data.vertices)
    assert calls == [(f / LAST, f"frame {f}") for f in range(1, LAST + 1)]
    assert (scene.frame_start, scene.frame_end, scene.frame_current) == (20, 40, 7)
    assert [ob.name for ob in bpy.context.selected_objects] == [muscle.name]
    assert bpy.context.view_layer.objects.active == muscle
    print(f"USD export of {LAST} frames, {out['points']} points: {out['seconds'] * 1000:.0f} ms")

    data = read_usd(out["file"], CHECKED)
    assert data["prim"] == "/root/Face/Face"
    assert data["metersPerUnit"] == 1.0 and data["upAxis"] == "Z"
    assert (data["startTimeCode"], data["endTimeCode"]) == (1.0, LAST)
    # time-sampled points, not UsdSkel blend shapes (which would hold the mesh before the stage)
    assert not data["blendShapes"]
    assert "st" in data["primvars"] and data["material"].endswith("/Skin")  # UVs and materials on
    assert set(data["samples"]) >= set(range(2, LAST + 1))
    axes = _FROM_UP[data["upAxis"]]
    for f in CHECKED:
        scene.frame_set(f)
        live = scenes.evaluated_positions(face).astype(np.float64)
        got = points(data, f)
        assert got.shape == live.shape
        local = np.abs(got - live).max()
        matrix = np.array(face.matrix_world, np.float64)
        world_live = live @ matrix[:3, :3].T + matrix[:3, 3]
        world = np.abs(points(data, f, "world") @ axes.T - world_live).max()
        print(f"frame {f}: max |USD - live| {local:.3g} (object space), {world:.3g} (world)")
        assert local <= tol, f"frame {f}: the USD points differ from the live face by {local}"
        assert world <= tol, f"frame {f}: the USD points in world space differ by {world}"

    # the wrinkles are in the file: on the last frame (full contraction) the points are not the
    # unwrinkled skin's, by far more than the tolerance; on the first (no contraction) they are
    scene.frame_set(LAST)
    wrinkles = np.abs(points(data, LAST) - wrinkle_skin(face)).max()
    print(f"wrinkles in the file at frame {LAST}: {wrinkles:.4g} (face size {size:.4g})")
    assert wrinkles > 100 * tol
    scene.frame_set(1)
    assert np.abs(points(data, 1) - wrinkle_skin(face)).max() <= tol


def test_usd_export_of_a_range_after_the_scenes(tmp_path):
    """A range wholly after the scene's own (Blender clamps an end set before its start)."""
    scene = bpy.context.scene
    face, _muscle = animated_face()
    scene.frame_start, scene.frame_end = 1, 3
    out = usd.export(bpy.context, face, str(tmp_path / "late.usda"), 5, 8)
    assert out["frames"] == 4 and out["wrinkled_frames"] == 4
    assert (scene.frame_start, scene.frame_end) == (1, 3)
    data = read_usd(out["file"], [5, 8])
    assert (data["startTimeCode"], data["endTimeCode"]) == (5.0, 8.0)
    scene.frame_set(8)
    assert np.abs(points(data, 8) - scenes.evaluated_positions(face)).max() <= 1e-6


def _refused(match, face, path, start=1, end=3):
    scene = bpy.context.scene
    before = (scene.frame_start, scene.frame_end, scene.frame_current, list(bpy.context.selected_objects))
    with pytest.raises(WrinkleError, match=match):
        usd.export(bpy.context, face, str(path), start, end)
    assert (scene.frame_start, scene.frame_end, scene.frame_current,
            list(bpy.context.selected_objects)) == before


def test_usd_export_refuses_what_is_not_a_wrinkled_face(tmp_path):
    empty = bpy.data.objects.new("Empty", None)
    bpy.context.scene.collection.objects.link(empty)
    _refused(r'"Empty" is an empty, not a mesh', empty, tmp_path / "a.usd")
    face = scenes.make_face()
    _refused(r'"Face" has no Wrinkles modifier: enable wrinkles first', face, tmp_path / "a.usd")
    assert not (tmp_path / "a.usd").exists()


def test_usd_export_refuses_a_reversed_range(tmp_path):
    face, _muscle = scenes.wrinkled_face()
    _refused(r"The frame range 5-2 is empty: set End at or after Start", face, tmp_path / "a.usd", 5, 2)


def test_usd_export_refuses_paths_it_cannot_write(tmp_path):
    face, _muscle = scenes.wrinkled_face()
    (tmp_path / "file.txt").write_text("")
    _refused(r'is a file, not a folder', face, tmp_path / "file.txt" / "face.usd")
    (tmp_path / "dir.usd").mkdir()
    _refused(r"is a folder: choose a file name", face, tmp_path / "dir.usd")
    _refused(r"is not a USD file name: end it in \.usd", face, tmp_path / "face.abc")
    _refused(r"Save the \.blend file first", face, "//face.usd")
    _refused(r"No file to export to", face, "")


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root writes into read-only folders")
def test_usd_export_refuses_a_read_only_folder(tmp_path):
    face, _muscle = scenes.wrinkled_face()
    folder = tmp_path / "locked"
    folder.mkdir()
    folder.chmod(0o555)
    try:
        _refused(r"the folder .* is not writable", face, folder / "face.usd")
    finally:
        folder.chmod(0o755)


def test_usd_export_refuses_a_face_it_would_leave_out(tmp_path):
    """The exporter silently writes no mesh for a face hidden in the viewport (it cannot be
    selected) or from renders (its RENDER depsgraph leaves it out): refused instead."""
    face, _muscle = scenes.wrinkled_face()
    face.hide_render = True
    _refused(r'"Face" is disabled in renders, .*Free Bake', face, tmp_path / "a.usd")
    face.hide_render = False
    coll = bpy.data.collections.new("Heads")
    bpy.context.scene.collection.children.link(coll)
    coll.objects.link(face)
    bpy.context.scene.collection.objects.unlink(face)
    coll.hide_render = True
    _refused(r'"Face" is only in "Heads", disabled in renders', face, tmp_path / "a.usd")
    coll.hide_render = False
    face.hide_set(True)
    _refused(r'"Face" is hidden in the viewport', face, tmp_path / "a.usd")
    face.hide_set(False)
    bpy.context.view_layer.layer_collection.children["Heads"].exclude = True
    _refused(r'"Face" is not in the view layer', face, tmp_path / "a.usd")
    assert not (tmp_path / "a.usd").exists()


def test_usd_export_says_when_frames_lost_their_wrinkles(tmp_path):
    """When the frame stage cannot write a frame's wrinkles (here a Triangulate modifier
    moved above the Wrinkles modifier), the file is written, and the export says so."""
    face, muscle = scenes.wrinkled_face()
    face.modifiers.new("Triangulate", "TRIANGULATE")
    face.modifiers.move(len(face.modifiers) - 1, 0)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 20, 40
    scene.frame_set(30)
    for ob in scene.objects:
        ob.select_set(ob == muscle)
    bpy.context.view_layer.objects.active = muscle
    with pytest.raises(WrinkleError, match=r"written without the wrinkles of frame\(s\) 1, 2, 3: "
                                           r'The modifier "Triangulate" comes before Wrinkles'):
        usd.export(bpy.context, face, str(tmp_path / "a.usda"), 1, 3)
    assert (tmp_path / "a.usda").exists()
    # the scene as it was, after the export itself has run
    assert (scene.frame_start, scene.frame_end, scene.frame_current) == (20, 40, 30)
    assert bpy.context.selected_objects == [muscle] and bpy.context.view_layer.objects.active == muscle


def test_usd_export_options_exist_in_this_blender():
    have = set(bpy.ops.wm.usd_export.get_rna_type().properties.keys())
    kwargs = usd.options("/tmp/x.usd")
    assert set(kwargs) <= have
    assert {"selected_objects_only", "export_animation", "evaluation_mode", "export_shapekeys",
            "export_armatures", "export_uvmaps", "export_materials"} <= set(kwargs)
    assert kwargs["export_shapekeys"] is False and kwargs["evaluation_mode"] == "RENDER"


def test_usd_material_reads_as_a_preview_surface(tmp_path):
    """What a UsdPreviewSurface consumer reads from the face's material: the base normal map
    (written beside the file) through a UV reader of the mesh's own UV primvar, the colour as
    the material's value (not its procedural chain, which reads an attribute), and nothing of
    the wrinkle maps, which are no normal map."""
    from tests.blender import exportscenes

    face, _muscle = exportscenes.engine_face(parts=False)
    out = usd.export(bpy.context, face, str(tmp_path / "face.usdc"), 1, 3)
    data = read_usd(out["file"], [1])
    surface = data["surface"]
    assert surface["id"] == "UsdPreviewSurface"
    normal = surface["normal"]["from"]
    assert normal["id"] == "UsdUVTexture" and normal["exists"], normal
    assert normal["file"].startswith("./textures/") and "Skin Normal" in normal["file"]
    assert normal["st"]["id"] == "UsdPrimvarReader_float2" and normal["st"]["varname"] in data["primvars"]
    assert surface["diffuseColor"]["from"] is None
    np.testing.assert_allclose(surface["diffuseColor"]["value"], exportscenes.SKIN_COLOUR[:3], atol=1e-6)
    # every texture the material reads is on disk
    for name, inp in surface.items():
        if isinstance(inp, dict) and inp.get("from") and "file" in inp["from"]:
            assert inp["from"]["exists"], (name, inp)
    # the face's own material is as it was
    mat = face.data.materials[0]
    assert mat.name == "Skin" and any(n.name == "Wrinkle Map Blend" for n in mat.node_tree.nodes)
    assert [m.name for m in bpy.data.materials if m.name.startswith("Skin")] == ["Skin"]


def test_usd_leaves_out_the_addons_attributes_unless_asked(tmp_path):
    face, _muscle = animated_face()
    modifiers = [m.name for m in face.modifiers]
    lean = usd.export(bpy.context, face, str(tmp_path / "lean.usdc"), 1, LAST)
    assert [m.name for m in face.modifiers] == modifiers  # the temporary modifier is gone
    assert not [g for g in bpy.data.node_groups if g.name.startswith(usd.STRIP_NAME)]
    full = usd.export(bpy.context, face, str(tmp_path / "full.usdc"), 1, LAST, keep_attributes=True)
    lean_data, full_data = read_usd(lean["file"], CHECKED), read_usd(full["file"], CHECKED)
    ours = [p for p in full_data["primvars"] if p.startswith(usd.INTERNAL_PREFIXES)]
    assert {"wrinkle_offset", "wrinkle_skin", "wrinkle_frame"} <= set(ours)
    assert not [p for p in lean_data["primvars"] if p.startswith(usd.INTERNAL_PREFIXES)]
    assert "st" in lean_data["primvars"]
    for f in CHECKED:  # the wrinkles are the same
        np.testing.assert_array_equal(points(lean_data, f), points(full_data, f))
    lean_mb, full_mb = os.path.getsize(lean["file"]) / 1e6, os.path.getsize(full["file"]) / 1e6
    print(f"USD of {LAST} frames: {lean_mb:.3f} MB without the add-on's attributes, {full_mb:.3f} MB with")
    assert lean_mb < full_mb
