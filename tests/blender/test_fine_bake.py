"""Fine wrinkles on a farm with no add-on: Blender computes their shrinkage itself in the
face's modifier, so a face with fine wrinkles alone renders every frame from the file with
no bake at all, and a face with geometric wrinkles renders from Bake for Farm's stand-in,
whose Alembic cache carries the shrinkage with the positions.  Either way the farm renders
the live file's pixels, and no image sequence is written."""

import json
import textwrap

import bpy
import numpy as np
import pytest

from tests.blender import scenes
from tests.blender.test_curves import uv_face
from wrinkle_addon.glue.bando import fine_tree

FARM_SCRIPT = textwrap.dedent("""
    import json, sys
    import bpy
    blend, out = sys.argv[-2], sys.argv[-1]
    bpy.ops.wm.open_mainfile(filepath=blend)
    assert "wrinkle_addon" not in sys.modules, "the add-on must not be loaded on the farm"
    scene = bpy.context.scene
    scene.render.filepath = out + "/farm_####"
    bpy.ops.render.render(animation=True)
    json.dump({"ok": True}, open(out + "/done.json", "w"))
    bpy.ops.wm.read_factory_settings(use_empty=True)
""")


def _fine_scene(enable, pull, subdivide=False):
    """The forehead patch with fine wrinkles carved, its BrowsUp ramping 0 -> 1 over frames
    1..3 (the shrinkage across the furrows grows), a camera, a raking light.  ``enable``: the
    geometric stage on; ``pull``: a Frontalis contracting 0 -> 1 over the same frames, whose
    Waters pull the shrinkage sees; ``subdivide``: a Subdivision Surface last, which the
    farm's stand-in applies to the cache (and which interpolates the shrinkage as a UV map,
    so the face stores it on the corners live too)."""
    scene = bpy.context.scene
    face = uv_face(enable=enable)
    muscle = scenes.add_sheet(face, pull=0.3) if pull else None
    fs = face.ewrinkles_face.fine_wrinkles
    fs.resolution, fs.rest_height, fs.distance, fs.strength = "512", 0.0, 0.001, 2.0
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.carve_fine() == {"FINISHED"}
    scenes.animate_shape_key(face, [(1, 0.0), (3, 1.0)])
    if muscle is not None:
        for frame, value in ((1, 0.0), (3, 1.0)):
            muscle.ewrinkles_muscle.contraction = value
            muscle.keyframe_insert("ewrinkles_muscle.contraction", frame=frame)
    if subdivide:
        sub = face.modifiers.new("Subdivision", "SUBSURF")
        sub.levels = sub.render_levels = 1
    scenes.add_camera_and_light(scene)
    scenes.setup_cycles(scene, size=48, samples=4)
    scene.frame_start, scene.frame_end = 1, 3
    return scene, face


@pytest.mark.render
@pytest.mark.parametrize("enable, pull, subdivide", [(False, False, False), (True, False, False),
                                                     (True, True, False), (True, False, True)],
                         ids=["fine-alone-no-bake", "baked-stage", "baked-stage-with-pull",
                              "baked-subdivided"])
def test_fine_wrinkles_render_on_a_farm_as_they_do_live(tmp_path, enable, pull, subdivide):
    """Live, the shrinkage is stored at the vertices (on the corners when subdivided after);
    the bake's cache carries it as a UV map, on the corners, and the farm renders the same."""
    scene, face = _fine_scene(enable, pull, subdivide)
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))
    truth = {}
    for f in (1, 2, 3):
        scene.frame_set(f)
        scene.render.filepath = str(tmp_path / f"live_{f}.png")
        bpy.ops.render.render(write_still=True)
        truth[f] = scenes.load_png(tmp_path / f"live_{f}.png")
    # the shrinkage changes the picture: a farm that missed it would fail below
    assert np.abs(truth[3] - truth[1]).mean() > 0.01
    ev = face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    assert ev.attributes[fine_tree.SHRINKAGE_ATTR].domain == ("CORNER" if subdivide else "POINT")
    face = bpy.data.objects["Face"]
    if enable:
        bpy.context.view_layer.objects.active = face
        assert bpy.ops.wrinkle.bake() == {"FINISHED"}
        assert not list((tmp_path / "wrinkle_bake").glob("*.exr"))  # the cache alone
        bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))

    scenes.run_on_farm(FARM_SCRIPT, tmp_path / "shot.blend", tmp_path)
    assert json.loads((tmp_path / "done.json").read_text())["ok"]
    for f in (1, 2, 3):
        img = scenes.load_png(tmp_path / f"farm_{f:04d}.png")
        np.testing.assert_array_equal(img, truth[f], err_msg=f"frame {f}")


def test_bake_for_farm_of_fine_wrinkles_alone_has_nothing_to_bake(tmp_path):
    """Without geometric wrinkles there is nothing a farm could not compute: no bake runs, and
    the panel's bake says so rather than writing files."""
    scene, face = _fine_scene(enable=False, pull=False)
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))
    face = bpy.data.objects["Face"]
    bpy.context.view_layer.objects.active = face
    with pytest.raises(RuntimeError, match="nothing to bake.*computes on a farm by itself"):
        bpy.ops.wrinkle.bake()
    assert not (tmp_path / "wrinkle_bake").exists()
    assert fine_tree.find_modifier(face) is not None
