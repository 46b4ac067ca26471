# SPDX-License-Identifier: GPL-3.0-or-later
"""Building shader node groups in code: the one helper every method's node groups use."""

import bpy

_KINDS = {"GeometryNodeTree": "Geometry Nodes", "ShaderNodeTree": "shader"}


def use_nodes(id_block):
    """Switch on a material's nodes: needed before Blender 5, where they are always on and
    ``use_nodes`` is deprecated (reading it warns too)."""
    if bpy.app.version < (5, 0, 0) and not id_block.use_nodes:
        id_block.use_nodes = True


def ensure_group(name, tree_type, version, build, error, key="ewrinkles_version"):
    """The shared node group ``name`` of ``tree_type``: reused when its ``key`` says
    ``version``, else built (or rebuilt) by ``build(ng)`` and tagged.  Raises ``error`` for a
    group of that name of another type, or one to rebuild that is linked and read-only."""
    ng = bpy.data.node_groups.get(name)
    if ng is not None and ng.bl_idname != tree_type:
        raise error(f'A node group named "{name}" exists but is not a {_KINDS.get(tree_type, tree_type)} '
                    "group; rename it")
    if ng is not None and ng.get(key) == version:
        return ng
    if ng is not None and (ng.library is not None or not ng.is_editable):
        raise error(f'The node group "{name}" is linked from a library and cannot be edited; make it local')
    if ng is None:
        ng = bpy.data.node_groups.new(name, tree_type)
    build(ng)
    ng[key] = version
    return ng


def nodes_modifier(ob, group_name):
    """The first Geometry Nodes modifier of ``ob`` whose group is ``group_name`` (or a copy of
    it, "<name>.001"), or None."""
    for mod in ob.modifiers:
        if mod.type == "NODES" and mod.node_group is not None and mod.node_group.name.startswith(group_name):
            return mod
    return None


def _input_struct(mod, identifier):
    """Blender 5.2's RNA struct of the modifier's input, or None before 5.2 (and for an
    identifier the modifier does not have)."""
    inputs = getattr(getattr(mod, "properties", None), "inputs", None)
    return None if inputs is None else getattr(inputs, identifier, None)


def modifier_input(mod, identifier, default=None):
    """The value of the Geometry Nodes modifier ``mod``'s input ``identifier`` (its socket's
    identifier).  Blender 5.2 gives the inputs RNA properties (``mod.properties.inputs``);
    before, they are the modifier's custom properties."""
    if getattr(mod, "properties", None) is not None:
        item = _input_struct(mod, identifier)
        return default if item is None else item.value
    return mod.get(identifier, default)


def set_modifier_input(mod, identifier, value):
    """Set the modifier's input ``identifier`` (see :func:`modifier_input`) and tag its object
    (neither way of setting it does)."""
    if getattr(mod, "properties", None) is not None:
        _input_struct(mod, identifier).value = value
    else:
        mod[identifier] = value
    mod.id_data.update_tag()


def float_inputs(ng, specs):
    """Add a float input to the group ``ng`` for each ``(name, default, min, max, tooltip)``."""
    for name, default, lo, hi, tip in specs:
        s = ng.interface.new_socket(name, in_out="INPUT", socket_type="NodeSocketFloat")
        s.default_value, s.min_value, s.max_value, s.description = default, lo, hi, tip


class Builder:
    """Small helpers to add shader math nodes in a column layout."""

    def __init__(self, ng):
        self.ng = ng
        self.x = 0
        self.y = 0

    def node(self, kind, **props):
        n = self.ng.nodes.new(kind)
        for key, value in props.items():
            setattr(n, key, value)
        n.location = (self.x, self.y)
        self.y -= 160
        return n

    def link(self, out, inp):
        self.ng.links.new(out, inp)

    def math(self, op, a, b=None, c=None, clamp=False):
        n = self.node("ShaderNodeMath", operation=op, use_clamp=clamp)
        for i, v in enumerate((a, b, c)):
            if v is None:
                continue
            if isinstance(v, (int, float)):
                n.inputs[i].default_value = v
            else:
                self.link(v, n.inputs[i])
        return n.outputs[0]

    def vmath(self, op, a, b=None, c=None, scale=None):
        n = self.node("ShaderNodeVectorMath", operation=op)
        for i, v in enumerate((a, b, c)):
            if v is None:
                continue
            if isinstance(v, tuple):
                n.inputs[i].default_value = v
            else:
                self.link(v, n.inputs[i])
        if scale is not None:
            if isinstance(scale, (int, float)):
                n.inputs["Scale"].default_value = scale
            else:
                self.link(scale, n.inputs["Scale"])
        return n.outputs["Value"] if op in ("DOT_PRODUCT", "LENGTH", "DISTANCE") else n.outputs["Vector"]

    def combine(self, x, y, z):
        n = self.node("ShaderNodeCombineXYZ")
        for i, v in enumerate((x, y, z)):
            if isinstance(v, (int, float)):
                n.inputs[i].default_value = v
            else:
                self.link(v, n.inputs[i])
        return n.outputs[0]

    def separate(self, v):
        n = self.node("ShaderNodeSeparateXYZ")
        self.link(v, n.inputs[0])
        return n.outputs

    def decode(self, color):
        """2 c - 1 as a vector."""
        return self.vmath("MULTIPLY_ADD", color, (2.0, 2.0, 2.0), (-1.0, -1.0, -1.0))


def ensure_node(nt, name, kind, location):
    """The node named ``name`` of type ``kind`` in tree ``nt``, created at ``location`` (and
    labelled with its name) if missing or of another type."""
    node = nt.nodes.get(name)
    if node is not None and node.bl_idname != kind:
        nt.nodes.remove(node)
        node = None
    if node is None:
        node = nt.nodes.new(kind)
        node.name = node.label = name
        node.location = location
    return node


def principled(nt):
    """The material's Principled BSDF: the one the active output shows, else the first."""
    bsdfs = [n for n in nt.nodes if n.type == "BSDF_PRINCIPLED"]
    for out in (n for n in nt.nodes if n.type == "OUTPUT_MATERIAL" and n.is_active_output):
        linked = [lk.from_node for lk in out.inputs["Surface"].links]
        if linked and linked[0].type == "BSDF_PRINCIPLED":
            return linked[0]
    return bsdfs[0] if bsdfs else None


LAYER_TAG = "ewrinkles_normal_layer"


def normal_input(nt, bsdf):
    """The socket a normal map should feed in material ``nt``: the BSDF's Normal, or, when
    normal layers of ours (nodes tagged ``LAYER_TAG``, each with a ``Normal`` input it
    perturbs, like the fine wrinkles' bump) already feed it, the Normal input at the end of
    their chain.  So the wrinkle maps and the fine wrinkles stack in one material whichever
    is set up first."""
    sock = bsdf.inputs["Normal"]
    seen = set()
    while sock.links:
        node = sock.links[0].from_node
        if not node.get(LAYER_TAG) or node.name in seen or "Normal" not in node.inputs:
            break
        seen.add(node.name)
        sock = node.inputs["Normal"]
    return sock
