"""Limit faults: muscle settings that size the work (a stored wrinkle count of a million,
the panel's extremes, NaN), and UV layouts the UV-space wrinkles cannot use (collapsed,
bow-tie vertices, UVs collapsed after a good carve)."""

import math
import tracemalloc

import bmesh
import bpy
import numpy as np
import pytest

from tests.blender import scenes
from tests.blender.test_curves import add_curve, uv_face
from tests.blender.test_fine import _carve
from wrinkle_addon.glue import pipeline, registry, status, surface
from wrinkle_addon.glue.bando import fine as fine_glue


def _source(name):
    return next(s for s in registry.sources() if s.name == name)


def _static(face, name):
    """The source's static data, built as the frame stage builds it."""
    s = surface.Surface(face, need_uv=False)
    mesh = registry.MeshArrays(s.rest, s.edges, s.tris)
    return _source(name).build(face, mesh, {o.session_uid for o in bpy.context.scene.objects})


def _full_check():
    pipeline.update_scene(bpy.context.scene, bpy.context.evaluated_depsgraph_get())


# --- 4: a muscle's settings size the work by the mesh, never beyond ----------------------
def _peak_mb(run):
    tracemalloc.start()
    try:
        run()
        return tracemalloc.get_traced_memory()[1] / 1e6
    finally:
        tracemalloc.stop()


def test_a_stored_million_wrinkles_builds_in_bounded_memory_and_says_so():
    face, muscle = scenes.wrinkled_face()
    face.data.shape_keys.key_blocks["BrowsUp"].value = 1.0
    muscle.ewrinkles_muscle["n_wrinkles"] = 10**6  # as a crafted file stores it: no min/max
    assert muscle.ewrinkles_muscle.n_wrinkles == 10**6
    peak = _peak_mb(_full_check)
    assert peak < 200  # the face has 2,800 vertices; the grid alone took 24 GB
    message = status.get(face, "muscles")
    assert '"Frontalis" asks for 1000000 wrinkles, more than the mesh can show' in message
    static = _static(face, "muscles")
    (i, asked, built), = static.plan.limits
    # a wrinkle per two edges along the region: the sheet's region is 0.6 Ls = 0.047 long
    # over edges of 2 mm
    assert asked == 10**6 and 5 <= built <= 15 and f"it shows {built}." in message
    assert len(static.plan.smooth_norm) <= 4 * len(static.plan.row_vert)
    assert np.isfinite(scenes.offsets(face)).all() and np.abs(scenes.offsets(face)).max() > 0


def test_the_panel_extremes_build_a_grid_bounded_by_the_region():
    """1000 wrinkles, Wrinkling Region 0.97 and an angle of pi, all within the panel's
    ranges: one build took 5 minutes and 15 GB."""
    face = scenes.make_face()
    bpy.ops.wrinkle.enable()
    bpy.ops.wrinkle.add_muscle(kind="LINEAR", use_points=True,
                               points=(0.0, 0.0, 0.04, 0.03, 0.0, 0.04) + (0.0,) * 6, name="Wide")
    muscle = bpy.context.view_layer.objects.active
    s = muscle.ewrinkles_muscle
    s.n_wrinkles, s.lambda_w, s.angle, s.radius = 1000, 0.97, math.pi, 0.06
    bpy.context.view_layer.objects.active = face
    static = _static(face, "muscles")
    plan = static.plan
    assert plan.region_sizes[0] > 0
    assert len(plan.smooth_norm) <= 4 * len(plan.row_vert)
    (_i, asked, built), = plan.limits
    assert asked == 1000 and 1 <= built < 10
    assert _peak_mb(lambda: _static(face, "muscles")) < 50
    _full_check()
    assert "it shows" in status.get(face, "muscles")


def test_nan_muscle_settings_are_named_in_the_panel_and_keep_one_key():
    face, muscle = scenes.wrinkled_face()
    nan = float("nan")
    muscle.ewrinkles_muscle.k0 = nan  # a FloatProperty lets NaN through
    muscle.ewrinkles_muscle.width = nan
    src = _source("muscles")
    in_scene = {o.session_uid for o in bpy.context.scene.objects}
    assert src.static_key(face, in_scene) == src.static_key(face, in_scene)  # no rebuild every frame
    _full_check()
    message = status.get(face, "muscles")
    assert '"Frontalis": Width Ws, Furrow Depth are not numbers (NaN) and cannot be used.' in message
    assert np.isfinite(scenes.offsets(face)).all()
    muscle.ewrinkles_muscle.k0, muscle.ewrinkles_muscle.width = 0.0008, 0.1
    _full_check()
    assert "NaN" not in status.get(face, "muscles")


# --- 13: UV layouts the fine wrinkles and the curves cannot use --------------------------
def _collapse(face, layer=None):
    me = face.data
    layer = layer or me.uv_layers[0]
    layer.uv.foreach_set("vector", np.full(len(me.loops) * 2, 0.5, np.float32))
    me.update()


def _bowtie_face():
    """The test forehead with one more triangle hanging on a corner vertex: a bow-tie."""
    face = uv_face(shape_key=False, enable=False)
    me = face.data
    bm = bmesh.new()
    bm.from_mesh(me)
    bm.verts.ensure_lookup_table()
    v0 = bm.verts[0]
    a = bm.verts.new((v0.co.x - 0.01, 0.0, v0.co.z + 0.005))
    b = bm.verts.new((v0.co.x - 0.01, 0.0, v0.co.z + 0.015))
    bm.faces.new((v0, a, b))
    uv = bm.loops.layers.uv.active
    for f in bm.faces:
        for loop in f.loops:
            co = loop.vert.co
            loop[uv].uv = ((co.x + 0.09) / 0.2, (co.z + 0.02) / 0.12)
    bm.to_mesh(me)
    bm.free()
    rest = np.array([v.co for v in me.vertices])
    face.shape_key_add(name="Basis")
    key = face.shape_key_add(name="BrowsUp")
    key.points.foreach_set("co", scenes.squash_vertical(rest, 0.7, scenes.HEIGHT).astype(np.float32).ravel())
    bpy.context.view_layer.objects.active = face
    bpy.ops.wrinkle.enable()
    return face


def test_carve_refuses_a_collapsed_uv_map_and_changes_nothing():
    face = uv_face(with_uv=False)
    face.data.uv_layers.new(name="Fresh")
    _collapse(face)
    with pytest.raises(RuntimeError, match='The UV map "Fresh" of "Face" is collapsed'):
        _carve(face)
    assert face.ewrinkles_face.fine_wrinkles.image_1 is None
    assert face.data.attributes.get(fine_glue.FIELD_ATTRS[0]) is None


def test_carve_and_the_curves_refuse_bow_tie_vertices_with_a_message():
    face = _bowtie_face()
    with pytest.raises(RuntimeError, match="bow-tie vertices .vertex 0 is one."):
        _carve(face)
    assert face.ewrinkles_face.fine_wrinkles.image_1 is None
    add_curve(face)
    _full_check()
    assert "bow-tie" in status.get(face, "curves")


def test_uvs_collapsed_after_a_good_carve_are_reported_and_agree_after_reopening(tmp_blend):
    face = uv_face()
    assert _carve(face) == {"FINISHED"}
    add_curve(face)
    _full_check()
    assert status.get(face, "fine_wrinkles") == "" and status.get(face, "curves") == ""
    _collapse(face)
    _full_check()
    fine_message, curve_message = status.get(face, "fine_wrinkles"), status.get(face, "curves")
    assert fine_message.startswith('Fine wrinkles: The UV map "UVMap" of "Face" is collapsed')
    assert curve_message.startswith('Wrinkle curves: The UV map "UVMap" of "Face" is collapsed')
    with pytest.raises(RuntimeError, match="is collapsed"):
        bpy.ops.wrinkle.bake_wrinkle_map(resolution="512", mode="MUSCLES")
    path = str(tmp_blend("collapsed"))
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    face = bpy.data.objects["Face"]
    _full_check()
    assert status.get(face, "fine_wrinkles") == fine_message
    assert status.get(face, "curves") == curve_message


def test_a_uv_edit_in_edit_mode_is_noticed_on_the_next_viewport_frame():
    face = uv_face()
    assert _carve(face) == {"FINISHED"}
    bpy.context.scene.frame_set(1)
    assert status.get(face, "fine_wrinkles") == ""
    bpy.ops.object.mode_set(mode="EDIT")
    bm = bmesh.from_edit_mesh(face.data)
    uv = bm.loops.layers.uv.active
    for f in bm.faces:
        for loop in f.loops:
            loop[uv].uv = (0.5, 0.5)
    bmesh.update_edit_mesh(face.data)
    bpy.ops.object.mode_set(mode="OBJECT")
    bpy.context.scene.frame_set(2)
    assert "is collapsed" in status.get(face, "fine_wrinkles")
