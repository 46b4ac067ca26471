# SPDX-License-Identifier: GPL-3.0-or-later
"""The fine wrinkles' shrinkage computed by Blender: a Geometry Nodes modifier built in code.

The shrinkage across each of the two direction fields (Bando et al. 2002, §7, eq. 4) is a
shading value, like the edge tension a Geometry Nodes setup computes natively, so Blender
computes it itself every frame, with no Python, on a farm with no add-on too.  The static
part of :func:`core.bando.fine.plan` is stored on the mesh as hidden point attributes
(:func:`write_slots`): per field, the far vertex and the coefficient of each of a vertex's
four slots, and its share.  The tree, per vertex and field::

    l_j  = max(|p - p[far_j]|, 1e-30)            Evaluate at Index of p
    q_j  = coef_j / l_j
    s    = (share - 1 / (q_0 + q_1) - 1 / (q_2 + q_3)) * share

``p`` is the skin as the modifier receives it (shape keys, bones, every deformer before
it) plus the muscles' Waters pull, which the frame stage writes as ``wrinkle_pull``
(``glue.stage.PULL_ATTR``) with the frame it belongs to: wrinkles never feed the
shrinkage they come from, and the pull does, as in the NumPy stage.  The result, both
fields as one 2-D vector (``SHRINKAGE_ATTR``), is what the *Fine Wrinkles* shader group
reads.  It is stored at the vertices, where it is computed, unless the modifier's *Corners*
input asks for a UV map (one 2-D vector a face corner, each its vertex's): the Alembic
bake carries only UV maps to the farm's stand-in, so Bake for Farm exports with it on, and
so does a face with a modifier after this one that makes new vertices (a Subdivision
Surface, say), which interpolates a UV map differently from a vertex attribute
(:func:`wants_corners`).  Storing the corners cost a third of a Geometry Nodes tension
setup's time at 50k vertices.  ``core.bando.fine.slot_shrinkages`` is the tree's NumPy transcription and
``core.bando.fine.shrinkages`` the reference it equals (tested, at every vertex).

The modifier sits directly above the Wrinkles modifier (its input is the stage's skin), or,
on a face without one, after the deformers; its group is tagged (``glue.stage.READS_SKIN``)
so that Enable Wrinkles, which adds the stage after the deformers, moves it directly above.
"""

import contextlib

import bpy
import numpy as np

from .. import meshio, nodes, stage
from ..errors import WrinkleError

GROUP_NAME = "Fine Wrinkle Shrinkage"
MODIFIER_NAME = "Fine Wrinkles"
VERSION = 2  # 2: at the vertices unless Corners is on
SHRINKAGE_ATTR = "ewrinkles_fine_shrinkage"  # 2-D vector (field 1, field 2), at the vertices or corners
CORNERS_INPUT = "Corners"
SKIN_ATTR = ".ewrinkles_fine_skin"  # inside the tree only: the skin it measures
TINY = 1e-30  # as core.bando.field: a collapsed edge gives s -> 1, never NaN


def far_attr(f, j):
    return f".ewrinkles_fine_far{f + 1}_{j}"


def coef_attr(f, j):
    return f".ewrinkles_fine_coef{f + 1}_{j}"


def share_attr(f):
    return f".ewrinkles_fine_share{f + 1}"


def slot_attributes():
    """Every stored attribute's ``(name, data type)``."""
    out = []
    for f in range(2):
        out += [(far_attr(f, j), "INT") for j in range(4)]
        out += [(coef_attr(f, j), "FLOAT") for j in range(4)]
        out.append((share_attr(f), "FLOAT"))
    return out


class FineTreeError(WrinkleError):
    """A problem with the fine wrinkles' modifier; the message is shown as is."""


def _build_group(ng):
    ng.interface.clear()
    ng.nodes.clear()
    ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    corners = ng.interface.new_socket(CORNERS_INPUT, in_out="INPUT", socket_type="NodeSocketBool")
    corners.default_value = False
    corners.description = ("Store the shrinkage as a UV map, one value a face corner (Bake for Farm, and a "
                           "face subdivided after this modifier), instead of one a vertex")
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    b = nodes.Builder(ng)
    gin = b.node("NodeGroupInput")

    def named(kind, name):
        n = b.node("GeometryNodeInputNamedAttribute", data_type=kind)
        n.inputs["Name"].default_value = name
        return n.outputs["Attribute"]

    # the skin plus this frame's pull (stamped as the stage's offsets are), stored once: an
    # Evaluate at Index evaluates its whole value field again for each of its eight uses
    b.x = 200
    time = b.node("GeometryNodeInputSceneTime")
    same = b.node("FunctionNodeCompare", data_type="FLOAT", operation="EQUAL")
    same.inputs["Epsilon"].default_value = stage.FRAME_EPSILON
    b.link(time.outputs["Frame"], same.inputs[0])
    b.link(named("FLOAT", stage.FRAME_ATTR), same.inputs[1])
    pull = b.vmath("SCALE", named("FLOAT_VECTOR", stage.PULL_ATTR), scale=same.outputs["Result"])
    skin = b.node("GeometryNodeStoreNamedAttribute", data_type="FLOAT_VECTOR", domain="POINT")
    skin.inputs["Name"].default_value = SKIN_ATTR
    b.link(gin.outputs[0], skin.inputs["Geometry"])
    position = b.node("GeometryNodeInputPosition").outputs["Position"]
    b.link(b.vmath("ADD", position, pull), skin.inputs["Value"])
    p = named("FLOAT_VECTOR", SKIN_ATTR)
    fields = []
    for f in range(2):
        b.x, b.y = 400 + 900 * f, 0
        q = []
        for j in range(4):
            at = b.node("GeometryNodeFieldAtIndex", data_type="FLOAT_VECTOR", domain="POINT")
            b.link(p, at.inputs["Value"])
            b.link(named("INT", far_attr(f, j)), at.inputs["Index"])
            length = b.math("MAXIMUM", b.vmath("DISTANCE", p, at.outputs["Value"]), TINY)
            q.append(b.math("DIVIDE", named("FLOAT", coef_attr(f, j)), length))
        b.x += 300
        sides = b.math("ADD", b.math("DIVIDE", 1.0, b.math("ADD", q[0], q[1])),
                       b.math("DIVIDE", 1.0, b.math("ADD", q[2], q[3])))
        share = named("FLOAT", share_attr(f))
        fields.append(b.math("MULTIPLY", b.math("SUBTRACT", share, sides), share))
    b.x, b.y = 2200, 0
    both = b.combine(fields[0], fields[1], 0.0)
    at_points = b.node("GeometryNodeStoreNamedAttribute", data_type="FLOAT2", domain="POINT")
    at_points.inputs["Name"].default_value = SHRINKAGE_ATTR
    b.link(skin.outputs["Geometry"], at_points.inputs["Geometry"])
    b.link(both, at_points.inputs["Value"])
    # or computed once per vertex, then stored on the corners (each corner gets its vertex's)
    b.y = -250
    per_vertex = b.node("GeometryNodeFieldOnDomain", data_type="FLOAT_VECTOR", domain="POINT")
    b.link(both, per_vertex.inputs["Value"])
    at_corners = b.node("GeometryNodeStoreNamedAttribute", data_type="FLOAT2", domain="CORNER")
    at_corners.inputs["Name"].default_value = SHRINKAGE_ATTR
    b.link(skin.outputs["Geometry"], at_corners.inputs["Geometry"])
    b.link(per_vertex.outputs["Value"], at_corners.inputs["Value"])
    b.x, b.y = 2500, 0
    switch = b.node("GeometryNodeSwitch", input_type="GEOMETRY")  # only the chosen branch runs
    b.link(gin.outputs[CORNERS_INPUT], switch.inputs["Switch"])
    b.link(at_points.outputs["Geometry"], switch.inputs["False"])
    b.link(at_corners.outputs["Geometry"], switch.inputs["True"])
    b.x += 250
    drop = b.node("GeometryNodeRemoveAttribute")
    drop.inputs["Name"].default_value = SKIN_ATTR
    b.link(switch.outputs[0], drop.inputs["Geometry"])
    gout = b.node("NodeGroupOutput")
    b.link(drop.outputs["Geometry"], gout.inputs[0])
    ng[stage.READS_SKIN] = True


def ensure_group():
    """The shared node group; reused when it exists, refused when linked and read-only."""
    return nodes.ensure_group(GROUP_NAME, "GeometryNodeTree", VERSION, _build_group, FineTreeError,
                              key="ewrinkles_fine_tree_version")


def upgrade_group(face):
    """Rebuild the modifier's group of an older version in place (its users stay), and set its
    Corners input; a line for the console, or "" when it is up to date."""
    mod = find_modifier(face)
    ng = mod.node_group if mod is not None else None
    if ng is None or ng.get("ewrinkles_fine_tree_version") == VERSION or ng.library is not None:
        return ""
    mod.node_group = ensure_group()
    sync_corners(face)
    return (f"its fine wrinkles' shrinkage is stored at the vertices (Fine Wrinkle Shrinkage version "
            f"{VERSION}), on the corners only for a bake or a subdivision after it")


def find_modifier(face):
    return nodes.nodes_modifier(face, GROUP_NAME)


def _home(face):
    """Where the modifier belongs: directly above the Wrinkles modifier, else above the first
    modifier that changes the topology, else at the bottom."""
    mods = list(face.modifiers)
    wrinkles = stage.find_modifier(face)
    if wrinkles is not None:
        return mods.index(wrinkles)
    return next((i for i, m in enumerate(mods) if m.type in stage.TOPOLOGY_MODIFIERS), len(mods))


def ensure_modifier(face):
    """Add the modifier (or put it back in its place) and return it."""
    mod = find_modifier(face)
    if mod is None:
        mod = face.modifiers.new(MODIFIER_NAME, "NODES")
        mod.show_in_editmode = False
    mod.node_group = ensure_group()
    mods = list(face.modifiers)
    here = mods.index(mod)
    home = _home(face)
    if home > here:
        home -= 1  # counted with the modifier itself still above
    if home != here:
        face.modifiers.move(here, home)
    mod.show_viewport = mod.show_render = True
    sync_corners(face)
    return mod


def _after(face, mod):
    """The face's modifiers after ``mod``."""
    mods = list(face.modifiers)
    return mods[mods.index(mod) + 1:]


def order_problem(face):
    """Why the modifier does not measure the skin the wrinkles see, or "": a missing or
    disabled modifier, or a modifier between it and the Wrinkles modifier (without one, a
    deformer after it)."""
    mod = find_modifier(face)
    if mod is None:
        return (f'The "{MODIFIER_NAME}" modifier of the fine wrinkles is missing: undo, or carve them '
                "again")
    if not (mod.show_viewport and mod.show_render):
        return f'The "{mod.name}" modifier is disabled: the fine wrinkles do not follow the skin'
    after = _after(face, mod)
    wrinkles = stage.find_modifier(face)
    if wrinkles is not None:
        if wrinkles not in after:
            return f'Move the "{mod.name}" modifier above "{wrinkles.name}"'
        between = [m for m in after[:after.index(wrinkles)] if m.show_viewport or m.show_render]
    else:
        between = [m for m in after
                   if (m.show_viewport or m.show_render) and m.type not in stage.TOPOLOGY_MODIFIERS]
    if between:
        place = f'directly above "{wrinkles.name}"' if wrinkles is not None else "below it"
        return (f'The modifier "{between[0].name}" changes the skin after "{mod.name}": move '
                f'"{mod.name}" {place}')
    return ""


def holds(me, slots):
    """Whether the mesh ``me`` stores exactly ``slots`` (a ``core.bando.fine.VertexSlots``)."""
    n = len(me.vertices)
    for f in range(2):
        for name, kind, values in _slot_arrays(slots, f):
            att = meshio.attribute(me, name, kind)
            if att is None or len(att.data) != n:
                return False
            got = np.empty(n, np.int32 if kind == "INT" else np.float32)
            att.data.foreach_get("value", got)
            if not np.array_equal(got, values):
                return False
    return True


def _slot_arrays(slots, f):
    for j in range(4):
        yield far_attr(f, j), "INT", slots.far[f, j]
        yield coef_attr(f, j), "FLOAT", slots.coef[f, j]
    yield share_attr(f), "FLOAT", slots.share[f]


def write_slots(me, slots):
    """Store ``slots`` on the mesh (unless it holds them already).  Returns whether it wrote."""
    if holds(me, slots):
        return False
    for f in range(2):
        for name, kind, values in _slot_arrays(slots, f):
            att = meshio.point_attribute(me, name, kind)
            att.data.foreach_set("value", np.ascontiguousarray(values))
    me.update_tag()
    return True


def shrinkage(face, depsgraph=None):
    """Both fields' shrinkage (2, N) float32 at the face's N vertices as Blender computed it in
    ``depsgraph`` (the context's by default), or None when the evaluated mesh holds none."""
    dg = depsgraph or bpy.context.evaluated_depsgraph_get()
    ev = face.evaluated_get(dg).data
    att = ev.attributes.get(SHRINKAGE_ATTR)
    if att is None or att.domain not in ("POINT", "CORNER") or att.data_type != "FLOAT2":
        return None
    values = np.empty(2 * len(att.data), np.float32)
    att.data.foreach_get("vector", values)
    values = values.reshape(-1, 2).T
    if att.domain == "CORNER":
        verts, _starts, _sizes = meshio.read_polygons(ev)
        out = np.zeros((2, len(ev.vertices)), np.float32)
        out[:, verts] = values
        values = out
    return values[:, :len(face.data.vertices)]


def write_evaluated(ev, corner_verts, values):
    """Write both fields' shrinkage ``values`` (2, N) float32 at the face's N vertices into
    the evaluated mesh ``ev`` (its ``SHRINKAGE_ATTR``, as the tree stores it: at the vertices,
    or each corner its vertex's), where ``corner_verts`` are the face's corner vertices.
    False when ``ev`` holds no such attribute on the same vertices or corners (the tree did
    not run, or the topology changed), and nothing is written."""
    att = ev.attributes.get(SHRINKAGE_ATTR)
    if att is None or att.data_type != "FLOAT2" or len(ev.vertices) != values.shape[1]:
        return False
    if att.domain == "POINT" and len(att.data) == values.shape[1]:
        att.data.foreach_set("vector", np.ascontiguousarray(values.T).reshape(-1))
        return True
    if att.domain == "CORNER" and len(att.data) == len(corner_verts):
        att.data.foreach_set("vector", np.ascontiguousarray(values.T[corner_verts]).reshape(-1))
        return True
    return False


_exporting = set()  # session_uid of the faces whose Alembic bake is being exported


def wants_corners(face):
    """Whether the modifier should store the shrinkage on the face corners (a UV map): while
    Bake for Farm exports the face (the cache carries only UV maps), or when a modifier after
    it, enabled in the viewport or in renders, makes new vertices, which interpolate a UV
    map (smoothly, as the farm's stand-in does) and a vertex attribute (linearly)
    differently."""
    if face.session_uid in _exporting:
        return True
    mod = find_modifier(face)
    return mod is not None and any((m.show_viewport or m.show_render) and m.type in stage.TOPOLOGY_MODIFIERS
                                   for m in _after(face, mod))


def _corners_input(face):
    """(the modifier, its Corners input's identifier), or (the modifier or None, None)."""
    mod = find_modifier(face)
    ng = mod.node_group if mod is not None else None
    item = ng.interface.items_tree.get(CORNERS_INPUT) if ng is not None else None
    return mod, (item.identifier if item is not None else None)


def corners(face):
    """Whether the face's modifier stores the corners (its Corners input), or None without one."""
    mod, key = _corners_input(face)
    return None if key is None else bool(nodes.modifier_input(mod, key, False))


def sync_corners(face):
    """Set the modifier's Corners input to :func:`wants_corners` (only if it differs)."""
    mod, key = _corners_input(face)
    want = wants_corners(face)
    if key is not None and bool(nodes.modifier_input(mod, key, False)) != want:
        nodes.set_modifier_input(mod, key, want)
    return want


@contextlib.contextmanager
def exporting(face):
    """The shrinkage on the corners while the block exports ``face``'s Alembic cache."""
    _exporting.add(face.session_uid)
    try:
        sync_corners(face)
        yield
    finally:
        _exporting.discard(face.session_uid)
        sync_corners(face)


def remove(face):
    """The modifier and every attribute it reads, gone (the group stays while others use it)."""
    mod = find_modifier(face)
    if mod is not None:
        face.modifiers.remove(mod)
    me = face.data
    for name, _kind in slot_attributes():
        att = me.attributes.get(name)
        if att is not None:
            me.attributes.remove(att)
    ng = bpy.data.node_groups.get(GROUP_NAME)
    if ng is not None and ng.users == 0 and ng.library is None:
        bpy.data.node_groups.remove(ng)
