# SPDX-License-Identifier: GPL-3.0-or-later
"""The face's materials as another program reads them: what the exports hand to Blender's
glTF and USD exporters.

Both exporters turn a Principled BSDF into the consumer's material (glTF's metallic-
roughness material, USD's ``UsdPreviewSurface``) by following each input's links to an
image texture, and write what they find: an image feeding ``Normal`` through any chain
becomes the material's normal texture.  The add-on's materials feed ``Normal`` from the
*Wrinkle Map Blend* group, whose first image is a wrinkle map (a partial-derivative map,
blue 0: a normal pointing into the skin to a consumer that reads it as a normal map), and
the sample skin from a bump of its procedural pores and fine wrinkles, whose first image
is a fine-wrinkle height field.  Both are wrong in every engine on every frame.  The
wrinkle maps reach a consumer as data instead, with their table and weights
(docs/wrinkle_package.md), and the exports carry them beside the material.

So the exports write **copies** of the materials (:func:`plain_copy`) in which:

* ``Normal`` reads the face's **base normal map** through a Normal Map node (the image
  that feeds the blend group's *Base Normal*: a standard tangent-space normal map), or
  nothing when there is none: the skin's own normal, as an engine shades it before the
  wrinkle maps are added;
* any other input whose chain holds no image texture, or holds one of the add-on's node
  groups (procedural colour, roughness from the skin's regions, attributes such as the
  rest positions), is unlinked: the consumer reads the input's own value, which the add-on's
  materials set to the skin's mean colour and roughness (``glue.skin_materials``), instead
  of the exporter's guess at the chain;
* an image chain of the artist's own (a colour texture into *Base Color*, say) is kept as it
  is;
* a surface that is not a Principled BSDF (the sample head's corneas and tear film, a
  transparent shader plus a glossy one), which the exporters cannot read and write as an
  opaque white material over the eyes, becomes a Principled BSDF of the material's viewport
  colour, alpha, roughness and metalness (*Viewport Display*), blended when its alpha is
  under 1.

The originals are never changed.
"""

from ..maps.nodegroups import BLEND_GROUP

_PREFIX = "ewrinkles_"  # every custom property of the add-on's groups starts with it
NORMAL_NODE = "Exported Base Normal"


def _is_ours(node):
    tree = getattr(node, "node_tree", None) if node.type == "GROUP" else None
    return tree is not None and (tree.name.startswith(BLEND_GROUP)
                                 or any(k.startswith(_PREFIX) for k in tree.keys()))


def upstream(socket):
    """Every node that feeds ``socket``, through any chain (groups as single nodes)."""
    seen, todo = {}, [link.from_node for link in socket.links]
    while todo:
        node = todo.pop()
        if node.name in seen:
            continue
        seen[node.name] = node
        for inp in node.inputs:
            todo.extend(link.from_node for link in inp.links if link.is_valid)
    return list(seen.values())


def base_normal_image(tree):
    """The image node that feeds the wrinkle-map blend's *Base Normal*, or None."""
    for node in tree.nodes:
        tree_ = node.node_tree if node.type == "GROUP" else None
        if tree_ is not None and tree_.name.startswith(BLEND_GROUP):
            sock = node.inputs.get("Base Normal")
            if sock is not None and sock.is_linked and sock.links[0].from_node.type == "TEX_IMAGE":
                return sock.links[0].from_node
    return None


def _surface(tree):
    """The Surface input of the material's active output, or None."""
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_MATERIAL"]
    out = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    return out.inputs["Surface"] if out is not None else None


def _foreign_surface(tree):
    sock = _surface(tree)
    return sock is not None and sock.is_linked and sock.links[0].from_node.type != "BSDF_PRINCIPLED"


def needs_copy(mat):
    """Whether a consumer would misread ``mat`` (what :func:`plain` changes)."""
    tree = mat.node_tree if mat is not None else None
    return tree is not None and (_foreign_surface(tree) or bool(_changes(tree)))


def _stand_in(mat, tree):
    """A Principled BSDF of ``mat``'s viewport display values on the active output."""
    sock = _surface(tree)
    bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
    bsdf.location = (sock.node.location.x - 300, sock.node.location.y - 400)
    r, g, b, a = mat.diffuse_color
    bsdf.inputs["Base Color"].default_value = (r, g, b, 1.0)
    bsdf.inputs["Alpha"].default_value = a
    bsdf.inputs["Roughness"].default_value = mat.roughness
    bsdf.inputs["Metallic"].default_value = mat.metallic
    tree.links.new(bsdf.outputs["BSDF"], sock)
    if a < 1.0:
        mat.surface_render_method = "BLENDED"


def _changes(tree):
    """[(bsdf, input name)] that :func:`plain` replaces."""
    out = []
    for bsdf in tree.nodes:
        if bsdf.type != "BSDF_PRINCIPLED":
            continue
        for sock in bsdf.inputs:
            if not sock.is_linked:
                continue
            nodes = upstream(sock)
            ours = any(_is_ours(n) for n in nodes)
            image = any(n.type == "TEX_IMAGE" for n in nodes)
            if ours or not image:
                out.append((bsdf, sock.name))
    return out


def plain(mat, uv_map=""):
    """Make ``mat`` (a copy) read as the module doc says; ``uv_map`` names the base normal
    map's UV map, "" for the render-active one.  The base map then reads that map by default,
    with no UV Map node, which the exporters write as their default UV set (USD's ``st``,
    glTF's ``TEXCOORD_0``): the USD exporter names a UV Map node's empty map ``_``."""
    tree = mat.node_tree
    if _foreign_surface(tree):
        _stand_in(mat, tree)
    base = base_normal_image(tree)
    for bsdf, name in _changes(tree):
        sock = bsdf.inputs[name]
        for link in list(sock.links):
            tree.links.remove(link)
        if name == "Normal" and base is not None:
            nmap = tree.nodes.new("ShaderNodeNormalMap")
            nmap.name = nmap.label = NORMAL_NODE
            nmap.space = "TANGENT"
            nmap.uv_map = uv_map
            nmap.location = (bsdf.location.x - 220, bsdf.location.y - 420)
            tree.links.new(base.outputs["Color"], nmap.inputs["Color"])
            tree.links.new(nmap.outputs["Normal"], sock)
            if not uv_map:
                for link in list(base.inputs["Vector"].links):
                    if link.from_node.type == "UVMAP":
                        tree.links.remove(link)


def uv_map(ob):
    """The UV map of ``ob``'s wrinkle maps for :func:`plain`: "" for the render-active one."""
    name = ob.ewrinkles_face.maps.uv_map
    render = next((uv.name for uv in ob.data.uv_layers if uv.active_render), "")
    return "" if name == render else name


def plain_copy(mat, ob):
    """A copy of ``mat`` (a material of ``ob``) under a temporary name, made plain
    (:func:`plain`); the caller removes it."""
    copy = mat.copy()
    if copy.node_tree is not None:
        plain(copy, uv_map(ob))
    return copy

