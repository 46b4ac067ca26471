# SPDX-License-Identifier: GPL-3.0-or-later
"""Landmarks and the facial muscle set (Zhang's ten muscles as mirrored pairs, the sphincters
and the Procerus), placed from eight landmark empties (``core.muscles.presets``)."""

import math

import bpy
import numpy as np
from mathutils import Vector

from ...core import zones
from ...core.muscles import landmark_finder, presets
from .. import meshio
from . import objects as muscle_objects

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
    return {key: bpy.data.objects.get(landmark_name(face, key)) for key, _l, _d in presets.LANDMARKS}


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


def build_muscle_set(context, face, landmarks):
    """Create the facial muscle set (``presets.MUSCLES``: mirrored pairs and the midline
    muscles) from face-local landmarks, and put the landmark empties
    there (the no-wrinkle zones are built from them).  Returns the new muscle objects.

    Every end point is projected onto the skin first: creating objects changes the
    depsgraph, and an evaluated object must not be used after that.
    """
    dg = context.evaluated_depsgraph_get()
    mw = face.matrix_world
    placed = []
    for role, side, kind, pts in presets.layout(landmarks):
        local = []
        for x, z in pts:
            loc = project_front(face, dg, x, z)
            if loc is None:
                loc = Vector((x, float(landmarks["glabella"][1]), z))
            local.append(loc)
        if kind == "SHEET":
            # one depth for the sheet's four corners: its fibre is then exactly the layout's
            # (vertical for the Frontalis), so every sheet measures l the same way and their
            # furrows join at the borders instead of stepping by the forehead's curvature
            depth = sum(p.y for p in local) / len(local)
            local = [Vector((p.x, depth, p.z)) for p in local]
        elif kind == "SPHINCTER":
            # in the face's front plane, at the depth of its axes' ends (its centre is in the
            # eye or the mouth, an opening a ray may pass through): its rho and theta are then
            # measured as the face is seen from the front, like the no-wrinkle zones
            depth = (local[1].y + local[2].y) / 2
            local = [Vector((p.x, depth, p.z)) for p in local]
        placed.append((role, side, kind, [mw @ p for p in local]))
    # The Frontalis sheets share one length Ls and one reach behind their attachment line, so eq. 7
    # puts their furrows in phase and a furrow crosses the forehead (presets.layout).
    spans = [((w[2] + w[3]) / 2 - (w[0] + w[1]) / 2).length
             for r, _s, _k, w in placed if r in presets.FOREHEAD]
    sheet_length = presets.SHEET_LENGTH * max(spans) if spans else None
    back_reach = (presets.sheet_reach(landmarks) * muscle_objects.face_scale(face) / sheet_length
                  if sheet_length else 0.0)
    set_landmarks(context, face, {k: landmarks[k] for k, _l, _d in presets.LANDMARKS})
    names = {r: n for r, n, _k in presets.MUSCLES}
    made = []
    for role, side, kind, world in placed:
        params = dict(presets.ROLE_PARAMS.get(role, {}))
        if role in presets.FOREHEAD:
            params["length"] = sheet_length
            params["back_reach"] = max(back_reach, 0.0)
            # its lines are the forehead's: the region ends at the brows (the insertion line),
            # though the pull reaches below them; past it a brow down folded the lateral brow
            own_span = ((world[2] + world[3]) / 2 - (world[0] + world[1]) / 2).length
            params["region_end"] = own_span / sheet_length
            # a slab as deep as the sheet is long: the forehead curves back toward the temples
            # across an outer sheet's width, and a thinner slab faded its furrows out at the
            # seam with its neighbour, so they ended bluntly there
            params["depth"] = sheet_length
        for key in ("angle", "angle_c"):
            if key in params:
                params[key] = math.radians(params[key])
        name = names[role] if side == "C" else f"{names[role]}.{side}"
        ob = muscle_objects.create(context, face, kind, world, name=name, **params)
        ob.ewrinkles_muscle.role = role
        ob.ewrinkles_muscle.side = side
        made.append(ob)
    return made


def set_landmarks(context, face, located):
    """Create or move the landmark empties of ``face`` to the face-local points ``located``
    (a dict by landmark name).  They show the artist what the muscle set and the no-wrinkle
    zones (``core.zones``: eyelids and lips) were built from, and moving one rebuilds both."""
    coll = muscle_objects.muscle_collection(context.scene)
    for key, _label, desc in presets.LANDMARKS:
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
        ob["wrinkle_landmark"] = key
        ob["description"] = desc
        ob.show_name = True


def place_landmarks(context, face):
    """Place (or move back) the landmark empties of ``face`` where the finder puts them.

    Returns ``(method, message)``: the rule that found them (``landmark_finder.RULES``) or
    ``landmark_finder.FALLBACK``, and the message for the artist when the bounding box was
    used.  The found points are on the surface already; only bounding-box guesses are
    projected onto the front of the surface."""
    found, method, message = find_landmarks(face)
    located = {key: Vector(found[key]) for key, _label, _desc in presets.LANDMARKS}
    if method == landmark_finder.FALLBACK:
        dg = context.evaluated_depsgraph_get()
        located = {key: project_front(face, dg, v[0], v[2]) or v for key, v in located.items()}
    set_landmarks(context, face, located)  # after the ray casts: data changes
    return method, message
