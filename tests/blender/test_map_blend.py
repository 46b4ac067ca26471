"""The "Wrinkle Map Blend" node group against the NumPy reference, pixel by pixel."""

import bpy
import numpy as np
import pytest

from tests.blender import mapscenes
from wrinkle_addon.core.maps import jimenez as wm
from wrinkle_addon.glue.maps import nodegroups

SIZE = 16


def _inputs(rng, n_maps=2, difference=False):
    base = mapscenes.random_normal_map(rng, SIZE, 0.25)
    maps = []
    for _ in range(n_maps):
        w = mapscenes.random_normal_map(rng, SIZE, 0.25)
        maps.append(wm.difference_map(base, w) if difference else wm.normal_to_derivative(w))
    mask_a = rng.uniform(0, 1, (SIZE, SIZE, 4)).astype(np.float32) * 0.5
    mask_b = rng.uniform(0, 1, (SIZE, SIZE, 4)).astype(np.float32) * 0.5
    # negative, in-range and > 1 weights: the group must clamp each zone to [0, 1]
    weights = rng.choice([-0.7, 0.0, 0.3, 0.6, 1.8], size=(n_maps, 8)).astype(np.float32)
    return base, maps, mask_a, mask_b, weights


def _render(plane, render_small, tmp_path, base, maps, mask_a, mask_b, weights, strength, difference):
    img = mapscenes.data_image
    mapscenes.blend_material(
        plane, img("base", base), [img(f"map{k}", m) for k, m in enumerate(maps)],
        img("maskA", mask_a), img("maskB", mask_b), weights, strength, difference)
    px = render_small(bpy.context.scene, tmp_path / "n.exr", size=SIZE, samples=1)
    return px[..., :3]


@pytest.mark.parametrize("difference", [False, True], ids=["pd", "difference"])
@pytest.mark.render
def test_cycles_normals_match_the_numpy_reference(render_small, tmp_path, difference):
    rng = np.random.default_rng(3)
    plane = mapscenes.plane_scene(SIZE)
    base, maps, mask_a, mask_b, weights = _inputs(rng, 2, difference)
    got = _render(plane, render_small, tmp_path, base, maps, mask_a, mask_b, weights, 0.8, difference)
    want = wm.encode(wm.blend(base, maps, mask_a, mask_b, weights, 0.8, difference))
    flat = wm.encode(wm.normalize(wm.decode(base)))
    assert np.abs(want - flat).max() > 0.05  # the wrinkles change the normals
    err = np.abs(got - want).max()
    assert err < 1e-4, err


@pytest.mark.render
def test_zone_clamp_and_a_third_map(render_small, tmp_path):
    """Weights of 5 and 1 give the same picture (clamp); a third map is honoured."""
    rng = np.random.default_rng(5)
    plane = mapscenes.plane_scene(SIZE)
    base, maps, mask_a, mask_b, weights = _inputs(rng, 3)
    weights[:] = 0.0
    weights[2, 0] = 5.0
    got = _render(plane, render_small, tmp_path, base, maps, mask_a, mask_b, weights, 1.0, False)
    clamped = weights.copy()
    clamped[2, 0] = 1.0
    want = wm.encode(wm.blend(base, maps, mask_a, mask_b, clamped, 1.0))
    assert np.abs(got - want).max() < 1e-4


def test_existing_group_is_reused_and_extended():
    ng = nodegroups.ensure_blend_group(2)
    mat = mapscenes.node_material("M")
    node = mat.node_tree.nodes.new("ShaderNodeGroup")
    node.node_tree = ng
    val = mat.node_tree.nodes.new("ShaderNodeValue")
    mat.node_tree.links.new(val.outputs[0], node.inputs[nodegroups.zone_socket(1, 3)])
    again = nodegroups.ensure_blend_group(3)
    assert again == ng and len([g for g in bpy.data.node_groups if g.name.startswith("Wrinkle Map")]) == 1
    assert nodegroups.map_count(ng) == 3
    assert node.inputs[nodegroups.zone_socket(1, 3)].is_linked  # the link survived the extension


def test_group_with_foreign_type_is_refused():
    bpy.data.node_groups.new(nodegroups.BLEND_GROUP, "GeometryNodeTree")
    with pytest.raises(nodegroups.MapError, match="not a shader group"):
        nodegroups.ensure_blend_group(2)


def _eevee(scene):
    scene.render.engine = "BLENDER_EEVEE_NEXT" if bpy.app.version < (5, 0, 0) else "BLENDER_EEVEE"
    scene.view_settings.view_transform = "Standard"
    scene.render.filter_size = 0.0
    scene.eevee.taa_render_samples = 1
    settings = scene.render.image_settings
    settings.file_format, settings.color_mode, settings.color_depth = "OPEN_EXR", "RGBA", "32"


def _eevee_render(scene, path, size):
    _eevee(scene)
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    img = bpy.data.images.load(str(path))
    px = np.empty(size * size * 4, np.float32)
    img.pixels.foreach_get(px)
    return px.reshape(size, size, 4)[..., :3]


@pytest.mark.render
def test_eevee_normals_match_the_numpy_reference(tmp_path):
    """EEVEE runs on Mesa's llvmpipe here (no GPU), about 1-2 s for 8 x 8.  A probe
    renders a constant emission first, so a machine whose OpenGL cannot shade at all
    skips with that reason instead of failing on the wrinkle maps."""
    plane = mapscenes.plane_scene(SIZE)
    probe = mapscenes.show_normal_material(plane, lambda nt: _constant(nt, (0.2, -0.4, 0.9)))
    got = _eevee_render(bpy.context.scene, tmp_path / "probe.exr", SIZE)
    if np.abs(got - np.array([0.6, 0.3, 0.95])).max() > 0.01:
        pytest.skip(f"EEVEE cannot shade on this machine (a constant emission rendered as {got[0, 0]})")
    plane.data.materials.clear()
    bpy.data.materials.remove(probe)
    rng = np.random.default_rng(3)
    base, maps, mask_a, mask_b, weights = _inputs(rng, 2)
    img = mapscenes.data_image
    mapscenes.blend_material(
        plane, img("base", base), [img(f"map{k}", m) for k, m in enumerate(maps)],
        img("maskA", mask_a), img("maskB", mask_b), weights, 0.8)
    got = _eevee_render(bpy.context.scene, tmp_path / "eevee.exr", SIZE)
    want = wm.encode(wm.blend(base, maps, mask_a, mask_b, weights, 0.8))
    assert np.abs(got - want).max() < 2e-3  # half floats in EEVEE's buffers


def _constant(nt, vector):
    n = nt.nodes.new("ShaderNodeCombineXYZ")
    for i, v in enumerate(vector):
        n.inputs[i].default_value = v
    return n.outputs[0]
