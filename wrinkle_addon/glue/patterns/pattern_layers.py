# SPDX-License-Identifier: GPL-3.0-or-later
"""Pattern-function layers on a face: their frames (Empties), regions and static data for
``core.patterns``, and what the operators do (add at the cursor or the selection, mirror,
apply as a shape key)."""

from types import SimpleNamespace

import bpy
import numpy as np
from mathutils import Matrix, Vector

from ...core.patterns import functions
from .. import faces, landmarks, meshio, surface
from ..errors import WrinkleError

COLLECTION_NAME = "Wrinkle Pattern Frames"
# Per type, the parameters of the paper's shapes that new layers get beyond their defaults
# (a furrow 0.3-2 mm deep on a 25 cm head); the frames' sizes and regions are
# ``core.patterns.functions.FRAMES``, in units of the distance between the eyes.
KIND_DEFAULTS = {"FOREHEAD": {"depth": -0.25}, "DIMPLE": {"depth": 0.14}, "EYE_POUCH": {"flatness": 16.0}}
EYES_PER_SIZE = 0.2  # the distance between the eyes, as a fraction of the face's size
BORDER = 0.4  # the border's width as a fraction of the radius


class PatternError(WrinkleError):
    """Bad input for a pattern layer; the message is meant for the user."""


def stack(face):
    return face.ewrinkles_face.patterns


def active_index(st):
    """The index of the stack's active layer, inside the stack (-1 when it is empty).  RNA
    does not check a stored index when it is read, so a file can hold any integer (-3, 99);
    every reader of ``active`` goes through here."""
    n = len(st.layers)
    return min(max(int(st.active), 0), n - 1) if n else -1


_RNA = {}  # (layer class, property) -> what setting() checks a value against


def _rna(lay, prop):
    """What :func:`setting` needs of a property's definition, read once per registered class
    (about 2 us a read from ``bl_rna``, and a layer's settings are read every frame)."""
    key = (type(lay), prop)
    got = _RNA.get(key)
    if got is None:
        rna = lay.bl_rna.properties[prop]
        enum = frozenset(i.identifier for i in rna.enum_items) if rna.type == "ENUM" else None
        number = rna.type in {"INT", "FLOAT"} and not rna.is_array
        bounds = (rna.default, rna.hard_min, rna.hard_max) if number else None
        got = _RNA[key] = (rna.name, enum, bounds)
    return got


def setting(lay, prop):
    """The layer's setting ``prop``, checked as it is read: RNA does not check stored values
    on read, so a file can hold any number.  An enum value this version does not know reads
    as "" and raises PatternError; a number outside its property's range is clamped into it,
    and NaN gives the property's default."""
    name, enum, bounds = _rna(lay, prop)
    value = getattr(lay, prop)
    if enum is not None and value not in enum:
        raise PatternError(f'The layer "{lay.name}" has a {name} that this version of the add-on '
                           f"does not know (the file was changed or made by another version): pick its "
                           f"{name} again")
    if bounds is not None:
        if value != value:  # NaN
            return bounds[0]
        return type(value)(min(max(value, bounds[1]), bounds[2]))
    return value


def face_size(face):
    rest = meshio.read_vectors(face.data, "position")
    return float(np.ptp(rest, axis=0).max()) if len(rest) else 1.0


def face_measure(face):
    """The face's size (face units) that the defaults are fractions of, and its landmarks
    (face space, or None): with the landmarks placed (the left side's; the right is the left
    mirrored about the glabella), the distance between the eyes over
    ``EYES_PER_SIZE`` (so a head with a neck or shoulders gets the same patterns as one
    without), else the mesh's largest extent."""
    marks = landmarks.landmark_positions(face)
    if marks is not None:
        e = functions.eye_distance(marks)
        if e > 1e-9:
            return e / EYES_PER_SIZE, marks
    return face_size(face), marks


def to_frame(face, frame_ob):
    """The 4x4 matrix from the face's space to the frame's, and the length of one unit of the
    frame's z in the face's units."""
    m = np.array(frame_ob.matrix_world.inverted_safe() @ face.matrix_world, np.float64)
    z = np.array(face.matrix_world.inverted_safe().to_3x3() @ frame_ob.matrix_world.col[2].xyz, np.float64)
    return m, float(np.linalg.norm(z))


def vertex_group_weights(face, name):
    """The weights (N,) of the vertex group ``name`` (0 for vertices not in it).  Raises
    PatternError."""
    vg = face.vertex_groups.get(name) if name else None
    if vg is None:
        raise PatternError(f'"{face.name}" has no vertex group named "{name}"')
    vert, _group, weight = meshio.vertex_group_weights(face.data, {vg.index})
    w = np.zeros(len(face.data.vertices))
    w[vert] = weight
    if not (w > 0).any():
        raise PatternError(f'The vertex group "{name}" of "{face.name}" is empty: assign vertices to it')
    return w


def build_layer(face, mesh, lay):
    """The static data (``core.patterns.functions.Layer``) of the layer settings ``lay`` on the face's
    rest mesh ``mesh``.  Raises PatternError, also for a setting the file holds that this
    version does not know (:func:`setting`)."""
    kind, region, _drive = setting(lay, "kind"), setting(lay, "region"), setting(lay, "drive")
    shape = setting(lay, "shape")
    radius, border = setting(lay, "radius"), setting(lay, "border")
    if lay.frame is None or lay.frame.name not in bpy.context.scene.objects:
        raise PatternError(f'The layer "{lay.name}" has lost its frame (the Empty was deleted): pick '
                           "another Empty as its Frame")
    m, scale = to_frame(face, lay.frame)
    rest = np.asarray(mesh.rest, np.float64)
    local = rest @ m[:3, :3].T + m[:3, 3]
    if region == "RADIUS":
        if radius <= 0.0:
            raise PatternError(f'The layer "{lay.name}" has a radius of 0: it covers nothing')
        centre = np.array(face.matrix_world.inverted_safe() @ lay.frame.matrix_world.translation, np.float64)
        dist = np.linalg.norm(rest - centre, axis=1) * face_unit(face)
        weight = functions.damping_radius(dist, radius, border)
        if not (weight > 0).any():
            raise PatternError(f'The layer "{lay.name}" covers no vertex: move its frame onto the skin or '
                               "make its radius larger")
    else:
        w = vertex_group_weights(face, lay.vertex_group)
        unit = face_unit(face)
        weight = functions.damping_border(functions.border_distance(rest * unit, mesh.edges, w > 0, border),
                                         border, w)
    keep = landmarks.keep_out(face, rest)  # with the landmarks placed: nothing on lids and lips
    if keep is not None:
        weight = weight * keep
    return functions.layer(kind, local, rest, mesh.edges, weight, setting(lay, "fraction"),
                          setting(lay, "seed"), scale, shape)


def refine_need(face, factor, scene):
    """The pattern layers' refinement rule for ``glue.refine.refine``: a callable
    ``(rest, edges) -> indices`` of the edges in a layer's region longer than its
    ``core.patterns.functions.half_cycle`` over ``factor``, or None when the face has no layer to
    show.  Layers that cannot be built (no frame, an empty group) ask for nothing."""
    live = [lay for lay in stack(face).layers if lay.show_viewport or lay.show_render]
    if not live:
        return None

    def need(rest, edges):
        mesh = SimpleNamespace(rest=rest, edges=edges)
        limit = np.full(len(edges), np.inf)
        for lay in live:
            try:
                built = build_layer(face, mesh, lay)
            except PatternError:
                continue
            t, _strength, alpha, beta, gamma = values(face, lay, scene)
            inside = np.zeros(len(rest), bool)
            inside[built.verts] = True
            near = inside[edges[:, 0]] | inside[edges[:, 1]]
            step = functions.half_cycle(built.kind, t, alpha, beta, gamma, built.shape) * built.scale / factor
            limit[near] = np.minimum(limit[near], step)
        d = rest[edges[:, 1]] - rest[edges[:, 0]]
        return np.flatnonzero(np.sqrt(np.einsum("ij,ij->i", d, d)) > limit)

    return need


def face_unit(face):
    """Scene units per face unit (the face's scale; radius and border are scene lengths)."""
    return float(np.cbrt(abs(np.linalg.det(np.array(face.matrix_world.to_3x3())))) or 1.0)


def values(face, lay, scene, skin_compression=None):
    """This frame's ``(t, strength, alpha, beta, gamma)`` of the layer ``lay``; the strength
    driven by a shape key or a muscle here, by the compression in the source.  Raises
    PatternError for a type or drive this version does not know (:func:`setting`)."""
    spec = functions.spec(setting(lay, "kind"), setting(lay, "shape"))
    params = {p.key: setting(lay, p.prop) for p in spec.params}
    t = setting(lay, "time")
    if lay.follow_scene:
        fps = scene.render.fps / (scene.render.fps_base or 1.0)
        t += setting(lay, "speed") * (scene.frame_current + scene.frame_subframe) / max(fps, 1e-6)
    strength = setting(lay, "strength")
    drive = setting(lay, "drive")
    if drive == "SHAPE_KEY":
        keys = face.data.shape_keys
        block = keys.key_blocks.get(lay.drive_shape_key) if keys is not None else None
        strength *= block.value if block is not None else 0.0
    elif drive == "MUSCLE":
        m = lay.drive_muscle
        strength *= m.ewrinkles_muscle.contraction if m is not None else 0.0
    return (float(t), float(strength), float(params.get("alpha", 0.0)), float(params.get("beta", 0.0)),
            float(params.get("gamma", 0.0)))


# --------------------------------------------------------------------------- operators
def surface_frame(face, point, normal, unit, up=(0.0, 0.0, 1.0), flip=False, aspect=1.0):
    """A world matrix at ``point`` (face space) with z along ``normal`` (face space), y along
    ``up`` (face space; the face's up, its z, by default) in the tangent plane, scaled to
    ``unit`` (scene units), its y ``aspect`` times that; ``flip`` mirrors its x (so that a
    pattern on the character's right points the same way from the midline as on its left)."""
    n = Vector(normal).normalized()
    up = Vector(up)
    y = up - up.dot(n) * n
    if y.length < 1e-6:
        y = Vector((0.0, 1.0, 0.0)) - n * n.y
    y.normalize()
    x = y.cross(n)
    rot = Matrix((x, y, n)).transposed().to_4x4()
    w = face.matrix_world
    world_rot = (w.to_3x3().normalized() @ rot.to_3x3()).to_4x4()
    world = Matrix.Translation(w @ Vector(point)) @ world_rot
    return world @ Matrix.Diagonal((-unit if flip else unit, unit * aspect, unit, 1.0))


def nearest_on_skin(face, point_world):
    """The closest point on the face's rest surface to ``point_world`` and the normal of the
    triangle it lies on, both in the face's space."""
    rest, tris = surface.triangles(face.data)
    if len(tris) == 0:
        raise PatternError(f'"{face.name}" has no faces to put a pattern on')
    local = np.array(face.matrix_world.inverted_safe() @ Vector(point_world), np.float64)
    tri, _bary, _dist, loc = surface.Snapper(rest, tris).nearest(local[None])
    a, b, c = rest[tris[tri[0]]]
    return Vector(loc[0].tolist()), Vector(np.cross(b - a, c - a).tolist()).normalized()


def patch_normal(face, point, radius, normal):
    """The skin's mean normal (face space) over the triangles within ``radius`` (face units) of
    ``point``, area-weighted and turned to the side of ``normal``: a frame at a corner of the
    skin (the eye's outer corner, in the fold of the lids) faces the way the patch around it
    does, not the way its one nearest triangle does.  ``normal`` when no triangle is near."""
    rest, tris = surface.triangles(face.data)
    if len(tris) == 0:
        return Vector(normal)
    a, b, c = rest[tris[:, 0]], rest[tris[:, 1]], rest[tris[:, 2]]
    near = np.linalg.norm((a + b + c) / 3.0 - np.asarray(point, np.float64), axis=1) < radius
    n = np.cross(b[near] - a[near], c[near] - a[near]).sum(axis=0)
    if not np.linalg.norm(n) > 1e-12:
        return Vector(normal)
    n = Vector((n / np.linalg.norm(n)).tolist())
    return n if n.dot(Vector(normal)) >= 0.0 else -n


def selected_point(face):
    """The centre and mean normal of the face's selected vertices (face space).  Raises
    PatternError when none is selected."""
    me = face.data
    n = len(me.vertices)
    sel = np.zeros(n, bool)
    me.vertices.foreach_get("select", sel)
    if not sel.any():
        raise PatternError(f'No vertex of "{face.name}" is selected: select some in Edit Mode, or add '
                           "the pattern at the 3D cursor")
    co = meshio.read_vectors(me, "position")[sel].mean(axis=0)
    normals = np.empty(n * 3, np.float32)
    me.vertices.foreach_get("normal", normals)
    normal = normals.reshape(-1, 3)[sel].mean(axis=0)
    if np.linalg.norm(normal) < 1e-9:
        raise PatternError("The selected vertices face every way: select a patch of skin")
    return Vector(co.tolist()), Vector(normal.tolist())


def add_layer(context, face, kind, point, normal):
    """A new layer of ``kind`` with a new frame Empty on the skin at ``point`` (face space),
    its z along the skin's mean normal around it (:func:`patch_normal`, on the side of
    ``normal``); sized for the face (:func:`face_measure`) by ``core.patterns.functions.FRAMES``.
    A type with a face-shaped variant (``core.patterns.functions.VARIANTS``) gets it; with
    the landmarks placed, a frame on the character's right is mirrored (its +x away from the
    midline, as the Mirror operator makes it) and the cheek fold's frame is turned along the
    fold (``core.patterns.functions.places``).  Returns the layer."""
    size, marks = face_measure(face)
    size *= face_unit(face)
    shape = "FACE" if kind in functions.VARIANTS else "PAPER"
    spec = functions.spec(kind, shape)
    f = functions.FRAMES[kind]
    d = dict(KIND_DEFAULTS.get(kind, {}) if shape == "PAPER" else {}, unit=f["unit"] * EYES_PER_SIZE,
             radius=f["radius"] * EYES_PER_SIZE, aspect=f.get("aspect", 1.0))
    up, flip = (0.0, 0.0, 1.0), False
    if marks is not None and kind in functions.LATERAL:
        mid = float(np.asarray(marks["glabella"])[0])
        flip = float(point[0]) < mid
        if kind == "CHEEK" and shape == "FACE":  # along the fold; the right side's mirrored
            up = tuple((functions.places(marks)["CHEEK"][1] * (-1.0 if flip else 1.0, 1.0, 1.0)).tolist())
    normal = patch_normal(face, point, 0.35 * d["radius"] * size / face_unit(face), normal)
    ob = bpy.data.objects.new(f"{face.name} {kind.replace('_', ' ').title()} Frame", None)
    ob.empty_display_type = "ARROWS"
    faces.helper_collection(context.scene, COLLECTION_NAME).objects.link(ob)
    ob.matrix_world = surface_frame(face, point, normal, d["unit"] * size, up, flip, d["aspect"])
    st = stack(face)
    lay = st.layers.add()
    lay.name = kind.replace("_", " ").title()
    lay.kind = kind
    lay.shape = shape
    lay.frame = ob
    for p in spec.params:
        setattr(lay, p.prop, d.get(p.prop, p.default))
    lay.time, lay.follow_scene = spec.time, spec.runs
    lay.radius = d["radius"] * size
    lay.border = BORDER * lay.radius
    st.active = len(st.layers) - 1
    return lay


def layer_settings(lay):
    """Every setting of the layer ``lay`` as a plain dict, checked as :func:`setting` reads
    them.  Raises PatternError."""
    return {p.identifier: setting(lay, p.identifier) for p in lay.bl_rna.properties
            if not p.is_readonly and p.identifier != "rna_type"}


def copy_layer(face, index, frame=None):
    """A copy of the stack's layer ``index`` at the end of the stack (sharing its frame, or
    ``frame``).  Its settings are read into a dict first: ``layers.add()`` can move the
    stack's items in memory, so a layer held across it is left pointing at freed memory."""
    st = stack(face)
    settings = layer_settings(st.layers[index])
    lay = st.layers.add()
    for key, value in settings.items():
        setattr(lay, key, value)
    if frame is not None:
        lay.frame = frame
    st.active = len(st.layers) - 1
    return lay


def mirror_layer(context, face, index):
    """A copy of the stack's layer ``index`` mirrored across the face's own x = 0 plane: a
    new frame Empty that is the mirror image of the old one (its x scale negative), so the
    pattern is mirrored too."""
    src = stack(face).layers[index]
    name, frame = src.name, src.frame
    if frame is None:
        raise PatternError(f'The layer "{name}" has no frame to mirror')
    w = face.matrix_world
    flip = Matrix.Diagonal((-1.0, 1.0, 1.0, 1.0))
    ob = frame.copy()
    ob.name = frame.name + " Mirrored"
    faces.helper_collection(context.scene, COLLECTION_NAME).objects.link(ob)
    ob.matrix_world = w @ flip @ w.inverted_safe() @ frame.matrix_world
    lay = copy_layer(face, index, ob)  # src is not used after this: the add may have moved it
    lay.name = name + " Mirrored"
    if lay.region == "GROUP":
        other = mirror_name(lay.vertex_group)
        if other and face.vertex_groups.get(other) is not None:
            lay.vertex_group = other
    keys = face.data.shape_keys
    other = mirror_name(lay.drive_shape_key)
    if other and keys is not None and keys.key_blocks.get(other) is not None:
        lay.drive_shape_key = other  # eyeSquint_L drives the left layer, eyeSquint_R the right
    return lay


def mirror_name(name):
    """The other side's name of ``name`` (``.L``/``.R``, ``_L``/``_R``, Left/Right), or ""."""
    for a, b in ((".L", ".R"), ("_L", "_R"), ("Left", "Right"), (".l", ".r"), ("_l", "_r")):
        if name.endswith(a):
            return name[: -len(a)] + b
        if name.endswith(b):
            return name[: -len(b)] + a
    return ""


def apply_layer(context, face, index, mesh):
    """Bake the layer ``index`` as it is on this frame into a new shape key at value 1 (its
    heights along the rest normals), then remove it.  Returns the shape key."""
    st = stack(face)
    lay = st.layers[index]
    static = build_layer(face, mesh, lay)
    pl = functions.plan([static])
    h = functions.heights(pl, [values(face, lay, context.scene)])
    me = face.data
    n = len(me.vertices)
    normals = np.empty(n * 3, np.float32)
    me.vertices.foreach_get("normal", normals)
    normals = normals.reshape(-1, 3)
    if me.shape_keys is None:
        face.shape_key_add(name="Basis", from_mix=False)
    key = face.shape_key_add(name=f"Pattern {lay.name}", from_mix=False)
    co = np.empty(n * 3, np.float32)
    key.data.foreach_get("co", co)
    co = co.reshape(-1, 3)
    co[pl.footprint] += (h[:, None] * normals[pl.footprint]).astype(np.float32)
    key.data.foreach_set("co", co.ravel())
    key.value = 1.0
    st.layers.remove(index)
    st.active = max(0, active_index(st))
    return key
