"""Operators: muscle set from landmarks, expression presets, refinement, adding muscles."""

import bpy
import numpy as np
import pytest

from tests.blender import scenes
from wrinkle_addon import muscle_objects, pipeline
from wrinkle_addon.core import presets


def test_refine_keeps_uvs_shape_keys_vertex_groups_and_materials():
    face, muscle = scenes.wrinkled_face(n_wrinkles=8)
    me = face.data
    me.uv_layers.new(name="UVMap")
    vg = face.vertex_groups.new(name="Forehead")
    vg.add(list(range(len(me.vertices))), 0.5, "REPLACE")
    mat = bpy.data.materials.new("Skin")
    me.materials.append(mat)
    n = len(me.vertices)
    bpy.context.view_layer.objects.active = face
    bpy.ops.wrinkle.refine(edges_per_half_cycle=4)
    assert len(me.vertices) > n
    assert "UVMap" in me.uv_layers and me.materials[0] == mat
    assert face.vertex_groups["Forehead"].index == vg.index
    weights = {g.weight for v in me.vertices for g in v.groups}
    assert weights == {0.5}
    keys = me.shape_keys.key_blocks
    assert [k.name for k in keys] == ["Basis", "BrowsUp"]
    brows = np.empty(len(me.vertices) * 3, np.float32)
    keys["BrowsUp"].points.foreach_get("co", brows)
    basis = np.empty_like(brows)
    keys["Basis"].points.foreach_get("co", basis)
    assert np.abs(brows - basis).max() > 0.005  # the new vertices carry the shape key too
    # every half cycle now spans at least 4 edges inside the wrinkling region
    from wrinkle_addon import meshio
    from wrinkle_addon.core import system

    core = [muscle_objects.to_core(muscle, face)]
    assert len(system.refine_edges(meshio.read_vectors(me, "position"), meshio.read_edges(me), core, 4)) == 0
    bpy.context.scene.frame_set(2)
    assert pipeline.status(face) == ""


def test_muscle_set_and_expressions():
    face = scenes.make_face()
    bpy.ops.wrinkle.enable()
    bpy.ops.wrinkle.add_landmarks()
    assert sum(ob.name.startswith("WL ") for ob in bpy.data.objects) == len(presets.LANDMARKS)
    bpy.context.view_layer.objects.active = face
    bpy.ops.wrinkle.add_muscle_set()
    muscles = muscle_objects.live_muscles(face)
    assert len(muscles) == 20
    roles = {(m.wrinkle_muscle.role, m.wrinkle_muscle.side) for m in muscles}
    assert roles == {(r, s) for r, _n, _k in presets.MUSCLES for s in "LR"}
    with pytest.raises(RuntimeError, match="already has"):
        bpy.ops.wrinkle.add_muscle_set()
    scene = bpy.context.scene
    for frame, expression in ((1, "NEUTRAL"), (10, "SURPRISE"), (20, "FROWN"), (30, "FEAR")):
        scene.frame_set(frame)
        bpy.ops.wrinkle.expression(expression=expression)
    for frame, expression in ((10, "SURPRISE"), (20, "FROWN"), (30, "FEAR"), (1, "NEUTRAL")):
        scene.frame_set(frame)
        table = presets.EXPRESSIONS[expression]
        for m in muscles:
            assert m.wrinkle_muscle.contraction == pytest.approx(table.get(m.wrinkle_muscle.role, 0.0))


def test_mirrored_pairs_are_symmetric():
    lm = presets.estimate_landmarks((-0.08, -0.1, 0.0), (0.08, 0.1, 0.25))
    layout = presets.layout(lm)
    by_key = {(role, side): pts for role, side, _k, pts in layout}
    for role, _n, _k in presets.MUSCLES:
        left, right = by_key[(role, "L")], by_key[(role, "R")]
        np.testing.assert_allclose(np.sort(left[:, 0]), np.sort(-right[:, 0]), atol=1e-12)
        assert left[:, 0].mean() > 0  # the left muscle lies on the +X side (sheets may cross the midline)


def test_add_muscle_at_cursor_gets_visible_defaults():
    face = scenes.make_face()
    bpy.ops.wrinkle.enable()
    bpy.context.scene.cursor.location = (0.0, 0.0, 0.06)
    bpy.ops.wrinkle.add_muscle(kind="LINEAR")
    muscle = bpy.context.view_layer.objects.active
    assert muscle.wrinkle_muscle.is_muscle and muscle.parent == face
    assert muscle.wrinkle_muscle.k0 > 0 and muscle.wrinkle_muscle.radius > 0
    muscle.wrinkle_muscle.contraction = 1.0
    bpy.context.scene.frame_set(2)
    off = scenes.offsets(face)
    assert np.abs(off).max() > 1e-3  # the first try gives a visible result
