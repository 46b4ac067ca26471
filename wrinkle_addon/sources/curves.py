# SPDX-License-Identifier: GPL-3.0-or-later
"""Large-scale wrinkles along curves (Bando, Kuratate & Nishita 2002, §6-7) as a wrinkle
source: each wrinkle curve's profile ``S(l)`` (eq. 2) along the normal, modulated by the
skin's shrinkage across the curve (eq. 4-5), from ``core.bando``."""

import bpy
import numpy as np

from ..core import combine
from ..core.bando import large, mapped
from ..glue import surface
from ..glue.bando import curves
from ..glue.registry import WrinkleSource
from ..props.bando import WrinkleCurveList
from ..ui import bando as bando_ui

# how far a curve sample may lie off the skin: 4 wrinkle widths, at least 2 % of the face
TOLERANCE_WIDTHS, TOLERANCE_FACE = 4.0, 0.02


class _Static:
    __slots__ = ("plan", "footprint", "uids", "n_items", "problem")

    def __init__(self, face, plan=None, uids=frozenset(), problem=""):
        self.plan, self.uids, self.problem = plan, uids, problem
        self.n_items = len(face.ewrinkles_face.wrinkle_curves.items)
        verts = plan.footprint if plan is not None else np.zeros(0, np.int64)
        self.footprint = combine.Footprint(height_verts=verts)


class CurveSource(WrinkleSource):
    name = "curves"
    label = "Wrinkle Curves"
    geometric = True
    properties = (("wrinkle_curves", WrinkleCurveList),)

    def active(self, face):
        return len(face.ewrinkles_face.wrinkle_curves.items) > 0

    def static_key(self, face, in_scene):
        uv = [(lay.name, lay.active_render) for lay in face.data.uv_layers]
        return ((tuple(map(tuple, face.matrix_world)), tuple(uv), face.ewrinkles_face.maps.uv_map,
                 surface.uv_key(face))
                + tuple(curves.signature(c) for c in curves.live_curves(face, in_scene)))

    def unchanged(self, face, static, changes, in_scene):
        # a curve edited, moved or with a parameter set is tagged by Blender; so is the face
        # when moved; a curve added to the list or deleted changes the list or the scene
        return (not changes.get(face.session_uid, (False, False))[0] and static.uids <= in_scene
                and not static.uids & changes.keys()
                and len(face.ewrinkles_face.wrinkle_curves.items) == static.n_items)

    def build(self, face, mesh, in_scene):
        live = curves.live_curves(face, in_scene)
        # every curve of the list, enabled or not: enabling one must be noticed (unchanged)
        uids = frozenset(r.object.session_uid for r in face.ewrinkles_face.wrinkle_curves.items
                         if r.object is not None and r.object.session_uid in in_scene)
        if not live:
            return _Static(face, uids=uids)
        try:
            s = surface.Surface(face)
            why = surface.layout_problem(face, s)
            if why:
                return _Static(face, uids=uids, problem=f"Wrinkle curves: {why}")
            m = mapped.mapped_mesh(s.tris, s.uv, len(s.rest))
            snapper = surface.Snapper(s.rest, s.tris)
            scale = float(np.ptp(s.rest, axis=0).max()) or 1.0
            found, rest_heights = [], []
            for ob in live:
                p = ob.ewrinkles_curve
                tolerance = max(TOLERANCE_FACE * scale, TOLERANCE_WIDTHS * p.width)
                for poly in curves.uv_polylines(ob, face, snapper, s.uv, tolerance):
                    found.append({"polyline_uv": poly, "d": p.depth, "w": p.width, "taper": p.taper})
                    rest_heights.append(p.rest_height)
            plan = large.build(m, s.rest, found, rest_heights)
        except (curves.CurveError, surface.SurfaceError) as exc:
            return _Static(face, uids=uids, problem=str(exc))
        except ValueError as exc:  # the core's checks, written for the artist
            return _Static(face, uids=uids, problem=f"Wrinkle curves: {exc}")
        return _Static(face, plan, uids)

    def contribute(self, face, static, skin, inputs):
        if static.plan is None or len(static.footprint.height_verts) == 0:
            return combine.Contribution()
        return combine.Contribution(height=large.heights(static.plan, skin))

    def map_heights(self, face, mesh, skin, formed):
        static = self.build(face, mesh, {o.session_uid for o in bpy.context.scene.objects})
        if static.problem:
            raise curves.CurveError(static.problem)
        if static.plan is None:
            return None
        out = np.zeros(len(mesh.rest), np.float32)
        if formed:  # every wrinkle at its full height: M(s) = 1
            out[static.footprint.height_verts] = large.heights(static.plan, None, formed=True)
        else:
            out[static.footprint.height_verts] = large.heights(static.plan, skin)
        return out

    def refine_need(self, face, factor, scene):
        return curves.refine_need(face)

    def problems(self, face, static):
        return static.problem

    def draw(self, layout, context, face):
        bando_ui.draw_face_curves(layout, context, face)
