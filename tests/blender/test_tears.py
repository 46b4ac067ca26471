"""Dripping tears in Blender: a Geometry Nodes teardrop that forms at a point of the face,
falls and forms again, in a water material, with no Python per frame."""

import bpy
import numpy as np
import pytest

from tests.blender import scenes
from wrinkle_addon.core.patterns import tears as core
from wrinkle_addon.glue.patterns import tears

MID = scenes.HEIGHT / 2


def _teardrop():
    face = scenes.make_face()
    bpy.context.scene.cursor.location = (0.0, -0.1, MID)
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.add_teardrop(every=2.0, lasts=1.5) == {"FINISHED"}
    ob = next(o for o in bpy.data.objects if o.name.endswith("Teardrop"))
    return face, ob


def _points(ob):
    ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    co = np.empty(len(ev.vertices) * 3, np.float32)
    ev.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def test_the_drop_is_the_formula_falls_and_forms_again():
    face, ob = _teardrop()
    assert ob.parent == face
    # on the skin, out along its normal (-Y) by the drop's widest radius
    width = tears.get_input(ob.modifiers[tears.MODIFIER_NAME], "Width")
    where = np.array(ob.matrix_world.translation)
    np.testing.assert_allclose(where, (0.0, -tears.REACH * width, MID), atol=1e-6)
    mod = ob.modifiers[tears.MODIFIER_NAME]
    values = {name: tears.get_input(mod, name) for name, *_rest in tears.INPUTS}
    scene = bpy.context.scene
    fps = scene.render.fps / scene.render.fps_base
    centres = {}
    for frame in (1, 13, 25):
        scene.frame_set(frame)
        got = _points(ob)
        tau = core.age(frame / fps, values["Start"], values["Every"], values["Lasts"])
        u, v = np.meshgrid(np.linspace(0, np.pi, tears.NU), np.linspace(0, 2 * np.pi, tears.NV),
                           indexing="ij")
        want = core.teardrop(u, v, tau, values["Width"], values["Length"], values["Speed"]).reshape(-1, 3)
        d = np.linalg.norm(got[:, None, :] - want[None, :, :], axis=2)
        assert d.min(axis=1).max() < 1e-6 and d.min(axis=0).max() < 1e-6  # the same surface
        centres[frame] = got.mean(axis=0)
    assert centres[25][2] < centres[13][2] < centres[1][2]  # it falls
    scene.frame_set(40)  # 1.67 s: past its 1.5 s
    assert len(_points(ob)) == 0
    scene.frame_set(49)  # 2.04 s: the next drop
    np.testing.assert_allclose(_points(ob).mean(axis=0), centres[1], atol=2e-4)


def test_the_water_material():
    _face, ob = _teardrop()
    mat = ob.data.materials[0]
    bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    assert bsdf.inputs["Transmission Weight"].default_value == 1.0
    assert bsdf.inputs["IOR"].default_value == pytest.approx(1.33)
    assert bsdf.inputs["Roughness"].default_value < 0.1


def test_no_drop_for_a_bad_period():
    face = scenes.make_face()
    with pytest.raises(tears.TearError, match="Every"):
        tears.add_teardrop(bpy.context, face, (0, 0, 0), Every=0.0)
