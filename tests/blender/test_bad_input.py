"""Bad input gets a clear message, and nothing is lost."""

import bpy
import numpy as np
import pytest

from tests.blender import scenes
from wrinkle_addon.glue import pipeline


def _frames(face, frames=(1, 2)):
    for f in frames:
        bpy.context.scene.frame_set(f)
    pos = scenes.evaluated_positions(face)
    assert np.isfinite(pos).all()
    assert "Internal error" not in pipeline.status_of(face)
    return pos


def test_mesh_without_faces_is_refused():
    me = bpy.data.meshes.new("Edges")
    me.from_pydata([(0, 0, 0), (1, 0, 0), (1, 1, 0)], [(0, 1), (1, 2)], [])
    ob = bpy.data.objects.new("Edges", me)
    bpy.context.scene.collection.objects.link(ob)
    bpy.context.view_layer.objects.active = ob
    with pytest.raises(RuntimeError, match="has no faces"):
        bpy.ops.wrinkle.enable()
    assert not ob.modifiers and not ob.ewrinkles_face.enabled


def test_non_mesh_object_is_refused():
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    bpy.context.scene.collection.objects.link(cam)
    bpy.context.view_layer.objects.active = cam
    with pytest.raises(RuntimeError, match="not a mesh"):
        bpy.ops.wrinkle.enable()
    curve = bpy.data.objects.new("Curve", bpy.data.curves.new("Curve", "CURVE"))
    bpy.context.scene.collection.objects.link(curve)
    bpy.context.view_layer.objects.active = curve
    with pytest.raises(RuntimeError, match="not a mesh"):
        bpy.ops.wrinkle.add_muscle()
    empty = bpy.data.objects.new("Empty", None)
    bpy.context.scene.collection.objects.link(empty)
    bpy.context.view_layer.objects.active = empty
    with pytest.raises(RuntimeError, match='"Empty" is an empty, not a mesh'):
        bpy.ops.wrinkle.enable()


def test_every_check_of_a_face_says_the_same():
    """One face check: the operators of every method refuse a non-mesh with one message."""
    empty = bpy.data.objects.new("Empty", None)
    bpy.context.scene.collection.objects.link(empty)
    bpy.context.view_layer.objects.active = empty
    messages = set()
    for op in (bpy.ops.wrinkle.enable, bpy.ops.wrinkle.bake_wrinkle_map, bpy.ops.wrinkle.generate_masks,
               bpy.ops.wrinkle.refine, bpy.ops.wrinkle.add_muscle_set):
        with pytest.raises(RuntimeError) as err:
            op("EXEC_DEFAULT")
        messages.add(str(err.value).split("poll() ")[-1].strip())
    assert messages == {'"Empty" is an empty, not a mesh: select the face mesh'}


def test_loose_vertices_zero_length_edges_degenerate_triangles_and_ngons():
    from tests.core.meshes import grid

    rest, _e, _t, quads = grid(50, 30, scenes.WIDTH, scenes.HEIGHT)
    n = len(rest)
    extra = [(0.2, 0, 0.0), (0.3, 0, 0.0), (0.3, 0, 0.0),  # loose, and a zero-length edge
             (0.0, -0.01, 0.03), (0.0, -0.01, 0.03), (0.01, -0.01, 0.03)]  # degenerate triangle
    angles = np.linspace(0, 5 * np.pi / 3, 6)
    hexagon = [(0.09 + 0.01 * np.cos(a), 0.0, 0.04 + 0.01 * np.sin(a)) for a in angles]
    verts = [tuple(v) for v in rest] + extra + hexagon
    faces = [tuple(q) for q in quads] + [(n + 3, n + 4, n + 5), tuple(range(n + 6, n + 12))]
    me = bpy.data.meshes.new("Messy")
    me.from_pydata(verts, [(n + 1, n + 2)], faces)
    face = bpy.data.objects.new("Messy", me)
    bpy.context.scene.collection.objects.link(face)
    bpy.context.view_layer.objects.active = face
    face.shape_key_add(name="Basis")
    key = face.shape_key_add(name="BrowsUp")
    co = np.array(verts, np.float32)
    co[:n] = scenes.squash_vertical(rest, 0.7, scenes.HEIGHT)
    key.points.foreach_set("co", co.ravel())
    key.value = 1.0
    bpy.ops.wrinkle.enable()
    scenes.add_sheet(face, contraction=1.0)
    pos = _frames(face)
    assert len(pos) == len(me.vertices)
    assert np.abs(scenes.offsets(face)).max() > 0
    assert max(p.loop_total for p in me.polygons) == 6


def test_muscle_attachment_equal_to_insertion():
    face = scenes.make_face()
    bpy.ops.wrinkle.enable()
    with pytest.raises(RuntimeError, match="distinct"):
        bpy.ops.wrinkle.add_muscle(kind="LINEAR", use_points=True, points=(0, 0, 0.04) * 4)
    bpy.context.view_layer.objects.active = face
    bpy.ops.wrinkle.add_muscle(kind="LINEAR", use_points=True, points=(0, 0, 0.04, 0.04, 0, 0.04) + (0,) * 6)
    muscle = bpy.context.view_layer.objects.active
    muscle.ewrinkles_muscle.contraction = 1.0
    muscle.data.vertices[1].co = muscle.data.vertices[0].co  # edited onto its attachment
    _frames(face)
    assert "attachment equals its insertion" in pipeline.status_of(face)


@pytest.mark.parametrize("prop,value,message", [
    ("length", 0.0, "Ls is 0"), ("width", 0.0, "Ws is 0"),
])
def test_sheet_zero_sizes(prop, value, message):
    face, muscle = scenes.wrinkled_face(contraction=1.0)
    setattr(muscle.ewrinkles_muscle, prop, value)
    _frames(face)
    assert message in pipeline.status_of(face)
    assert np.abs(scenes.offsets(face)).max() == 0


def test_linear_zero_radius():
    face = scenes.make_face()
    bpy.ops.wrinkle.enable()
    bpy.ops.wrinkle.add_muscle(kind="LINEAR", use_points=True, points=(0, 0, 0.04, 0.04, 0, 0.04) + (0,) * 6)
    muscle = bpy.context.view_layer.objects.active
    muscle.ewrinkles_muscle.contraction = 1.0
    muscle.ewrinkles_muscle.radius = 0.0
    _frames(face)
    assert "R is 0" in pipeline.status_of(face)


@pytest.mark.parametrize("nw", [0, 1000])
def test_extreme_wrinkle_counts(nw):
    face, muscle = scenes.wrinkled_face(contraction=1.0, n_wrinkles=nw)
    face.data.shape_keys.key_blocks["BrowsUp"].value = 1.0
    _frames(face)
    off = scenes.offsets(face)
    assert np.isfinite(off).all() and np.abs(off).max() < 0.05


@pytest.mark.parametrize("prop", ["k0", "alpha", "lambda_w", "pull", "length", "width", "depth",
                                  "contraction"])
def test_nan_typed_into_a_field(prop):
    face, muscle = scenes.wrinkled_face(contraction=1.0)
    face.data.shape_keys.key_blocks["BrowsUp"].value = 1.0
    setattr(muscle.ewrinkles_muscle, prop, float("nan"))
    _frames(face)
    face.ewrinkles_face.strength = float("nan")
    _frames(face, (3,))
    assert np.isfinite(scenes.offsets(face)).all()


def test_linked_read_only_mesh_is_refused(tmp_path):
    scenes.make_face("Linked")
    lib = tmp_path / "lib.blend"
    bpy.data.libraries.write(str(lib), {bpy.data.objects["Linked"]})
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    with bpy.data.libraries.load(str(lib), link=True) as (src, dst):
        dst.objects = ["Linked"]
    ob = dst.objects[0]
    bpy.context.scene.collection.objects.link(ob)
    bpy.context.view_layer.objects.active = ob
    with pytest.raises(RuntimeError, match="linked"):
        bpy.ops.wrinkle.enable()
    assert not ob.ewrinkles_face.enabled


def test_muscle_deleted_while_referenced_shows_in_list():
    face, muscle = scenes.wrinkled_face(contraction=1.0)
    bpy.data.objects.remove(muscle)
    _frames(face)
    assert len(face.ewrinkles_face.muscles) == 1 and face.ewrinkles_face.muscles[0].object is None
    bpy.context.view_layer.objects.active = face
    bpy.ops.wrinkle.remove_muscle()
    assert len(face.ewrinkles_face.muscles) == 0


def test_handler_never_raises_on_broken_state():
    face, muscle = scenes.wrinkled_face(contraction=1.0)
    face.modifiers.remove(face.modifiers[0])  # the user deleted our modifier
    _frames(face)
    assert "modifier is missing" in pipeline.status_of(face)
    face.data.attributes.remove(face.data.attributes["wrinkle_offset"])
    bpy.ops.wrinkle.enable()
    _frames(face, (4,))
    assert pipeline.status_of(face) == ""


def test_linked_duplicates_sharing_a_mesh_get_a_message():
    face, _muscle = scenes.wrinkled_face(contraction=1.0)
    twin = bpy.data.objects.new("Twin", face.data)
    bpy.context.scene.collection.objects.link(twin)
    bpy.context.view_layer.objects.active = twin
    bpy.ops.wrinkle.enable()
    _frames(face)
    assert "shares its mesh" in pipeline.status_of(face) and "shares its mesh" in pipeline.status_of(twin)
