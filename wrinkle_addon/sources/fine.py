# SPDX-License-Identifier: GPL-3.0-or-later
"""Fine-scale wrinkles (Bando, Kuratate & Nishita 2002, §5 and §7) as a wrinkle source: the
carved height images live in the material (``Fine Wrinkles`` node group); every frame this
source measures the skin's shrinkage across each of the two direction fields (eq. 4) and
writes it as two point attributes, which the group turns into ``M(s)`` (eq. 5)."""

import numpy as np

from ..core import combine
from ..core.bando import fine, mapped
from ..glue import meshio, surface
from ..glue.bando import fine as fine_glue
from ..glue.bando import shading
from ..glue.registry import WrinkleSource
from ..props.bando import WrinkleFineSettings
from ..ui import bando as bando_ui


class _Static:
    __slots__ = ("plan", "problem", "out")

    def __init__(self, plan=None, problem=""):
        self.plan, self.problem = plan, problem
        # the frame's two shrinkages, written in place: the stage writes them right away
        self.out = None if plan is None else np.empty((2, plan.n_verts), np.float32)


class FineSource(WrinkleSource):
    name = fine_glue.SOURCE
    label = "Fine Wrinkles"
    geometric = False  # shading only: runs on any face that has carved fine wrinkles
    properties = (("fine_wrinkles", WrinkleFineSettings),)

    def active(self, face):
        return face.ewrinkles_face.fine_wrinkles.image_1 is not None

    def static_key(self, face, in_scene):
        fs = face.ewrinkles_face.fine_wrinkles
        return (meshio.topology_key(face.data), fs.uv_map, fs.image_1.name, fs.furrows,
                surface.uv_key(face, fs.uv_map or None))

    def unchanged(self, face, static, changes, in_scene):
        # only a new carving (which forgets the cache) or an edit changes it; an edit (of the
        # UVs, say) tags the mesh with every flag, animation only with geometry
        return not changes.get(face.session_uid, (False, False))[0]

    def build(self, face, mesh, in_scene):
        fs = face.ewrinkles_face.fine_wrinkles
        try:
            s = surface.Surface(face, fs.uv_map or None)
            why = surface.layout_problem(face, s)
            if why:
                return _Static(problem=f"Fine wrinkles: {why}")
            m = mapped.mapped_mesh(s.tris, s.uv, len(s.rest))
            fields = fine_glue.read_fields(face, s, m)
            if fields is None:
                return _Static(problem="The fine wrinkles' direction fields are missing: carve them again")
            return _Static(fine.plan(m, mesh.rest, fields[0], fields[1]))
        except surface.SurfaceError as exc:
            return _Static(problem=str(exc))
        except ValueError as exc:  # the core's checks (non-finite fields, say)
            return _Static(problem=f"Fine wrinkles: {exc}. Carve them again")

    def contribute(self, face, static, skin, inputs):
        if static.plan is None:
            return combine.Contribution()
        s1, s2 = fine.shrinkages(static.plan, skin, static.out)
        return combine.Contribution(attributes={shading.S1_ATTR: s1, shading.S2_ATTR: s2})

    def problems(self, face, static):
        return static.problem

    def bake(self, face, scene, frame_start, frame_end, progress):
        n = fine_glue.bake_shrinkage(face, scene, frame_start, frame_end, progress)
        return f"the fine wrinkles' shrinkage of {n} frame(s) as an image sequence"

    def bakes(self, face):
        return self.active(face) and fine_glue.can_bake(face)

    def check(self, face, scene, frame_start, frame_end):
        return fine_glue.bake_problem(face)

    def has_bake(self, face):
        return fine_glue.has_baked_shrinkage(face)

    def free_bake(self, face):
        fine_glue.free_baked_shrinkage(face)

    def draw(self, layout, context, face):
        bando_ui.draw_face_fine(layout, context, face)
