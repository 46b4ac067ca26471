# SPDX-License-Identifier: GPL-3.0-or-later
"""The face's landmark empties (``core.landmark_finder.LANDMARKS``): found on the mesh,
placed, read back.  Every method places its work from them: the muscle set
(``glue.muscles.muscle_set``), the no-wrinkle zones on the eyelids and lips (``keep_out``),
the pattern layers' frames, the skin's regions."""

import bpy
import numpy as np
from mathutils import Vector

from ..core import landmark_finder, zones
from . import faces, meshio

LANDMARK_PREFIX = "WL "


def surface_scale(face):
    dims = face.dimensions
    return max(max(dims), 1e-6)


def find_landmarks(face):
    """``(landmarks, method, message)`` of ``landmark_finder.find_landmarks`` on the face's
    rest mesh (its own positions, polygons and shape keys; face-local)."""
    me = face.data
    rest = meshio.read_vectors(me, "position")
    polys = meshio.read_polygons(me)
    return landmark_finder.find_landmarks(rest, polys, meshio.shape_keys(me, len(rest)))


def guess_landmarks(face):
    """Face-local landmarks found on the face (``find_landmarks``), without the method."""
    return find_landmarks(face)[0]


def project_front(face, dg, x, z):
    """Project a face-local (x, z) onto the front of the surface by a ray along +Y."""
    ev = face.evaluated_get(dg)
    lo = min(v[1] for v in face.bound_box) - 1.0
    ok, loc, _n, _i = ev.ray_cast(Vector((x, lo, z)), Vector((0.0, 1.0, 0.0)))
    return loc if ok else None


def landmark_name(face, key):
    """The name of ``face``'s landmark empty ``key``."""
    return f"{LANDMARK_PREFIX}{face.name} {key}"


def _empties(face):
    """{key: the landmark empty of ``face``, or None}, for every landmark."""
    return {key: bpy.data.objects.get(landmark_name(face, key)) for key, _l, _d in landmark_finder.LANDMARKS}


def landmark_positions(face):
    """Face-local landmark positions from the landmark empties, or ``None`` if any is missing."""
    empties = _empties(face)
    if any(ob is None for ob in empties.values()):
        return None
    inv = face.matrix_world.inverted()
    return {key: np.array(inv @ ob.matrix_world.translation) for key, ob in empties.items()}


def keep_out(face, rest):
    """Per-vertex weight (N,) that keeps wrinkles and pull off the eyelids and the lips
    (``core.zones.keep_out``), from the face's landmark empties; None when they are not all
    placed.  The frame stage and the wrinkle-map bakes use the same one."""
    points = landmark_positions(face)
    return None if points is None else zones.keep_out(rest, points)


def landmark_objects(face):
    """The landmark empties of ``face`` that exist."""
    return [ob for ob in _empties(face).values() if ob is not None]


def set_landmarks(context, face, located):
    """Create or move the landmark empties of ``face`` to the face-local points ``located``
    (a dict by landmark name).  They show the artist what the muscle set and the no-wrinkle
    zones (``core.zones``: eyelids and lips) were built from, and moving one rebuilds both."""
    coll = faces.helper_collection(context.scene, faces.RIG_COLLECTION)
    for key, _label, desc in landmark_finder.LANDMARKS:
        name = landmark_name(face, key)
        ob = bpy.data.objects.get(name)
        if ob is None:
            ob = bpy.data.objects.new(name, None)
            ob.empty_display_type = "SPHERE"
            coll.objects.link(ob)
        ob.empty_display_size = 0.01 * surface_scale(face)
        ob.parent = face
        ob.matrix_parent_inverse.identity()
        ob.location = Vector(located[key])
        ob["ewrinkles_landmark"] = key
        ob["ewrinkles_description"] = desc
        ob.show_name = True


def place_landmarks(context, face):
    """Place (or move back) the landmark empties of ``face`` where the finder puts them.

    Returns ``(method, message)``: the rule that found them (``landmark_finder.RULES``) or
    ``landmark_finder.FALLBACK``, and the message for the artist when the bounding box was
    used.  The found points are on the surface already; only bounding-box guesses are
    projected onto the front of the surface."""
    found, method, message = find_landmarks(face)
    located = {key: Vector(found[key]) for key, _label, _desc in landmark_finder.LANDMARKS}
    if method == landmark_finder.FALLBACK:
        dg = context.evaluated_depsgraph_get()
        located = {key: project_front(face, dg, v[0], v[2]) or v for key, v in located.items()}
    set_landmarks(context, face, located)  # after the ray casts: data changes
    return method, message
