"""The fine wrinkles' shrinkage computed by Blender (the *Fine Wrinkles* Geometry Nodes
modifier, ``glue.bando.fine_tree``) against the NumPy reference ``core.bando.fine.shrinkages``
at every vertex, on frames driven by shape keys, by bones and by the muscles' Waters pull;
where the modifier sits in the stack; and files carved before it existed."""

import bpy
import numpy as np
import pytest

from tests.blender import scenes
from tests.blender.test_curves import uv_face
from wrinkle_addon.core.bando import fine, mapped
from wrinkle_addon.glue import meshio, pipeline, stage, status, surface
from wrinkle_addon.glue.bando import fine as fine_glue
from wrinkle_addon.glue.bando import fine_tree, shading

FRAMES = (1, 2, 3, 2, 1)  # up the ramp and back: a pull that goes away must leave too


def _carve(face):
    fs = face.ewrinkles_face.fine_wrinkles
    fs.resolution = "512"
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.carve_fine() == {"FINISHED"}


def _add_bones(face):
    """An armature whose "Brow" bone pulls the top of the patch down by 1.5 cm over frames
    1..3 while "Base" holds the bottom, their weights ramping with the height (Blender
    normalises a vertex's weights): the forehead squashes vertically."""
    scene = bpy.context.scene
    arm = bpy.data.objects.new("Rig", bpy.data.armatures.new("Rig"))
    scene.collection.objects.link(arm)
    bpy.context.view_layer.objects.active = arm
    bpy.ops.object.mode_set(mode="EDIT")
    for name, z in (("Brow", scenes.HEIGHT), ("Base", 0.0)):
        bone = arm.data.edit_bones.new(name)
        bone.head, bone.tail = (0.0, 0.02, z), (0.0, 0.02, z + 0.03)
    bpy.ops.object.mode_set(mode="OBJECT")
    z = meshio.read_vectors(face.data, "position")[:, 2]
    brow, base = face.vertex_groups.new(name="Brow"), face.vertex_groups.new(name="Base")
    for i, w in enumerate(np.clip(z / scenes.HEIGHT, 0.0, 1.0) ** 2):
        brow.add([i], float(w), "REPLACE")
        base.add([i], float(1.0 - w), "REPLACE")
    mod = face.modifiers.new("Armature", "ARMATURE")
    mod.object = arm
    face.modifiers.move(len(face.modifiers) - 1, 0)
    pose = arm.pose.bones["Brow"]
    for frame, drop in ((1, 0.0), (3, 0.015)):
        pose.location = (0.0, -drop, 0.0)  # the bone's Y runs up the face
        pose.keyframe_insert("location", frame=frame)
    bpy.context.view_layer.objects.active = face


def _scene(driver):
    """The patch with fine wrinkles carved (from BrowsUp), then animated over frames 1..3 by
    one ``driver``; BrowsUp stays at 0 unless it is the driver."""
    face = uv_face()
    muscle = scenes.add_sheet(face, pull=0.3) if driver == "muscle-pull" else None
    if muscle is not None:
        muscle.ewrinkles_muscle.contraction = 0.0
    _carve(face)
    face.data.shape_keys.key_blocks["BrowsUp"].value = 0.0
    if driver == "shape-key":
        scenes.animate_shape_key(face, [(1, 0.0), (3, 1.0)])
    elif driver == "bones":
        _add_bones(face)
    else:
        for frame, value in ((1, 0.0), (3, 1.0)):
            muscle.ewrinkles_muscle.contraction = value
            muscle.keyframe_insert("ewrinkles_muscle.contraction", frame=frame)
    return face


def _reference(face):
    """The NumPy reference of this frame: the plan of the stored fields on the skin the
    stage received plus this frame's pull (the stage's own tangential offsets)."""
    fs = face.ewrinkles_face.fine_wrinkles
    s = surface.Surface(face, fs.uv_map or None)
    m = mapped.mapped_mesh(s.tris, s.uv, len(s.rest))
    plan = fine.plan(m, s.rest, *fine_glue.read_fields(face, s, m))
    dg = bpy.context.evaluated_depsgraph_get()
    skin = meshio.read_vectors(face.evaluated_get(dg).data, stage.SKIN_ATTR)
    pull = np.zeros_like(skin)
    if stage.holds_frame(face.data, dg) and meshio.attribute(face.data, stage.PULL_ATTR, "FLOAT_VECTOR"):
        pull = meshio.read_vectors(face.data, stage.PULL_ATTR)
    return fine.shrinkages(plan, skin + pull), fine.shrinkages(plan, skin), float(np.abs(pull).max())


@pytest.mark.parametrize("driver", ["shape-key", "bones", "muscle-pull"])
def test_blender_computes_the_reference_shrinkage_at_every_vertex(driver):
    """Each frame as the viewport shows it (written in place after the first: there the
    source writes the pulled skin's shrinkage itself), then as a render computes it (written
    back: the tree sees the pull), both against the reference of the render's pull."""
    face = _scene(driver)
    scene = bpy.context.scene
    grew, in_place = [], []
    for f in FRAMES:
        scene.frame_set(f)  # the viewport's path
        viewport = fine_tree.shrinkage(face).copy()
        in_place.append(not stage.holds_frame(face.data, bpy.context.evaluated_depsgraph_get()))
        pipeline.export_frame(scene, face)  # a render's path: the pull stamped in the mesh
        want, unpulled, pull = _reference(face)
        np.testing.assert_allclose(viewport, want, rtol=0, atol=1e-6, err_msg=f"{driver}, viewport {f}")
        np.testing.assert_allclose(fine_tree.shrinkage(face), want, rtol=0, atol=1e-6,
                                   err_msg=f"{driver}, render {f}")
        grew.append(float(want[0].max()))
        if driver == "muscle-pull" and f == 3:
            assert pull > 1e-3, "the muscle does not pull"
            assert np.abs(unpulled - want).max() > 0.05, "the pull does not change the shrinkage"
        if driver != "muscle-pull":
            assert pull == 0.0
    assert grew[0] < 1e-4 and grew[2] > 0.1 and grew[-1] < 1e-4, grew
    # the viewport frames stay in place; the second may be written back, where its skin (a
    # pull's rest) equals the first's: the stage cannot tell its mesh was evaluated again
    assert in_place[2:] == [True] * (len(FRAMES) - 2), in_place


def test_renders_and_exports_see_the_same_shrinkage_as_the_viewport():
    """A render's or an export's frame goes through the write-back path: the modifier sees
    the pull there too."""
    face = _scene("muscle-pull")
    scene = bpy.context.scene
    scene.frame_set(3)
    viewport = fine_tree.shrinkage(face).copy()
    scene.frame_set(1)
    with pipeline.suspended():
        scene.frame_set(3)
    assert np.abs(fine_tree.shrinkage(face) - viewport).max() > 0.05  # not measured yet
    pipeline.export_frame(scene, face)
    np.testing.assert_array_equal(fine_tree.shrinkage(face), viewport)


def _domain(face):
    ev = face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    return ev.attributes[fine_tree.SHRINKAGE_ATTR].domain


def test_the_shrinkage_is_stored_on_the_corners_only_where_a_uv_map_is_needed():
    """At the vertices, where it is computed; on the corners (a UV map) while Bake for Farm
    exports the cache, which carries only UV maps, and while a modifier after it makes new
    vertices, which interpolate a UV map otherwise than a vertex attribute."""
    face = _scene("shape-key")
    scene = bpy.context.scene
    scene.frame_set(3)
    assert _domain(face) == "POINT" and fine_tree.corners(face) is False
    want = fine_tree.shrinkage(face).copy()
    assert want[0].max() > 0.1
    sub = face.modifiers.new("Subdivision", "SUBSURF")
    for f in (2, 3):  # viewport frames: the source sees the new modifier
        scene.frame_set(f)
    assert fine_tree.corners(face) is True and _domain(face) == "CORNER"
    sub.show_viewport = sub.show_render = False
    for f in (2, 3):
        scene.frame_set(f)
    assert fine_tree.corners(face) is False and _domain(face) == "POINT"
    np.testing.assert_array_equal(fine_tree.shrinkage(face), want)
    sub.show_render = True  # rendered subdivided: the render must match the farm's
    scene.frame_set(2)
    assert fine_tree.corners(face) is True
    face.modifiers.remove(sub)
    scene.frame_set(3)
    assert fine_tree.corners(face) is False
    with fine_tree.exporting(face):
        assert fine_tree.corners(face) is True
        scene.frame_set(2)
        scene.frame_set(3)  # the frames an export steps through keep it
        assert _domain(face) == "CORNER"
        np.testing.assert_array_equal(fine_tree.shrinkage(face), want)
    assert fine_tree.corners(face) is False
    scene.frame_set(2)
    scene.frame_set(3)
    assert _domain(face) == "POINT"


def test_the_modifier_sits_above_the_wrinkles_modifier_and_says_when_it_does_not():
    face = uv_face(enable=False)
    face.modifiers.new("Subdivision", "SUBSURF")
    _carve(face)
    names = [m.name for m in face.modifiers]
    assert names == [fine_tree.MODIFIER_NAME, "Subdivision"]  # after the deformers, before the topology
    assert bpy.ops.wrinkle.enable() == {"FINISHED"}
    assert [m.name for m in face.modifiers] == [fine_tree.MODIFIER_NAME, stage.MODIFIER_NAME, "Subdivision"]
    assert fine_tree.order_problem(face) == ""
    displace = face.modifiers.new("Displace", "DISPLACE")
    face.modifiers.move(len(face.modifiers) - 1, 1)  # between the two
    assert "Displace" in fine_tree.order_problem(face)
    bpy.context.scene.frame_set(2)
    assert "Displace" in status.get(face)
    face.modifiers.remove(displace)
    fine_tree.find_modifier(face).show_render = False
    assert "disabled" in fine_tree.order_problem(face)
    fine_tree.ensure_modifier(face)
    assert fine_tree.order_problem(face) == ""
    # switching wrinkles off and on keeps the order
    face.ewrinkles_face.enabled = False
    face.ewrinkles_face.enabled = True
    assert [m.name for m in face.modifiers][:2] == [fine_tree.MODIFIER_NAME, stage.MODIFIER_NAME]


def test_an_armature_added_later_keeps_the_skin_measured_where_the_stage_reads_it():
    """Enable Wrinkles on a face whose fine wrinkles were carved before its rig: the stage
    goes after the deformers and the modifier moves with it, directly above."""
    face = uv_face(enable=False)
    _carve(face)
    _add_bones(face)  # the Armature goes first in the stack, above the modifier
    face.modifiers.move(0, len(face.modifiers) - 1)  # an artist's Armature at the bottom instead
    assert "Armature" in fine_tree.order_problem(face)
    assert bpy.ops.wrinkle.enable() == {"FINISHED"}
    assert [m.name for m in face.modifiers] == ["Armature", fine_tree.MODIFIER_NAME, stage.MODIFIER_NAME]
    assert fine_tree.order_problem(face) == ""


def test_a_face_carved_before_the_modifier_is_brought_up_to_date_on_load(tmp_path):
    """What an older version saved: the shrinkage as point attributes written every frame,
    and a farm bake's image sequence read through a texture node into the group's Baked
    Shrinkage input.  Opened now, the face gets its modifier and plan, the group keeps its
    links, the texture node goes and the face shows the same shrinkage as a new carving."""
    face = _scene("shape-key")
    bpy.context.scene.frame_set(3)
    want = fine_tree.shrinkage(face).copy()
    # make it the old layout
    fine_tree.remove(face)
    for name in fine_glue.LEGACY_ATTRS:
        meshio.write_floats(face.data, name, np.zeros(len(face.data.vertices), np.float32))
    nt = face.ewrinkles_face.fine_wrinkles.material.node_tree
    group = nt.nodes[fine_glue.GROUP_NODE]
    ng = group.node_tree
    ng.interface.new_socket("Baked Shrinkage", in_out="INPUT", socket_type="NodeSocketColor")
    ng.interface.new_socket("Use Baked", in_out="INPUT", socket_type="NodeSocketFloat")
    ng["ewrinkles_version"] = 3
    tex = nt.nodes.new("ShaderNodeTexImage")
    tex.name = fine_glue.LEGACY_BAKE_NODE
    tex.image = bpy.data.images.new("Face_fine_shrinkage", 4, 4, float_buffer=True)
    nt.links.new(tex.outputs["Color"], group.inputs["Baked Shrinkage"])
    links = len(nt.links)
    path = tmp_path / "old.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.open_mainfile(filepath=str(path))

    face = bpy.data.objects["Face"]
    nt = face.ewrinkles_face.fine_wrinkles.material.node_tree
    group = nt.nodes[fine_glue.GROUP_NODE]
    assert fine_tree.find_modifier(face) is not None and fine_tree.order_problem(face) == ""
    assert group.node_tree.get("ewrinkles_version") == shading.VERSION
    assert "Baked Shrinkage" not in group.inputs and "Use Baked" not in group.inputs
    assert fine_glue.LEGACY_BAKE_NODE not in nt.nodes
    assert len(nt.links) == links - 1  # only the texture's link went
    assert group.inputs["Height 1"].is_linked and group.outputs["Normal"].is_linked
    assert not any(face.data.attributes.get(n) for n in fine_glue.LEGACY_ATTRS)
    bpy.context.scene.frame_set(1)
    bpy.context.scene.frame_set(3)
    np.testing.assert_array_equal(fine_tree.shrinkage(face), want)


def test_a_face_of_shrinkage_group_version_1_is_brought_up_to_date_on_load(tmp_path, capfd):
    """``data/fine_tree_v1.blend`` was saved by the version whose group always stored the
    corners (``data/make_fine_tree_v1_blend.py``): opened now, its group is rebuilt in place,
    the face stores the vertices and shows the shrinkage that version computed."""
    from pathlib import Path

    path = tmp_path / "v1.blend"
    path.write_bytes((Path(__file__).with_name("data") / "fine_tree_v1.blend").read_bytes())
    capfd.readouterr()
    bpy.ops.wm.open_mainfile(filepath=str(path))
    assert "stored at the vertices" in capfd.readouterr().out
    face = bpy.data.objects["Face"]
    mod = fine_tree.find_modifier(face)
    assert mod.node_group["ewrinkles_fine_tree_version"] == fine_tree.VERSION
    assert fine_tree.corners(face) is False and fine_tree.order_problem(face) == ""
    bpy.context.scene.frame_set(3)
    assert _domain(face) == "POINT"
    want = np.array(face["v1_shrinkage"], np.float32).reshape(2, -1)
    assert want[0].max() > 0.1
    np.testing.assert_allclose(fine_tree.shrinkage(face), want, rtol=0, atol=1e-7)
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    capfd.readouterr()
    bpy.ops.wm.open_mainfile(filepath=str(path))
    assert "stored at the vertices" not in capfd.readouterr().out
