# SPDX-License-Identifier: GPL-3.0-or-later
"""Shader node groups of the animated wrinkle maps (Jimenez et al. 2011), built in code.

``Wrinkle Map Blend`` (shared by every material) is Listing 1.1 generalised to K wrinkle
maps, each with its own 8 zone weights (Oat's stretch and compress maps are K = 2)::

    s_k = Strength * sum_z mask_z * clamp(Map k Zone z, 0, 1)
    PD:   n = normalize(b_x/b_z + sum_k s_k w'_kx,  b_y/b_z + sum_k s_k w'_ky,  1)
    diff: n = normalize(b + sum_k s_k 2 decode(d_k))

(evaluated in an equivalent form with fewer nodes: see ``_build_blend``)

with ``b = decode(Base Normal)`` a standard tangent-space normal map, converted to a
partial derivative in the shader so artists keep their base map; ``Difference Maps`` (0
or 1) picks §1.2.1's difference maps instead of PD maps.  The result goes through a
Normal Map node (tangent space of the render-active UV map) to the ``Normal`` output;
the ``Color`` output is its input, for a Normal Map node of another UV map.
:func:`core.maps.jimenez.blend` is the NumPy reference; a Cycles test compares them.

``Wrinkle Weights <face>`` (one per face) turns the expression values into the zone
inputs: it holds one Value node per expression (driven by its source) and the table as
Math nodes, ``strength_z * clamp(sum_e value_e * weight_ez, 0, 1) ** power_z`` per map
and zone.  Why in the shader and not in driver expressions: a sum over 20 expressions
overflows Blender's 255-character expression limit (CC/iC Blender Tools ran into it), and
chained drivers depend on evaluation order.  Here every driver has one variable and no
expression, so it evaluates with Python auto-run off, the table has no size limit, and
Cycles folds the whole network to 8 K constants before rendering (every input is a
constant), so it costs nothing per sample.  The tension-driven zone values that the add-on
writes every frame are packed three to a colour (:data:`TENSION_NODES`): every value set
makes Blender update the node tree, so a frame costs three updates instead of eight.  A
shader reads no alpha from a colour (Separate Color gives red, green and blue), so 8
values need three colours, not two.
"""

import bpy

from ...core.maps.jimenez import N_ZONES, ZONES
from ..errors import WrinkleError
from ..nodes import Builder

BLEND_GROUP = "Wrinkle Map Blend"
WEIGHTS_PREFIX = "Wrinkle Weights"
# 2: the cheaper graph (no division, no normalisation); 3: the Color output; 4: zones at
# weight 0 fold away (and with them the lookups of masks and maps they alone read)
VERSION = 4
FLAT = (0.5, 0.5, 0.5, 1.0)  # decodes to 0 in both PD and difference maps


class MapError(WrinkleError):
    """A problem the user must fix; the message is shown as is."""


def zone_socket(k, z):
    return f"Map {k + 1} {ZONES[z][1]}"


def map_socket(k):
    return f"Map {k + 1}"


def _inputs(ng):
    return {s.name: s for s in ng.interface.items_tree if s.item_type == "SOCKET" and s.in_out == "INPUT"}


def _new_input(ng, name, kind, default=None, lo=None, hi=None, description=""):
    s = ng.interface.new_socket(name, in_out="INPUT", socket_type=kind)
    s.description = description
    if default is not None:
        s.default_value = default
    if lo is not None:
        s.min_value, s.max_value = lo, hi
    return s


def map_count(ng):
    names = _inputs(ng)
    k = 0
    while map_socket(k) in names:
        k += 1
    return k


def _ensure_interface(ng, n_maps):
    """Add missing sockets only, so links from materials that use the group survive.
    Returns how many were added."""
    have = _inputs(ng)
    outputs = {s.name for s in ng.interface.items_tree if s.item_type == "SOCKET" and s.in_out == "OUTPUT"}
    added = ("Normal" not in outputs) + ("Color" not in outputs)
    if "Normal" not in outputs:
        s = ng.interface.new_socket("Normal", in_out="OUTPUT", socket_type="NodeSocketVector")
        s.description = "The blended normal, through a Normal Map node of the render-active UV map"
    if "Color" not in outputs:
        s = ng.interface.new_socket("Color", in_out="OUTPUT", socket_type="NodeSocketColor")
        s.description = ("The blended normal as a tangent-space colour, not normalised: feed it to "
                         "a Normal Map node to use the tangents of another UV map")
    spec = [
        ("Strength", "NodeSocketFloat", 1.0, 0.0, 10.0, "Overall strength of the wrinkle maps"),
        ("Difference Maps", "NodeSocketFloat", 0.0, 0.0, 1.0,
         "0: the wrinkle maps are partial-derivative maps; 1: they are difference maps "
         "d = 0.5 + 0.5 (w - b) (Jimenez et al. 2011, §1.2.1)"),
        ("Base Normal", "NodeSocketColor", (0.5, 0.5, 1.0, 1.0), None, None,
         "The base tangent-space normal map (standard encoding)"),
        ("Mask A", "NodeSocketColor", (0.0, 0.0, 0.0, 1.0), None, None, "Zones 1-3 in R, G, B"),
        ("Mask A Alpha", "NodeSocketFloat", 0.0, 0.0, 1.0, "Zone 4 (alpha of mask A)"),
        ("Mask B", "NodeSocketColor", (0.0, 0.0, 0.0, 1.0), None, None, "Zones 5-7 in R, G, B"),
        ("Mask B Alpha", "NodeSocketFloat", 0.0, 0.0, 1.0, "Zone 8 (alpha of mask B)"),
    ]
    for k in range(n_maps):
        spec.append((map_socket(k), "NodeSocketColor", FLAT, None, None,
                     f"Wrinkle map {k + 1}: a partial-derivative map (or a difference map)"))
        spec += [(zone_socket(k, z), "NodeSocketFloat", 0.0, -10.0, 10.0,
                  f"Summed weight of zone {z + 1} ({ZONES[z][1]}) for map {k + 1}; clamped to [0, 1]")
                 for z in range(N_ZONES)]
    for name, kind, default, lo, hi, desc in spec:
        if name not in have:
            s = _new_input(ng, name, kind, default, lo, hi, desc)
            if name in ("Difference Maps", "Mask A Alpha", "Mask B Alpha"):
                s.subtype = "FACTOR"
            added += 1
    return added


def _by_id(sockets, identifier):
    """ShaderNodeMix has sockets with duplicate names: pick by identifier
    (docs/architecture.md, "Measured Blender facts")."""
    return next(s for s in sockets if s.identifier == identifier)


def _build_blend(ng):
    """(Re)build the inside of the blend group for the maps its interface holds.

    The graph renders Listing 1.1 exactly but with as few per-sample nodes as the algebra
    allows (Cycles pays for every node at every shading point).  With ``c`` the base map's
    colour, ``b = 2c - 1`` and ``b_z > 0``, the PD blend ``normalize(b_xy / b_z + D, 1)``
    equals ``normalize(b + b_z (D, 0))``, and the Normal Map node normalises its decoded
    input anyway, so the group hands it ``c + (c_z - 1/2) (D, 0)`` with
    ``D = sum_k s_k w'_k``: no division, no normalisation.  Difference maps give
    ``c + sum_k s_k (2 d_k - 1)`` the same way.  The per-zone clamps and the strength fold
    into constants before rendering (their inputs are constants), as does the unused mode.
    Every zone enters through a product and a sum, which Cycles folds when the zone's
    weight is 0, so the zones an expression leaves at 0 cost nothing per sample, nor do
    the mask lookups only they read, and with every weight at 0 (a neutral frame) the
    group is the base map alone: on the ICT head's skin with subsurface, a render at
    Strength 0 cost 1.097 times the plain skin with the multiply-adds of version 3, 0.994
    with these.
    """
    ng.nodes.clear()
    k_maps = map_count(ng)
    b = Builder(ng)
    gin = b.node("NodeGroupInput")
    gin.location = (-1400, 0)
    gout = b.node("NodeGroupOutput")
    gout.location = (1000, 0)
    o = gin.outputs
    diff = o["Difference Maps"]

    # decoding of a wrinkle map: PD (2r - 1, 2g - 1, 0); difference (2 d - 1)
    b.x, b.y = -1100, 400
    dec_mul = b.combine(2.0, 2.0, b.math("MULTIPLY", diff, 2.0))
    dec_add = b.combine(-1.0, -1.0, b.math("MULTIPLY", diff, -1.0))
    # scale of the summed offsets: PD (c_z - 1/2); difference 1
    b.x, b.y = -700, 400
    half_bz = b.math("SUBTRACT", b.separate(o["Base Normal"])[2], 0.5)
    mix = b.node("ShaderNodeMix", data_type="FLOAT", clamp_factor=True)
    b.link(diff, mix.inputs["Factor"])
    b.link(half_bz, _by_id(mix.inputs, "A_Float"))
    _by_id(mix.inputs, "B_Float").default_value = 1.0
    mode_scale = _by_id(mix.outputs, "Result_Float")

    total = None
    for k in range(k_maps):
        # s_k = sum_z mask_z * Strength * clamp(w_kz, 0, 1): the MAXIMUM node's clamp is
        # the paper's per-zone clamp
        b.x, b.y = -1100, -k * 1800
        w = [b.math("MULTIPLY", b.math("MAXIMUM", o[zone_socket(k, z)], 0.0, clamp=True), o["Strength"])
             for z in range(N_ZONES)]
        b.x = -700
        # products and sums only, never MULTIPLY_ADD: Cycles folds x * 0 to 0 and x + 0 to
        # x, not a MULTIPLY_ADD by 0, so zones at weight 0 cost nothing
        s = b.math("ADD", b.vmath("DOT_PRODUCT", o["Mask A"], b.combine(w[0], w[1], w[2])),
                   b.vmath("DOT_PRODUCT", o["Mask B"], b.combine(w[4], w[5], w[6])))
        s = b.math("ADD", s, b.math("MULTIPLY", o["Mask A Alpha"], w[3]))
        s = b.math("ADD", s, b.math("MULTIPLY", o["Mask B Alpha"], w[7]))
        b.x = -300
        term = b.vmath("SCALE", b.vmath("MULTIPLY_ADD", o[map_socket(k)], dec_mul, dec_add), scale=s)
        total = term if total is None else b.vmath("ADD", total, term)
    b.x, b.y = 300, 0
    color = b.vmath("ADD", b.vmath("SCALE", total, scale=mode_scale), o["Base Normal"])
    nmap = b.node("ShaderNodeNormalMap", space="TANGENT")
    b.link(color, nmap.inputs["Color"])
    b.link(nmap.outputs["Normal"], gout.inputs["Normal"])
    b.link(color, gout.inputs["Color"])
    ng["ewrinkles_map_version"] = VERSION


def _check_editable(ng):
    if ng.library is not None or not ng.is_editable:
        lib = ng.library.filepath if ng.library is not None else "a library"
        raise MapError(f'The node group "{ng.name}" is linked from {lib} and is read-only: '
                       "make it local to change it")
    if ng.bl_idname != "ShaderNodeTree":
        raise MapError(f'A node group named "{ng.name}" exists but is not a shader group; rename it')


def ensure_blend_group(n_maps=2):
    """The shared ``Wrinkle Map Blend`` group with at least ``n_maps`` maps.

    An existing group is reused: missing sockets are added (existing links stay) and its
    inside is rebuilt only when it lacks maps or sockets (deleted by hand, or a crafted
    file whose version tag lies) or was built by another version.
    """
    ng = bpy.data.node_groups.get(BLEND_GROUP)
    if ng is not None:
        _check_editable(ng)
        if (ng.get("ewrinkles_map_version") == VERSION and map_count(ng) >= n_maps
                and not _ensure_interface(ng, map_count(ng))):
            return ng
    else:
        ng = bpy.data.node_groups.new(BLEND_GROUP, "ShaderNodeTree")
    _ensure_interface(ng, max(n_maps, map_count(ng)))
    _build_blend(ng)
    return ng


# ---------------------------------------------------------------------------------------
# The per-face weights group: expression values -> zone inputs of the blend group


def expr_node(e):
    return f"Expression {e}"


def weight_node(e, z):
    return f"Weight {e} {z}"


# The tension-driven zone values, three to a colour: zone z is channel z % 3 (red, green,
# blue) of the RGB node TENSION_NODES[z // 3].  Before weights version 2 each zone had a
# Value node of its own (legacy_tension_node), which material.upgrade packs.
TENSION_NODES = ("Tension A", "Tension B", "Tension C")
WEIGHTS_VERSION = 2


def tension_slot(z):
    """(RGB node name, channel) holding zone ``z``'s tension value."""
    return TENSION_NODES[z // 3], z % 3


def legacy_tension_node(z):
    return f"Tension {z}"


def _layout_key(n_maps, map_of_expression):
    return f"w{WEIGHTS_VERSION}:{n_maps}:" + ",".join(str(m) for m in map_of_expression)


def upgrade_layout_key(ng):
    """Tag a group of weights version 1 whose tension ``material.upgrade`` packed as
    version 2 (its layout is otherwise the same)."""
    key = ng.get("ewrinkles_layout")
    if isinstance(key, str) and not key.startswith("w"):
        ng["ewrinkles_layout"] = f"w{WEIGHTS_VERSION}:{key}"


def add_tension_nodes(ng, x=-200, y=0):
    """The three RGB nodes of the tension values and their Separate Color nodes; returns the
    8 output sockets, one a zone, in zone order."""
    b = Builder(ng)
    outs = []
    for i, name in enumerate(TENSION_NODES):
        zones = range(3 * i, min(3 * i + 3, N_ZONES))
        b.x, b.y = x - 200, y - 200 * i
        rgb = b.node("ShaderNodeRGB", name=name, label="Tension " + ", ".join(ZONES[z][1] for z in zones))
        rgb.outputs[0].default_value = (0.0, 0.0, 0.0, 1.0)
        b.x += 180
        split = b.node("ShaderNodeSeparateColor", name=f"{name} Split")
        split.mode = "RGB"
        b.link(rgb.outputs[0], split.inputs[0])
        outs += [split.outputs[c] for c in range(len(zones))]
    return outs


def build_weights(ng, names, map_of_expression, n_maps):
    """Rebuild the weights group for expressions ``names`` (each on wrinkle map
    ``map_of_expression[e]``, 0-based) and ``n_maps`` maps.

    Per map k and zone z: ``S * clamp(T_z [k = 0] + sum_e value_e * weight_ez, 0, 1) ** P``,
    a chain of Math MULTIPLY_ADD nodes named :func:`weight_node` (input 1 holds the
    weight), so weights change without a rebuild (:func:`set_weights`).  Drivers on the
    group's ``Expression e`` Value nodes are removed with them: the caller re-adds them.
    """
    _check_editable(ng)
    if ng.animation_data is not None:
        ng.animation_data_clear()
    ng.nodes.clear()
    ng.interface.clear()
    for k in range(n_maps):
        for z in range(N_ZONES):
            ng.interface.new_socket(zone_socket(k, z), in_out="OUTPUT", socket_type="NodeSocketFloat")
    b = Builder(ng)
    gout = b.node("NodeGroupOutput")
    gout.location = (600 + 300 * len(names), 0)
    values = []
    b.x = -400
    for e, name in enumerate(names):
        n = b.node("ShaderNodeValue", name=expr_node(e), label=name[:60] or f"Expression {e + 1}")
        values.append(n.outputs[0])
    tensions = add_tension_nodes(ng)
    for k in range(n_maps):
        for z in range(N_ZONES):
            b.x, b.y = 0, -(k * N_ZONES + z) * 220
            acc = tensions[z] if k == 0 else 0.0
            for e in range(len(names)):
                if map_of_expression[e] != k:
                    continue
                acc = b.math("MULTIPLY_ADD", values[e], 0.0, acc)
                acc.node.name = weight_node(e, z)
                b.x += 200
                b.y += 160
            clamped = b.math("MAXIMUM", acc, 0.0, clamp=True)
            shaped = b.math("POWER", clamped, 1.0)
            shaped.node.name = f"Power {k} {z}"
            out = b.math("MULTIPLY", shaped, 1.0)
            out.node.name = f"Strength {k} {z}"
            b.link(out, gout.inputs[zone_socket(k, z)])
    ng["ewrinkles_layout"] = _layout_key(n_maps, map_of_expression)


def weights_layout_matches(ng, map_of_expression, n_maps):
    """Whether ``ng`` is the weights group :func:`build_weights` makes for this layout.

    The tag is read from the file, so the nodes that :func:`set_weights` writes are
    checked too: a group whose nodes were deleted by hand (or whose tag was crafted) is
    rebuilt rather than trusted."""
    if ng.get("ewrinkles_layout") != _layout_key(n_maps, map_of_expression):
        return False
    nodes = ng.nodes
    names = [expr_node(e) for e in range(len(map_of_expression))]
    names += list(TENSION_NODES) + [f"{n} Split" for n in TENSION_NODES]
    names += [f"{kind} {k} {z}" for kind in ("Power", "Strength")
              for k in range(n_maps) for z in range(N_ZONES)]
    names += [weight_node(e, z) for e in range(len(map_of_expression)) for z in range(N_ZONES)]
    return all(name in nodes for name in names)


def set_weights(ng, table, manual_values, zone_strength, zone_power, n_maps):
    """Write the table (E, 8), the manual expression values (E,; None = driven) and the
    per-zone response into an existing weights group without rebuilding it."""
    nodes = ng.nodes
    for e, row in enumerate(table):
        for z in range(N_ZONES):
            node = nodes.get(weight_node(e, z))
            if node is not None and node.inputs[1].default_value != float(row[z]):
                node.inputs[1].default_value = float(row[z])
        v = manual_values[e]
        if v is not None:
            out = nodes[expr_node(e)].outputs[0]
            if out.default_value != v:
                out.default_value = v
    for k in range(n_maps):
        for z in range(N_ZONES):
            p, s = nodes[f"Power {k} {z}"].inputs[1], nodes[f"Strength {k} {z}"].inputs[1]
            if p.default_value != float(zone_power[z]):
                p.default_value = float(zone_power[z])
            if s.default_value != float(zone_strength[z]):
                s.default_value = float(zone_strength[z])


def set_tension(ng, values):
    """Write the 8 tension-driven zone values, a colour (one node tree update) for each
    three, and only the colours that changed."""
    v = [float(x) for x in values] + [0.0] * (3 * len(TENSION_NODES) - N_ZONES)
    for i, name in enumerate(TENSION_NODES):
        node = ng.nodes.get(name)
        if node is None:
            continue
        out = node.outputs[0]
        rgb = tuple(v[3 * i: 3 * i + 3])
        if tuple(out.default_value[:3]) != rgb:
            out.default_value = (*rgb, 1.0)


def read_tension(ng):
    """The 8 tension-driven zone values the group holds (zeros where a node is missing)."""
    out = [0.0] * N_ZONES
    for z in range(N_ZONES):
        name, c = tension_slot(z)
        node = ng.nodes.get(name)
        if node is not None:
            out[z] = float(node.outputs[0].default_value[c])
    return out
