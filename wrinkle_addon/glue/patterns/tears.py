# SPDX-License-Identifier: GPL-3.0-or-later
"""Dripping tears ("Pattern functions and tears", §4.1) as objects: the teardrop surface of
``core.patterns.tears`` built by a Geometry Nodes group from the scene time, so a drop animates, falls,
repeats and renders with no Python (and on a farm with no add-on), in a water material."""

import math

import bpy

from ...core.patterns import tears
from ..errors import WrinkleError
from ..faces import collections_for
from ..nodes import Builder, float_inputs, principled, use_nodes
from ..nodes import ensure_group as ensure_group_of

GROUP_NAME = "Teardrop"
MODIFIER_NAME = "Teardrop"
MATERIAL_NAME = "Tear Water"
VERSION = 1
NU, NV = 24, 32  # rows from the top to the bottom of the drop, columns around it
REACH = 1.6  # the drop's widest radius at its birth is 1.51 Width: a drop this far out touches the skin
INPUTS = (  # name, default, min, max, tooltip
    ("Width", 0.0025, 0.0, 0.05, "The drop's size across (the formula's alpha), in scene units"),
    ("Length", 0.0016, 0.0, 0.05, "The drop's size along its fall (the formula's beta), in scene units; "
     "the drop is 2 x Length x t long"),
    ("Speed", 0.02, 0.0, 1.0, "How fast the drop falls (the formula's lambda), in scene units per second"),
    ("Start", 0.0, -1e6, 1e6, "When the first drop forms, in seconds of scene time"),
    ("Every", 2.0, 0.01, 1e6, "How often a new drop falls, in seconds"),
    ("Lasts", 1.2, 0.0, 1e6, "How long each drop shows, in seconds"),
)


class TearError(WrinkleError):
    """Bad input for a tear; the message is meant for the user."""


def _build(ng):
    ng.interface.clear()
    ng.nodes.clear()
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    float_inputs(ng, INPUTS)
    mat = ng.interface.new_socket("Material", in_out="INPUT", socket_type="NodeSocketMaterial")
    mat.description = "The tear's material (water)"
    b = Builder(ng)
    gin = b.node("NodeGroupInput")
    i = gin.outputs
    b.x = 200
    grid = b.node("GeometryNodeMeshGrid")
    grid.inputs["Size X"].default_value = math.pi
    grid.inputs["Size Y"].default_value = 2.0 * math.pi
    grid.inputs["Vertices X"].default_value = NU
    grid.inputs["Vertices Y"].default_value = NV
    sep = b.node("ShaderNodeSeparateXYZ")
    b.link(b.node("GeometryNodeInputPosition").outputs[0], sep.inputs[0])
    u = b.math("ADD", sep.outputs["X"], 0.5 * math.pi)  # 0 at the top, pi at the bottom
    v = b.math("ADD", sep.outputs["Y"], math.pi)  # around
    b.x = 400
    since = b.math("SUBTRACT", b.node("GeometryNodeInputSceneTime").outputs["Seconds"], i["Start"])
    tau = b.math("FLOORED_MODULO", since, i["Every"])  # the drop's age
    t = b.math("ADD", tau, tears.T0)
    cos_u = b.math("COSINE", u)
    r = b.math("DIVIDE", b.math("MULTIPLY", i["Width"], b.math("SINE", u)), b.math("ADD", t, cos_u))
    b.x = 600
    z = b.math("SUBTRACT", b.math("MULTIPLY", b.math("MULTIPLY", i["Length"], t), cos_u),
               b.math("MULTIPLY_ADD", i["Length"], tears.T0, b.math("MULTIPLY", i["Speed"], tau)))
    xyz = b.node("ShaderNodeCombineXYZ")
    b.link(b.math("MULTIPLY", r, b.math("COSINE", v)), xyz.inputs["X"])
    b.link(b.math("MULTIPLY", r, b.math("SINE", v)), xyz.inputs["Y"])
    b.link(z, xyz.inputs["Z"])
    b.x = 800
    setpos = b.node("GeometryNodeSetPosition")
    b.link(grid.outputs["Mesh"], setpos.inputs["Geometry"])
    b.link(xyz.outputs[0], setpos.inputs["Position"])
    merge = b.node("GeometryNodeMergeByDistance")  # the seam around and the two tips
    merge.inputs["Distance"].default_value = 1e-7
    b.link(setpos.outputs[0], merge.inputs["Geometry"])
    # no drop before Start or past its lifetime in its cycle
    hidden = b.node("FunctionNodeBooleanMath", operation="OR")
    before = b.node("FunctionNodeCompare", data_type="FLOAT", operation="LESS_THAN")
    b.link(since, before.inputs[0])
    before.inputs[1].default_value = 0.0
    late = b.node("FunctionNodeCompare", data_type="FLOAT", operation="GREATER_EQUAL")
    b.link(tau, late.inputs[0])
    b.link(i["Lasts"], late.inputs[1])
    b.link(before.outputs["Result"], hidden.inputs[0])
    b.link(late.outputs["Result"], hidden.inputs[1])
    b.x = 1000
    delete = b.node("GeometryNodeDeleteGeometry")
    b.link(merge.outputs[0], delete.inputs["Geometry"])
    b.link(hidden.outputs[0], delete.inputs["Selection"])
    setmat = b.node("GeometryNodeSetMaterial")
    b.link(delete.outputs[0], setmat.inputs["Geometry"])
    b.link(i["Material"], setmat.inputs["Material"])
    smooth = b.node("GeometryNodeSetShadeSmooth")
    b.link(setmat.outputs[0], smooth.inputs["Geometry"])
    gout = b.node("NodeGroupOutput")
    b.link(smooth.outputs[0], gout.inputs["Geometry"])


def ensure_group():
    return ensure_group_of(GROUP_NAME, "GeometryNodeTree", VERSION, _build, TearError)


def water_material():
    """Clear water: full transmission, IOR 1.33, low roughness."""
    mat = bpy.data.materials.get(MATERIAL_NAME) or bpy.data.materials.new(MATERIAL_NAME)
    use_nodes(mat)
    bsdf = principled(mat.node_tree)
    bsdf.inputs["Base Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bsdf.inputs["Transmission Weight"].default_value = 1.0
    bsdf.inputs["IOR"].default_value = 1.33
    bsdf.inputs["Roughness"].default_value = 0.03
    mat.diffuse_color = (0.8, 0.9, 1.0, 0.3)
    return mat


def _input(mod, name):
    """The modifier's value of the group input ``name``: ``(holder, key)``.  Blender 5 keeps
    a Geometry Nodes modifier's inputs in ``properties.inputs`` (each with a ``value``);
    Blender 4 as ID properties of the modifier keyed by the socket's identifier."""
    ident = next(s.identifier for s in mod.node_group.interface.items_tree
                 if getattr(s, "in_out", "") == "INPUT" and s.name == name)
    props = getattr(mod, "properties", None)
    if props is not None and hasattr(props, "inputs"):
        return getattr(props.inputs, ident), "value"
    return mod, ident


def set_input(mod, name, value):
    holder, key = _input(mod, name)
    if key == "value":
        holder.value = value
    else:
        holder[key] = value


def get_input(mod, name):
    holder, key = _input(mod, name)
    return holder.value if key == "value" else holder[key]


def add_teardrop(context, face, location, **values):
    """A new teardrop object at ``location`` (world), parented to ``face`` so it follows it;
    ``values``: the group's inputs by name (Width, Length, Speed, Start, Every, Lasts)."""
    if values.get("Every", 1.0) <= 0.0:
        raise TearError("A tear must fall every so many seconds: Every must be above 0")
    me = bpy.data.meshes.new("Teardrop")
    ob = bpy.data.objects.new(f"{face.name} Teardrop", me)
    for coll in collections_for(face, context.scene):
        coll.objects.link(ob)
    ob.location = location
    ob.parent = face
    ob.matrix_parent_inverse = face.matrix_world.inverted_safe()
    mod = ob.modifiers.new(MODIFIER_NAME, "NODES")
    mod.node_group = ensure_group()
    mat = water_material()
    me.materials.append(mat)
    set_input(mod, "Material", mat)
    for name, value in values.items():
        set_input(mod, name, float(value))
    return ob
