"""Pattern-function layers in Blender: a stack of layers on the face, each a pattern in the
frame of an Empty, damped toward its region's border, summed with the other sources."""

import bpy
import numpy as np
import pytest

from tests.blender import scenes
from tests.blender.test_curves import heights
from wrinkle_addon.core.patterns import functions as patterns
from wrinkle_addon.glue.patterns import pattern_layers as glue

MID = scenes.HEIGHT / 2


def _face(enable=True):
    face = scenes.make_face()
    if enable:
        assert bpy.ops.wrinkle.enable() == {"FINISHED"}
    return face


def _add(face, kind="FOREHEAD", at=(0.0, -0.2, MID)):
    bpy.context.scene.cursor.location = at
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.add_pattern(kind=kind, where="CURSOR") == {"FINISHED"}
    st = face.ewrinkles_face.patterns
    return st.layers[st.active]


def _rest(face):
    return np.array([v.co for v in face.data.vertices])


def _expected(face, lay, t):
    """The layer's heights from the formula: the pattern at the vertices' frame coordinates,
    times the radius damping, times the frame's size."""
    rest = _rest(face)
    m = np.array(lay.frame.matrix_world.inverted() @ face.matrix_world)
    local = rest @ m[:3, :3].T + m[:3, 3]
    centre = np.array(lay.frame.matrix_world.translation)
    damp = patterns.damping_radius(np.linalg.norm(rest - centre, axis=1), lay.radius, lay.border)
    spec = patterns.spec(lay.kind, lay.shape)
    p = {q.key: getattr(lay, q.prop) for q in spec.params}
    f = patterns.pattern(lay.kind, local[:, 0], local[:, 1], t, shape=lay.shape, **p)
    return f * damp * lay.frame.matrix_world.col[2].xyz.length


def test_a_layer_added_at_the_cursor_sits_on_the_skin_facing_out_and_follows_its_formula():
    face = _face()
    lay = _add(face)
    ob = lay.frame
    assert ob is not None and ob.type == "EMPTY"
    z = np.array(ob.matrix_world.col[2].xyz.normalized())
    np.testing.assert_allclose(z, [0.0, -1.0, 0.0], atol=1e-6)  # the patch faces -Y
    assert abs(ob.matrix_world.translation.y) < 1e-6  # on the skin, not at the cursor
    assert lay.follow_scene and lay.kind == "FOREHEAD"
    scene = bpy.context.scene
    scene.frame_set(1)
    h = heights(face)
    t = lay.speed * 1 / (scene.render.fps / scene.render.fps_base)
    want = _expected(face, lay, t)
    np.testing.assert_allclose(h, want, atol=2e-7)
    assert np.abs(h).max() > 2e-4  # visible: furrows of a few tenths of a millimetre
    far = np.linalg.norm(_rest(face) - np.array(ob.matrix_world.translation), axis=1) > lay.radius
    assert far.any() and (h[far] == 0.0).all()


def test_moving_the_frame_moves_the_pattern_and_the_scene_time_runs_it():
    face = _face()
    lay = _add(face, "CHEEK")
    assert lay.shape == "FACE" and not lay.follow_scene  # the smile's fold: it does not run
    lay.shape, lay.follow_scene = "PAPER", True  # the paper's ripples run
    scene = bpy.context.scene
    scene.frame_set(1)
    before = heights(face)
    lay.frame.location.x += 0.02
    moved = heights(face)
    assert np.abs(moved - before).max() > 0.3 * np.abs(before).max() > 0
    np.testing.assert_allclose(moved, _expected(face, lay, lay.speed / 24.0 * 1), atol=2e-7)
    scene.frame_set(13)
    assert np.abs(heights(face) - moved).max() > 0.2 * np.abs(moved).max()  # the ripples run
    lay.follow_scene = False
    lay.time = 0.5
    a = heights(face)
    lay.time = 0.5 + 2 * np.pi  # a running cycle repeats
    np.testing.assert_allclose(heights(face), a, atol=1e-7)


def _builds(face):
    """The build serial number of the patterns' static data (``glue.pipeline``'s cache)."""
    from wrinkle_addon.glue import pipeline

    return pipeline._cache[face.session_uid].statics["patterns"][2]


@pytest.mark.parametrize("region", ["RADIUS", "GROUP"])
def test_an_animated_frame_places_the_pattern_every_frame_without_rebuilding_the_layer(region):
    """Turning and scaling the frame (and, for a vertex-group region, moving it) changes only
    where the pattern lies: every frame places it again from the region's rest positions,
    the region itself is not rebuilt.  The heights are those of the formula at every frame."""
    face = _face()
    lay = _add(face, "CHEEK")
    lay.shape, lay.follow_scene = "PAPER", False
    if region == "GROUP":
        group = face.vertex_groups.new(name="Region")
        group.add(list(range(len(face.data.vertices))), 1.0, "REPLACE")
        lay.region, lay.vertex_group = "GROUP", "Region"
    ob = lay.frame
    base = ob.matrix_world.copy()
    for frame, turn, size, shift in ((1, 0.0, 1.0, 0.0), (5, 0.6, 1.3, 0.01)):
        ob.rotation_euler.z = turn
        ob.scale = (size, size, size)
        if region == "GROUP":
            ob.location.x = base.translation.x + shift
        for path in ("rotation_euler", "scale", "location"):
            ob.keyframe_insert(path, frame=frame)
    scene = bpy.context.scene
    scene.frame_set(1)
    first = heights(face)
    built = _builds(face)
    for f in (2, 3, 4, 5):
        scene.frame_set(f)
        h = heights(face)
        if region == "RADIUS":
            np.testing.assert_allclose(h, _expected(face, lay, lay.time), atol=2e-7)
        assert _builds(face) == built, f"rebuilt on frame {f}"
    assert np.abs(h - first).max() > 0.1 * np.abs(first).max() > 0  # the pattern moved
    # a rebuild from scratch gives the same heights
    from wrinkle_addon.glue import pipeline

    pipeline.forget(face)
    np.testing.assert_allclose(heights(face), h, atol=1e-9)


def test_moving_a_radius_frame_over_the_face_rebuilds_its_region():
    face = _face()
    lay = _add(face, "CHEEK")
    scene = bpy.context.scene
    scene.frame_set(1)
    built = _builds(face)
    lay.frame.location.x += 0.02
    h = heights(face)
    assert _builds(face) != built
    assert not lay.follow_scene  # the cheek's fold does not run: t is its time
    np.testing.assert_allclose(h, _expected(face, lay, lay.time), atol=2e-7)


def test_strength_follows_a_shape_key_a_muscle_or_the_compression():
    face = _face()
    lay = _add(face)
    lay.follow_scene = False
    key = face.data.shape_keys.key_blocks["BrowsUp"]
    lay.drive, lay.drive_shape_key = "SHAPE_KEY", "BrowsUp"
    key.value = 0.0
    assert np.abs(heights(face)).max() == 0.0
    key.value = 0.5
    half = heights(face)
    key.value = 1.0
    full = heights(face)
    assert np.abs(full).max() > 0 and np.allclose(half, 0.5 * full, atol=1e-7)
    lay.drive = "COMPRESSION"  # BrowsUp squashes the forehead vertically
    lay.full_compression = 1.0
    key.value = 0.0
    assert np.abs(heights(face)).max() == 0.0
    key.value = 1.0
    squashed = heights(face)
    assert 0 < np.abs(squashed).max() < np.abs(full).max() * 1.01


def test_hidden_layers_and_the_stack_operators():
    face = _face()
    lay = _add(face)
    lay.follow_scene = False
    base = heights(face)
    lay.show_viewport = False
    assert np.abs(heights(face)).max() == 0.0
    lay.show_viewport = True
    assert bpy.ops.wrinkle.duplicate_pattern() == {"FINISHED"}
    st = face.ewrinkles_face.patterns
    assert len(st.layers) == 2 and st.layers[1].frame == lay.frame
    np.testing.assert_allclose(heights(face), 2 * base, atol=1e-7)  # the layers add up
    assert bpy.ops.wrinkle.move_pattern(direction="UP") == {"FINISHED"} and st.active == 0
    assert bpy.ops.wrinkle.remove_pattern() == {"FINISHED"} and len(st.layers) == 1
    np.testing.assert_allclose(heights(face), base, atol=1e-7)
    assert bpy.ops.wrinkle.mirror_pattern() == {"FINISHED"}
    mirrored = st.layers[st.active]
    assert mirrored.frame != lay.frame and mirrored.frame.matrix_world.determinant() < 0
    h = heights(face)
    rest = _rest(face)
    # the mirror image across x = 0: each vertex has a partner at -x
    order = np.lexsort((rest[:, 2], np.round(rest[:, 0], 6)))
    partner = np.lexsort((rest[:, 2], np.round(-rest[:, 0], 6)))
    np.testing.assert_allclose(h[order], h[partner], atol=1e-7)
    assert bpy.ops.wrinkle.remove_pattern() == {"FINISHED"}


def test_apply_bakes_the_layer_into_a_shape_key():
    face = _face()
    lay = _add(face, "DIMPLE")
    h = heights(face)
    assert h.min() < -1e-4  # a dip
    assert bpy.ops.wrinkle.apply_pattern() == {"FINISHED"}
    assert len(face.ewrinkles_face.patterns.layers) == 0
    key = face.data.shape_keys.key_blocks["Pattern Dimple"]
    assert key.value == 1.0
    moved = np.array([p.co for p in key.data]) - _rest(face)
    np.testing.assert_allclose(-moved[:, 1], h, atol=1e-6)
    del lay


def test_patterns_add_to_the_other_sources():
    face, _muscle = scenes.wrinkled_face()
    bpy.context.scene.frame_set(1)
    alone = heights(face)
    lay = _add(face, "FROWN")
    lay.follow_scene = False
    both = heights(face)
    lay.show_viewport = False
    assert np.abs(heights(face) - alone).max() < 1e-9
    lay.show_viewport = True
    pattern_only = both - alone
    np.testing.assert_allclose(pattern_only, _expected(face, lay, lay.time), atol=1e-6)


@pytest.mark.parametrize("breakage, message", [
    ("delete_frame", "lost its frame"),
    ("radius", "radius of 0"),
    ("empty_group", "is empty"),
    ("huge", None),
])
def test_bad_input_gets_a_message_and_no_nan(breakage, message):
    from wrinkle_addon.glue import status

    face = _face()
    lay = _add(face)
    if breakage == "delete_frame":
        bpy.data.objects.remove(lay.frame)
    elif breakage == "radius":
        lay.radius = 0.0
    elif breakage == "empty_group":
        face.vertex_groups.new(name="Nothing")
        lay.region, lay.vertex_group = "GROUP", "Nothing"
    else:
        lay.depth = 1e30
        lay.waviness = 1e30
    h = heights(face)
    assert np.isfinite(h).all()
    if message:
        assert (h == 0).all()
        assert message in status.get(face, "patterns", family=True)


def test_a_vertex_group_region_fades_to_zero_at_its_border():
    face = _face()
    lay = _add(face)
    lay.follow_scene = False
    rest = _rest(face)
    inside = np.flatnonzero(np.abs(rest[:, 0]) < 0.03)
    vg = face.vertex_groups.new(name="Middle")
    vg.add(inside.tolist(), 1.0, "REPLACE")
    lay.region, lay.vertex_group, lay.border = "GROUP", "Middle", 0.01
    h = heights(face)
    outside = np.ones(len(rest), bool)
    outside[inside] = False
    assert (h[outside] == 0).all() and np.abs(h[inside]).max() > 1e-4
    edge = np.abs(np.abs(rest[:, 0]) - 0.03) < 0.0025
    assert np.abs(h[edge & ~outside]).max() < 0.3 * np.abs(h[inside]).max()
    assert glue.vertex_group_weights(face, "Middle").sum() == len(inside)


def test_bake_wrinkle_map_bakes_the_patterns():
    from tests.blender.test_curves import uv_face
    from wrinkle_addon.glue.maps import map_bake

    face = uv_face()
    lay = _add(face)
    lay.follow_scene = False
    lay.drive, lay.drive_shape_key = "SHAPE_KEY", "BrowsUp"  # nothing at rest
    formed = map_bake.bake_height(face, "MUSCLES")  # no muscles: the pattern alone, at full strength
    assert formed.min() < -1e-4 and formed.max() > 1e-4
    assert np.all(map_bake.bake_height(face, "POSE") == 0.0)
    face.data.shape_keys.key_blocks["BrowsUp"].value = 1.0
    bpy.context.view_layer.update()
    np.testing.assert_allclose(map_bake.bake_height(face, "POSE"), formed, atol=1e-7)
    pd = map_bake.bake_wrinkle_map(face, 128, "MUSCLES")
    assert np.abs(pd[..., :2] - 0.5).max() > 0.05  # the map shows the furrows' slopes


@pytest.mark.render
def test_a_layer_hidden_in_renders_is_not_rendered(render_small, tmp_path):
    face = _face()
    lay = _add(face)
    lay.follow_scene = False
    lay.depth = -1.0  # deep furrows, plain in a tiny render
    scene = bpy.context.scene
    scenes.add_camera_and_light(scene)
    px = {}
    for name, viewport, render in (("none", False, False), ("hidden", True, False), ("shown", True, True)):
        lay.show_viewport, lay.show_render = viewport, render
        px[name] = render_small(scene, tmp_path / f"{name}.png", size=32, samples=2)
        if name == "hidden":
            assert np.abs(heights(face)).max() > 1e-4  # the viewport shows it
    assert np.abs(px["hidden"] - px["none"]).max() < 1e-6
    assert np.abs(px["shown"] - px["none"]).max() > 0.05


def test_mirroring_swaps_the_sides_of_the_driving_shape_key_and_group():
    face = _face()
    for name in ("eyeSquint_L", "eyeSquint_R"):
        face.shape_key_add(name=name)
    for name in ("Cheek.L", "Cheek.R"):
        face.vertex_groups.new(name=name).add(list(range(len(face.data.vertices))), 1.0, "REPLACE")
    lay = _add(face, "EYE_CORNER")
    lay.drive, lay.drive_shape_key = "SHAPE_KEY", "eyeSquint_L"
    lay.region, lay.vertex_group = "GROUP", "Cheek.L"
    assert bpy.ops.wrinkle.mirror_pattern() == {"FINISHED"}
    other = face.ewrinkles_face.patterns.layers[-1]
    assert (other.drive_shape_key, other.vertex_group) == ("eyeSquint_R", "Cheek.R")
    assert glue.mirror_name("Brow_L") == "Brow_R" and glue.mirror_name("Nose") == ""


def test_layers_stay_off_the_eyelids_and_the_lips():
    """With the landmarks placed, a crow's-feet layer at the eye corner and a dimple beside the
    mouth fan over the eyelid and the lips in their frames, and leave them still."""
    from sample_scenes import patterns as sample
    from sample_scenes.lib import headgen, rigging, scene_setup
    from wrinkle_addon.core import zones
    from wrinkle_addon.glue import landmarks

    data = headgen.make_head(12000)
    face = scene_setup.mesh_object_from_arrays("Head", data["positions"], data["quads"], data["corner_uvs"])
    rigging.wrinkle_face(face, data["landmarks"], refine=False)
    face.ewrinkles_face.strength = 0.0  # the pattern layers alone
    for r in face.ewrinkles_face.muscles:
        r.object.ewrinkles_muscle.pull = 0.0
    muscle = face.ewrinkles_face.muscles[0].object
    drivers = {k: ("MUSCLE", muscle) for k in ("EYE_CORNER", "DIMPLE", "FROWN")}
    sample.add_layers(face, data["landmarks"], drivers)
    for lay in face.ewrinkles_face.patterns.layers:
        lay.drive, lay.radius = "NONE", 3 * lay.radius  # reaching well over the lids and the lips
    rest = np.array([v.co for v in face.data.vertices])
    inside = zones.face_zones(rest, landmarks.landmark_positions(face)).inside
    h = heights_of(face)
    assert np.abs(h[~inside]).max() > 1e-4
    assert np.abs(h[inside]).max() == 0.0


def heights_of(face):
    bpy.context.view_layer.update()
    from wrinkle_addon.glue import pipeline

    pipeline.update_scene(bpy.context.scene, bpy.context.evaluated_depsgraph_get(), only_if_changed=True)
    bpy.context.view_layer.update()
    ev = face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    n = len(face.data.vertices)
    pos, skin = np.empty(n * 3, np.float32), np.empty(n * 3, np.float32)
    ev.attributes["position"].data.foreach_get("vector", pos)
    ev.attributes["wrinkle_skin"].data.foreach_get("vector", skin)
    return np.linalg.norm((pos - skin).reshape(-1, 3), axis=1)


def test_refine_splits_the_edges_a_layer_cannot_resolve_and_only_in_its_region():
    """Refine Wrinkling Regions on a face with a crow's-feet layer and no muscle: the edges in
    the layer's region end up shorter than its furrow over Edges per Half Cycle; the rest of
    the face is untouched."""
    face = _face()
    lay = _add(face, "EYE_CORNER")
    lay.sharpness = 12.0  # narrow furrows: the patch's 2 mm edges are too long for them
    before = len(face.data.vertices)
    assert bpy.ops.wrinkle.refine(edges_per_half_cycle=3.0) == {"FINISHED"}
    assert len(face.data.vertices) > before
    rest = _rest(face)
    edges = np.array([e.vertices[:] for e in face.data.edges])
    length = np.linalg.norm(rest[edges[:, 0]] - rest[edges[:, 1]], axis=1)
    centre = np.array(face.matrix_world.inverted() @ lay.frame.matrix_world.translation)
    dist = np.linalg.norm(rest[edges].mean(axis=1) - centre, axis=1)
    step = patterns.half_cycle("EYE_CORNER", lay.time, lay.depth, lay.sharpness, lay.count, lay.shape)
    scale = glue.to_frame(face, lay.frame)[1]
    inside = dist < 0.9 * lay.radius
    assert length[inside].max() <= step * scale / 3.0 + 1e-9
    grid = max(scenes.WIDTH / 69, scenes.HEIGHT / 39)
    assert np.isclose(length[dist > 1.5 * lay.radius].max(), grid, rtol=1e-3)  # not split there
    assert bpy.ops.wrinkle.refine(edges_per_half_cycle=3.0) == {"FINISHED"}  # nothing more to do
    assert len(face.data.vertices) == len(rest)


def test_layers_added_on_a_head_get_the_face_shaped_variants_sized_and_turned_from_its_landmarks():
    """On a head with its landmarks placed: crow's feet, frown and cheek get their anatomical
    shape (the dimple the paper's), each frame sized from the distance between the eyes and
    facing out of the skin around it (the eye corner's too, in the fold of the lids), the
    right side's mirrored so its +x points away from the midline, and the cheek's turned
    along the fold."""
    from sample_scenes import patterns as sample
    from sample_scenes.lib import headgen, rigging, scene_setup

    data = headgen.make_head(12000)
    face = scene_setup.mesh_object_from_arrays("Head", data["positions"], data["quads"], data["corner_uvs"])
    rigging.wrinkle_face(face, data["landmarks"], refine=False)
    marks = data["landmarks"]
    e = 2.0 * abs(marks["eye_L"][0] - marks["glabella"][0])
    at = patterns.places(marks)
    for kind in ("EYE_CORNER", "CHEEK", "DIMPLE", "FROWN"):
        for side in (1.0, -1.0):
            point = sample._front_hit(face, at[kind][0] * np.array([side, 1.0, 1.0]))
            lay = _add(face, kind, at=tuple(point))
            assert lay.shape == ("PAPER" if kind == "DIMPLE" else "FACE")
            m = np.array(lay.frame.matrix_world)
            x, y, z = (m[:3, i] for i in range(3))
            assert np.linalg.norm(z) == pytest.approx(patterns.FRAMES[kind]["unit"] * e, rel=1e-4)
            z = z / np.linalg.norm(z)
            assert z[1] < -0.4 and abs(z[2]) < 0.5  # out of the skin, toward the front, not down
            if kind in patterns.LATERAL:
                assert np.sign(x[0]) == side  # away from the midline on both sides
            if kind == "CHEEK":
                top, bottom = patterns.fold_ends(marks)
                along = ((top - bottom) * np.array([side, 1.0, 1.0]))[[0, 2]]
                front = y[[0, 2]]  # seen from the front: the tangent plane's y leans back with the skin
                assert np.dot(front / np.linalg.norm(front), along / np.linalg.norm(along)) > 0.98
            if kind == "FROWN":
                break


def test_a_layer_saved_before_the_shape_existed_keeps_the_papers_pattern():
    face = _face()
    lay = _add(face, "EYE_CORNER")
    assert lay.shape == "FACE"
    scene = bpy.context.scene
    scene.frame_set(1)
    anatomical = heights(face)
    np.testing.assert_allclose(anatomical, _expected(face, lay, lay.time), atol=2e-7)
    lay.property_unset("shape")  # as a file saved before the setting existed holds it
    assert lay.shape == "PAPER"
    paper = heights(face)
    np.testing.assert_allclose(paper, _expected(face, lay, lay.time), atol=2e-7)
    assert np.abs(paper - anatomical).max() > 0.2 * np.abs(anatomical).max() > 0


def test_viewport_frames_skip_the_static_key_until_something_it_reads_changes(monkeypatch):
    """On viewport frames that only animate the skin (a shape key), the layers' settings are
    read once, for the frame's inputs: the static key is not computed (``unchanged``).  A
    setting edited, a region's frame moved or a setting animated makes the next frame compute
    it, and rebuild when it changed."""
    from wrinkle_addon.glue import registry

    face = _face()
    lay = _add(face, "CHEEK")
    scenes.animate_shape_key(face, [(1, 0.0), (20, 1.0)])
    source = next(s for s in registry.sources() if s.name == "patterns")
    calls = []
    real = type(source).static_key
    monkeypatch.setattr(type(source), "static_key", lambda self, *a: calls.append(1) or real(self, *a))
    scene = bpy.context.scene
    scene.frame_set(1)
    scene.frame_set(2)
    calls.clear()
    built = _builds(face)
    for f in (3, 4, 5):
        scene.frame_set(f)
    assert calls == [] and _builds(face) == built  # the shape key alone: nothing to check

    def next_frame():
        calls.clear()
        scene.frame_set(scene.frame_current + 1)
        return bool(calls)

    lay.radius *= 1.2  # an edit tags the face
    assert next_frame() and _builds(face) != built
    built = _builds(face)
    assert not next_frame()
    lay.frame.location.x += 0.01  # a region around its frame: the frame moved
    assert next_frame() and _builds(face) != built
    built = _builds(face)
    np.testing.assert_allclose(heights(face), _expected(face, lay, lay.time), atol=2e-7)
    assert not next_frame()
    # an animated setting tags nothing that says so: the key is computed on every frame
    lay.keyframe_insert("radius", frame=scene.frame_current)
    lay.radius *= 1.3
    lay.keyframe_insert("radius", frame=scene.frame_current + 4)
    assert next_frame() and next_frame()
    assert _builds(face) != built  # the radius changed between the keys
