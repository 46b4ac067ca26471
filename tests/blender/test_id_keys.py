"""A file saved under the custom property names of older versions (``migrate.KEYS``) opens
with every value under its ``ewrinkles_`` name, and the add-on reads them there: nothing is
rebuilt or lost."""

import bpy
import numpy as np

from tests.blender import mapscenes
from wrinkle_addon.glue import nodes, stage
from wrinkle_addon.glue.maps import map_material, nodegroups
from wrinkle_addon.props import migrate

OLD = dict(migrate.KEYS)
SIZE = 8


def _plain(value):
    for method in ("to_dict", "to_list"):
        if hasattr(value, method):
            return getattr(value, method)()
    return value


def _reopen(path):
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path))


def _old_keys():
    """(holder, key) of every old key stored (a description may be the artist's own)."""
    holders = [*bpy.data.objects, *bpy.data.materials, *bpy.data.node_groups]
    holders += [n for ng in bpy.data.node_groups for n in ng.nodes]
    holders += [n for m in bpy.data.materials if m.node_tree for n in m.node_tree.nodes]
    return [(h.name, k) for h in holders for k in h.keys() if k in OLD and k != "description"]


def test_every_old_key_moves_to_its_new_name_when_the_file_opens(tmp_blend):
    ng = bpy.data.node_groups.new("Old Group", "ShaderNodeTree")
    ng.use_fake_user = True
    node = ng.nodes.new("ShaderNodeValue")
    node.name = "Inner"
    mat = bpy.data.materials.new("Old Material")
    mat.use_fake_user = True
    nodes.use_nodes(mat)
    mat_node = mat.node_tree.nodes.new("ShaderNodeBump")
    mat_node.name = "Blend"
    mark = bpy.data.objects.new("Old Landmark", None)
    other = bpy.data.objects.new("Artist's Empty", None)
    for ob in (mark, other):
        bpy.context.scene.collection.objects.link(ob)
    written = {
        ng.name: (ng, {"wrinkle_baked": ["a", "b"], "wrinkle_layout": "w2:2:0,1", "wrinkle_map_version": 4,
                       "wrinkle_stage_version": {"odd": [1, 2]}}),
        "Inner": (node, {"wrinkle_previous_normal": ["Bump", "Normal"]}),
        mat.name: (mat, {"wrinkle_map_version": 3}),
        "Blend": (mat_node, {"wrinkle_previous_normal": ["Image", "Color"]}),
        mark.name: (mark, {"wrinkle_landmark": "chin", "description": "The chin's lowest point"}),
    }
    for holder, values in written.values():
        for key, value in values.items():
            holder[key] = value
    other["description"] = "mine"
    assert {k for _h, v in written.values() for k in v} == set(OLD)  # every old key is tried
    _reopen(tmp_blend("old"))

    ng = bpy.data.node_groups["Old Group"]
    mat = bpy.data.materials["Old Material"]
    found = {ng.name: ng, "Inner": ng.nodes["Inner"], mat.name: mat, "Blend": mat.node_tree.nodes["Blend"],
             "Old Landmark": bpy.data.objects["Old Landmark"]}
    for name, (_holder, values) in written.items():
        holder = found[name]
        assert not set(values) & set(holder.keys()), name
        moved = {OLD[k]: _plain(holder.get(OLD[k])) for k in values}
        assert moved == {OLD[k]: v for k, v in values.items()}, name
    assert bpy.data.objects["Artist's Empty"]["description"] == "mine"  # not a landmark: the artist's own
    assert "ewrinkles_description" not in bpy.data.objects["Artist's Empty"]
    assert migrate.rename_keys() == []  # nothing left to move


def test_a_new_key_already_there_wins():
    ng = bpy.data.node_groups.new("Both", "ShaderNodeTree")
    ng["wrinkle_layout"], ng["ewrinkles_layout"] = "old", "new"
    ob = bpy.data.objects.new("Both", None)
    ob["wrinkle_landmark"], ob["ewrinkles_landmark"] = "brow", "chin"
    ob["description"] = "The brow"
    moved = migrate.rename_keys()
    assert sorted(moved) == ["Both: description", "Both: wrinkle_landmark", "Both: wrinkle_layout"]
    assert list(ng.keys()) == ["ewrinkles_layout"] and ng["ewrinkles_layout"] == "new"
    assert not {"wrinkle_landmark", "description"} & set(ob.keys())
    assert (ob["ewrinkles_landmark"], ob["ewrinkles_description"]) == ("chin", "The brow")


def test_a_linked_group_is_left_as_its_library_holds_it(tmp_blend):
    ng = bpy.data.node_groups.new("Library Group", "ShaderNodeTree")
    ng.use_fake_user = True
    ng["wrinkle_layout"] = "w2:2:0"
    lib = tmp_blend("library")
    bpy.data.libraries.write(str(lib), {ng})
    bpy.data.node_groups.remove(ng)
    with bpy.data.libraries.load(str(lib), link=True) as (src, dst):
        dst.node_groups = ["Library Group"]
    linked = bpy.data.node_groups["Library Group"]
    assert linked.library is not None
    assert migrate.rename_keys() == []
    assert linked["wrinkle_layout"] == "w2:2:0"


def _to_old_names(face):
    """Store the face's custom properties under the names an older version used."""
    maps = face.ewrinkles_face.maps
    blend_node = maps.material.node_tree.nodes[map_material.BLEND_NODE]
    for holder in (bpy.data.node_groups[nodegroups.BLEND_GROUP], maps.weights_group,
                   bpy.data.node_groups[stage.GROUP_NAME], blend_node):
        for old, new in migrate.KEYS:
            if new in holder:
                holder[old] = _plain(holder[new])
                del holder[new]


def test_a_face_saved_under_the_old_names_opens_with_nothing_rebuilt(tmp_blend):
    z = np.zeros((SIZE, SIZE, 4), np.float32)
    plane = mapscenes.skin_plane(SIZE, z, z, np.full((SIZE, SIZE, 3), 0.5, np.float32))
    nt = plane.active_material.node_tree
    bsdf = next(n for n in nt.nodes if n.type == "BSDF_PRINCIPLED")
    bump = nt.nodes.new("ShaderNodeBump")
    nt.links.new(bump.outputs["Normal"], bsdf.inputs["Normal"])
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    stage.ensure_modifier(plane)
    groups = (nodegroups.BLEND_GROUP, plane.ewrinkles_face.maps.weights_group.name, stage.GROUP_NAME)
    for group in groups:  # a rebuild would clear it
        bpy.data.node_groups[group].nodes.new("NodeFrame").name = "Kept"
    _to_old_names(plane)
    assert len(_old_keys()) == 4
    name, bump = plane.name, bump.name
    _reopen(tmp_blend("old"))

    assert _old_keys() == []
    plane = bpy.data.objects[name]
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}  # reads the tags: all up to date
    assert stage.ensure_group() == bpy.data.node_groups[stage.GROUP_NAME]
    for group in groups:
        assert "Kept" in bpy.data.node_groups[group].nodes, group
    assert bpy.ops.wrinkle.remove_wrinkle_maps() == {"FINISHED"}  # reads the previous normal
    nt = plane.active_material.node_tree
    bsdf = next(n for n in nt.nodes if n.type == "BSDF_PRINCIPLED")
    assert bsdf.inputs["Normal"].links[0].from_node.name == bump
