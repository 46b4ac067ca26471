# SPDX-License-Identifier: GPL-3.0-or-later
"""The facial muscle set (Zhang's ten muscles as mirrored pairs, the sphincters and the
Procerus), placed from the face's landmarks (``core.muscles.presets``)."""

import math

from mathutils import Vector

from ...core import landmark_finder
from ...core.muscles import presets
from .. import landmarks
from . import muscle_objects


def build_muscle_set(context, face, points):
    """Create the facial muscle set (``presets.MUSCLES``: mirrored pairs and the midline
    muscles) from the face-local landmark ``points``, and put the landmark empties
    there (the no-wrinkle zones are built from them).  Returns the new muscle objects.

    Every end point is projected onto the skin first: creating objects changes the
    depsgraph, and an evaluated object must not be used after that.
    """
    dg = context.evaluated_depsgraph_get()
    mw = face.matrix_world
    placed = []
    for role, side, kind, pts in presets.layout(points):
        local = []
        for x, z in pts:
            loc = landmarks.project_front(face, dg, x, z)
            if loc is None:
                loc = Vector((x, float(points["glabella"][1]), z))
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
    back_reach = (presets.sheet_reach(points) * muscle_objects.face_scale(face) / sheet_length
                  if sheet_length else 0.0)
    landmarks.set_landmarks(context, face, {k: points[k] for k, _l, _d in landmark_finder.LANDMARKS})
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
