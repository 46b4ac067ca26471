"""The expression table: drivers, zone sums, clamp, cancelling, and files without Python."""

import addon_utils
import bpy
import numpy as np
import pytest

from tests.blender import mapscenes
from wrinkle_addon.core.maps import jimenez as wm
from wrinkle_addon.glue.maps import map_material, nodegroups

SIZE = 8
FLAT = np.tile(np.array([0.5, 0.5, 1.0], np.float32), (SIZE, SIZE, 1))


def _pd_map(rng):
    return wm.normal_to_derivative(mapscenes.random_normal_map(rng, SIZE, 0.3))


def _expected(face, values, map_a, mask_a, mask_b, base=FLAT, tension=0.0):
    maps = face.ewrinkles_face.maps
    sums = wm.expression_sums(values, map_material.table(maps)) + tension
    w = wm.zone_response(sums, np.array(maps.zone_strength), np.array(maps.zone_power))
    return wm.encode(wm.blend(base, [map_a, np.full_like(map_a, 0.5)], mask_a, mask_b,
                              [w, np.zeros(8)], maps.strength))


def _render(render_small, tmp_path, name="r.exr"):
    return render_small(bpy.context.scene, tmp_path / name, size=SIZE, samples=1)[..., :3]


def _forehead_face(rng, keys=("browInnerUp_L", "browDown_L"), cuts=0):
    """Zones 1-4 (the forehead) each cover a quarter of the plane; mask B is empty."""
    mask_a = np.zeros((SIZE, SIZE, 4), np.float32)
    half = SIZE // 2
    mask_a[:half, :half, 0] = mask_a[:half, half:, 1] = 1.0
    mask_a[half:, :half, 2] = mask_a[half:, half:, 3] = 1.0
    mask_b = np.zeros((SIZE, SIZE, 4), np.float32)
    map_a = _pd_map(rng)
    face = mapscenes.skin_plane(SIZE, mask_a, mask_b, map_a, keys=keys, cuts=cuts)
    return face, map_a, mask_a, mask_b


@pytest.mark.render
def test_surprise_plus_anger_smooths_the_forehead(render_small, tmp_path):
    """Jimenez et al. Fig. 1.5: anger's negative forehead weights cancel surprise's."""
    rng = np.random.default_rng(0)
    face, map_a, mask_a, mask_b = _forehead_face(rng)
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    assert bpy.ops.wrinkle.load_map_preset(preset="TABLE_1_1") == {"FINISHED"}
    names = [ex.name for ex in face.ewrinkles_face.maps.expressions]
    assert face.ewrinkles_face.maps.expressions["Surprise"].shape_key == "browInnerUp_L"
    assert face.ewrinkles_face.maps.expressions["Anger"].shape_key == "browDown_L"
    mapscenes.show_blend_output(face.ewrinkles_face.maps.material)
    keys = face.data.shape_keys.key_blocks
    flat = wm.encode(wm.normalize(wm.decode(FLAT)))

    keys["browInnerUp_L"].value = 1.0
    surprise = _render(render_small, tmp_path, "s.exr")
    keys["browDown_L"].value = 1.0
    both = _render(render_small, tmp_path, "sa.exr")

    values = np.array([1.0 if n in ("Surprise", "Anger") else 0.0 for n in names])
    assert np.abs(both - _expected(face, values, map_a, mask_a, mask_b)).max() < 1e-4
    dev_surprise = np.abs(surprise - flat).max(axis=2)
    dev_both = np.abs(both - flat).max(axis=2)
    half = SIZE // 2
    assert dev_surprise.min() > 0.01  # surprise wrinkles the whole forehead
    # inner forehead (Blue, Brown: 0.8 - 0.8): smooth, to the bit
    assert dev_both[half:].max() < 1e-5
    # outer forehead (Red, Green: 0.8 - 0.6 = 0.2): a quarter of the slope is left
    assert dev_both[:half].max() < 0.3 * dev_surprise[:half].max() + 1e-3


def test_zone_weights_are_what_the_weights_group_computes():
    """material.zone_weights: per map, the table's weights over the expressions' driven
    values, clamped, with the zones' Response and Strength; an expression on map 2 lights
    map 2 only."""
    rng = np.random.default_rng(3)
    face, *_ = _forehead_face(rng)
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    assert bpy.ops.wrinkle.load_map_preset(preset="TABLE_1_1") == {"FINISHED"}
    maps = face.ewrinkles_face.maps
    maps.expressions["Surprise"].map_index = 2
    maps.zone_power[2] = 2.0
    maps.zone_strength[0] = 1.5
    keys = face.data.shape_keys.key_blocks
    keys["browInnerUp_L"].value, keys["browDown_L"].value = 0.7, 0.5
    bpy.context.view_layer.update()
    got = map_material.zone_weights(face)
    names = [ex.name for ex in maps.expressions]
    table = map_material.table(maps)
    anger = 0.5 * table[names.index("Anger")]
    surprise = 0.7 * table[names.index("Surprise")]
    power, strength = np.array(maps.zone_power), np.array(maps.zone_strength)
    np.testing.assert_allclose(got[0], strength * np.clip(anger, 0, 1) ** power, atol=1e-6)
    np.testing.assert_allclose(got[1], strength * np.clip(surprise, 0, 1) ** power, atol=1e-6)
    assert got[1][2] == pytest.approx(0.56 ** 2) and got[0][0] == 0.0  # anger's forehead: < 0, clamped


@pytest.mark.render
def test_uvs_outside_the_0_1_square_get_no_wrinkles(render_small, tmp_path):
    """The masks cover the 0-1 UV square: UVs in another tile (the ICT head's back of the
    head lies at u 1-2) must not wrap around onto the face's zones."""
    rng = np.random.default_rng(1)
    face, _map_a, _mask_a, _mask_b = _forehead_face(rng)
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    assert bpy.ops.wrinkle.load_map_preset(preset="TABLE_1_1") == {"FINISHED"}
    mapscenes.show_blend_output(face.ewrinkles_face.maps.material)
    face.data.shape_keys.key_blocks["browInnerUp_L"].value = 1.0
    flat = wm.encode(wm.normalize(wm.decode(FLAT)))
    inside = _render(render_small, tmp_path, "in.exr")
    uv = np.empty(len(face.data.loops) * 2, np.float32)
    layer = face.data.uv_layers.active.uv
    layer.foreach_get("vector", uv)
    uv[0::2] += 1.0  # the next tile along u
    layer.foreach_set("vector", uv)
    face.data.update()
    outside = _render(render_small, tmp_path, "out.exr")
    assert np.abs(inside - flat).max(axis=2).min() > 0.01
    assert np.abs(outside - flat).max() < 1e-5


@pytest.mark.render
def test_a_wrinkle_uv_map_other_than_the_render_one_gets_its_own_tangents(render_small, tmp_path):
    """The shared group's Normal Map node uses the render-active UV map; a face whose maps
    live on another UV map gets a Normal Map node of that map, so its tangents match."""
    rng = np.random.default_rng(2)
    face, map_a, mask_a, mask_b = _forehead_face(rng)
    me = face.data
    own = me.uv_layers.active.name
    uv = np.empty(len(me.loops) * 2, np.float32)
    me.uv_layers[own].uv.foreach_get("vector", uv)
    uv = uv.reshape(-1, 2)
    turned = me.uv_layers.new(name="Turned")  # the same layout turned by 90 degrees
    turned.uv.foreach_set("vector", np.stack([1.0 - uv[:, 1], uv[:, 0]], 1).ravel())
    turned.active_render = True
    face.ewrinkles_face.maps.uv_map = own
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    assert bpy.ops.wrinkle.load_map_preset(preset="TABLE_1_1") == {"FINISHED"}
    mat = face.ewrinkles_face.maps.material
    assert mat.node_tree.nodes[map_material.NORMAL_NODE].uv_map == own
    mapscenes.show_blend_output(mat)
    me.shape_keys.key_blocks["browInnerUp_L"].value = 1.0
    got = _render(render_small, tmp_path)
    values = np.array([float(ex.name == "Surprise") for ex in face.ewrinkles_face.maps.expressions])
    assert np.abs(got - _expected(face, values, map_a, mask_a, mask_b)).max() < 1e-4
    # back on the render UV map, the extra node goes
    face.ewrinkles_face.maps.uv_map = ""
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    assert map_material.NORMAL_NODE not in mat.node_tree.nodes


@pytest.mark.render
def test_a_third_map_from_its_panel_slot(render_small, tmp_path):
    """Maps 3-8 have slots too: an image in Wrinkle Map 3 is wired into the group's Map 3
    and carries the expressions whose Map is 3."""
    rng = np.random.default_rng(4)
    face, map_a, mask_a, mask_b = _forehead_face(rng)
    map_c = _pd_map(rng)
    maps = face.ewrinkles_face.maps
    maps.map_c = mapscenes.data_image("Third", map_c)
    assert map_material.n_maps(maps) == 3
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    assert bpy.ops.wrinkle.load_map_preset(preset="TABLE_1_1") == {"FINISHED"}
    maps.expressions["Surprise"].map_index = 3
    nt = maps.material.node_tree
    assert nt.nodes["Wrinkle Map 3"].outputs["Color"].links[0].to_socket.name == nodegroups.map_socket(2)
    mapscenes.show_blend_output(maps.material)
    face.data.shape_keys.key_blocks["browInnerUp_L"].value = 1.0
    got = _render(render_small, tmp_path)
    row = wm.zone_response(maps.expressions["Surprise"].weights, np.array(maps.zone_strength),
                           np.array(maps.zone_power))
    flat = np.full_like(map_a, 0.5)
    want = wm.encode(wm.blend(FLAT, [map_a, flat, map_c], mask_a, mask_b, [np.zeros(8), np.zeros(8), row],
                              maps.strength))
    assert np.abs(got - want).max() < 1e-4
    on_map_1 = wm.encode(wm.blend(FLAT, [map_a], mask_a, mask_b, [row], maps.strength))
    assert np.abs(got - on_map_1).max() > 0.01  # the third map's wrinkles, not the first's


@pytest.mark.render
def test_twenty_expressions_times_eight_zones(render_small, tmp_path):
    """Every zone sums 20 driven expressions: no expression-length limit, exact sums,
    per-zone strength and response curve."""
    rng = np.random.default_rng(1)
    keys = [f"key{i:02d}" for i in range(20)]
    mask_a = rng.uniform(0, 0.5, (SIZE, SIZE, 4)).astype(np.float32)
    mask_b = rng.uniform(0, 0.5, (SIZE, SIZE, 4)).astype(np.float32)
    map_a = _pd_map(rng)
    face = mapscenes.skin_plane(SIZE, mask_a, mask_b, map_a, keys=keys)
    maps = face.ewrinkles_face.maps
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    table = rng.uniform(-0.25, 0.25, (20, 8)).round(3)
    for i, k in enumerate(keys):
        assert bpy.ops.wrinkle.add_map_expression() == {"FINISHED"}
        ex = maps.expressions[i]
        ex.name, ex.source, ex.shape_key = f"E{i}", "SHAPE_KEY", k
        ex.weights = table[i]
    maps.zone_strength = rng.uniform(0.5, 2.0, 8)
    maps.zone_power = rng.uniform(0.25, 2.0, 8)
    ng = maps.weights_group
    drivers = ng.animation_data.drivers
    assert len(drivers) == 20
    assert all(fc.driver.type == "AVERAGE" and len(fc.driver.variables) == 1 for fc in drivers)
    mapscenes.show_blend_output(maps.material)
    values = rng.uniform(0, 1, 20)
    for k, v in zip(keys, values):
        face.data.shape_keys.key_blocks[k].value = float(v)
    got = _render(render_small, tmp_path)
    want = _expected(face, values, map_a, mask_a, mask_b)
    sums = wm.expression_sums(values, table)
    assert (sums < 0).any() and ((sums > 0) & (sums < 1)).any()
    assert np.abs(got - want).max() < 1e-4


@pytest.fixture
def no_autorun():
    prefs = bpy.context.preferences.filepaths
    old = prefs.use_scripts_auto_execute
    prefs.use_scripts_auto_execute = False
    yield
    prefs.use_scripts_auto_execute = old


@pytest.mark.render
def test_drivers_render_in_a_file_reopened_without_python_or_addon(render_small, tmp_path, tmp_blend,
                                                                  no_autorun):
    rng = np.random.default_rng(2)
    face, map_a, mask_a, mask_b = _forehead_face(rng)
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    assert bpy.ops.wrinkle.load_map_preset(preset="TABLE_1_1") == {"FINISHED"}
    mapscenes.show_blend_output(face.ewrinkles_face.maps.material)
    names = [ex.name for ex in face.ewrinkles_face.maps.expressions]
    key = face.data.shape_keys.key_blocks["browInnerUp_L"]
    for frame, v in ((1, 0.0), (5, 1.0)):
        key.value = v
        key.keyframe_insert("value", frame=frame)
    scene = bpy.context.scene
    scene.frame_set(5)
    values = np.array([1.0 if n == "Surprise" else 0.0 for n in names])
    want5 = _expected(face, values, map_a, mask_a, mask_b)
    path = tmp_blend("maps")
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    addon_utils.disable("wrinkle_addon", default_set=True)
    try:
        bpy.ops.wm.open_mainfile(filepath=str(path), use_scripts=False)
        scene = bpy.context.scene
        scene.frame_set(1)
        scene.frame_set(5)
        got5 = _render(render_small, tmp_path, "5.exr")
        scene.frame_set(1)
        got1 = _render(render_small, tmp_path, "1.exr")
    finally:
        addon_utils.enable("wrinkle_addon", default_set=True)
    assert np.abs(got5 - want5).max() < 1e-4
    assert np.abs(got1 - wm.encode(wm.normalize(wm.decode(FLAT)))).max() < 1e-5


@pytest.mark.render
def test_negative_and_large_weights_are_clamped_per_zone(render_small, tmp_path):
    rng = np.random.default_rng(4)
    face, map_a, mask_a, mask_b = _forehead_face(rng, keys=())
    maps = face.ewrinkles_face.maps
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    assert bpy.ops.wrinkle.add_map_expression() == {"FINISHED"}
    ex = maps.expressions[0]
    ex.value = 1.0
    ex.weights = (3.0, -2.0, 1.0, 0.5, 0, 0, 0, 0)
    mapscenes.show_blend_output(maps.material)
    got = _render(render_small, tmp_path)
    want = wm.encode(wm.blend(FLAT, [map_a, np.full_like(map_a, 0.5)], mask_a, mask_b,
                              [[1.0, 0.0, 1.0, 0.5, 0, 0, 0, 0], np.zeros(8)]))
    assert np.abs(got - want).max() < 1e-4


def test_remove_restores_the_previous_normal_input():
    rng = np.random.default_rng(5)
    face, *_ = _forehead_face(rng, keys=())
    mat = face.active_material
    nt = mat.node_tree
    bsdf = next(n for n in nt.nodes if n.type == "BSDF_PRINCIPLED")
    nmap = nt.nodes.new("ShaderNodeNormalMap")
    tex = nt.nodes.new("ShaderNodeTexImage")
    tex.image = mapscenes.data_image("Existing Normal", FLAT)
    nt.links.new(tex.outputs["Color"], nmap.inputs["Color"])
    nt.links.new(nmap.outputs["Normal"], bsdf.inputs["Normal"])
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    assert face.ewrinkles_face.maps.base_image.name == "Existing Normal"  # picked up as the base
    assert bsdf.inputs["Normal"].links[0].from_node.name == "Wrinkle Map Blend"
    assert bpy.ops.wrinkle.remove_wrinkle_maps() == {"FINISHED"}
    assert bsdf.inputs["Normal"].links[0].from_node == nmap
    assert not any(n.name.startswith("Wrinkle") for n in nt.nodes)


@pytest.mark.parametrize("case", ["no_uv", "no_principled", "missing_file", "wrong_channels",
                                  "non_square", "size_mismatch", "linked_group"])
def test_bad_input_is_refused_and_leaves_the_material_unchanged(case, tmp_path):
    rng = np.random.default_rng(6)
    face, *_ = _forehead_face(rng, keys=())
    maps = face.ewrinkles_face.maps
    mat = face.active_material
    if case == "no_uv":
        face.data.uv_layers.remove(face.data.uv_layers[0])
        match = "no UV map"
    elif case == "no_principled":
        for n in list(mat.node_tree.nodes):
            if n.type == "BSDF_PRINCIPLED":
                mat.node_tree.nodes.remove(n)
        match = "no Principled BSDF"
    elif case == "missing_file":
        img = bpy.data.images.new("Lost", 4, 4)
        img.source = "FILE"
        img.filepath = str(tmp_path / "nowhere.png")
        maps.map_a = img
        match = "no pixels"
    elif case == "wrong_channels":
        maps.mask_a = bpy.data.images.new("RGB mask", SIZE, SIZE, alpha=False)  # no zone 4
        match = "no alpha channel"
    elif case == "non_square":
        maps.map_a = mapscenes.data_image("wide", np.full((SIZE, 2 * SIZE, 4), 0.5))
        match = "must be square"
    elif case == "size_mismatch":
        maps.map_b = mapscenes.data_image("small", np.full((SIZE // 2, SIZE // 2, 4), 0.5))
        match = "differ in size"
    else:
        ng = bpy.data.node_groups.new(nodegroups.BLEND_GROUP, "ShaderNodeTree")
        path = tmp_path / "lib.blend"
        bpy.data.libraries.write(str(path), {ng})
        bpy.data.node_groups.remove(ng)
        with bpy.data.libraries.load(str(path), link=True) as (src, dst):
            dst.node_groups = [nodegroups.BLEND_GROUP]
        match = "read-only"
    before = sorted((n.name, n.bl_idname) for n in mat.node_tree.nodes)
    links = len(mat.node_tree.links)
    with pytest.raises(RuntimeError, match=match):  # an ERROR report, the operator cancelled
        bpy.ops.wrinkle.setup_wrinkle_maps()
    assert sorted((n.name, n.bl_idname) for n in mat.node_tree.nodes) == before
    assert len(mat.node_tree.links) == links
    assert match in map_material.check(face)


@pytest.mark.render
def test_tension_mode_follows_the_measured_compression_in_renders(render_small, tmp_path):
    """Zone weights from the skin's compression, frame by frame, in background renders:
    a shape key squashes the plane along v by 30 % on frame 3, not on frame 1."""
    rng = np.random.default_rng(7)
    face, map_a, mask_a, mask_b = _forehead_face(rng, keys=("Squash",), cuts=9)
    # the rest plane is 1/0.7 taller than the camera's view; "Squash" brings it to the
    # 2 x 2 square the camera frames exactly, so frame 3 maps pixels to texels 1:1
    keys = face.data.shape_keys.key_blocks
    co = np.empty(len(face.data.vertices) * 3, np.float32)
    keys["Basis"].points.foreach_get("co", co)
    tall = co.reshape(-1, 3) * np.array([1.0, 1 / 0.7, 1.0], np.float32)
    for block in (keys["Basis"],):
        block.points.foreach_set("co", tall.ravel())
    face.data.vertices.foreach_set("co", tall.ravel())
    key = keys["Squash"]
    key.points.foreach_set("co", co)
    for frame, v in ((1, 0.0), (3, 1.0)):
        key.value = v
        key.keyframe_insert("value", frame=frame)
    maps = face.ewrinkles_face.maps
    maps.weight_mode, maps.tension_gain = "TENSION", 2.0
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    mapscenes.show_blend_output(maps.material)
    scene = bpy.context.scene
    scene.frame_set(3)
    # edges along v shrink by 30 %, along u not: an inner vertex's mean shrinkage is 0.15
    # (0.1 on the borders along v), so each forehead zone weighs about 2 * 0.15
    tension = nodegroups.read_tension(maps.weights_group)
    assert all(0.25 < t <= 0.3 + 1e-6 for t in tension[:4]) and tension[4:] == [0.0] * 4
    got3 = _render(render_small, tmp_path, "3.exr")
    want3 = _expected(face, np.zeros(0), map_a, mask_a, mask_b, tension=np.array(tension))
    scene.frame_set(1)
    got1 = _render(render_small, tmp_path, "1.exr")
    assert np.abs(got3 - want3).max() < 1e-4
    assert np.abs(got1 - wm.encode(wm.normalize(wm.decode(FLAT)))).max() < 1e-5
    # render(animation=True) sets the frames itself
    scene.frame_start, scene.frame_end = 3, 3
    scene.frame_set(1)
    scene.render.filepath = str(tmp_path / "anim_")
    scene.render.image_settings.file_format = "OPEN_EXR"
    bpy.ops.render.render(animation=True)
    img = bpy.data.images.load(str(tmp_path / "anim_0003.exr"))
    px = np.empty(SIZE * SIZE * 4, np.float32)
    img.pixels.foreach_get(px)
    assert np.abs(px.reshape(SIZE, SIZE, 4)[..., :3] - want3).max() < 1e-4


@pytest.mark.render
def test_muscle_driven_weights_bake_for_a_farm_without_the_addon(render_small, tmp_path, tmp_blend,
                                                                 no_autorun):
    """A muscle's contraction is an add-on property: the bake keys the expression value,
    so a file opened without the add-on renders the same frames."""
    rng = np.random.default_rng(8)
    face, map_a, mask_a, mask_b = _forehead_face(rng, keys=())
    muscle = bpy.data.objects.new("Frontalis", bpy.data.meshes.new("Frontalis"))
    bpy.context.scene.collection.objects.link(muscle)
    muscle.ewrinkles_muscle.is_muscle = True
    for frame, c in ((1, 0.0), (4, 1.0)):
        muscle.ewrinkles_muscle.contraction = c
        muscle.keyframe_insert("ewrinkles_muscle.contraction", frame=frame)
    bpy.context.view_layer.objects.active = face
    maps = face.ewrinkles_face.maps
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    assert bpy.ops.wrinkle.add_map_expression() == {"FINISHED"}
    ex = maps.expressions[0]
    ex.source, ex.muscle, ex.weights = "MUSCLE", muscle, (0.5, 0.5, 1.0, 1.0, 0, 0, 0, 0)
    mapscenes.show_blend_output(maps.material)
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 4
    scene.frame_set(3)
    live3 = _render(render_small, tmp_path, "live3.exr")
    c3 = muscle.ewrinkles_muscle.contraction  # keyed 0 -> 1 over frames 1-4 (Bezier ease)
    assert 0.2 < c3 < 0.95
    assert np.abs(live3 - _expected(face, [c3], map_a, mask_a, mask_b)).max() < 1e-4
    assert bpy.ops.wrinkle.bake() == {"FINISHED"}
    assert not maps.weights_group.animation_data.drivers
    path = tmp_blend("farm")
    name = face.name
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    addon_utils.disable("wrinkle_addon", default_set=True)
    try:
        bpy.ops.wm.open_mainfile(filepath=str(path), use_scripts=False)
        bpy.context.scene.frame_set(3)
        farm3 = _render(render_small, tmp_path, "farm3.exr")
    finally:
        addon_utils.enable("wrinkle_addon", default_set=True)
    assert np.abs(farm3 - live3).max() < 1e-5
    bpy.ops.wm.open_mainfile(filepath=str(path))
    face = bpy.data.objects[name]
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.free_bake() == {"FINISHED"}
    assert len(face.ewrinkles_face.maps.weights_group.animation_data.drivers) == 1
