# SPDX-License-Identifier: GPL-3.0-or-later
"""Wrinkle-curve objects (Bando, Kuratate & Nishita 2002, §6): Bézier curves drawn on a face
that mark the furrows of large-scale wrinkles.

The glue reads each curve's splines in bulk and samples them in the face's space
(``glue.curve_objects``), snaps the samples to the face's rest surface and turns them into
UV polylines: the paper draws its curves in texture space, we let the artist draw
them on the skin and project them (§6: "the curve is projected into the UV space").
"""

import bpy
import numpy as np

from ...core.bando import curves as core_curves
from .. import curve_objects, faces
from ..errors import WrinkleError

COLLECTION_NAME = "Wrinkle Curves"


class CurveError(WrinkleError):
    """A wrinkle curve that cannot be used; the message is meant for the user."""


def live_curves(face, in_scene=None):
    """The face's enabled wrinkle curves that exist in the scene, in list order."""
    out = []
    for ref in face.ewrinkles_face.wrinkle_curves.items:
        ob = ref.object
        if ob is None or ob.type != "CURVE" or not ob.ewrinkles_curve.is_curve:
            continue
        if in_scene is not None and ob.session_uid not in in_scene:
            continue
        if ob.ewrinkles_curve.enabled:
            out.append(ob)
    return out


def parameters(curve_ob):
    s = curve_ob.ewrinkles_curve
    return (curve_ob.name, s.depth, s.width, s.rest_height, s.taper, s.enabled)


def signature(curve_ob):
    """Everything static about a curve: its matrix, its splines and its parameters."""
    splines = tuple((k, p.tobytes(), None if hl is None else hl.tobytes(),
                     None if hr is None else hr.tobytes(), c)
                    for k, p, hl, hr, c in curve_objects.spline_data(curve_ob))
    return (tuple(map(tuple, curve_ob.matrix_world)), splines) + parameters(curve_ob)


def uv_polylines(curve_ob, face, snapper, corner_uv, tolerance):
    """The curve's splines as UV polylines (a list of (k, 2)), snapped to the rest surface.
    Raises CurveError when a spline lies farther than ``tolerance`` (face units) from the
    skin, outside the 0-1 UV square, or across a UV seam."""
    out = []
    for pts in curve_objects.face_space_samples(curve_ob, face):
        if len(pts) < 2 or not np.isfinite(pts).all():
            raise CurveError(f'The wrinkle curve "{curve_ob.name}" needs at least two points')
        tri, bary, dist, _loc = snapper.nearest(pts)
        far = float(np.max(dist))
        if not np.isfinite(far) or far > tolerance:
            raise CurveError(
                f'The wrinkle curve "{curve_ob.name}" is off the surface of "{face.name}" '
                f"({far * 1000:.1f} mm away in the face's units): draw it with snapping to the face, "
                "or use Snap to Face")
        uv = np.einsum("kc,kcj->kj", bary, corner_uv[tri])
        if not ((uv >= 0.0) & (uv <= 1.0)).all():
            raise CurveError(f'The wrinkle curve "{curve_ob.name}" runs outside the 0-1 UV square of '
                             f'"{face.name}": wrinkles are placed in UV space, so move it or fix the UVs')
        step = np.linalg.norm(np.diff(uv, axis=0), axis=1)
        step3 = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        ratio = step / np.maximum(step3, 1e-12)
        typical = np.median(ratio[step3 > 1e-12]) if (step3 > 1e-12).any() else 0.0
        if typical > 0 and (ratio > 20.0 * typical).any():
            raise CurveError(f'The wrinkle curve "{curve_ob.name}" crosses a UV seam of "{face.name}": '
                             "split it at the seam (one curve per side)")
        out.append(uv)
    return out


def create(context, face, points, name=None):
    """A new wrinkle curve through the (k, 3) ``points`` (k >= 2) in ``face``'s local space,
    with automatic handles, parented to ``face`` (so it follows the face) and added to its
    list."""
    points = np.asarray(points, np.float64).reshape(-1, 3)
    if len(points) < 2 or not np.isfinite(points).all():
        raise CurveError("A wrinkle curve needs at least two distinct, finite points")
    coll = faces.helper_collection(context.scene, COLLECTION_NAME)
    cu = bpy.data.curves.new(name or "Wrinkle Curve", "CURVE")
    cu.dimensions = "3D"
    spline = cu.splines.new("BEZIER")
    spline.bezier_points.add(len(points) - 1)
    spline.bezier_points.foreach_set("co", points.ravel())
    for bp in spline.bezier_points:  # a handful of points
        bp.handle_left_type = bp.handle_right_type = "AUTO"
    ob = bpy.data.objects.new(cu.name, cu)
    coll.objects.link(ob)
    ob.parent = face
    ob.matrix_parent_inverse.identity()  # the curve's space is the face's
    ob.ewrinkles_curve.is_curve = True
    lst = face.ewrinkles_face.wrinkle_curves
    lst.items.add().object = ob
    lst.active = len(lst.items) - 1
    return ob


def annotation_strokes(scene):
    """The points (k, 3) world space of every annotation stroke of ``scene``, oldest first:
    of each layer, the frame shown at the current frame (the last one at or before it)."""
    data = getattr(scene, "annotation", None) or getattr(scene, "grease_pencil", None)  # 5.x, 4.x
    if data is None:
        return []
    out = []
    for layer in data.layers:
        frames = sorted(layer.frames, key=lambda f: f.frame_number)
        shown = [f for f in frames if f.frame_number <= scene.frame_current] or frames[:1]
        if not shown:
            continue
        for stroke in shown[-1].strokes:
            arr = np.empty(len(stroke.points) * 3, np.float32)
            stroke.points.foreach_get("co", arr)
            out.append(arr.reshape(-1, 3).astype(np.float64))
    return out


def refine_need(face):
    """The wrinkle curves' refinement rule for ``glue.refine.refine``: a callable
    ``(rest, edges) -> indices`` of the edges longer than ``core.bando.curves.edge_limits``
    allows around the face's enabled curves, or None when it has none."""
    live = live_curves(face)
    if not live:
        return None
    polylines, widths = [], []
    for ob in live:
        for pts in curve_objects.face_space_samples(ob, face):
            polylines.append(pts)
            widths.append(ob.ewrinkles_curve.width)

    def need(rest, edges):
        limit = core_curves.edge_limits(rest, edges, polylines, widths)
        d = rest[edges[:, 1]] - rest[edges[:, 0]]
        return np.flatnonzero(np.sqrt(np.einsum("ij,ij->i", d, d)) > limit)

    return need
