# SPDX-License-Identifier: GPL-3.0-or-later
"""Shader node groups of Bando, Kuratate & Nishita 2002, built in code.

``Fine Wrinkles`` bump-maps the two carved height images (§5), each scaled by the
amplitude modulation ``M(s)`` (eq. 5) of its own direction's shrinkage ``s`` (§7)::

    h = (H1 - 1) M(s1) + (H2 - 1) M(s2)
    M(s) = (1 - r) s + r            for s >= 0
           r exp((1/r - 1) s)        for s < 0

``H1``, ``H2`` are the height images (1 = no furrow, the paper's white), ``s1``, ``s2``
the two components of the corner attribute ``SHRINKAGE_ATTR`` that the face's *Fine
Wrinkles* modifier computes every frame (``glue.bando.fine_tree``), interpolated across each
triangle by the renderer as §7 interpolates shrinkage from the three vertices, and ``r`` the
rest height (0.5 by default: fine wrinkles show at rest).  A farm's stand-in reads the same
attribute from the Alembic bake, so it renders the same.  Each term is its own Bump
node, chained from the group's ``Normal`` input, so the group stacks on whatever normal the
material had (the wrinkle maps' included: ``glue.nodes.normal_input``).  A Bump node
differentiates its ``Height`` input (at points a fraction of a pixel apart) but not its
``Distance``: so ``H - 1`` is the height and ``M(s)`` scales the distance.  The furrows'
slopes are then ``M(s) ∇H``, the shrinkage the amplitude at the shading point.
``core.bando.field.modulation`` is the NumPy reference; a test compares them.

``Skin Pigment`` is eq. 6 of §8: ``c = b - m a_m - h a_h``, the base colour minus the
light absorbed by melanin ``m`` and hemoglobin ``h``, clamped to [0, 1].
"""

import bpy

from ..errors import WrinkleError
from ..nodes import LAYER_TAG, Builder, principled, use_nodes

FINE_GROUP = "Fine Wrinkles"
PIGMENT_GROUP = "Skin Pigment"
SHRINKAGE_ATTR = "ewrinkles_fine_shrinkage"  # corner 2-D vector, written by the Fine Wrinkles modifier
# 2: the Baked Shrinkage and Use Baked inputs; 3: M(s) scales each bump's distance; 4: the
# shrinkage from the modifier's corner attribute, the baked inputs gone
VERSION = 4
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


def _group(name, interface, build):
    """The group ``name`` at ``VERSION``: made, or brought up to date in place.  Its sockets
    are kept where ``interface`` still has them (their links in every material stay), the
    others removed, the missing added; then its nodes are built again."""
    ng = bpy.data.node_groups.get(name)
    if ng is not None:
        _check(ng)
        if ng.get("ewrinkles_version") == VERSION:
            return ng
        ng.nodes.clear()
    else:
        ng = bpy.data.node_groups.new(name, "ShaderNodeTree")
    wanted = interface()
    have = {(it.name, it.in_out): it for it in ng.interface.items_tree if it.item_type == "SOCKET"}
    for key, item in have.items():
        if key not in wanted or item.socket_type != wanted[key][0]:
            ng.interface.remove(item)
    for (sname, in_out), (kind, default, lo, hi, description, hide) in wanted.items():
        item = next((it for it in ng.interface.items_tree
                     if it.item_type == "SOCKET" and it.name == sname and it.in_out == in_out), None)
        if item is None:
            _socket(ng, sname, in_out, kind, default, lo, hi, description, hide)
        else:
            item.description = description
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


def _fine_interface():
    return {
        ("Height 1", "INPUT"): ("NodeSocketFloat", 1.0, 0.0, 1.0,
                                "The first carved height image (1: no furrow)", False),
        ("Height 2", "INPUT"): ("NodeSocketFloat", 1.0, 0.0, 1.0,
                                "The second carved height image, of the second direction field", False),
        ("Rest Height", "INPUT"): ("NodeSocketFloat", 0.5, 0.0, 1.0,
                                   "Height of the fine wrinkles on the undeformed skin relative to their "
                                   "full height (Bando 2002 eq. 5's r)", False),
        ("Strength", "INPUT"): ("NodeSocketFloat", 1.0, 0.0, 10.0, "Strength of the bump", False),
        ("Distance", "INPUT"): ("NodeSocketFloat", 0.0004, 0.0, 0.01,
                                "Depth of a full furrow, in scene units", False),
        ("Normal", "INPUT"): ("NodeSocketVector", None, None, None,
                              "The normal to bump (the material's own, or the wrinkle maps')", True),
        ("Normal", "OUTPUT"): ("NodeSocketVector", None, None, None, "The bumped normal", False),
    }


def _build_fine(ng):
    b = Builder(ng)
    gin = b.node("NodeGroupInput")
    b.x = 250
    r = gin.outputs["Rest Height"]
    normal = gin.outputs["Normal"]
    node = b.node("ShaderNodeAttribute", attribute_type="GEOMETRY", attribute_name=SHRINKAGE_ATTR)
    node.name = node.label = "Shrinkage"
    shrinkage = b.separate(node.outputs["Vector"])  # x: across field 1, y: across field 2
    for k, height in enumerate((gin.outputs["Height 1"], gin.outputs["Height 2"])):
        s_k = shrinkage[k]
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


def _pigment_interface():
    return {
        ("Base Color", "INPUT"): ("NodeSocketColor", BASE_SKIN, None, None,
                                  "Skin colour without pigment (Bando 2002 eq. 6's b)", False),
        ("Melanin", "INPUT"): ("NodeSocketFloat", 0.2, 0.0, 2.0,
                               "Amount of melanin m: paint it, or animate it (tanning, freckles)", False),
        ("Hemoglobin", "INPUT"): ("NodeSocketFloat", 0.2, 0.0, 2.0,
                                  "Amount of hemoglobin h: paint it, or animate it (blushing, pallor)",
                                  False),
        ("Melanin Absorption", "INPUT"): ("NodeSocketColor", MELANIN_ABSORPTION, None, None,
                                          "Light absorbed by one unit of melanin per channel (eq. 6's a_m)",
                                          False),
        ("Hemoglobin Absorption", "INPUT"): ("NodeSocketColor", HEMOGLOBIN_ABSORPTION, None, None,
                                             "Light absorbed by one unit of hemoglobin per channel "
                                             "(eq. 6's a_h)", False),
        ("Color", "OUTPUT"): ("NodeSocketColor", None, None, None, "The skin colour c", False),
    }


def _build_pigment(ng):
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
    return _group(FINE_GROUP, _fine_interface, _build_fine)


def ensure_pigment_group():
    """The shared ``Skin Pigment`` group (§8, eq. 6)."""
    return _group(PIGMENT_GROUP, _pigment_interface, _build_pigment)


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
