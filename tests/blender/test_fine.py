"""Fine-scale wrinkles (Bando et al. 2002, §5 and §7) on a face in Blender: Carve Fine
Wrinkles makes the two height images, stores the fields and the plan, adds the modifier that
measures the shrinkage across each field every frame, wires the node group; bad input
changes nothing."""

import bpy
import numpy as np
import pytest

from tests.blender.test_curves import uv_face
from wrinkle_addon.core.bando import field as core_field
from wrinkle_addon.glue.bando import fine as fine_glue
from wrinkle_addon.glue.bando import fine_tree, shading


def _carve(face, resolution="512", **settings):
    fs = face.ewrinkles_face.fine_wrinkles
    fs.resolution = resolution
    for k, v in settings.items():
        setattr(fs, k, v)
    bpy.context.view_layer.objects.active = face
    return bpy.ops.wrinkle.carve_fine()


def _shrinkage(face):
    """Both fields' shrinkage (2, N) as Blender computed it in the face's modifier."""
    out = fine_tree.shrinkage(face)
    assert out is not None, "the evaluated face holds no shrinkage"
    return out


@pytest.fixture
def carved():
    face = uv_face()
    assert _carve(face) == {"FINISHED"}
    return face


def test_carving_makes_two_packed_images_the_fields_and_the_material(carved):
    fs = carved.ewrinkles_face.fine_wrinkles
    assert fs.image_1 is not None and fs.image_2 is not None
    assert fs.image_1.packed_file is not None and fs.image_1.size[0] == 512
    assert fs.furrows > 50 and 0.3 < fs.coverage <= 1.0
    px = np.empty(512 * 512 * 4, np.float32)
    fs.image_1.pixels.foreach_get(px)
    h = px.reshape(512, 512, 4)[..., 0]
    assert h.min() < 0.9 and h.max() == 1.0  # furrows below the white
    nt = fs.material.node_tree
    group = nt.nodes[fine_glue.GROUP_NODE]
    bsdf = next(n for n in nt.nodes if n.type == "BSDF_PRINCIPLED")
    assert bsdf.inputs["Normal"].links[0].from_node == group
    for name in fine_glue.FIELD_ATTRS:
        assert carved.data.attributes[name].domain == "CORNER"


def test_the_face_field_runs_across_the_compression():
    face = uv_face()
    _carve(face)
    from wrinkle_addon.core.bando import mapped
    from wrinkle_addon.glue import surface

    s = surface.Surface(face)
    m = mapped.mapped_mesh(s.tris, s.uv, len(s.rest))
    f1, _f2 = fine_glue.read_fields(face, s, m)
    strong = np.linalg.norm(f1, axis=1) > 0.2
    assert strong.mean() > 0.3
    # BrowsUp squashes the forehead vertically: the furrows run across it (along U)
    assert np.median(np.abs(f1[strong, 0]) / np.linalg.norm(f1[strong], axis=1)) > 0.95


def test_the_shrinkage_follows_the_pose(carved):
    key = carved.data.shape_keys.key_blocks["BrowsUp"]
    key.value = 0.0
    bpy.context.scene.frame_set(1)
    s1 = _shrinkage(carved)[0]
    assert np.abs(s1).max() < 1e-4  # rest: no shrinkage
    key.value = 1.0
    bpy.context.scene.frame_set(1)
    s1, s2 = _shrinkage(carved)
    assert s1.max() > 0.2  # across the horizontal furrows the skin shrinks
    assert np.median(s2[s1 > 0.1]) < np.median(s1[s1 > 0.1])  # less across the second field


def test_the_same_seed_carves_the_same_images():
    face = uv_face()
    _carve(face, seed=3)
    a = np.array(face.ewrinkles_face.fine_wrinkles.image_1.pixels[:])
    _carve(face, seed=3)
    b = np.array(face.ewrinkles_face.fine_wrinkles.image_1.pixels[:])
    _carve(face, seed=4)
    c = np.array(face.ewrinkles_face.fine_wrinkles.image_1.pixels[:])
    assert np.array_equal(a, b) and not np.array_equal(a, c)


def test_the_group_computes_eq5_like_the_numpy_reference():
    """The node group's M(s) network, evaluated by walking its math nodes, against
    ``core.bando.field.modulation``."""
    ng = shading.ensure_fine_group()
    math_nodes = [n for n in ng.nodes if n.type == "MATH"]
    assert len(math_nodes) >= 12
    for s, r in [(-0.5, 0.5), (-0.1, 0.2), (0.0, 0.5), (0.3, 0.5), (0.8, 0.0), (-0.3, 0.0)]:
        expected = float(core_field.modulation(np.array([s]), r)[0])
        assert _eval_modulation(ng, s, r) == pytest.approx(expected, abs=1e-6)


_OPS = {
    "MINIMUM": min, "MAXIMUM": max, "SUBTRACT": lambda a, b: a - b, "ADD": lambda a, b: a + b,
    "MULTIPLY": lambda a, b: a * b, "DIVIDE": lambda a, b: a / b, "MULTIPLY_ADD": lambda a, b, c: a * b + c,
    "EXPONENT": lambda a: float(np.exp(a)), "GREATER_THAN": lambda a, b: 1.0 if a > b else 0.0,
}


def _eval_modulation(ng, s, r):
    """Evaluate the group's first M(s) (shrinkage s across field 1, rest height r) in Python."""
    def value(sock):
        if not sock.is_linked:
            return sock.default_value
        src = sock.links[0].from_socket
        node = src.node
        if node.bl_idname == "ShaderNodeSeparateXYZ":  # the shrinkage attribute's components
            assert node.inputs[0].links[0].from_node.type == "ATTRIBUTE"
            return s
        if node.type == "GROUP_INPUT":
            return {"Rest Height": r, "Distance": 1.0}[src.name]
        args = [value(i) for i in node.inputs[: {"MULTIPLY_ADD": 3, "EXPONENT": 1}.get(node.operation, 2)]]
        return _OPS[node.operation](*args)

    # the first term (H1 - 1) M(s1) is the first bump: height H1 - 1, distance Distance M(s1)
    return value(ng.nodes["Bump 1"].inputs["Distance"])


def test_no_uv_map_disables_carving():
    uv_face(with_uv=False)
    assert not bpy.ops.wrinkle.carve_fine.poll()


def test_overlapping_uv_islands_are_refused_and_nothing_changes():
    face = uv_face()
    layer = face.data.uv_layers.active
    uv = np.empty(len(face.data.loops) * 2, np.float32)
    layer.uv.foreach_get("vector", uv)
    uv = uv.reshape(-1, 2)
    uv[:, 0] = np.where(uv[:, 0] > 0.5, 1.0 - uv[:, 0], uv[:, 0])  # mirrored halves
    layer.uv.foreach_set("vector", uv.ravel())
    images = len(bpy.data.images)
    with pytest.raises(RuntimeError, match="overlapping"):
        _carve(face)
    assert len(bpy.data.images) == images
    assert face.ewrinkles_face.fine_wrinkles.image_1 is None


def test_guides_without_any_guide_get_a_message():
    face = uv_face()
    with pytest.raises(RuntimeError, match="No guides"):
        _carve(face, field_source="GUIDES")


def test_guides_on_selected_vertices_set_the_field():
    face = uv_face()
    me = face.data
    sel = np.zeros(len(me.vertices), bool)
    sel[:: 97] = True
    me.vertices.foreach_set("select", sel)
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.fine_direction(direction=(0.0, 0.0, 0.8)) == {"FINISHED"}  # vertical
    assert _carve(face, resolution="512") == {"FINISHED"}
    from wrinkle_addon.core.bando import mapped
    from wrinkle_addon.glue import surface

    s = surface.Surface(face)
    m = mapped.mapped_mesh(s.tris, s.uv, len(s.rest))
    f1, _f2 = fine_glue.read_fields(face, s, m)
    n = np.linalg.norm(f1, axis=1)
    assert np.median(np.abs(f1[:, 1]) / np.maximum(n, 1e-12)) > 0.95  # along V: vertical
    assert np.median(n) == pytest.approx(0.8, abs=0.1)


def test_remove_takes_the_layer_out_and_keeps_the_material_working(carved):
    mat = carved.ewrinkles_face.fine_wrinkles.material
    bpy.context.view_layer.objects.active = carved
    assert bpy.ops.wrinkle.remove_fine() == {"FINISHED"}
    assert fine_glue.GROUP_NODE not in mat.node_tree.nodes
    assert fine_tree.find_modifier(carved) is None
    assert not any(carved.data.attributes.get(name) for name, _kind in fine_tree.slot_attributes())
    bpy.context.scene.frame_set(2)  # the source is gone: nothing measured
    assert fine_tree.shrinkage(carved) is None


def test_fine_wrinkles_survive_saving_and_reopening(carved, tmp_blend):
    path = str(tmp_blend("fine"))
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    face = bpy.data.objects["Face"]
    fs = face.ewrinkles_face.fine_wrinkles
    assert fs.image_1 is not None and fs.image_1.packed_file is not None
    assert fs.image_1.size[0] == 512 and min(fs.image_1.pixels[:]) < 0.9
    face.data.shape_keys.key_blocks["BrowsUp"].value = 1.0
    bpy.context.scene.frame_set(1)
    assert _shrinkage(face)[0].max() > 0.2


def test_directions_from_the_muscles_alone():
    from tests.blender import scenes

    face = uv_face(shape_key=False, enable=False)
    bpy.context.view_layer.objects.active = face
    with pytest.raises(RuntimeError, match="Nothing deforms"):
        _carve(face)
    scenes.add_sheet(face, pull=0.3)  # a Frontalis: pulls the forehead up, squeezing it
    assert _carve(face) == {"FINISHED"}
    assert face.ewrinkles_face.fine_wrinkles.furrows > 20


def test_the_shrinkage_sees_the_muscles_pull():
    """The frame stage hands the skin pulled by the muscles to the sources after them: a
    contracting Frontalis squeezes the forehead, and the fine wrinkles deepen with it."""
    from tests.blender import scenes

    face = uv_face(shape_key=False)
    muscle = scenes.add_sheet(face, pull=0.3)
    assert _carve(face) == {"FINISHED"}
    scene = bpy.context.scene
    muscle.ewrinkles_muscle.contraction = 0.0
    scene.frame_set(1)
    assert np.abs(_shrinkage(face)[0]).max() < 1e-4
    muscle.ewrinkles_muscle.contraction = 1.0
    scene.frame_set(1)
    assert _shrinkage(face)[0].max() > 0.05  # (0 before the pull was handed on)
