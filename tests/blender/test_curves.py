"""Large-scale wrinkles along curves (Bando et al. 2002, §6-7) on a face in Blender: the
operators make curves on the skin, the frame stage raises eq. 2's profile modulated by the
shrinkage across the curve, and bad input gets a clear message and changes nothing."""

import bpy
import numpy as np
import pytest

from tests.blender import scenes
from wrinkle_addon.core.bando import curves as core_curves
from wrinkle_addon.glue import pipeline, status

MID = scenes.HEIGHT / 2


def uv_face(uv_scale=1.0, with_uv=True, shape_key=True, enable=True):
    """The test forehead with a planar UV map (x, z) over the 0-1 square (times ``uv_scale``),
    wrinkles enabled."""
    face = scenes.make_face(shape_key=shape_key)
    if with_uv:
        me = face.data
        layer = me.uv_layers.new(name="UVMap")
        co = np.array([v.co for v in me.vertices])
        corner = np.empty(len(me.loops), np.int32)
        me.loops.foreach_get("vertex_index", corner)
        uv = np.stack([(co[:, 0] + scenes.WIDTH / 2) / scenes.WIDTH, co[:, 2] / scenes.HEIGHT], 1)
        layer.uv.foreach_set("vector", (uv[corner] * uv_scale).astype(np.float32).ravel())
    if enable:
        bpy.ops.wrinkle.enable()
    return face


def add_curve(face, depth=0.001, width=0.002, rest_height=0.3):
    bpy.context.scene.cursor.location = (0.0, 0.0, MID)
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.add_curve(length=0.4) == {"FINISHED"}
    ob = face.ewrinkles_face.wrinkle_curves.items[-1].object
    s = ob.ewrinkles_curve
    s.depth, s.width, s.rest_height = depth, width, rest_height
    return ob


def heights(face):
    """The offsets along the face's normal (-Y): the curve source's heights, after an
    interactive edit (what the depsgraph handler does in the interface; it does nothing in
    background mode, so it is called here)."""
    bpy.context.view_layer.update()
    pipeline.update_scene(bpy.context.scene, bpy.context.evaluated_depsgraph_get(), only_if_changed=True)
    bpy.context.view_layer.update()
    return -scenes.offsets(face)[:, 1]


def test_a_curve_raises_a_sharp_furrow_with_round_bulges_deepening_as_the_skin_shrinks():
    face = uv_face()
    ob = add_curve(face)
    assert ob.parent == face and ob.ewrinkles_curve.is_curve
    bpy.context.scene.frame_set(1)
    rest = np.array([v.co for v in face.data.vertices])
    h = heights(face)
    centre = np.isclose(rest[:, 0], rest[np.argmin(np.abs(rest[:, 0])), 0])  # the middle column
    l = np.abs(rest[centre, 2] - MID)
    expected = 0.3 * core_curves.profile(l, 0.001, 0.002) * core_curves.window(l, 0.002)
    np.testing.assert_allclose(h[centre], expected, atol=2e-6)  # the furrow and both bulges
    assert h.min() == pytest.approx(expected.min(), rel=0.02) and expected.min() < -0.8e-4
    far = np.abs(rest[:, 2] - MID) > 10 * 0.002 + 1e-3
    assert np.all(h[far] == 0.0)
    face.data.shape_keys.key_blocks["BrowsUp"].value = 1.0  # shrinks the skin across the curve
    deeper = heights(face)
    assert deeper.min() < 1.3 * h.min()  # M(s) grows with the shrinkage


def test_editing_the_curve_or_its_width_updates_the_face():
    face = uv_face()
    ob = add_curve(face)
    before = heights(face)
    ob.ewrinkles_curve.width = 0.004
    wider = heights(face)
    assert np.count_nonzero(wider) > 1.5 * np.count_nonzero(before)
    ob.location.z += 0.01  # the whole curve moves up the face
    moved = heights(face)
    rest = np.array([v.co for v in face.data.vertices])
    assert rest[np.argmin(moved), 2] == pytest.approx(MID + 0.01, abs=0.003)


def test_curve_from_selected_edges():
    face = uv_face()
    me = face.data
    co = np.array([v.co for v in me.vertices])
    row = np.isclose(co[:, 2], co[np.argmin(np.abs(co[:, 2] - MID)), 2]) & (np.abs(co[:, 0]) < 0.03)
    ev = np.empty(len(me.edges) * 2, np.int32)
    me.edges.foreach_get("vertices", ev)
    ev = ev.reshape(-1, 2)
    sel = row[ev].all(axis=1)
    me.edges.foreach_set("select", sel)
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.curve_from_edges() == {"FINISHED"}
    ob = face.ewrinkles_face.wrinkle_curves.items[-1].object
    assert len(ob.data.splines[0].bezier_points) == row.sum()
    assert heights(face).min() < 0.0


def test_curve_from_edges_refuses_a_branching_selection():
    face = uv_face()
    face.data.edges.foreach_set("select", np.ones(len(face.data.edges), bool))
    bpy.context.view_layer.objects.active = face
    with pytest.raises(RuntimeError, match="branch"):
        bpy.ops.wrinkle.curve_from_edges()
    assert len(face.ewrinkles_face.wrinkle_curves.items) == 0


def _message(face):
    return status.get(face, "curves")


def test_no_uv_map_gets_a_message_and_no_change():
    face = uv_face(with_uv=False)
    add_curve(face)
    assert np.all(heights(face) == 0.0)
    assert "no UV map" in _message(face)


def test_a_curve_outside_the_uv_square_gets_a_message():
    face = uv_face(uv_scale=3.0)
    add_curve(face)
    assert np.all(heights(face) == 0.0)
    assert "outside the 0-1 UV square" in _message(face)


def test_a_curve_off_the_surface_gets_a_message():
    face = uv_face()
    ob = add_curve(face)
    assert heights(face).min() < 0.0
    ob.location.y -= 0.05  # 5 cm in front of the face
    assert np.all(heights(face) == 0.0)
    assert "off the surface" in _message(face)
    ob.location.y += 0.05
    assert heights(face).min() < 0.0 and _message(face) == ""


def test_zero_length_curve_and_zero_width_get_messages():
    face = uv_face()
    ob = add_curve(face)
    ob.ewrinkles_curve.width = 0.0
    assert np.all(heights(face) == 0.0)
    assert "width" in _message(face).lower()
    ob.ewrinkles_curve.width = 0.002
    pts = ob.data.splines[0].bezier_points
    for bp in pts:
        bp.handle_left_type = bp.handle_right_type = "FREE"  # automatic handles would move
        bp.co = bp.handle_left = bp.handle_right = pts[0].co.copy()
    ob.data.update_tag()
    assert np.all(heights(face) == 0.0)
    assert "length" in _message(face).lower() or "zero" in _message(face).lower()


def test_the_curves_survive_saving_and_reopening(tmp_blend):
    face = uv_face()
    add_curve(face)
    bpy.context.scene.frame_set(1)
    before = heights(face)
    path = str(tmp_blend("curves"))
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    face = bpy.data.objects["Face"]
    assert len(face.ewrinkles_face.wrinkle_curves.items) == 1
    bpy.context.scene.frame_set(1)
    np.testing.assert_allclose(heights(face), before, atol=1e-7)


def test_bake_wrinkle_map_bakes_the_curves():
    from wrinkle_addon.glue.maps import map_bake

    face = uv_face()
    add_curve(face, rest_height=0.0)
    formed = map_bake.bake_height(face, "MUSCLES")  # no muscles: the curves alone, fully formed
    rest = np.array([v.co for v in face.data.vertices])
    assert formed.min() < -0.25e-3 and formed.max() > 0.0  # S(1 mm) = -0.3 d: the nearest row
    assert rest[np.argmin(formed), 2] == pytest.approx(MID, abs=0.003)
    assert np.all(map_bake.bake_height(face, "POSE") == 0.0)  # r = 0 at rest: nothing this frame
    face.data.shape_keys.key_blocks["BrowsUp"].value = 1.0
    bpy.context.view_layer.update()
    posed = map_bake.bake_height(face, "POSE")
    assert formed.min() < posed.min() < 0.0
    pd = map_bake.bake_wrinkle_map(face, 128, "MUSCLES")
    assert np.abs(pd[..., :2] - 0.5).max() > 0.05  # the map shows the furrow's slopes


def test_an_animated_enable_switches_the_wrinkle_frame_by_frame():
    """Viewport frames: a curve keyed off, then on, appears on the frame it is enabled."""
    face = uv_face()
    ob = add_curve(face)
    s = ob.ewrinkles_curve
    s.enabled = False
    s.keyframe_insert("enabled", frame=1)
    s.enabled = True
    s.keyframe_insert("enabled", frame=5)
    shown = {}
    for f in range(1, 8):
        bpy.context.scene.frame_set(f)
        bpy.context.view_layer.update()
        shown[f] = float(np.abs(scenes.evaluated_positions(face) - _skin(face)).max())
    assert shown[1] == 0.0 and shown[4] == 0.0
    assert shown[5] > 1e-5 and shown[7] > 1e-5


def _skin(face):
    ev = face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    out = np.empty((len(ev.vertices), 3), np.float32)
    ev.attributes["wrinkle_skin"].data.foreach_get("vector", out.ravel())
    return out


@pytest.mark.skipif(bpy.app.version < (5, 0, 0),
                    reason="bpy 4.5 cannot add annotation strokes from Python (strokes.new is missing)")
def test_curve_from_an_annotation_stroke():
    face = uv_face()
    scene = bpy.context.scene
    gp = bpy.data.annotations.new("Annotations")
    scene.annotation = gp
    stroke = gp.layers.new("Note").frames.new(1).strokes.new()
    xs = np.linspace(-0.03, 0.03, 15)
    pts = np.stack([xs, np.full_like(xs, -0.002), MID + 0.004 * np.sin(60 * xs)], 1)  # just off the skin
    stroke.points.add(len(pts))
    stroke.points.foreach_set("co", pts.astype(np.float32).ravel())
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.curve_from_stroke() == {"FINISHED"}
    ob = face.ewrinkles_face.wrinkle_curves.items[-1].object
    co = np.array([p.co for p in ob.data.splines[0].bezier_points])
    assert len(co) >= 2 and np.abs(co[:, 1]).max() < 1e-6  # snapped onto the skin (y = 0)
    assert heights(face).min() < 0.0


def test_curve_from_stroke_without_a_stroke_says_so():
    face = uv_face()
    bpy.context.view_layer.objects.active = face
    with pytest.raises(RuntimeError, match="No annotation stroke"):
        bpy.ops.wrinkle.curve_from_stroke()


def test_refine_splits_the_edges_around_a_curve_only():
    from wrinkle_addon.core.bando import curves as core_curves
    from wrinkle_addon.glue import meshio

    face = uv_face()
    ob = add_curve(face, width=0.003)
    before = len(face.data.vertices)
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.refine() == {"FINISHED"}  # no muscles: the curves' rule alone
    rest = meshio.read_vectors(face.data, "position").astype(np.float64)
    edges = meshio.read_edges(face.data).astype(np.int64)
    from wrinkle_addon.glue import curve_objects

    limit = core_curves.edge_limits(rest, edges, curve_objects.face_space_samples(ob, face), [0.003])
    length = np.linalg.norm(rest[edges[:, 1]] - rest[edges[:, 0]], axis=1)
    assert np.all(length <= limit + 1e-9)
    assert before < len(face.data.vertices) < 3 * before  # refined around the curve, not everywhere
    far = np.abs(rest[:, 2] - MID) > 0.035
    assert far.sum() > 0 and np.isinf(limit[far[edges].all(axis=1)]).all()
    assert heights(face).min() < 0.0  # the curve still raises its wrinkle on the finer mesh


def test_refine_without_muscles_or_curves_says_so():
    face = uv_face()
    bpy.context.view_layer.objects.active = face
    with pytest.raises(RuntimeError, match="no muscles, wrinkle curves or pattern layers"):
        bpy.ops.wrinkle.refine()
