# SPDX-License-Identifier: GPL-3.0-or-later
"""Shader node groups of Bando, Kuratate & Nishita 2002, built in code.

``Fine Wrinkles`` bump-maps the two carved height images (§5), each scaled by the
amplitude modulation ``M(s)`` (eq. 5) of its own direction's shrinkage ``s`` (§7)::

    h = (H1 - 1) M(s1) + (H2 - 1) M(s2)
    M(s) = (1 - r) s + r            for s >= 0
           r exp((1/r - 1) s)        for s < 0

``H1``, ``H2`` are the height images (1 = no furrow, the paper's white), ``s1``, ``s2``
the point attributes the frame stage writes (``S1_ATTR``, ``S2_ATTR``), interpolated across
each triangle by the renderer as §7 interpolates shrinkage from the three vertices, and
``r`` the rest height (0.5 by default: fine wrinkles show at rest).  After *Bake for Farm*
the group reads ``s1``, ``s2`` from the red and green of its ``Baked Shrinkage`` input
instead (``Use Baked`` = 1): an image sequence of the frames' shrinkage in UV space, which
renders with no add-on (``glue.bando.fine.bake_shrinkage``).  Each term is its own Bump
node, chained from the group's ``Normal`` input, so the group stacks on whatever normal the
material had (the wrinkle maps' included: ``glue.nodes.normal_input``).  A Bump node
differentiates its ``Height`` input (at points a fraction of a pixel apart) but not its
``Distance``: so ``H - 1`` is the height and ``M(s)`` scales the distance.  The furrows'
slopes are then ``M(s) ∇H``, the shrinkage the amplitude at the shading point.  Were
``M(s)`` inside the height, the bump would also differentiate the shrinkage, and the live
attribute (a plane per triangle, extended past the triangle's edges) and the baked image
(the neighbouring triangle's values past an edge) give different slopes there: up to 0.02
in a few pixels of a 64-pixel render where Waters' pull bends the shrinkage (measured on
bpy 4.5), however fine and exact the image.
``core.bando.field.modulation`` is the NumPy reference; a test compares them.

``Skin Pigment`` is eq. 6 of §8: ``c = b - m a_m - h a_h``, the base colour minus the
light absorbed by melanin ``m`` and hemoglobin ``h``, clamped to [0, 1].
"""

import bpy

from ..errors import WrinkleError
from ..nodes import LAYER_TAG, Builder, principled, use_nodes

FINE_GROUP = "Fine Wrinkles"
PIGMENT_GROUP = "Skin Pigment"
S1_ATTR = "ewrinkles_fine_s1"
S2_ATTR = "ewrinkles_fine_s2"
VERSION = 3  # 2: the Baked Shrinkage and Use Baked inputs; 3: M(s) scales each bump's distance
# Absorption of melanin and hemoglobin per RGB channel: the paper determined its values
# empirically and does not print them.  Ours follow the shape of the two absorption spectra
# over the visible band: melanin absorbs more toward blue (skin turns brown), hemoglobin
# absorbs green and blue most (skin turns red).
MELANIN_ABSORPTION = (0.30, 0.45, 0.52, 1.0)
HEMOGLOBIN_ABSORPTION = (0.05, 0.32, 0.28, 1.0)
BASE_SKIN = (0.85, 0.68, 0.58, 1.0)


class ShadingError(WrinkleError):
    """A node group of ours that cannot be rebuilt; the message is meant for the user."""


def _check(ng):
    if ng.library is not None or not ng.is_editable:
        raise ShadingError(f'The node group "{ng.name}" is linked and read-only: make it local to change it')
    if ng.bl_idname != "ShaderNodeTree":
        raise ShadingError(f'A node group named "{ng.name}" exists but is not a shader group; rename it')


def _socket(ng, name, in_out, kind, default=None, lo=None, hi=None, description="", hide_value=False):
    s = ng.interface.new_socket(name, in_out=in_out, socket_type=kind)
    s.description = description
    if default is not None:
        s.default_value = default
    if lo is not None:
        s.min_value, s.max_value = lo, hi
    if hide_value:
        s.hide_value = True
    return s


def _group(name, build):
    ng = bpy.data.node_groups.get(name)
    if ng is not None:
        _check(ng)
        if ng.get("ewrinkles_version") == VERSION:
            return ng
        ng.nodes.clear()
        ng.interface.clear()
    else:
        ng = bpy.data.node_groups.new(name, "ShaderNodeTree")
    build(ng)
    ng["ewrinkles_version"] = VERSION
    return ng


def _modulation(b, s, r):
    """Eq. 5 as math nodes: ``M(s)`` for the shrinkage output ``s`` and rest height ``r``."""
    s = b.math("MINIMUM", s, 1.0)
    grow = b.math("MULTIPLY_ADD", s, b.math("SUBTRACT", 1.0, r), r)  # (1 - r) s + r
    k = b.math("SUBTRACT", b.math("DIVIDE", 1.0, b.math("MAXIMUM", r, 1e-4)), 1.0)
    fade = b.math("MULTIPLY", r, b.math("EXPONENT", b.math("MULTIPLY", k, b.math("MINIMUM", s, 0.0))))
    shrinks = b.math("GREATER_THAN", s, -1e-9)  # 1 where s >= 0
    return b.math("ADD", b.math("MULTIPLY", grow, shrinks),
                  b.math("MULTIPLY", fade, b.math("SUBTRACT", 1.0, shrinks)))


def _build_fine(ng):
    _socket(ng, "Height 1", "INPUT", "NodeSocketFloat", 1.0, 0.0, 1.0,
            "The first carved height image (1: no furrow)")
    _socket(ng, "Height 2", "INPUT", "NodeSocketFloat", 1.0, 0.0, 1.0,
            "The second carved height image, of the second direction field")
    _socket(ng, "Rest Height", "INPUT", "NodeSocketFloat", 0.5, 0.0, 1.0,
            "Height of the fine wrinkles on the undeformed skin relative to their full height "
            "(Bando 2002 eq. 5's r)")
    _socket(ng, "Strength", "INPUT", "NodeSocketFloat", 1.0, 0.0, 10.0, "Strength of the bump")
    _socket(ng, "Distance", "INPUT", "NodeSocketFloat", 0.0004, 0.0, 0.01,
            "Depth of a full furrow, in scene units")
    _socket(ng, "Normal", "INPUT", "NodeSocketVector", None, None, None,
            "The normal to bump (the material's own, or the wrinkle maps')", hide_value=True)
    _socket(ng, "Baked Shrinkage", "INPUT", "NodeSocketColor", (0.0, 0.0, 0.0, 1.0),
            description="The shrinkage across each field baked for a farm (red: the first, green: "
            "the second), read when Use Baked is 1")
    _socket(ng, "Use Baked", "INPUT", "NodeSocketFloat", 0.0, 0.0, 1.0,
            "1: read the shrinkage from Baked Shrinkage (a farm bake), 0: from the mesh's "
            "attributes, which the add-on writes every frame")
    _socket(ng, "Normal", "OUTPUT", "NodeSocketVector", description="The bumped normal")
    b = Builder(ng)
    gin = b.node("NodeGroupInput")
    b.x = 250
    r = gin.outputs["Rest Height"]
    baked = b.node("ShaderNodeSeparateColor")
    b.link(gin.outputs["Baked Shrinkage"], baked.inputs["Color"])
    normal = gin.outputs["Normal"]
    pairs = ((gin.outputs["Height 1"], S1_ATTR, 0), (gin.outputs["Height 2"], S2_ATTR, 1))
    for k, (height, attr, channel) in enumerate(pairs):
        node = b.node("ShaderNodeAttribute", attribute_type="GEOMETRY", attribute_name=attr)
        node.name = node.label = f"Shrinkage {k + 1}"
        live = node.outputs["Fac"]  # s = live + (baked - live) * use
        s_k = b.math("MULTIPLY_ADD", b.math("SUBTRACT", baked.outputs[channel], live),
                     gin.outputs["Use Baked"], live)
        bump = b.node("ShaderNodeBump")  # (H - 1) M(s): the height H - 1, the distance M(s)
        bump.name = bump.label = f"Bump {k + 1}"
        b.link(b.math("SUBTRACT", height, 1.0), bump.inputs["Height"])
        b.link(b.math("MULTIPLY", gin.outputs["Distance"], _modulation(b, s_k, r)), bump.inputs["Distance"])
        b.link(gin.outputs["Strength"], bump.inputs["Strength"])
        b.link(normal, bump.inputs["Normal"])
        normal = bump.outputs["Normal"]
    b.x = 600
    gout = b.node("NodeGroupOutput")
    b.link(normal, gout.inputs["Normal"])


def _build_pigment(ng):
    _socket(ng, "Base Color", "INPUT", "NodeSocketColor", BASE_SKIN, description="Skin colour "
            "without pigment (Bando 2002 eq. 6's b)")
    _socket(ng, "Melanin", "INPUT", "NodeSocketFloat", 0.2, 0.0, 2.0,
            "Amount of melanin m: paint it, or animate it (tanning, freckles)")
    _socket(ng, "Hemoglobin", "INPUT", "NodeSocketFloat", 0.2, 0.0, 2.0,
            "Amount of hemoglobin h: paint it, or animate it (blushing, pallor)")
    _socket(ng, "Melanin Absorption", "INPUT", "NodeSocketColor", MELANIN_ABSORPTION,
            description="Light absorbed by one unit of melanin per channel (eq. 6's a_m)")
    _socket(ng, "Hemoglobin Absorption", "INPUT", "NodeSocketColor", HEMOGLOBIN_ABSORPTION,
            description="Light absorbed by one unit of hemoglobin per channel (eq. 6's a_h)")
    _socket(ng, "Color", "OUTPUT", "NodeSocketColor", description="The skin colour c")
    b = Builder(ng)
    gin = b.node("NodeGroupInput")
    b.x = 250
    melanin = b.vmath("SCALE", gin.outputs["Melanin Absorption"], scale=gin.outputs["Melanin"])
    blood = b.vmath("SCALE", gin.outputs["Hemoglobin Absorption"], scale=gin.outputs["Hemoglobin"])
    c = b.vmath("SUBTRACT", b.vmath("SUBTRACT", gin.outputs["Base Color"], melanin), blood)
    c = b.vmath("MINIMUM", b.vmath("MAXIMUM", c, (0.0, 0.0, 0.0)), (1.0, 1.0, 1.0))
    gout = b.node("NodeGroupOutput")
    b.link(c, gout.inputs["Color"])


def ensure_fine_group():
    """The shared ``Fine Wrinkles`` group, built or rebuilt when another version made it."""
    return _group(FINE_GROUP, _build_fine)


def ensure_pigment_group():
    """The shared ``Skin Pigment`` group (§8, eq. 6)."""
    return _group(PIGMENT_GROUP, _build_pigment)


def tag_layer(node):
    """Mark a material node as one of our normal layers (see ``glue.nodes.normal_input``)."""
    node[LAYER_TAG] = True


PIGMENT_NODE = "Skin Pigment"


def add_pigment(material):
    """Put the ``Skin Pigment`` group in front of the material's Principled BSDF Base Color:
    what fed it (a texture, or its colour) becomes the group's Base Color.  Returns the
    group node.  Raises ShadingError."""
    if material.library is not None:
        raise ShadingError(f'The material "{material.name}" is linked and read-only: make it local')
    use_nodes(material)
    nt = material.node_tree
    bsdf = principled(nt)
    if bsdf is None:
        raise ShadingError(f'The material "{material.name}" has no Principled BSDF')
    node = nt.nodes.get(PIGMENT_NODE)
    if node is None:
        node = nt.nodes.new("ShaderNodeGroup")
        node.name = node.label = PIGMENT_NODE
        node.location = (bsdf.location.x - 300, bsdf.location.y)
    node.node_tree = ensure_pigment_group()
    base = bsdf.inputs["Base Color"]
    if base.links and base.links[0].from_node != node:
        nt.links.new(base.links[0].from_socket, node.inputs["Base Color"])
    elif not base.links:
        node.inputs["Base Color"].default_value = base.default_value
    nt.links.new(node.outputs["Color"], base)
    return node
