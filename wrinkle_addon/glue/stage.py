# SPDX-License-Identifier: GPL-3.0-or-later
"""The output stage: a Geometry Nodes modifier built in code (docs/architecture.md).

Inside the modifier the incoming position (the deformed skin before any
wrinkle) is stored as ``wrinkle_skin``; then the vector attribute
``wrinkle_offset``, computed in NumPy and written onto the original mesh, is
added to the position.  The frame stage reads ``wrinkle_skin`` back from the
evaluated mesh, so wrinkles never feed back into the compression they are
computed from.  The tree needs no Python to evaluate, so saved files render
without the add-on, with the offset of the frame they were saved on.

Every write of the offsets also writes the frame they belong to (``wrinkle_frame``), and,
where a tree above the stage measures the skin (the fine wrinkles' shrinkage), the part of
them that moves the skin tangentially (``wrinkle_pull``).
The tree applies the offsets only on that frame: where the add-on is missing, every other
frame renders without wrinkles instead of with another frame's (stale) wrinkles.
"""

import bpy
import numpy as np

from . import meshio, nodes
from .errors import WrinkleError

GROUP_NAME = "Wrinkle Output"
MODIFIER_NAME = "Wrinkles"
SKIN_ATTR = "wrinkle_skin"
OFFSET_ATTR = "wrinkle_offset"
FRAME_ATTR = "wrinkle_frame"
# the tangential part of the offsets (Waters' pull), written with them for the trees that
# measure the skin as the sources do (glue.bando.fine_tree): stamped by FRAME_ATTR too
PULL_ATTR = "wrinkle_pull"
# a Geometry Nodes group tagged with this reads the skin the stage receives: Enable Wrinkles
# puts the stage directly below its modifier
READS_SKIN = "ewrinkles_reads_skin"
VERSION = 2  # 2: the offsets apply only on the frame they were computed for
FRAME_EPSILON = 0.001  # the tree applies the offsets where |frame - wrinkle_frame| <= this
TOPOLOGY_MODIFIERS = {
    "SUBSURF", "MULTIRES", "REMESH", "DECIMATE", "TRIANGULATE", "BEVEL", "SOLIDIFY", "MIRROR",
    "ARRAY", "BOOLEAN", "SKIN", "WELD", "SCREW", "EDGE_SPLIT", "WIREFRAME", "MASK", "BUILD",
}


class StageError(WrinkleError):
    """A problem with the output stage; the message is shown as is."""


def _build_group(ng):
    ng.interface.clear()
    ng.nodes.clear()
    ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    nodes, links = ng.nodes, ng.links
    gin = nodes.new("NodeGroupInput")
    gout = nodes.new("NodeGroupOutput")
    pos = nodes.new("GeometryNodeInputPosition")
    store = nodes.new("GeometryNodeStoreNamedAttribute")
    store.data_type = "FLOAT_VECTOR"
    store.domain = "POINT"
    store.inputs["Name"].default_value = SKIN_ATTR
    offset = nodes.new("GeometryNodeInputNamedAttribute")
    offset.data_type = "FLOAT_VECTOR"
    offset.inputs["Name"].default_value = OFFSET_ATTR
    stamp = nodes.new("GeometryNodeInputNamedAttribute")
    stamp.data_type = "FLOAT"
    stamp.inputs["Name"].default_value = FRAME_ATTR
    time = nodes.new("GeometryNodeInputSceneTime")
    same = nodes.new("FunctionNodeCompare")  # |frame - stamp| <= 0.001: this frame's offsets
    same.data_type = "FLOAT"
    same.operation = "EQUAL"
    same.inputs["Epsilon"].default_value = FRAME_EPSILON
    gate = nodes.new("ShaderNodeVectorMath")
    gate.operation = "SCALE"
    setpos = nodes.new("GeometryNodeSetPosition")
    links.new(gin.outputs[0], store.inputs["Geometry"])
    links.new(pos.outputs[0], store.inputs["Value"])
    links.new(store.outputs[0], setpos.inputs["Geometry"])
    links.new(time.outputs["Frame"], same.inputs[0])
    links.new(stamp.outputs["Attribute"], same.inputs[1])
    links.new(offset.outputs["Attribute"], gate.inputs[0])
    links.new(same.outputs["Result"], gate.inputs["Scale"])
    links.new(gate.outputs["Vector"], setpos.inputs["Offset"])
    links.new(setpos.outputs[0], gout.inputs[0])
    for i, node in enumerate((gin, pos, store, offset, setpos, gout)):
        node.location = (200 * i, 0)
    for i, node in enumerate((time, stamp, same, gate)):
        node.location = (400 + 200 * (i // 2) + 200 * (i == 3), -200 - 150 * (i % 2))


def ensure_group():
    """The shared node group; reused when it exists, refused when linked and read-only."""
    return nodes.ensure_group(GROUP_NAME, "GeometryNodeTree", VERSION, _build_group, StageError,
                              key="ewrinkles_stage_version")


def find_modifier(ob):
    return nodes.nodes_modifier(ob, GROUP_NAME)


def ensure_modifier(ob):
    """Add the stage after the deformers and before the first topology-changing modifier; a
    tree that measures its skin (``READS_SKIN``) goes directly above it."""
    mod = find_modifier(ob)
    if mod is None:
        mod = ob.modifiers.new(MODIFIER_NAME, "NODES")
        mod.node_group = ensure_group()
        mod.show_in_editmode = False
        index = len(ob.modifiers) - 1
        for i, other in enumerate(ob.modifiers):
            if other.type in TOPOLOGY_MODIFIERS:
                index = i
                break
        if index != len(ob.modifiers) - 1:
            ob.modifiers.move(len(ob.modifiers) - 1, index)
        for reader in [m for m in ob.modifiers if _reads_skin(m)]:  # directly above the stage
            mods = list(ob.modifiers)
            here, there = mods.index(reader), mods.index(mod)
            ob.modifiers.move(here, there - 1 if here < there else there)
    mod.show_viewport = True
    mod.show_render = True
    ensure_offset_attribute(ob.data)
    return mod


def _reads_skin(mod):
    return mod.type == "NODES" and mod.node_group is not None and bool(mod.node_group.get(READS_SKIN))


_REORDERS = (TOPOLOGY_MODIFIERS | {"NODES"}) - {"SUBSURF"}  # after the stage: may renumber vertices


def order_problem(ob, mod, evaluated_count):
    """Why the evaluated skin cannot be matched to the mesh's vertices, or ``None``.

    Modifiers before the stage must keep the vertex count; after it, only
    Subdivision Surface is allowed to add vertices (it keeps the original ones
    first, see ``meshio.read_vector_prefix``).
    """
    n = len(ob.data.vertices)
    mods = list(ob.modifiers)
    index = mods.index(mod)
    active = [(i, m) for i, m in enumerate(mods) if m.show_viewport or m.show_render]
    before = [m for i, m in active if i < index and m.type in TOPOLOGY_MODIFIERS]
    after = [m for i, m in active if i > index and m.type in _REORDERS]
    if before:
        return (f'The modifier "{before[0].name}" comes before Wrinkles and changes the vertex count: '
                "move Wrinkles above it, or apply it")
    if evaluated_count == n:
        return None
    if evaluated_count > n and not after:
        return None
    return ("A modifier changes the vertex count: keep the Wrinkles modifier after the deformers "
            "and before Subdivision Surface, and apply other topology modifiers")


def output_is_final(ob, mod):
    """Whether the positions the stage ``mod`` outputs are the face's final ones in the
    viewport, so the frame stage may write them into the evaluated mesh itself.

    True when no modifier shown in the viewport comes after the stage, except a final
    Subdivision Surface: run on the CPU it changes the vertex count, and the in-place
    write refuses that mesh anyway; with GPU subdivision the evaluated mesh keeps the base
    vertices and is subdivided when drawn, so it is the stage's output (not measurable on
    the test machines, which have no GPU).  Any other later modifier (a deformer such as
    Displace, Smooth, Corrective Smooth or Armature, a node group) may move the points, and
    writing over its result would throw its effect away.
    """
    mods = list(ob.modifiers)
    after = [m for m in mods[mods.index(mod) + 1:] if m.show_viewport]
    return not after or (len(after) == 1 and after[0].type == "SUBSURF")


def frame_of(depsgraph):
    """``depsgraph``'s frame as the tree sees it: the Scene Time node's Frame is the scene's
    frame with its subframe and with the time remapping (Frame Map Old/New) applied, which is
    ``Scene.frame_current_final``."""
    return depsgraph.scene_eval.frame_current_final


def stamp(ob, depsgraph):
    """Mark the offsets just written as those of ``depsgraph``'s frame (:func:`frame_of`)."""
    me = ob.data
    meshio.write_floats(me, FRAME_ATTR, np.full(len(me.vertices), frame_of(depsgraph), np.float32))


def holds_frame(me, depsgraph):
    """Whether the offsets the original mesh ``me`` holds are stamped with ``depsgraph``'s
    frame, so that the tree shows them on it (a saved file, a render)."""
    att = meshio.attribute(me, FRAME_ATTR, "FLOAT")
    if att is None or len(att.data) == 0:
        return False
    return abs(att.data[0].value - frame_of(depsgraph)) <= FRAME_EPSILON


def ensure_offset_attribute(me):
    return meshio.point_attribute(me, OFFSET_ATTR, "FLOAT_VECTOR")


def remove(ob):
    """Remove the modifier and every attribute the add-on stored: the mesh is as before."""
    mod = find_modifier(ob)
    if mod is not None:
        ob.modifiers.remove(mod)
    me = ob.data
    for name in (OFFSET_ATTR, SKIN_ATTR, FRAME_ATTR, PULL_ATTR):
        att = me.attributes.get(name)
        if att is not None:
            me.attributes.remove(att)
    ng = bpy.data.node_groups.get(GROUP_NAME)
    if ng is not None and ng.users == 0 and ng.library is None:
        bpy.data.node_groups.remove(ng)
