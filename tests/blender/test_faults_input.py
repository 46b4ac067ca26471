"""Input faults: images made in Blender, shape-key names that need escaping, NaN settings,
pixels that are not finite, muscles linked from a library, crafted custom properties."""

import math

import bpy
import numpy as np
import pytest

from tests.blender import mapscenes, scenes
from wrinkle_addon.glue.maps import map_material, nodegroups

SIZE = 8
ODD_KEY = 'Brow "up" \\ L'  # a quote and a backslash: both need escaping in a data path


def _pixels(img):
    buf = np.empty(len(img.pixels), np.float32)
    img.pixels.foreach_get(buf)
    return buf


def _painted(name, float_buffer, seed):
    """A new, never saved, never packed image with known pixels, as a user paints it."""
    img = bpy.data.images.new(name, SIZE, SIZE, alpha=True, float_buffer=float_buffer)
    px = np.random.default_rng(seed).uniform(0.0, 1.0, SIZE * SIZE * 4).astype(np.float32)
    px = np.round(px * 255) / 255  # exact in a byte image too
    img.pixels.foreach_set(px)
    img.use_fake_user = True
    assert img.packed_file is None and img.source == "GENERATED"
    return img, px


def _skin_plane(keys=()):
    """The plane with a Principled material and no wrinkle-map images yet."""
    return mapscenes.principled_plane(SIZE, keys)


def _wired_plane(keys=()):
    z = np.zeros((SIZE, SIZE, 4), np.float32)
    plane = mapscenes.skin_plane(SIZE, z, z, np.full((SIZE, SIZE, 3), 0.5, np.float32), keys=keys)
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    return plane


# --- images made in Blender keep their pixels ----------------------------------------------
@pytest.mark.parametrize("float_buffer", [False, True])
def test_set_up_keeps_the_pixels_of_unsaved_unpacked_images(float_buffer, tmp_blend):
    plane = _skin_plane()
    mask, mask_px = _painted("Painted Mask", float_buffer, 1)
    wmap, map_px = _painted("Painted Map", float_buffer, 2)
    maps = plane.ewrinkles_face.maps
    maps.mask_a, maps.map_a = mask, wmap
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    for img, px in ((mask, mask_px), (wmap, map_px)):
        np.testing.assert_allclose(_pixels(img), px, atol=1e-6)
        assert img.colorspace_settings.name == "Non-Color"
        assert img.packed_file is not None  # so it is saved with the file
    assert mask.alpha_mode == "CHANNEL_PACKED"
    # a second run (the tags are right now) changes nothing either
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    np.testing.assert_allclose(_pixels(mask), mask_px, atol=1e-6)
    path = str(tmp_blend("painted"))
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    np.testing.assert_allclose(_pixels(bpy.data.images["Painted Mask"]), mask_px, atol=1e-6)
    np.testing.assert_allclose(_pixels(bpy.data.images["Painted Map"]), map_px, atol=1e-6)


def test_set_up_keeps_unsaved_changes_of_a_file_image(tmp_path):
    plane = _skin_plane()
    mask, px = _painted("Mask File", False, 3)
    mask.filepath_raw = str(tmp_path / "mask.png")
    mask.file_format = "PNG"
    mask.save()
    assert mask.source == "FILE" and not mask.is_dirty
    px = 1.0 - px
    mask.pixels.foreach_set(px)  # painted after saving: the change lives only in memory
    plane.ewrinkles_face.maps.mask_a = mask
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    np.testing.assert_allclose(_pixels(mask), px, atol=1e-6)
    assert mask.colorspace_settings.name == "Non-Color" and mask.alpha_mode == "CHANNEL_PACKED"
    assert mask.packed_file is None  # still the user's file, with its unsaved changes


# --- shape-key names with a quote and a backslash ------------------------------------------
def _driver(idb, path):
    fc = idb.animation_data.drivers.find(path) if idb.animation_data else None
    assert fc is not None, f"no driver on {path}"
    return fc


def test_a_shape_key_with_quotes_drives_a_muscle():
    face, muscle = scenes.wrinkled_face()
    key = face.shape_key_add(name=ODD_KEY)
    key.value = 0.0
    bpy.context.view_layer.objects.active = muscle
    assert bpy.ops.wrinkle.drive_contraction(shape_key=ODD_KEY, gain=0.5) == {"FINISHED"}
    fc = _driver(muscle, "ewrinkles_muscle.contraction")
    assert fc.driver.is_valid and fc.driver.is_simple_expression, fc.driver.expression
    for value in (0.8, 0.3):
        key.value = value
        bpy.context.view_layer.update()
        assert fc.driver.is_valid
        assert muscle.ewrinkles_muscle.contraction == pytest.approx(0.5 * value, abs=1e-6)


def test_a_shape_key_with_quotes_drives_a_map_expression():
    plane = _wired_plane(keys=(ODD_KEY,))
    assert bpy.ops.wrinkle.add_map_expression() == {"FINISHED"}
    maps = plane.ewrinkles_face.maps
    ex = maps.expressions[0]
    ex.source = "SHAPE_KEY"
    ex.shape_key = ODD_KEY
    assert map_material.binding_problem(plane, 0) == ""
    ng = maps.weights_group
    path = f'nodes["{nodegroups.expr_node(0)}"].outputs[0].default_value'
    fc = _driver(ng, path)
    assert fc.driver.is_valid and fc.driver.type == "AVERAGE"
    key = plane.data.shape_keys.key_blocks[ODD_KEY]
    for value in (0.7, 0.2):
        key.value = value
        bpy.context.view_layer.update()
        assert fc.driver.is_valid
        assert ng.nodes[nodegroups.expr_node(0)].outputs[0].default_value == pytest.approx(value, abs=1e-6)


# --- NaN settings --------------------------------------------------------------------------
def test_tension_gain_and_the_other_map_settings_refuse_nan():
    plane = _wired_plane()
    assert bpy.ops.wrinkle.add_map_expression() == {"FINISHED"}
    maps = plane.ewrinkles_face.maps
    nan = float("nan")
    maps.tension_gain = 2.0
    maps.tension_gain = nan
    assert maps.tension_gain == 5.0  # the default
    maps.strength = nan
    assert maps.strength == 1.0
    maps.zone_strength[2] = nan
    assert tuple(maps.zone_strength) == (1.0,) * 8
    maps.zone_power = (0.5, nan, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5)
    assert tuple(maps.zone_power) == (0.5, 1.0, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5)
    ex = maps.expressions[0]
    ex.weights[0] = 0.25
    ex.weights[1] = nan
    assert tuple(ex.weights)[:2] == (0.25, 0.0)
    ex.value = nan
    assert ex.value == 0.0
    # and nothing non-finite reached the weights group
    for node in maps.weights_group.nodes:
        for sock in node.inputs:
            value = getattr(sock, "default_value", 0.0)
            if isinstance(value, float):
                assert math.isfinite(value), (node.name, sock.name)


# --- pixels that are not finite in the converters ------------------------------------------
def _float_image(name, rgb):
    img = mapscenes.data_image(name, rgb)
    return img


def _bad_pixels(base_rgb):
    rgb = np.array(base_rgb, np.float32).copy()
    rgb[0, 0, 0] = np.nan
    rgb[1, 2, 1] = np.inf
    rgb[3, 3, 2] = -np.inf
    return rgb


def _read(name):
    img = bpy.data.images[name]
    return _pixels(img).reshape(img.size[1], img.size[0], 4)


FLAT_NORMAL = np.tile(np.array([0.5, 0.5, 1.0], np.float32), (SIZE, SIZE, 1))
TILTED = np.tile(np.array([0.6, 0.45, 0.95], np.float32), (SIZE, SIZE, 1))


def test_convert_to_derivative_replaces_non_finite_pixels(capfd):
    _float_image("Bad Normal", _bad_pixels(TILTED))
    assert bpy.ops.wrinkle.convert_to_derivative(source="Bad Normal", output="PD") == {"FINISHED"}
    out = _read("PD")
    assert np.isfinite(out).all()
    np.testing.assert_allclose(out[0, 0, :3], (0.5, 0.5, 0.0), atol=1e-6)  # a flat normal's
    np.testing.assert_allclose(out[3, 3, :3], (0.5, 0.5, 0.0), atol=1e-6)
    assert out[0, 1, 0] != 0.5  # the finite pixels are converted as before
    text = capfd.readouterr().out
    assert "3 pixels were not finite (NaN or infinity) and were replaced by a flat normal" in text


def test_convert_to_normal_replaces_non_finite_pixels(capfd):
    pd = np.tile(np.array([0.6, 0.4, 0.0], np.float32), (SIZE, SIZE, 1))
    pd[5, 5, 2] = np.nan  # blue is not read from a PD map: not counted
    _float_image("Bad PD", _bad_pixels(pd))
    assert bpy.ops.wrinkle.convert_to_normal(source="Bad PD", output="N") == {"FINISHED"}
    out = _read("N")
    assert np.isfinite(out).all()
    np.testing.assert_allclose(out[0, 0, :3], (0.5, 0.5, 1.0), atol=1e-6)
    np.testing.assert_allclose(out[1, 2, :3], (0.5, 0.5, 1.0), atol=1e-6)
    text = capfd.readouterr().out
    assert "2 pixels were not finite (NaN or infinity) and were replaced by zero slopes" in text


def test_make_difference_map_replaces_non_finite_pixels(capfd):
    _float_image("Base", _bad_pixels(FLAT_NORMAL))
    wrinkle = TILTED.copy()
    wrinkle[6, 6, 0] = np.inf
    wrinkle[0, 0, 1] = np.nan  # the same pixel as the base's NaN: counted once
    _float_image("Wrinkle", wrinkle)
    assert bpy.ops.wrinkle.make_difference_map(base="Base", wrinkle="Wrinkle", output="D") == {"FINISHED"}
    out = _read("D")
    assert np.isfinite(out).all()
    for row, col in ((0, 0), (1, 2), (3, 3), (6, 6)):
        np.testing.assert_allclose(out[row, col, :3], 0.5, atol=1e-6)
    np.testing.assert_allclose(out[2, 2, :3], 0.5 + 0.5 * (TILTED[0, 0] - FLAT_NORMAL[0, 0]), atol=1e-6)
    text = capfd.readouterr().out
    assert "4 pixels were not finite (NaN or infinity) and were replaced by a flat normal" in text


# --- muscles linked from a library ---------------------------------------------------------
def test_disable_with_delete_muscles_keeps_muscles_linked_from_a_library(tmp_blend, capfd):
    face = scenes.make_face("Library Face")
    bpy.ops.wrinkle.enable()
    lib_muscle = scenes.add_sheet(face)
    lib_name = lib_muscle.name
    lib_path = str(tmp_blend("library"))
    bpy.ops.wm.save_as_mainfile(filepath=lib_path)

    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    with bpy.data.libraries.load(lib_path, link=True) as (data_from, data_to):
        data_to.objects = [lib_name]
    linked = data_to.objects[0]
    assert linked.library is not None and linked.ewrinkles_muscle.is_muscle
    bpy.context.scene.collection.objects.link(linked)
    face = scenes.make_face("Local Face")
    bpy.ops.wrinkle.enable()
    local = scenes.add_sheet(face)
    local_name = local.name
    face.ewrinkles_face.muscles.add().object = linked
    assert [r.object for r in face.ewrinkles_face.muscles] == [local, linked]
    capfd.readouterr()

    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.disable(remove_muscles=True) == {"FINISHED"}
    muscles = [ob for ob in bpy.data.objects if ob.ewrinkles_muscle.is_muscle]
    assert all(ob.library is not None for ob in muscles)  # the local muscle is deleted
    assert not any(ob.name == local_name and ob.library is None for ob in bpy.data.objects)
    kept = [ob for ob in bpy.data.objects if ob.name == lib_name and ob.library is not None]
    assert kept == [linked]  # the linked one is not ours to delete
    assert [r.object for r in face.ewrinkles_face.muscles] == [linked]  # it stays on the face
    assert not face.ewrinkles_face.enabled
    assert "1 muscle(s) linked from a library were kept" in capfd.readouterr().out


# --- crafted custom properties -------------------------------------------------------------
CRAFTED = [5, "ab", [1, 2], [1.5], {"a": 1}, {"a": "x", "b": "y"}, ["a"], ["a", "b", "c"],
           [["a", "b"]], [b"a", b"b"]]


BSDF = "<the BSDF node's name>"
CRAFTED_PREVIOUS = CRAFTED + [[BSDF], {BSDF: 1}, [BSDF, "x", "y"]]


def _named(value, name):
    """``value`` with the BSDF placeholder replaced by ``name``: a real node, so that
    what follows the name is used."""
    if isinstance(value, dict):
        return {_named(k, name): v for k, v in value.items()}
    if isinstance(value, list):
        return [_named(v, name) for v in value]
    return name if value == BSDF else value


@pytest.mark.parametrize("value", CRAFTED_PREVIOUS, ids=repr)
def test_remove_wrinkle_maps_ignores_a_crafted_previous_normal(value):
    plane = _wired_plane()
    nt = plane.ewrinkles_face.maps.material.node_tree
    bsdf = next(n for n in nt.nodes if n.type == "BSDF_PRINCIPLED")
    nt.nodes[map_material.BLEND_NODE]["ewrinkles_previous_normal"] = _named(value, bsdf.name)
    assert bpy.ops.wrinkle.remove_wrinkle_maps.poll()
    assert bpy.ops.wrinkle.remove_wrinkle_maps() == {"FINISHED"}
    assert map_material.BLEND_NODE not in nt.nodes
    assert plane.ewrinkles_face.maps.material is None


@pytest.mark.parametrize("value", CRAFTED, ids=repr)
def test_free_bake_and_the_table_ignore_a_crafted_baked_list(value):
    plane = _wired_plane()
    maps = plane.ewrinkles_face.maps
    maps.weights_group["ewrinkles_baked"] = value
    assert bpy.ops.wrinkle.add_map_expression() == {"FINISHED"}  # binds, reading the list
    assert map_material.baked_paths(maps.weights_group) <= {"a", "b", "c"}
    if bpy.ops.wrinkle.free_bake.poll():
        assert bpy.ops.wrinkle.free_bake() == {"FINISHED"}
    assert not bpy.ops.wrinkle.free_bake.poll()


def test_remove_wrinkle_maps_still_restores_a_well_formed_previous_normal():
    plane = _skin_plane()
    z = np.zeros((SIZE, SIZE, 4), np.float32)
    maps = plane.ewrinkles_face.maps
    maps.mask_a = mapscenes.data_image("Mask A", z)
    maps.map_a = mapscenes.data_image("Map", np.full((SIZE, SIZE, 3), 0.5, np.float32))
    nt = plane.active_material.node_tree
    bsdf = next(n for n in nt.nodes if n.type == "BSDF_PRINCIPLED")
    bump = nt.nodes.new("ShaderNodeBump")
    nt.links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    assert bsdf.inputs["Normal"].links[0].from_node.name != bump.name
    assert bpy.ops.wrinkle.remove_wrinkle_maps() == {"FINISHED"}
    assert bsdf.inputs["Normal"].links[0].from_node == bump


@pytest.mark.parametrize("crafted", ["layout", "nodes"])
def test_a_weights_group_that_does_not_match_its_layout_tag_is_rebuilt(crafted):
    plane = _wired_plane()
    maps = plane.ewrinkles_face.maps
    ng = maps.weights_group
    if crafted == "layout":
        ng["ewrinkles_layout"] = {"a": 1}
    else:  # the tag says all is there, but a node is gone (deleted by hand, or crafted)
        ng.nodes.remove(ng.nodes["Power 0 3"])
    maps.strength = 0.5  # syncs
    assert map_material.status(plane) == ""
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    assert "Power 0 3" in ng.nodes


def test_a_blend_group_whose_version_tag_lies_is_completed():
    plane = _wired_plane()
    ng = bpy.data.node_groups[nodegroups.BLEND_GROUP]
    for name in ("Strength", "Mask B Alpha"):
        ng.interface.remove(next(s for s in ng.interface.items_tree
                                 if s.item_type == "SOCKET" and s.name == name))
    assert ng["ewrinkles_map_version"] == nodegroups.VERSION  # the tag says all is there
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    blend = plane.ewrinkles_face.maps.material.node_tree.nodes[map_material.BLEND_NODE]
    assert "Strength" in blend.inputs and blend.inputs["Mask B Alpha"].links
