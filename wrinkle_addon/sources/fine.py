# SPDX-License-Identifier: GPL-3.0-or-later
"""Fine-scale wrinkles (Bando, Kuratate & Nishita 2002, §5 and §7) as a wrinkle source: the
carved height images live in the material (``Fine Wrinkles`` node group), and Blender
itself measures the skin's shrinkage across each of the two direction fields every frame
(eq. 4), in the face's *Fine Wrinkles* Geometry Nodes modifier (``glue.bando.fine_tree``),
which the group turns into ``M(s)`` (eq. 5).  The source keeps the modifier's stored plan in
step with the mesh (an edit of the mesh or its UVs plans it again) and reports what stops
it; it has nothing to compute per frame, except on a viewport frame that the muscles pull
and the stage writes in place: the tree has not seen that pull, and the source writes the
shrinkage of the pulled skin into the evaluated mesh (NumPy, the tree's reference)."""

import numpy as np

from ..core.bando import fine, mapped
from ..glue import meshio, surface
from ..glue.bando import fine as fine_glue
from ..glue.bando import fine_tree
from ..glue.registry import WrinkleSource
from ..props.bando import WrinkleFineSettings
from ..ui import bando as bando_ui


class _Static:
    __slots__ = ("plan", "problem", "corner_verts", "values", "corners")

    def __init__(self, plan=None, problem="", corner_verts=None, corners=False):
        self.plan, self.problem, self.corner_verts = plan, problem, corner_verts
        self.corners = corners  # whether the modifier stores the corners (fine_tree.wants_corners)
        self.values = None if plan is None else np.empty((2, plan.n_verts), np.float32)


class FineSource(WrinkleSource):
    name = fine_glue.SOURCE
    label = "Fine Wrinkles"
    geometric = False  # shading only: runs on any face that has carved fine wrinkles
    reads_pull = True  # the modifier measures the skin plus the muscles' pull
    per_frame = False  # Blender computes the shrinkage: no Python per frame
    properties = (("fine_wrinkles", WrinkleFineSettings),)

    def active(self, face):
        return face.ewrinkles_face.fine_wrinkles.image_1 is not None

    def static_key(self, face, in_scene):
        fs = face.ewrinkles_face.fine_wrinkles
        return (meshio.topology_key(face.data), fs.uv_map, fs.image_1.name, fs.furrows,
                surface.uv_key(face, fs.uv_map or None), fine_tree.wants_corners(face))

    def unchanged(self, face, static, changes, in_scene):
        # only a new carving (which forgets the cache) or an edit changes it; an edit (of the
        # UVs, say) tags the mesh with every flag, animation only with geometry.  A
        # subdivision added after the modifier may tag it with neither: its domain is checked
        return (not changes.get(face.session_uid, (False, False))[0]
                and static.corners == fine_tree.wants_corners(face))

    def build(self, face, mesh, in_scene):
        fs = face.ewrinkles_face.fine_wrinkles
        corners = fine_tree.sync_corners(face)
        try:
            s = surface.Surface(face, fs.uv_map or None)
            why = surface.layout_problem(face, s)
            if why:
                return _Static(problem=f"Fine wrinkles: {why}")
            m = mapped.mapped_mesh(s.tris, s.uv, len(s.rest))
            fields = fine_glue.read_fields(face, s, m)
            if fields is None:
                return _Static(problem="The fine wrinkles' direction fields are missing: carve them again")
            plan = fine_glue.store_plan(face, s, m, fields)  # written if it differs
            return _Static(plan, corner_verts=meshio.read_polygons(face.data)[0], corners=corners)
        except surface.SurfaceError as exc:
            return _Static(problem=str(exc))
        except ValueError as exc:  # the core's checks (non-finite fields, say)
            return _Static(problem=f"Fine wrinkles: {exc}. Carve them again")

    def write_pulled(self, face, static, ev, pulled):
        if static.plan is None:
            return False
        fine.shrinkages(static.plan, pulled, out=static.values)
        return fine_tree.write_evaluated(ev, static.corner_verts, static.values)

    def problems(self, face, static):
        return static.problem or fine_tree.order_problem(face)

    def exporting(self, face):
        return fine_tree.exporting(face)

    def upgrade(self, face):
        return fine_glue.upgrade(face)

    def draw(self, layout, context, face):
        bando_ui.draw_face_fine(layout, context, face)
