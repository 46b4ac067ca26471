"""Dripping tears in Blender: a Geometry Nodes teardrop that forms at a point of the face,
falls and forms again, in a water material, with no Python per frame."""

import math
from pathlib import Path

import bpy
import numpy as np
import pytest
from mathutils import Vector

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


@pytest.mark.parametrize("tilt_deg, axis", [(30.0, "X"), (90.0, "X"), (30.0, "Y"), (90.0, "Y")])
def test_the_drop_falls_along_the_worlds_gravity_however_the_head_is_turned(tilt_deg, axis):
    """The head (the drop's parent) is tilted, before the drop is added and again after: the
    drop's axis and its fall stay along the world's -Z, and it still forms where it was put."""
    face = scenes.make_face()
    face.rotation_euler = {"X": (math.radians(tilt_deg), 0, 0), "Y": (0, math.radians(tilt_deg), 0)}[axis]
    bpy.context.view_layer.update()
    bpy.context.scene.cursor.location = face.matrix_world @ Vector((0.0, 0.0, MID))
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.add_teardrop(every=2.0, lasts=1.5) == {"FINISHED"}
    ob = next(o for o in bpy.data.objects if o.name.endswith("Teardrop"))
    scene = bpy.context.scene
    for turn in (0.0, -0.7 * math.radians(tilt_deg)):  # and the head turned again, the drop on it
        face.rotation_euler.z = turn
        world = {}
        for frame in (1, 13, 25):
            scene.frame_set(frame)
            m = ob.matrix_world
            world[frame] = _points(ob) @ np.array(m.to_3x3()).T + np.array(m.translation)
        for pts in world.values():  # the drop's axis, from its pointed top to its round bottom
            top, bottom = pts[pts[:, 2].argmax()], pts[pts[:, 2].argmin()]
            axis_dir = (bottom - top) / np.linalg.norm(bottom - top)
            assert axis_dir[2] < -0.9999, axis_dir
            width = np.ptp(pts[:, :2], axis=0)
            assert abs(width[0] - width[1]) < 0.05 * width.max()  # round about the world's Z
        fall = world[25].mean(axis=0) - world[1].mean(axis=0)
        assert fall[2] < 0.0
        np.testing.assert_allclose(fall[:2], 0.0, atol=1e-6 + 1e-4 * abs(fall[2]))  # straight down
        mod = ob.modifiers[tears.MODIFIER_NAME]
        values = {name: tears.get_input(mod, name) for name, *_rest in tears.INPUTS}
        tau = core.age(1 / (scene.render.fps / scene.render.fps_base), values["Start"], values["Every"],
                       values["Lasts"])
        origin = np.array(ob.matrix_world.translation)  # it hangs from where it formed, falling since
        top = core.teardrop(0.0, 0.0, tau, values["Width"], values["Length"], values["Speed"])[2]
        assert abs(world[1][:, 2].max() - (origin[2] + top)) < 1e-6


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


DATA = Path(__file__).resolve().parents[2] / "wrinkle_addon" / "data" / "ict_head.npz"


def test_on_the_scanned_head_the_drop_leaves_from_under_the_chin_and_falls_free():
    """The sample's drop on the ICT head forms where the skin under the chin faces down and
    falls along the world's -Z without touching the skin, over its whole life."""
    from mathutils.bvhtree import BVHTree

    from sample_scenes import patterns
    from sample_scenes.lib import ict

    data = ict.load_ict(DATA)
    face = ict.ict_object(data, name="ICTHead")
    lm = data["landmarks"]
    patterns.add_tear(face, lm, 30)
    ob = next(o for o in bpy.data.objects if o.name.endswith("Teardrop"))
    origin = np.array(ob.matrix_world.translation)
    assert origin[2] < lm["chin"][2] and origin[2] > lm["chin"][2] - 0.04  # under the chin
    assert abs(origin[0] - lm["chin"][0]) < 0.005
    fe = face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    bvh = BVHTree.FromPolygons([v.co[:] for v in fe.vertices], [p.vertices[:] for p in fe.polygons])
    centres = []
    for frame in range(30, 30 + 3 * 24, 8):  # its 3 s
        bpy.context.scene.frame_set(frame)
        pts = _points(ob) @ np.array(ob.matrix_world.to_3x3()).T + origin
        assert len(pts)
        for p in pts:
            loc, normal, _i, _d = bvh.find_nearest(Vector(p))
            assert (Vector(p) - loc).dot(normal) > 0.0  # outside the skin
        centres.append(pts.mean(axis=0))
    c = np.array(centres)
    assert (np.diff(c[:, 2]) < 0).all()
    np.testing.assert_allclose(c[:, :2], c[:1, :2].repeat(len(c), 0), atol=1e-6)

