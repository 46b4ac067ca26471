# SPDX-License-Identifier: GPL-3.0-or-later
"""Shedding tears ("Pattern functions and tears", §4.2) as objects: a tear that runs down a
path on the skin, built once in NumPy (``core.patterns.tears.Tear``) and then left to Blender:

- one Geometry Nodes group binds it to the skin, so it follows the face as it deforms: each
  vertex keeps the skin triangle under it, its barycentric weights there and its height
  along the triangle's normal (``core.patterns.tears.bind``), and is put back on that triangle of the
  face's evaluated mesh every frame (Surface Deform refuses faces with concave polygons,
  which real meshes have);
- the same group reveals it with the scene time, ``h = s + c t`` (step five), up to the
  path's end, where it stops: over the head, the last ``Head`` before ``h``, the tear
  narrows to a round tip (a quarter circle) and its top swells into a bead and comes down
  steeply onto its bottom at the front (``core.patterns.tears.bead_profile``); everything
  ahead of the head is removed.

Its material is a thin film of water (``tears.film_material``): the skin seen through it,
lit, with sharp Fresnel reflections.  So it animates and renders with no Python per frame
(and on a farm with no add-on)."""

import bpy
import numpy as np
from mathutils import Matrix

from ...core import mesh
from ...core.patterns import tears
from .. import curve_objects, meshio, surface
from ..faces import collections_for
from ..nodes import Builder, float_inputs
from ..nodes import ensure_group as ensure_group_of
from .pattern_layers import face_unit
from .tears import SURFACE_ATTR, TearError, film_material, get_input, set_input

GROUP_NAME = "Shedding Tear"
MODIFIER_NAME = "Shedding Tear"
SKIN_ATTRS = ("tear_skin_a", "tear_skin_b", "tear_skin_c")  # the skin triangle's vertices
WEIGHTS_ATTR = "tear_skin_weights"  # the barycentric weights there
LIFT_ATTR = "tear_skin_lift"  # the height along the triangle's normal
ARC_ATTR = "tear_arc"  # the arc length along the path under each vertex, scene units
PARTNER_ATTR = "tear_partner"  # the bottom vertex under each vertex
CENTRE_ATTR = "tear_centre"  # the vertex at the middle of each vertex's row, on its own sheet
VERSION = 2
ACROSS = 13  # points across the tear
ROWS_PER_WIDTH = 8  # rows along the path per tear width
GAP = 0.04  # the bottom's height over the skin, per tear width: above the chords across facets
INPUTS = (  # name, default, min, max, tooltip
    ("Shown", 0.0, 0.0, 1e3, "How much of its path the tear covers when it starts (the formula's s), "
     "in scene units"),
    ("Speed", 0.01, 0.0, 1e3, "How fast the tear runs down its path (the formula's c), in scene units per "
     "second"),
    ("Head", 0.003, 1e-6, 1e3, "The length of the tear's rounded head, in scene units"),
    ("Start", 0.0, -1e6, 1e6, "When the tear starts to run, in seconds of scene time"),
    ("Every", 0.0, 0.0, 1e6, "Run again every so many seconds, a running cycle; 0: run once and stay"),
    ("Bead", tears.BEAD, 0.0, 10.0, "How much the tear's head swells over its trail, the water gathered at "
     "its front: 0 a plain rounded end; at the default the head is about twice as thick as the trail"),
)


def _build(ng):
    ng.interface.clear()
    ng.nodes.clear()
    ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    float_inputs(ng, INPUTS)
    skin = ng.interface.new_socket("Skin", in_out="INPUT", socket_type="NodeSocketObject")
    skin.description = "The face the tear runs on; it follows its deformation"
    count = ng.interface.new_socket("Skin Vertices", in_out="INPUT", socket_type="NodeSocketInt")
    count.description = ("The face's vertex count when the tear was made; if the face's mesh changes, the "
                         "tear stays where it was made")
    b = Builder(ng)
    gin = b.node("NodeGroupInput")
    i = gin.outputs
    b.x = 200
    on_skin = _bound(b, i["Geometry"], i["Skin"], i["Skin Vertices"])
    arc = _named(b, ARC_ATTR, "FLOAT")
    since = b.math("SUBTRACT", b.node("GeometryNodeInputSceneTime").outputs["Seconds"], i["Start"])
    # the cycle: since - Every floor(since / Every); Blender's divide gives 0 for Every = 0
    tau = b.math("SUBTRACT", since, b.math("MULTIPLY", i["Every"],
                                           b.math("FLOOR", b.math("DIVIDE", since, i["Every"]))))
    b.x = 400
    h = b.math("MULTIPLY_ADD", i["Speed"], tau, i["Shown"])  # h = s + c t
    started = b.math("GREATER_THAN", since, -1e-6)
    h = b.math("MULTIPLY_ADD", b.math("ADD", h, 1.0), started, -1.0)  # before Start: -1, nothing shows
    # the tear stops at its path's end, its head gathered there
    length = b.node("GeometryNodeAttributeStatistic", data_type="FLOAT", domain="POINT")
    b.link(i["Geometry"], length.inputs["Geometry"])
    b.link(arc, length.inputs["Attribute"])
    h = b.math("MINIMUM", h, length.outputs["Max"])
    b.x = 600
    into = b.node("ShaderNodeMapRange", data_type="FLOAT", clamp=True)  # 0 behind the head, 1 at h
    b.link(arc, into.inputs["Value"])
    b.link(b.math("SUBTRACT", h, i["Head"]), into.inputs["From Min"])
    b.link(h, into.inputs["From Max"])
    x = into.outputs["Result"]
    # the bead (core.patterns.tears.bead_profile): (1 + Bead sin^2(pi x)) sqrt(1 - x^2)
    round_ = b.math("SUBTRACT", 1.0, b.math("MULTIPLY", x, x))
    swell = b.math("SINE", b.math("MULTIPLY", x, 3.141592653589793))
    thick = b.math("MULTIPLY", b.math("MULTIPLY_ADD", b.math("MULTIPLY", swell, swell), i["Bead"], 1.0),
                   b.math("SQRT", b.math("MAXIMUM", round_, 0.0)))
    wide = b.math("SQRT", b.math("MAXIMUM", round_, tears.OUTLINE_TIP ** 2))
    b.x = 800
    narrowed = _toward(b, on_skin, CENTRE_ATTR, wide)
    lowered = _toward(b, narrowed, PARTNER_ATTR, thick)
    # a face goes when none of its corners is behind the head (the mean of "behind" over
    # the face is 0): the faces across the head stay, their front lowered onto the bottom
    # (the comparison is made on the points, then averaged over each face)
    behind = b.node("GeometryNodeFieldOnDomain", data_type="FLOAT", domain="POINT")
    b.link(b.math("LESS_THAN", arc, h), behind.inputs[0])
    on_face = b.node("GeometryNodeFieldOnDomain", data_type="FLOAT", domain="FACE")
    b.link(behind.outputs[0], on_face.inputs[0])
    b.x = 1000
    delete = b.node("GeometryNodeDeleteGeometry", domain="FACE")
    b.link(lowered, delete.inputs["Geometry"])
    b.link(b.math("LESS_THAN", on_face.outputs[0], 1e-6), delete.inputs["Selection"])
    gout = b.node("NodeGroupOutput")
    b.link(delete.outputs[0], gout.inputs["Geometry"])


def _named(b, name, data_type):
    n = b.node("GeometryNodeInputNamedAttribute", data_type=data_type)
    n.inputs["Name"].default_value = name
    return n.outputs["Attribute"]


def _bound(b, geometry, skin_object, skin_count):
    """``geometry`` with each point put back on its skin triangle of the face as it is now
    (``core.patterns.tears.bound``); unchanged when the face's vertex count is not ``skin_count``."""
    info = b.node("GeometryNodeObjectInfo", transform_space="RELATIVE")
    b.link(skin_object, info.inputs["Object"])
    corners = []
    for name in SKIN_ATTRS:
        at = b.node("GeometryNodeSampleIndex", data_type="FLOAT_VECTOR", domain="POINT")
        b.link(info.outputs["Geometry"], at.inputs["Geometry"])
        b.link(b.node("GeometryNodeInputPosition").outputs[0], at.inputs["Value"])
        b.link(_named(b, name, "INT"), at.inputs["Index"])
        corners.append(at.outputs[0])
    a, c1, c2 = corners
    normal = b.vmath("NORMALIZE", b.vmath("CROSS_PRODUCT", b.vmath("SUBTRACT", c1, a),
                                          b.vmath("SUBTRACT", c2, a)))
    w = b.separate(_named(b, WEIGHTS_ATTR, "FLOAT_VECTOR"))
    p = b.vmath("SCALE", a, scale=w[0])
    p = b.vmath("ADD", p, b.vmath("SCALE", c1, scale=w[1]))
    p = b.vmath("ADD", p, b.vmath("SCALE", c2, scale=w[2]))
    p = b.vmath("ADD", p, b.vmath("SCALE", normal, scale=_named(b, LIFT_ATTR, "FLOAT")))
    setpos = b.node("GeometryNodeSetPosition")
    b.link(geometry, setpos.inputs["Geometry"])
    b.link(p, setpos.inputs["Position"])
    size = b.node("GeometryNodeAttributeDomainSize", component="MESH")
    b.link(info.outputs["Geometry"], size.inputs["Geometry"])
    same = b.node("FunctionNodeCompare", data_type="INT", operation="EQUAL")
    first, second = (s for s in same.inputs if s.type == "INT")
    b.link(size.outputs["Point Count"], first)
    b.link(skin_count, second)
    switch = b.node("GeometryNodeSwitch", input_type="GEOMETRY")
    b.link(same.outputs["Result"], switch.inputs["Switch"])
    b.link(geometry, switch.inputs["False"])
    b.link(setpos.outputs[0], switch.inputs["True"])
    return switch.outputs[0]


def _toward(b, geometry, index_attr, keep):
    """``geometry`` with each point moved toward the point whose index is its ``index_attr``,
    keeping the ``keep`` fraction of the way (0: onto it)."""
    position = b.node("GeometryNodeInputPosition").outputs[0]
    there = b.node("GeometryNodeSampleIndex", data_type="FLOAT_VECTOR", domain="POINT")
    b.link(geometry, there.inputs["Geometry"])
    b.link(position, there.inputs["Value"])
    b.link(_named(b, index_attr, "INT"), there.inputs["Index"])
    moved = b.vmath("ADD", there.outputs[0], b.vmath("SCALE", b.vmath("SUBTRACT", position, there.outputs[0]),
                                                     scale=keep))
    setpos = b.node("GeometryNodeSetPosition")
    b.link(geometry, setpos.inputs["Geometry"])
    b.link(moved, setpos.inputs["Position"])
    return setpos.outputs[0]


def ensure_group():
    return ensure_group_of(GROUP_NAME, "GeometryNodeTree", VERSION, _build, TearError)


def follow(old, new):
    """Make every shedding tear that follows the skin of ``old`` follow ``new``'s.  Bake for
    Farm hands a face's tears to its stand-in, whose evaluated mesh holds the baked wrinkles
    (a farm without the add-on evaluates the face itself without them), and Free Bake hands
    them back.  Both have the same vertices, so the tears' binding holds."""
    for ob in bpy.data.objects:
        for mod in ob.modifiers:
            if (mod.type == "NODES" and mod.node_group is not None and mod.node_group.name == GROUP_NAME
                    and ob.library is None and get_input(mod, "Skin") == old):
                set_input(mod, "Skin", new)
                # a new input value alone leaves the depsgraph's relations as they were, so the
                # tear could be evaluated before its new skin (a frame behind); assigning the
                # group rebuilds them (measured on bpy 4.5)
                mod.node_group = mod.node_group


# --------------------------------------------------------------------------- the path
def curve_path(face, curve):
    """The points (k, 3, face space) of the curve object ``curve``, from its start.  Raises
    TearError unless it is one stroke."""
    if curve.type != "CURVE" or len(curve.data.splines) != 1:
        raise TearError(f'"{curve.name}" is not a curve of one stroke: draw the tear\'s path as one '
                        "stroke (Curve > Draw, Depth: Surface)")
    return curve_objects.face_space_samples(curve, face)[0]


def selected_faces_path(face, step):
    """The middle line (k, 3, face space) of the face's selected faces and its half width,
    from the end that is higher in the world (tears run down).  Raises TearError."""
    me = face.data
    sel = np.zeros(len(me.polygons), bool)
    me.polygons.foreach_get("select", sel)
    if not sel.any():
        raise TearError(f'No face of "{face.name}" is selected: select the faces the tear runs over in '
                        "Edit Mode, or select a curve drawn on the skin")
    corner_vert, starts, sizes = meshio.read_polygons(me)
    used = np.unique(corner_vert[np.repeat(sel, sizes)])
    try:
        path, half = tears.spine(meshio.read_vectors(me, "position")[used], step)
    except ValueError as exc:
        raise TearError(f"The selected faces do not give a path: {exc}") from None
    up = np.array(face.matrix_world.to_3x3(), np.float64)[2]
    if (path[-1] - path[0]) @ up > 0:  # from the higher end
        path = path[::-1]
    return path, half


# --------------------------------------------------------------------------- the skin
class Skin:
    """The face's evaluated surface now (face space): what the tear is snapped and bound to,
    as the reveal group reads it on every frame."""

    def __init__(self, face, depsgraph):
        self.positions, self.tris = surface.triangles(face.evaluated_get(depsgraph).data)
        if len(self.tris) == 0:
            raise TearError(f'"{face.name}" has no faces for a tear to run on')
        self.normals = mesh.vertex_normals(self.positions, self.tris, len(self.positions))
        self.snapper = surface.Snapper(self.positions, self.tris)

    def snap(self, points):
        """The closest skin points (k, 3), the skin's smooth unit normals there (k, 3), the
        distances (k,) and the triangles they lie on (k,)."""
        tri, bary, dist, loc = self.snapper.nearest(points)
        n = np.einsum("kj,kjc->kc", bary, self.normals[self.tris[np.maximum(tri, 0)]])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        return loc, n, dist, tri


# --------------------------------------------------------------------------- the tear
def build(skin, path, half_width, thickness, gap, roughness=0.3, seed=0, unit=1.0, head=None):
    """The tear (``core.patterns.tears.Tear``, face space) along ``path`` (k, 3, face space) on ``skin``
    (:class:`Skin`): the path snapped to the skin, subdivided, widened into the base strip and
    snapped again; with the skin triangle (k n,) under each base point.  ``unit``: scene units
    per face unit, for the messages.  Raises TearError for a path off the skin or of one
    point."""
    path = np.asarray(path, np.float64).reshape(-1, 3)
    head = 2.0 * half_width if head is None else head
    if len(path) < 2:
        raise TearError(f"The tear's path has {len(path)} point{'s' * (len(path) != 1)}: it needs at "
                        "least two, along the skin")
    if half_width <= 0 or thickness <= 0:
        raise TearError("A tear needs a width and a thickness above 0")
    on, _n, dist, _tri = skin.snap(path)
    far = max(4.0 * half_width, 0.02 * float(np.ptp(skin.positions, axis=0).max()))
    if not np.isfinite(dist).all() or dist.max() > far:
        raise TearError(f"The tear's path runs up to {dist.max() * unit:.3g} scene units off the skin (more "
                        f"than {far * unit:.3g}): draw it on the face (Curve > Draw, Depth: Surface) or "
                        "select the faces it runs over")
    try:
        path = tears.resample(on, 2.0 * half_width / ROWS_PER_WIDTH)
    except ValueError as exc:
        raise TearError(f"The tear's path is too short: {exc}") from None
    if len(path) < 3:
        raise TearError("The tear's path is shorter than its width: draw a longer path")
    path, normals, _d, _tri = skin.snap(path)
    try:
        base, arc, across = tears.strip(path, normals, half_width, ACROSS, head=head)
    except ValueError as exc:
        raise TearError(f"The tear's path cannot carry a tear: {exc}") from None
    base, base_normals, _d, base_tri = skin.snap(base)
    tear = tears.Tear(base, base_normals, across, arc, len(path), half_width, thickness, gap,
                      roughness=roughness, seed=seed, head=head)
    return tear, base_tri


def _mesh(name, tear, unit, skin, base_tri):
    me = bpy.data.meshes.new(name)
    quads = np.asarray(tear.quads, np.int32)
    me.vertices.add(len(tear.positions))
    me.vertices.foreach_set("co", np.ascontiguousarray(tear.positions, np.float32).ravel())
    me.loops.add(quads.size)
    me.loops.foreach_set("vertex_index", quads.ravel())
    me.polygons.add(len(quads))
    me.polygons.foreach_set("loop_start", np.arange(0, quads.size, 4, dtype=np.int32))
    me.update()
    me.attributes.new(ARC_ATTR, "FLOAT", "POINT").data.foreach_set(
        "value", np.ascontiguousarray(tear.arc * unit, np.float32))
    tri = skin.tris[base_tri[tear.partner]]  # every vertex on its base point's triangle
    weights, lift = tears.bind(tear.positions, *(skin.positions[tri[:, k]] for k in range(3)))
    ints = ((PARTNER_ATTR, tear.partner), (CENTRE_ATTR, tear.centre)) + tuple(zip(SKIN_ATTRS, tri.T))
    for name, index in ints:
        att = me.attributes.new(name, "INT", "POINT")
        att.data.foreach_set("value", np.ascontiguousarray(index, np.int32))
    me.attributes.new(WEIGHTS_ATTR, "FLOAT_VECTOR", "POINT").data.foreach_set(
        "vector", np.ascontiguousarray(weights, np.float32).ravel())
    me.attributes.new(LIFT_ATTR, "FLOAT", "POINT").data.foreach_set(
        "value", np.ascontiguousarray(lift, np.float32))
    width = 2.0 * tear.half_width
    surface_uv = np.stack([tear.arc / width, tear.across[tear.partner], np.zeros(len(tear.arc))], 1)
    me.attributes.new(SURFACE_ATTR, "FLOAT_VECTOR", "POINT").data.foreach_set(
        "vector", np.ascontiguousarray(surface_uv, np.float32).ravel())
    me.shade_smooth()
    return me


def add_shedding_tear(context, face, path, half_width, thickness, gap, roughness=0.3, seed=0,
                      duration=None, progress=None, **values):
    """A new shedding tear object along ``path`` (k, 3, face space) on ``face``, bound to its
    evaluated skin as it is now, revealed by the scene time.  Lengths in face units; ``duration``: the
    seconds it takes to run its path (sets Speed); ``values``: the reveal group's inputs by
    name (Shown, Speed, Head, Start, Every), in scene units and seconds; ``progress``: a
    :class:`..progress.Progress`.  Raises TearError."""
    say = progress or (lambda *_a: None)
    unit = face_unit(face)
    skin = Skin(face, context.evaluated_depsgraph_get())
    tear, base_tri = build(skin, path, half_width, thickness, gap, roughness, seed, unit)
    say(0.6, "binding it to the skin")
    me = _mesh(f"{face.name} Tear", tear, unit, skin, base_tri)
    me.materials.append(film_material())
    ob = bpy.data.objects.new(f"{face.name} Tear", me)
    for coll in collections_for(face, context.scene):
        coll.objects.link(ob)
    ob.parent = face  # its mesh is in the face's space
    ob.matrix_parent_inverse = Matrix.Identity(4)
    mod = ob.modifiers.new(MODIFIER_NAME, "NODES")
    mod.node_group = ensure_group()
    set_input(mod, "Skin", face)
    set_input(mod, "Skin Vertices", len(skin.positions))
    values.setdefault("Head", 2.0 * half_width * unit)
    if duration is not None and "Speed" not in values:
        values["Speed"] = tear.length * unit / max(float(duration), 1e-6)
    for name, value in values.items():
        set_input(mod, name, float(value))
    ob["ewrinkles_tear_length"] = tear.length * unit
    return ob
