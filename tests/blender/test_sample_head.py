"""Add Sample Head: the shipped ICT head with its expressions, parts, materials and panel.

Nothing is rendered here; the look is checked by eye (README pictures, the showcase) and the
skin's regions in tests/core/test_skin.py."""

import bpy
import numpy as np
import pytest

from wrinkle_addon.glue import sample_head


def _add(**kw):
    assert bpy.ops.wrinkle.add_sample_head(**kw) == {"FINISHED"}
    skin = bpy.context.active_object
    parts = next((c for c in skin.children), None)
    return skin, parts


def _evaluated(ob):
    deps = bpy.context.evaluated_depsgraph_get()
    me = ob.evaluated_get(deps).data
    co = np.empty(len(me.vertices) * 3, np.float32)
    me.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def test_adds_the_head_with_its_expressions_at_the_cursor():
    bpy.context.scene.cursor.location = (0.5, 0.0, 1.2)
    skin, parts = _add()
    assert skin.name == "Sample Head" and skin.select_get()
    assert tuple(skin.location) == pytest.approx((0.5, 0.0, 1.2))
    keys = [k.name for k in skin.data.shape_keys.key_blocks]
    assert keys[0] == "Basis" and len(keys) == 54 and "jawOpen" in keys and "eyeBlink_L" in keys
    assert len(skin.data.vertices) == 11248 and len(skin.data.polygons) == 11144
    assert "UVMap" in skin.data.uv_layers
    assert parts is not None and parts.parent == skin
    assert [m.name for m in parts.data.materials] == [
        "Sample Eye", "Sample Cornea", "Sample Lacrimal Fluid", "Sample Lashes", "Sample Teeth",
        "Sample Gums and Tongue", "Sample Lower Lashes"]
    used = np.bincount([p.material_index for p in parts.data.polygons], minlength=7)
    assert (used > 0).all()


def test_parts_follow_blinks_and_jaw_by_one_variable_drivers():
    skin, parts = _add()
    kb = skin.data.shape_keys.key_blocks
    part_keys = parts.data.shape_keys
    for fc in part_keys.animation_data.drivers:
        drv = fc.driver
        assert drv.type == "AVERAGE" and len(drv.variables) == 1  # renders without the add-on
        assert drv.variables[0].targets[0].id == skin.data.shape_keys
    names = {k.name for k in part_keys.key_blocks}
    assert {"eyeBlink_L", "jawOpen"} <= names and "mouthClose" not in names  # only keys that move a part
    rest = _evaluated(parts)
    kb["jawOpen"].value = 1.0
    kb["eyeBlink_L"].value = 1.0
    posed = _evaluated(parts)
    moved = np.linalg.norm(posed - rest, axis=1)
    teeth = parts.data.materials.find("Sample Teeth")
    lashes = parts.data.materials.find("Sample Lashes")
    eyes = parts.data.materials.find("Sample Eye")
    def verts(slot):
        return np.unique([v for p in parts.data.polygons if p.material_index == slot for v in p.vertices])
    assert moved[verts(teeth)].max() > 0.02  # jawOpen drops the lower teeth (metres)
    left = verts(lashes)[rest[verts(lashes), 0] > 0]
    assert moved[left].max() > 0.01  # the left upper lashes close with the blink
    assert moved[verts(eyes)].max() < 1e-6  # the eyeballs stay


def test_skin_material_and_attributes():
    skin, parts = _add()
    mat = skin.data.materials[0]
    bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    assert bsdf.inputs["Subsurface Weight"].default_value == 1.0
    radius = tuple(bsdf.inputs["Subsurface Radius"].default_value)
    assert radius[0] > radius[1] > radius[2]  # red scatters furthest
    assert bsdf.inputs["Roughness"].is_linked and bsdf.inputs["Specular IOR Level"].is_linked
    assert bsdf.inputs["Base Color"].is_linked and bsdf.inputs["Normal"].is_linked
    images = [n for n in mat.node_tree.nodes if n.type == "TEX_IMAGE"]
    assert not images
    read = {n.attribute_name for n in mat.node_tree.nodes if n.type == "ATTRIBUTE"}
    assert read == {sample_head.REST_ATTR, sample_head.REGIONS_ATTR}
    for name in read:
        assert skin.data.attributes[name].domain == "POINT"
    eye = parts.data.materials["Sample Eye"]
    assert {n.attribute_name for n in eye.node_tree.nodes if n.type == "ATTRIBUTE"} == {sample_head.EYE_ATTR}
    assert sample_head.EYE_ATTR in parts.data.attributes


def test_the_wrinkles_stack_through_the_pore_bump():
    from wrinkle_addon.glue import nodes
    skin, _parts = _add(parts=False)
    mat = skin.data.materials[0]
    bsdf = nodes.principled(mat.node_tree)
    sock = nodes.normal_input(mat.node_tree, bsdf)
    assert sock.node.type == "BUMP" and sock.name == "Normal"  # a wrinkle map goes under the pores


def test_without_parts_and_undo():
    skin, parts = _add(parts=False)
    assert parts is None and len(bpy.data.objects) == 1
    assert "UNDO" in bpy.types.WRINKLE_OT_add_sample_head.bl_options


def test_survives_save_and_reload(tmp_blend):
    skin, parts = _add()
    path = str(tmp_blend("sample"))
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    skin = bpy.data.objects["Sample Head"]
    parts = skin.children[0]
    assert len(parts.data.shape_keys.animation_data.drivers) == len(parts.data.shape_keys.key_blocks) - 1
    assert sample_head.REGIONS_ATTR in skin.data.attributes
    rest = _evaluated(parts)
    skin.data.shape_keys.key_blocks["jawOpen"].value = 1.0
    assert np.abs(_evaluated(parts) - rest).max() > 0.02


def test_missing_data_is_a_clear_error_and_leaves_nothing(monkeypatch, tmp_path):
    monkeypatch.setattr(sample_head, "PARTS_FILE", tmp_path / "gone.npz")
    before = (len(bpy.data.objects), len(bpy.data.meshes), len(bpy.data.materials))
    with pytest.raises(RuntimeError, match="sample head's data cannot be read.*reinstall"):
        bpy.ops.wrinkle.add_sample_head()
    assert (len(bpy.data.objects), len(bpy.data.meshes), len(bpy.data.materials)) == before


def test_start_panel_offers_the_sample_head_when_nothing_is_selected():
    panel = bpy.types.VIEW3D_PT_wrinkle_start
    assert panel.poll(bpy.context)
    skin, _parts = _add(parts=False)
    assert not panel.poll(bpy.context) and bpy.types.VIEW3D_PT_wrinkle_face.poll(bpy.context)


def test_in_the_add_mesh_menu():
    from wrinkle_addon.ops import sample_head as op
    assert op.menu_func in bpy.types.VIEW3D_MT_mesh_add._dyn_ui_initialize()
