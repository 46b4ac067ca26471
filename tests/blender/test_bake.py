"""Farm-safe bake: the baked file renders identically with no add-on installed."""

import json
import textwrap

import bpy
import numpy as np
import pytest

from tests.blender import scenes

FARM_SCRIPT = textwrap.dedent("""
    import json, sys
    import bpy
    import numpy as np
    blend, out = sys.argv[-2], sys.argv[-1]
    bpy.ops.wm.open_mainfile(filepath=blend)
    assert "wrinkle_addon" not in sys.modules, "the add-on must not be loaded on the farm"
    assert not any("wrinkle" in getattr(h, "__module__", "") for h in bpy.app.handlers.frame_change_post)
    scene = bpy.context.scene
    baked = bpy.data.objects["Face Baked"]
    positions = {}
    for f in range(scene.frame_start, scene.frame_end + 1):
        scene.frame_set(f)
        ev = baked.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
        co = np.empty(len(ev.vertices) * 3, np.float32)
        ev.attributes["position"].data.foreach_get("vector", co)
        positions[f] = co.tolist()
    scene.render.filepath = out + "/farm_####"
    bpy.ops.render.render(animation=True)
    json.dump(positions, open(out + "/positions.json", "w"))
    bpy.ops.wm.read_factory_settings(use_empty=True)
""")


@pytest.mark.render
def test_bake_renders_without_the_addon(tmp_path):
    scene, face = scenes.animated_render_scene(3)
    truth_pos, truth_img = {}, {}
    for f in (1, 2, 3):
        scene.frame_set(f)
        truth_pos[f] = scenes.evaluated_positions(face).copy()
        scene.render.filepath = str(tmp_path / f"live_{f}.png")
        bpy.ops.render.render(write_still=True)
        truth_img[f] = scenes.load_png(tmp_path / f"live_{f}.png")
    blend = tmp_path / "shot.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))
    face = bpy.data.objects["Face"]
    bpy.context.view_layer.objects.active = face
    bpy.ops.wrinkle.bake()
    assert (tmp_path / "wrinkle_bake" / "Face.abc").exists()
    assert face.hide_render and face.ewrinkles_face.bake_object.name == "Face Baked"
    bpy.ops.wm.save_as_mainfile(filepath=str(blend))

    scenes.run_on_farm(FARM_SCRIPT, blend, tmp_path)
    farm = json.loads((tmp_path / "positions.json").read_text())
    for f in (1, 2, 3):
        got = np.array(farm[str(f)], np.float32).reshape(-1, 3)
        np.testing.assert_allclose(got, truth_pos[f], atol=1e-6, err_msg=f"frame {f}")
        img = scenes.load_png(tmp_path / f"farm_{f:04d}.png")
        assert np.abs(img - truth_img[f]).max() < 2e-3, f"farm render of frame {f}"


def test_free_bake_restores_live_rendering(tmp_path):
    face, _muscle = scenes.wrinkled_face()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "a.blend"))
    face = bpy.data.objects["Face"]
    bpy.context.view_layer.objects.active = face
    bpy.ops.wrinkle.bake(frame_start=1, frame_end=2)
    bpy.ops.wrinkle.free_bake()
    assert not face.hide_render and face.ewrinkles_face.bake_object is None
    assert "Face Baked" not in bpy.data.objects


def test_bake_needs_a_saved_file():
    scenes.wrinkled_face()
    with pytest.raises(RuntimeError, match="Save the .blend"):
        bpy.ops.wrinkle.bake()
