# SPDX-License-Identifier: GPL-3.0-or-later
"""Muscle objects: small wire meshes whose vertices are the muscle's end points.

* Linear muscle: 2 vertices, ``[m_A, m_I]`` (attachment, insertion).
* Sheet muscle: 4 vertices, ``[m_A1, m_A2, m_I2, m_I1]`` drawn as a quad.
* Sphincter muscle: ``[c, c + a, c + b]``, its centre and the ends of its two semi-axes,
  then a loop of ``RING`` vertices that draws its ring (only the first three are read).

The artist moves, rotates and scales the object with the normal tools, or
edits single end points in Edit Mode.  They never render.
"""

import math
import operator
import zlib

import bpy
import numpy as np
from mathutils import Matrix, Vector

from ...core import skin_age
from ...core.muscles import sphincter
from ...core.muscles.muscle import LINEAR, SHEET, SPHINCTER, Muscle
from .. import faces

RING = 24  # vertices of a sphincter's drawn ring


def world_points(ob):
    me = ob.data
    co = np.empty(len(me.vertices) * 3, dtype=np.float64)
    me.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    mw = np.array(ob.matrix_world, dtype=np.float64)
    return co @ mw[:3, :3].T + mw[:3, 3]


def face_scale(face):
    """Mean scale of the face object: converts world lengths to its local space."""
    det = abs(np.linalg.det(np.array(face.matrix_world, dtype=np.float64)[:3, :3]))
    return float(det ** (1.0 / 3.0)) if det > 1e-30 else 1.0


def to_core(muscle_ob, face):
    """The muscle in the face's local space, as a :class:`core.muscles.Muscle`."""
    s = muscle_ob.ewrinkles_muscle
    pts = world_points(muscle_ob)
    inv = np.array(face.matrix_world.inverted_safe(), dtype=np.float64)
    pts = pts @ inv[:3, :3].T + inv[:3, 3]
    scale = face_scale(face)
    fs = face.ewrinkles_face
    age = fs.skin_age
    if s.kind == "SHEET":
        if len(pts) < 4:
            pts = np.zeros((4, 3))
        attachment, insertion = pts[[0, 1]], pts[[3, 2]]
        kind, length, spread, spread_c = SHEET, s.length / scale, s.width / scale, s.width_c / scale
    elif s.kind == "SPHINCTER":
        if len(pts) < 3:
            pts = np.zeros((3, 3))
        attachment, insertion = pts[[0]], pts[[1, 2]]
        kind, length, spread, spread_c = SPHINCTER, s.reach, s.angle, s.angle_c
    else:
        if len(pts) < 2:
            pts = np.zeros((2, 3))
        attachment, insertion = pts[[0]], pts[[1]]
        kind, length, spread, spread_c = LINEAR, s.radius / scale, s.angle, s.angle_c
    return Muscle(
        kind=kind, attachment=attachment, insertion=insertion, length=length, spread=spread,
        spread_c=spread_c, lambda_w=s.lambda_w, n_wrinkles=s.n_wrinkles,
        k0=s.k0 * skin_age.depth_factor(age) / scale,
        alpha=s.alpha, pull=s.pull, depth=s.depth / scale, wrinkles_only=s.wrinkles_only,
        back_reach=s.back_reach, region_end=s.region_end,
        fade_ends=s.fade_ends,
        irregularity=fs.irregularity * skin_age.irregularity_factor(age) * s.irregularity, seed=fs.seed,
    )


def matrix_key(ob):
    """``ob.matrix_world`` as a tuple of floats, exact and comparable with ``==``: 1.2 us
    per call against 6 us for ``np.array(matrix).tobytes()`` (measured, bpy 4.5)."""
    return tuple(map(tuple, ob.matrix_world))


# The float settings that reach the core (``to_core``); contraction is read per frame.
FLOATS = ("radius", "angle", "angle_c", "length", "width", "width_c", "depth", "back_reach", "region_end",
          "reach", "lambda_w", "k0", "alpha", "pull", "irregularity")


# Every number among a muscle's static parameters (the floats, the count, the two switches),
# read in one call: 1.6 us against 2.6 us for the same attributes one by one (bpy 4.5).
_NUMBERS = operator.attrgetter(*FLOATS, "n_wrinkles", "wrinkles_only", "fade_ends")


def parameters(muscle_ob):
    """A muscle's static parameters (everything but its placement and its contraction).

    A NaN setting (a FloatProperty's min and max let NaN through, from a script or a
    file) is given as the string ``"nan"``: NaN is unequal to itself, and the plan would
    be rebuilt on every frame.  One sum finds it (an infinity or two only take the
    longer path)."""
    s = muscle_ob.ewrinkles_muscle
    numbers = _NUMBERS(s)
    total = sum(numbers)
    if total != total:
        numbers = tuple("nan" if v != v else v for v in numbers)
    return (muscle_ob.name, s.kind) + numbers


def face_parameters(face):
    """The face's settings that reach every muscle's static plan (``to_core``): its
    Irregularity, Seed and Skin Age, NaN given as ``"nan"`` (see :func:`parameters`)."""
    s = face.ewrinkles_face
    return tuple("nan" if v != v else v for v in (s.irregularity, s.seed, s.skin_age))


def name_seed(name):
    """A seed from an object's name (CRC32, in an IntProperty's range): two faces set up
    under different names get different irregular wrinkles."""
    return zlib.crc32(name.encode("utf-8")) & 0x7FFFFFFF


def set_up_face(face):
    """Give a face being set up (its wrinkles switched on, its first muscle added) its own
    Seed, from its name, and store its Irregularity, unless they are set already.  The seed
    is stored, so renaming the face later never changes its wrinkles; a stored Irregularity
    tells a file saved before the setting existed (``props.migrate``) from a new face."""
    s = face.ewrinkles_face
    if not s.is_property_set("seed"):
        s.seed = name_seed(face.name)
    if not s.is_property_set("irregularity"):
        s.irregularity = s.irregularity  # the default, stored


def not_finite(muscle_ob):
    """The panel labels of the muscle's float settings that are NaN.  The core replaces
    each one (``core.muscles.muscle.Muscle.sanitized``); the panel says so."""
    s = muscle_ob.ewrinkles_muscle
    props = s.bl_rna.properties
    return [props[k].name for k in FLOATS if not math.isfinite(getattr(s, k))]


def signature(muscle_ob):
    """Everything static about a muscle, to detect when the cached plan is stale: its
    placement (the raw inputs of :func:`world_points`, matrix and local points, rather than
    the points computed) and its :func:`parameters`."""
    me = muscle_ob.data
    co = np.empty(len(me.vertices) * 3, dtype=np.float32)
    me.attributes["position"].data.foreach_get("vector", co)
    return (matrix_key(muscle_ob), co.tobytes()) + parameters(muscle_ob)


def create(context, face, kind, points, name=None, reach=1.3, depth_factor=0.25, **params):
    """Create a muscle object from world-space end points and register it on ``face``.

    ``points`` is ``[attachment, insertion]`` for a linear muscle and
    ``[m_A1, m_A2, m_I2, m_I1]`` for a sheet, ``[c, c + a, c + b]`` for a sphincter.  The
    object's origin is the attachment (the middle of the attachment line for a sheet, the
    centre for a sphincter), so rotating and scaling it behaves naturally.  Unset parameters
    get defaults sized from the muscle itself: the
    area of influence reaches ``reach`` times the attachment-insertion distance,
    and the furrow depth k0 is ``depth_factor`` times the half cycle u.
    """
    pts = [Vector(p) for p in points]
    origin = (pts[0] + pts[1]) / 2 if kind == "SHEET" else pts[0]
    name = name or {"LINEAR": "Muscle", "SHEET": "Sheet Muscle"}.get(kind, "Sphincter Muscle")
    me = bpy.data.meshes.new(name)
    local = [p - origin for p in pts]
    edges = {"LINEAR": [(0, 1)], "SHEET": [(0, 1), (1, 2), (2, 3), (3, 0)]}.get(kind)
    if edges is None:  # a sphincter: its axes, and its ring drawn
        local, edges = sphincter_mesh(local[:3])
    me.from_pydata([tuple(p) for p in local], edges, [])
    ob = bpy.data.objects.new(name, me)
    ob.matrix_world = Matrix.Translation(origin)
    ob.display_type = "WIRE"
    ob.show_in_front = True
    ob.hide_render = True
    faces.helper_collection(context.scene, faces.RIG_COLLECTION).objects.link(ob)
    s = ob.ewrinkles_muscle
    s.is_muscle = True
    s.kind = kind
    for key, value in params.items():
        setattr(s, key, value)
    _size_defaults(s, kind, pts, reach, depth_factor, given=params)
    if face is not None:
        set_up_face(face)
        face.ewrinkles_face.muscles.add().object = ob
        if face.type == "MESH":
            ob.parent = face
            ob.matrix_parent_inverse = face.matrix_world.inverted()
    return ob


def sphincter_mesh(axes):
    """The vertices and edges of a sphincter's object from its local ``[c, c + a, c + b]``:
    those three, joined by its two axes, then its ring of ``RING`` vertices."""
    c, a, b = axes[0], axes[1] - axes[0], axes[2] - axes[0]
    ring = [c + a * math.cos(t) + b * math.sin(t) for t in (2 * math.pi * k / RING for k in range(RING))]
    edges = [(0, 1), (0, 2)] + [(3 + k, 3 + (k + 1) % RING) for k in range(RING)]
    return list(axes) + ring, edges


def _size_defaults(s, kind, pts, reach, depth_factor, given=()):
    """Defaults that give a visible result the first time, scaled to the muscle's size.

    The furrow depth k0 is a fraction of the half cycle u (eq. 6), so wrinkles keep
    their proportions whatever the size of the face.  Parameters in
    ``given`` are left as the caller set them.
    """
    if kind == "LINEAR":
        span = (pts[1] - pts[0]).length
        sizes = {"radius": reach * span}
    elif kind == "SPHINCTER":
        ring = max((pts[1] - pts[0]).length, (pts[2] - pts[0]).length)
        sizes = {"reach": reach, "depth": 2.0 * ring}
    else:
        a_c, i_c = (pts[0] + pts[1]) / 2, (pts[2] + pts[3]) / 2
        span = (i_c - a_c).length
        width = 0.5 * ((pts[1] - pts[0]).length + (pts[2] - pts[3]).length)
        sizes = {"length": reach * span, "width": width, "width_c": width / 6.0,
                 "depth": 0.5 * max(width, span)}
    for key, value in sizes.items():
        if key not in given:
            setattr(s, key, value)
    if kind == "SPHINCTER":
        u = sphincter.half_cycle(pts[1] - pts[0], pts[2] - pts[0], s.angle, max(s.n_wrinkles, 1))
    else:
        extent = s.radius if kind == "LINEAR" else s.length * (1.0 + s.back_reach)
        u = (1.0 - s.lambda_w) * extent / (2.0 * max(s.n_wrinkles, 1))
    if "k0" not in given:
        s.k0 = depth_factor * u


def linear_points_at(location, direction, length):
    d = Vector(direction).normalized()
    return [Vector(location), Vector(location) + d * length]


def sheet_points_at(location, up, across, length, width):
    up, across = Vector(up).normalized(), Vector(across).normalized()
    a_c = Vector(location) + up * length * 0.5
    i_c = Vector(location) - up * length * 0.5
    half = across * width * 0.5
    return [a_c - half, a_c + half, i_c + half, i_c - half]


def live_muscles(face, in_scene=None):
    """The face's muscle objects that still exist in a scene (deleted ones are skipped).

    ``in_scene``: the ``session_uid`` of every object of the face's scene, when the
    caller has them (the per-frame path); ``Object.users_scene`` scans every scene
    and costs ~6 us per muscle."""
    out = []
    for ref in face.ewrinkles_face.muscles:
        ob = ref.object
        if ob is None or ob.type != "MESH" or not ob.ewrinkles_muscle.is_muscle:
            continue
        if not (ob.session_uid in in_scene if in_scene is not None else ob.users_scene):
            continue
        out.append(ob)
    return out
