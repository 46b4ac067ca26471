# SPDX-License-Identifier: GPL-3.0-or-later
"""Curve objects read in bulk (``foreach_get``) and sampled in a face's space
(``core.bezier``): the wrinkle curves' furrows and the shedding tears' paths."""

import numpy as np

from ..core.bezier import bezier

SAMPLES_PER_SEGMENT = 24


def spline_points(spline, name):
    """A Bézier spline's ``co``, ``handle_left`` or ``handle_right`` (k, 3) float64."""
    pts = spline.bezier_points
    arr = np.empty(len(pts) * 3, np.float64)
    pts.foreach_get(name, arr)
    return arr.reshape(-1, 3)


def spline_data(curve_ob):
    """Per spline: ``(kind, points, handles_left, handles_right, cyclic)`` in the curve's
    own space (handles None for poly splines)."""
    out = []
    for spline in curve_ob.data.splines:
        if spline.type == "BEZIER":
            out.append(("BEZIER", spline_points(spline, "co"), spline_points(spline, "handle_left"),
                        spline_points(spline, "handle_right"), spline.use_cyclic_u))
        else:  # poly and NURBS: their control points as a polyline
            arr = np.empty(len(spline.points) * 4, np.float64)
            spline.points.foreach_get("co", arr)
            out.append(("POLY", arr.reshape(-1, 4)[:, :3], None, None, spline.use_cyclic_u))
    return out


def face_space_samples(curve_ob, face):
    """Each spline of ``curve_ob`` sampled densely, in ``face``'s local space: a list of
    (k, 3) arrays."""
    m = np.array(face.matrix_world.inverted_safe() @ curve_ob.matrix_world, np.float64)
    out = []
    for kind, p, hl, hr, cyclic in spline_data(curve_ob):
        if kind == "BEZIER":
            pts = bezier(p, hl, hr, SAMPLES_PER_SEGMENT, cyclic=cyclic) if len(p) > 1 else p
        else:
            pts = np.vstack([p, p[:1]]) if cyclic and len(p) > 1 else p
        out.append(pts @ m[:3, :3].T + m[:3, 3])
    return out
