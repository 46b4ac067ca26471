# SPDX-License-Identifier: GPL-3.0-or-later
"""Landmarks and the facial muscle set: Zhang's ten muscles as mirrored pairs, placed from
eight landmark empties (``core.muscles.presets``)."""

import math

import bpy
import numpy as np
from mathutils import Vector

from ...core.muscles import presets
from . import objects as muscle_objects

LANDMARK_PREFIX = "WL "


def surface_scale(face):
    dims = face.dimensions
    return max(max(dims), 1e-6)


def guess_landmarks(face):
    """Face-local landmark guesses from the face's bounding box."""
    bb = np.array([tuple(v) for v in face.bound_box])
    return presets.estimate_landmarks(bb.min(axis=0), bb.max(axis=0))


def project_front(face, dg, x, z):
    """Project a face-local (x, z) onto the front of the surface by a ray along +Y."""
    ev = face.evaluated_get(dg)
    lo = min(v[1] for v in face.bound_box) - 1.0
    ok, loc, _n, _i = ev.ray_cast(Vector((x, lo, z)), Vector((0.0, 1.0, 0.0)))
    return loc if ok else None


def landmark_positions(face):
    """Face-local landmark positions from the landmark empties, or ``None`` if any is missing."""
    out = {}
    inv = face.matrix_world.inverted()
    for key, _label, _desc in presets.LANDMARKS:
        ob = bpy.data.objects.get(f"{LANDMARK_PREFIX}{face.name} {key}")
        if ob is None:
            return None
        out[key] = np.array(inv @ ob.matrix_world.translation)
    return out


def build_muscle_set(context, face, landmarks):
    """Create the ten mirrored muscles from face-local landmarks.  Returns the new objects.

    Every end point is projected onto the skin first: creating objects changes the
    depsgraph, and an evaluated object must not be used after that.
    """
    dg = context.evaluated_depsgraph_get()
    mw = face.matrix_world
    placed = []
    for role, side, kind, pts in presets.layout(landmarks):
        world = []
        for x, z in pts:
            loc = project_front(face, dg, x, z)
            if loc is None:
                loc = Vector((x, float(landmarks["glabella"][1]), z))
            world.append(mw @ loc)
        placed.append((role, side, kind, world))
    # The sheets of one side share one length Ls, so eq. 7 puts their furrows in phase
    # where they overlap instead of beating against each other.
    spans = [((w[2] + w[3]) / 2 - (w[0] + w[1]) / 2).length for _r, _s, k, w in placed if k == "SHEET"]
    sheet_length = 1.3 * max(spans) if spans else None
    names = {r: n for r, n, _k in presets.MUSCLES}
    made = []
    for role, side, kind, world in placed:
        params = dict(presets.ROLE_PARAMS.get(role, {}))
        if kind == "SHEET":
            params["length"] = sheet_length
        if "angle" in params:
            params["angle"] = math.radians(params["angle"])
        ob = muscle_objects.create(context, face, kind, world, name=f"{names[role]}.{side}", **params)
        ob.ewrinkles_muscle.role = role
        ob.ewrinkles_muscle.side = side
        made.append(ob)
    return made


def place_landmarks(context, face):
    """Place (or move back) the landmark empties of ``face`` at guesses from its size,
    projected onto the front of its surface."""
    guess = guess_landmarks(face)
    dg = context.evaluated_depsgraph_get()
    located = {key: project_front(face, dg, guess[key][0], guess[key][2]) or Vector(guess[key])
               for key, _label, _desc in presets.LANDMARKS}  # before any data changes
    coll = muscle_objects.muscle_collection(context.scene)
    for key, _label, desc in presets.LANDMARKS:
        name = f"{LANDMARK_PREFIX}{face.name} {key}"
        ob = bpy.data.objects.get(name)
        if ob is None:
            ob = bpy.data.objects.new(name, None)
            ob.empty_display_type = "SPHERE"
            coll.objects.link(ob)
        ob.empty_display_size = 0.01 * surface_scale(face)
        ob.parent = face
        ob.matrix_parent_inverse.identity()
        ob.location = located[key]
        ob["wrinkle_landmark"] = key
        ob["description"] = desc
        ob.show_name = True
