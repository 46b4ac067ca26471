"""Operators: muscle set from landmarks, expression presets, refinement, adding muscles."""

import bpy
import numpy as np
import pytest

from tests.blender import scenes
from wrinkle_addon.core import landmark_finder
from wrinkle_addon.core.muscles import presets
from wrinkle_addon.glue import pipeline
from wrinkle_addon.glue.muscles import muscle_objects


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
    from wrinkle_addon.core.muscles import resolution
    from wrinkle_addon.glue import meshio

    core = [muscle_objects.to_core(muscle, face)]
    rest, edges = meshio.read_vectors(me, "position"), meshio.read_edges(me)
    assert len(resolution.refine_edges(rest, edges, core, 4)) == 0
    bpy.context.scene.frame_set(2)
    assert pipeline.status_of(face) == ""


def test_muscle_set_and_expressions():
    face = scenes.make_face()
    bpy.ops.wrinkle.enable()
    bpy.ops.wrinkle.add_landmarks()
    assert sum(ob.name.startswith("WL ") for ob in bpy.data.objects) == len(landmark_finder.LANDMARKS)
    bpy.context.view_layer.objects.active = face
    bpy.ops.wrinkle.add_muscle_set()
    muscles = muscle_objects.live_muscles(face)
    expect = {(r, s) for r, _n, _k in presets.MUSCLES for s in ("C" if r in presets.MIDLINE else "LR")}
    # Zhang's ten pairs, the Orbicularis Oculi pair and two on the midline
    assert len(muscles) == len(expect) == 24
    roles = {(m.ewrinkles_muscle.role, m.ewrinkles_muscle.side) for m in muscles}
    assert roles == expect
    kinds = {m.ewrinkles_muscle.role: m.ewrinkles_muscle.kind for m in muscles}
    assert kinds["ORBICULARIS_OCULI"] == kinds["ORBICULARIS_ORIS"] == "SPHINCTER"
    assert all(muscle_objects.to_core(m, face).problem() is None for m in muscles)
    # the Frontalis' wrinkling region ends at the brows (its own span of the sheets' Ls),
    # every other sheet's at its end
    for m in muscles:
        end = m.ewrinkles_muscle.region_end
        if m.ewrinkles_muscle.role in presets.FOREHEAD:
            assert end == pytest.approx(1.0 / presets.SHEET_LENGTH, rel=0.05)
            assert muscle_objects.to_core(m, face).region_end == pytest.approx(end, rel=1e-6)
        else:
            assert end == 1.0
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
            assert m.ewrinkles_muscle.contraction == pytest.approx(table.get(m.ewrinkles_muscle.role, 0.0))


def test_mirrored_pairs_are_symmetric():
    lm = landmark_finder.estimate_landmarks((-0.08, -0.1, 0.0), (0.08, 0.1, 0.25))
    layout = presets.layout(lm)
    by_key = {(role, side): pts for role, side, _k, pts in layout}
    kinds = {role: kind for role, _n, kind in presets.MUSCLES}
    for role in presets.MIDLINE:  # one muscle, symmetric about the midline
        pts = by_key[(role, "C")]
        if kinds[role] == "SHEET":  # its corners mirror each other
            np.testing.assert_allclose(np.sort(pts[:, 0]), np.sort(-pts[:, 0]), atol=1e-12)
        else:  # a sphincter's centre on it
            assert pts[0, 0] == pytest.approx(0.0, abs=1e-12)
    for role, _n, _k in presets.MUSCLES:
        if role in presets.MIDLINE:
            continue
        left, right = by_key[(role, "L")], by_key[(role, "R")]
        np.testing.assert_allclose(np.sort(left[:, 0]), np.sort(-right[:, 0]), atol=1e-12)
        assert left[:, 0].mean() > 0  # the left muscle lies on the +X side (sheets may cross the midline)


def test_add_muscle_at_cursor_gets_visible_defaults():
    face = scenes.make_face()
    bpy.ops.wrinkle.enable()
    bpy.context.scene.cursor.location = (0.0, 0.0, 0.06)
    bpy.ops.wrinkle.add_muscle(kind="LINEAR")
    muscle = bpy.context.view_layer.objects.active
    assert muscle.ewrinkles_muscle.is_muscle and muscle.parent == face
    assert muscle.ewrinkles_muscle.k0 > 0 and muscle.ewrinkles_muscle.radius > 0
    muscle.ewrinkles_muscle.contraction = 1.0
    bpy.context.scene.frame_set(2)
    off = scenes.offsets(face)
    assert np.abs(off).max() > 1e-3  # the first try gives a visible result


def test_add_sphincter_at_cursor_pulls_and_wrinkles():
    face = scenes.make_face()
    bpy.ops.wrinkle.enable()
    bpy.context.scene.cursor.location = (0.0, 0.0, 0.06)
    assert bpy.ops.wrinkle.add_muscle(kind="SPHINCTER") == {"FINISHED"}
    muscle = bpy.context.view_layer.objects.active
    s = muscle.ewrinkles_muscle
    assert s.kind == "SPHINCTER" and muscle.parent == face
    assert len(muscle.data.vertices) == 3 + muscle_objects.RING and s.k0 > 0 and s.reach >= 1.0
    core = muscle_objects.to_core(muscle, face)
    assert core.problem() is None
    s.contraction = 1.0
    bpy.context.scene.frame_set(2)
    off = scenes.offsets(face)
    assert np.abs(off).max() > 1e-3  # drawn toward its centre: visible the first time
    assert pipeline.status_of(face) == ""


def test_a_sphincter_on_one_line_is_refused():
    scenes.make_face()
    bpy.ops.wrinkle.enable()
    pts = [0.0, 0.0, 0.06, 0.02, 0.0, 0.06, 0.04, 0.0, 0.06] + [0.0] * 3
    with pytest.raises(RuntimeError, match="must not lie on one line"):
        bpy.ops.wrinkle.add_muscle(kind="SPHINCTER", use_points=True, points=pts)
    assert not any(ob.ewrinkles_muscle.is_muscle for ob in bpy.data.objects)


class _Event:
    def __init__(self, kind, value="PRESS"):
        self.type, self.value = kind, value
        self.mouse_region_x = self.mouse_region_y = 0


class _Picker:
    """Stands in for the running operator: the modal state machine without a window."""

    def __init__(self, kind, hits):
        from wrinkle_addon.ops.muscles import WRINKLE_OT_add_muscle

        self._cls = WRINKLE_OT_add_muscle
        self.kind, self._hits = kind, list(hits)
        self._picked, self._needed = [], 2 if kind == "LINEAR" else 4
        self.points, self.use_points, self.name, self.reports, self.executed = None, False, "", [], False

    def _hint(self):
        return self._cls._hint(self)

    def _ray_cast(self, context, event):
        return self._hits.pop(0)

    def report(self, level, msg):
        self.reports.append(msg)

    def execute(self, context):
        self.executed = True
        return {"FINISHED"}

    def modal(self, context, event):
        return self._cls.modal(self, context, event)


def test_pick_on_surface_state_machine():
    context = bpy.context
    picker = _Picker("SHEET", [(0, 0, 1), None, (1, 0, 1), (1, 0, 0), (0, 0, 0)])
    assert picker.modal(context, _Event("MOUSEMOVE")) == {"PASS_THROUGH"}
    results = [picker.modal(context, _Event("LEFTMOUSE")) for _ in range(5)]
    assert results[:4] == [{"RUNNING_MODAL"}] * 4 and results[4] == {"FINISHED"}
    assert picker.reports == ["Click on the face's surface"]  # the miss was reported, not counted
    assert picker.use_points and list(picker.points) == [0, 0, 1, 1, 0, 1, 1, 0, 0, 0, 0, 0]
    assert picker.executed
    cancel = _Picker("LINEAR", [])
    assert cancel.modal(context, _Event("ESC")) == {"CANCELLED"} and not cancel.executed
