"""Scenes for the wrinkle-map tests: a UV'd plane seen straight on, and data images."""

import bpy
import numpy as np

from wrinkle_addon.glue.maps import map_material, nodegroups


def data_image(name, pixels, closest=True):
    """A float, Non-Color image holding ``pixels`` (H, W, 3 or 4), row 0 at the bottom."""
    pixels = np.asarray(pixels, np.float32)
    h, w = pixels.shape[:2]
    if pixels.shape[2] == 3:
        pixels = np.concatenate([pixels, np.ones((h, w, 1), np.float32)], axis=2)
    img = bpy.data.images.new(name, w, h, alpha=True, float_buffer=True)
    img.colorspace_settings.name = "Non-Color"
    img.alpha_mode = "CHANNEL_PACKED"
    img.pixels.foreach_set(np.ascontiguousarray(pixels).ravel())
    img.pack()
    return img


def plane_scene(size, cuts=0):
    """A 2 x 2 plane at z = 0 with UVs over [0, 1]^2 (u along +X, v along +Y) and an
    orthographic camera looking down -Z that frames it exactly: pixel (i, j) of a
    ``size``-pixel render sees texel (i, j) of a ``size``-texel image."""
    if cuts:
        bpy.ops.mesh.primitive_grid_add(x_subdivisions=cuts, y_subdivisions=cuts, size=2.0)
    else:
        bpy.ops.mesh.primitive_plane_add(size=2.0)
    plane = bpy.context.active_object
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 2.0
    cam.location = (0.0, 0.0, 3.0)
    scene = bpy.context.scene
    scene.collection.objects.link(cam)
    scene.camera = cam
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.cycles.pixel_filter_type = "BOX"
    scene.cycles.filter_width = 0.01
    scene.cycles.samples = 1
    scene.cycles.max_bounces = 0
    scene.world = None
    return plane


def image_node(nodes, img):
    n = nodes.new("ShaderNodeTexImage")
    n.image = img
    n.interpolation = "Closest"
    return n


def emit_normal(nt, normal):
    """Nodes that emit 0.5 + 0.5 ``normal``; returns their Material Output."""
    enc = nt.nodes.new("ShaderNodeVectorMath")
    enc.operation = "MULTIPLY_ADD"
    nt.links.new(normal, enc.inputs[0])
    enc.inputs[1].default_value = (0.5, 0.5, 0.5)
    enc.inputs[2].default_value = (0.5, 0.5, 0.5)
    emit = nt.nodes.new("ShaderNodeEmission")
    nt.links.new(enc.outputs["Vector"], emit.inputs["Color"])
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(emit.outputs[0], out.inputs["Surface"])
    return out


def show_normal_material(plane, group_node_setup):
    """A material that emits 0.5 + 0.5 N (world normal) from ``group_node_setup(nt)``,
    which must return the output socket of a normal."""
    mat = node_material("ShowNormal")
    nt = mat.node_tree
    nt.nodes.clear()
    emit_normal(nt, group_node_setup(nt))
    plane.data.materials.append(mat)
    return mat


def blend_material(plane, base, maps, mask_a, mask_b, weights, strength=1.0, difference=False):
    """The wrinkle-map blend group fed by images and constant zone weights (K, 8)."""

    def setup(nt):
        ng = nodegroups.ensure_blend_group(len(maps))
        g = nt.nodes.new("ShaderNodeGroup")
        g.node_tree = ng
        nt.links.new(image_node(nt.nodes, base).outputs["Color"], g.inputs["Base Normal"])
        for label, img in (("Mask A", mask_a), ("Mask B", mask_b)):
            n = image_node(nt.nodes, img)
            nt.links.new(n.outputs["Color"], g.inputs[label])
            nt.links.new(n.outputs["Alpha"], g.inputs[label + " Alpha"])
        for k, img in enumerate(maps):
            nt.links.new(image_node(nt.nodes, img).outputs["Color"], g.inputs[nodegroups.map_socket(k)])
            for z in range(8):
                g.inputs[nodegroups.zone_socket(k, z)].default_value = float(weights[k][z])
        g.inputs["Strength"].default_value = strength
        g.inputs["Difference Maps"].default_value = 1.0 if difference else 0.0
        return g.outputs["Normal"]

    return show_normal_material(plane, setup)


def random_normal_map(rng, size, max_slope=0.35):
    """A standard normal map (size, size, 3) whose normals tilt at most atan(max_slope)
    per axis (Cycles bends normals that would reflect below the surface)."""
    d = rng.uniform(-max_slope, max_slope, (size, size, 2)).astype(np.float32)
    n = np.concatenate([d, np.ones((size, size, 1), np.float32)], axis=2)
    n /= np.linalg.norm(n, axis=2, keepdims=True)
    return 0.5 + 0.5 * n


def node_material(name):
    """A new material with a node tree (5.x materials always have one; 4.x needs use_nodes,
    which 5.x deprecates)."""
    mat = bpy.data.materials.new(name)
    if mat.node_tree is None:
        mat.use_nodes = True
    return mat


def principled_plane(size, keys=(), cuts=0):
    """The plane with a Principled "Skin" material and shape keys ``keys`` (at 0), active."""
    plane = plane_scene(size, cuts)
    mat = node_material("Skin")
    plane.data.materials.append(mat)
    if keys:
        plane.shape_key_add(name="Basis")
        for k in keys:
            plane.shape_key_add(name=k).value = 0.0
    bpy.context.view_layer.objects.active = plane
    return plane


def skin_plane(size, mask_a, mask_b, map_a, base=None, keys=(), cuts=0):
    """The plane with a Principled "Skin" material, shape keys ``keys`` (at 0) and the
    wrinkle-map images set on ``plane.ewrinkles_face.maps`` (not wired yet)."""
    plane = principled_plane(size, keys, cuts)
    maps = plane.ewrinkles_face.maps
    maps.mask_a = data_image("Mask A", mask_a)
    maps.mask_b = data_image("Mask B", mask_b)
    maps.map_a = data_image("Wrinkle PD", map_a)
    if base is not None:
        maps.base_image = data_image("Base", base)
    return plane


def show_blend_output(mat):
    """Make the material emit 0.5 + 0.5 N of the normal the wiring feeds the Principled
    BSDF (an extra, active Material Output), so a render shows the blended normal exactly."""
    nt = mat.node_tree
    bsdf = next(n for n in nt.nodes if n.type == "BSDF_PRINCIPLED")
    normal = bsdf.inputs["Normal"].links[0].from_socket
    for n in nt.nodes:
        if n.type == "OUTPUT_MATERIAL":
            n.is_active_output = False
    emit_normal(nt, normal).is_active_output = True
    for _prop, image_node_name, _socket in map_material.IMAGE_NODES:
        n = nt.nodes.get(image_node_name)
        if n is not None:
            n.interpolation = "Closest"
