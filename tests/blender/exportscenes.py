"""A small face with every kind of wrinkle data the exports carry: muscle wrinkles on an
animated shape key, a UV map, and wrinkle maps bound to the shape key."""

import bpy
import numpy as np

from tests.blender import mapscenes, scenes
from wrinkle_addon.core.maps import jimenez as wm

MAP_SIZE = 16
LAST = 9  # frames 1..LAST: rest, brows up, half way down


def _uv(face):
    """A UV map over [0, 1]^2 from the face's X and Z (it lies in the XZ plane)."""
    me = face.data
    uv = me.uv_layers.new(name="UVMap")
    co = np.empty(len(me.vertices) * 3, np.float32)
    me.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    corners = np.empty(len(me.loops), np.int32)
    me.loops.foreach_get("vertex_index", corners)
    lo, hi = co.min(axis=0), co.max(axis=0)
    u = (co[corners, 0] - lo[0]) / (hi[0] - lo[0])
    v = (co[corners, 2] - lo[2]) / (hi[2] - lo[2])
    uv.data.foreach_set("uv", np.stack([u, v], 1).astype(np.float32).ravel())


def wrinkled_face_with_maps(seed=0, maps=True):
    """The face (muscle wrinkles, BrowsUp keyed 0 -> 1 -> 0.5 over frames 1, 5, 9) with
    a partial-derivative wrinkle map and masks wired into its material, one expression
    "Brows" bound to BrowsUp on zones 1-2.  ``maps`` False: the same face and material
    without the wrinkle maps (what a package is imported onto)."""
    rng = np.random.default_rng(seed)
    face, muscle = scenes.wrinkled_face()
    _uv(face)
    face.data.materials.append(mapscenes.node_material("Skin"))
    scenes.animate_shape_key(face, [(1, 0.0), (5, 1.0), (LAST, 0.5)])
    bpy.context.scene.frame_start, bpy.context.scene.frame_end = 1, LAST
    if not maps:
        return face, muscle
    maps = face.ewrinkles_face.maps
    mask_a = np.zeros((MAP_SIZE, MAP_SIZE, 4), np.float32)
    mask_a[MAP_SIZE // 2:, :, 0] = mask_a[MAP_SIZE // 2:, :, 1] = 0.5
    mask_a[MAP_SIZE // 2:, : MAP_SIZE // 2, 3] = 0.25  # zone 4 over zones 1-2: RGB is not premultiplied
    mask_b = np.zeros((MAP_SIZE, MAP_SIZE, 4), np.float32)
    maps.mask_a = mapscenes.data_image("Mask A", mask_a)
    maps.mask_b = mapscenes.data_image("Mask B", mask_b)
    maps.map_a = mapscenes.data_image(
        "Wrinkle PD", wm.normal_to_derivative(mapscenes.random_normal_map(rng, MAP_SIZE, 0.3)))
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    assert bpy.ops.wrinkle.add_map_expression() == {"FINISHED"}
    ex = maps.expressions[-1]
    ex.name, ex.source, ex.shape_key = "Brows", "SHAPE_KEY", "BrowsUp"
    ex.weights = (1.0, 1.0, 0, 0, 0, 0, 0, 0)
    return face, muscle


def engine_face(base=True, parts=True):
    """The face of :func:`wrinkled_face_with_maps` as a studio's would be: with a base normal
    map (``base``), its colour from a procedural chain (an attribute, as the sample skin's
    is), and a part (``parts``): an "Eyes" mesh parented to it whose shape key follows the
    face's BrowsUp through a driver, as the sample head's eyes and teeth do."""
    face, muscle = wrinkled_face_with_maps()
    maps = face.ewrinkles_face.maps
    tree = face.data.materials[0].node_tree
    bsdf = next(n for n in tree.nodes if n.type == "BSDF_PRINCIPLED")
    bsdf.inputs["Base Color"].default_value = SKIN_COLOUR
    attr = tree.nodes.new("ShaderNodeAttribute")
    attr.attribute_name = "wrinkle_skin"  # positions as a colour: what a consumer must not read
    tree.links.new(attr.outputs["Color"], bsdf.inputs["Base Color"])
    if base:
        maps.base_image = mapscenes.data_image(
            "Skin Normal", mapscenes.random_normal_map(np.random.default_rng(7), MAP_SIZE, 0.2))
        bpy.context.view_layer.objects.active = face
        assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    if parts:
        me = bpy.data.meshes.new("Eyes")
        me.from_pydata([(0.0, -0.01, 0.02), (0.01, -0.01, 0.02), (0.0, -0.01, 0.03)], [], [(0, 1, 2)])
        eyes = bpy.data.objects.new("Eyes", me)
        bpy.context.scene.collection.objects.link(eyes)
        eyes.parent = face
        eyes.shape_key_add(name="Basis", from_mix=False)
        kb = eyes.shape_key_add(name="BrowsUp", from_mix=False)
        kb.data[2].co = (0.0, -0.01, 0.04)
        drv = kb.driver_add("value").driver
        drv.type = "AVERAGE"
        var = drv.variables.new()
        var.targets[0].id_type = "KEY"
        var.targets[0].id = face.data.shape_keys
        var.targets[0].data_path = 'key_blocks["BrowsUp"].value'
        mat = mapscenes.node_material("Cornea")
        mat.node_tree.nodes.clear()
        out = mat.node_tree.nodes.new("ShaderNodeOutputMaterial")
        film = mat.node_tree.nodes.new("ShaderNodeBsdfTransparent")
        mat.node_tree.links.new(film.outputs[0], out.inputs["Surface"])
        mat.diffuse_color = (0.9, 0.9, 0.9, 0.1)
        me.materials.append(mat)
    bpy.context.view_layer.update()
    return face, muscle


SKIN_COLOUR = (0.56, 0.34, 0.26, 1.0)
