"""Bake for Farm with fine wrinkles: their per-frame shrinkage is baked into an image
sequence, so a farm with no add-on renders the fine wrinkles as the live face does."""

import json
import textwrap

import bpy
import numpy as np
import pytest

from tests.blender import scenes
from tests.blender.test_curves import uv_face
from wrinkle_addon.glue.bando import fine as fine_glue

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


def _fine_scene():
    """The forehead patch with fine wrinkles carved, its BrowsUp ramping 0 -> 1 over frames
    1..3 (the shrinkage across the furrows grows), the muscles' geometric stage off: the
    fine wrinkles alone, a camera, a raking light."""
    scene = bpy.context.scene
    face = uv_face()
    fs = face.ewrinkles_face.fine_wrinkles
    fs.resolution, fs.rest_height, fs.distance, fs.strength = "512", 0.0, 0.001, 2.0
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.carve_fine() == {"FINISHED"}
    scenes.animate_shape_key(face, [(1, 0.0), (3, 1.0)])
    scenes.add_camera_and_light(scene)
    scenes.setup_cycles(scene, size=48, samples=4)
    scene.frame_start, scene.frame_end = 1, 3
    return scene, face


def test_baking_writes_the_shrinkage_of_every_frame_and_free_bake_goes_back(tmp_path):
    scene, face = _fine_scene()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))
    face = bpy.data.objects["Face"]
    bpy.context.view_layer.objects.active = face
    live = {}
    for f in (1, 3):
        scene.frame_set(f)
        live[f] = fine_glue._shrinkage_now(face, len(face.data.vertices))
    assert live[3][0].max() > 0.1 and np.abs(live[1]).max() < 1e-4
    assert bpy.ops.wrinkle.bake() == {"FINISHED"}
    files = sorted(p.name for p in (tmp_path / "wrinkle_bake").glob("*_fine_shrinkage_*.exr"))
    assert files == [f"Face_fine_shrinkage_{f:04d}.exr" for f in (1, 2, 3)]
    nt = face.ewrinkles_face.fine_wrinkles.material.node_tree
    tex = nt.nodes[fine_glue.BAKE_NODE]
    assert tex.image.source == "SEQUENCE" and tex.image.filepath.startswith("//")
    assert nt.nodes[fine_glue.GROUP_NODE].inputs["Use Baked"].default_value == 1.0
    # the baked frame 3 holds the live shrinkage (read back at the vertices' UVs)
    img = bpy.data.images.load(str(tmp_path / "wrinkle_bake" / files[2]), check_existing=False)
    px = np.empty(img.size[0] * img.size[1] * 4, np.float32)
    img.pixels.foreach_get(px)
    px = px.reshape(img.size[1], img.size[0], 4)
    me = face.data
    uv = np.empty(len(me.loops) * 2, np.float32)
    me.uv_layers.active.uv.foreach_get("vector", uv)
    corner = np.empty(len(me.loops), np.int32)
    me.loops.foreach_get("vertex_index", corner)
    uv = uv.reshape(-1, 2)
    inner = (uv > 0.05).all(axis=1) & (uv < 0.95).all(axis=1)
    i = np.clip((uv[inner] * img.size[0]).astype(int), 0, img.size[0] - 1)
    got = px[i[:, 1], i[:, 0], 0]
    np.testing.assert_allclose(got, live[3][0][corner[inner]], atol=0.03)
    assert bpy.ops.wrinkle.free_bake() == {"FINISHED"}
    assert fine_glue.BAKE_NODE not in nt.nodes
    assert nt.nodes[fine_glue.GROUP_NODE].inputs["Use Baked"].default_value == 0.0


@pytest.mark.render
def test_fine_wrinkles_render_on_a_farm_as_they_do_live(tmp_path):
    scene, face = _fine_scene()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))
    truth = {}
    for f in (1, 3):
        scene.frame_set(f)
        scene.render.filepath = str(tmp_path / f"live_{f}.png")
        bpy.ops.render.render(write_still=True)
        truth[f] = scenes.load_png(tmp_path / f"live_{f}.png")
    # the shrinkage changes the picture: a farm that missed it would fail below
    assert np.abs(truth[3] - truth[1]).mean() > 0.01
    face = bpy.data.objects["Face"]
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.bake() == {"FINISHED"}
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))

    scenes.run_on_farm(FARM_SCRIPT, tmp_path / "shot.blend", tmp_path)
    assert json.loads((tmp_path / "done.json").read_text())["ok"]
    for f in (1, 3):
        img = scenes.load_png(tmp_path / f"farm_{f:04d}.png")
        diff = np.abs(img - truth[f])
        # measured on bpy 4.5: 1e-5 mean against 0.048 between frames 1 and 3
        assert diff.mean() < 0.2 * np.abs(truth[3] - truth[1]).mean(), (f, diff.mean())
