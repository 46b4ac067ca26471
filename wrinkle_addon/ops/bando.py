# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators of the large-scale wrinkle curves (Bando, Kuratate & Nishita 2002, §6).

A wrinkle curve is a Bézier curve object on the face's surface.  The artist adds one at the
3D cursor, makes one from selected edges or from an annotation stroke, or turns a curve of
their own (drawn with the Curve Draw tool onto the surface) into one; Snap to Face puts its
points back on the skin.  Every operator is undoable and reports bad input clearly.
"""

import bpy
import numpy as np
from bpy.props import FloatProperty, FloatVectorProperty

from ..core.bando import curves as core_curves
from ..glue import curve_objects, faces, pipeline, surface
from ..glue.bando import curves, fine, shading
from ..glue.errors import WrinkleError
from ..glue.progress import Progress
from .common import face_poll, guarded, nothing_left_on_failure, select_only

_face = faces.active


def _snapper(face):
    s = surface.Surface(face, need_uv=False)
    return surface.Snapper(s.rest, s.tris), s


def _snap(snapper, local_points):
    """(k, 3) face-local points moved onto the rest surface."""
    tri, _bary, _dist, location = snapper.nearest(local_points)
    if (tri < 0).any():
        raise WrinkleError("Some points have no closest point on the face")
    return location


def _to_local(face, world):
    m = np.array(face.matrix_world.inverted_safe(), np.float64)
    return np.asarray(world, np.float64) @ m[:3, :3].T + m[:3, 3]


def _finish(context, ob):
    select_only(context, ob)
    pipeline.refresh_all(context)


class WRINKLE_OT_add_curve(bpy.types.Operator):
    """Add a large-scale wrinkle curve on the face at the 3D cursor, running across the face
    (along its X axis) on the surface. Edit its points to place the furrow"""

    bl_idname = "wrinkle.add_curve"
    bl_label = "Add Wrinkle Curve"
    bl_options = {"REGISTER", "UNDO"}

    length: FloatProperty(
        name="Length", description="Length of the new curve, as a fraction of the face's size",
        default=0.25, min=0.01, max=2.0, subtype="FACTOR",
    )

    poll = face_poll(lists=True)

    @guarded
    def execute(self, context):
        face = _face(context)
        snapper, _s = _snapper(face)
        size = float(np.ptp(snapper.rest, axis=0).max())
        centre = _to_local(face, [tuple(context.scene.cursor.location)])[0]
        half = 0.5 * self.length * size
        line = centre + np.linspace(-half, half, 5)[:, None] * np.array([1.0, 0.0, 0.0])
        with nothing_left_on_failure():
            ob = curves.create(context, face, _snap(snapper, line))
        _finish(context, ob)
        return {"FINISHED"}


class WRINKLE_OT_curve_from_edges(bpy.types.Operator):
    """Make a wrinkle curve through the face's selected edges (one connected path, in Edit
    Mode or from the last Edit Mode selection)"""

    bl_idname = "wrinkle.curve_from_edges"
    bl_label = "Wrinkle Curve from Edges"
    bl_options = {"REGISTER", "UNDO"}

    poll = face_poll(object_mode=False, lists=True)

    @guarded
    def execute(self, context):
        face = _face(context)
        was_edit = face.mode == "EDIT"
        if was_edit:
            face.update_from_editmode()
        me = face.data
        sel = np.zeros(len(me.edges), bool)
        me.edges.foreach_get("select", sel)
        if not sel.any():
            raise WrinkleError(f'Select a path of edges on "{face.name}" first (Edit Mode)')
        ev = np.empty(len(me.edges) * 2, np.int32)
        me.edges.foreach_get("vertices", ev)
        try:
            order = core_curves.chain_order(ev.reshape(-1, 2)[sel])
        except ValueError as exc:
            raise WrinkleError(str(exc)) from None
        co = np.empty(len(me.vertices) * 3, np.float64)
        me.vertices.foreach_get("co", co)
        pts = co.reshape(-1, 3)[np.asarray(order)]
        if was_edit:
            bpy.ops.object.mode_set(mode="OBJECT")
        with nothing_left_on_failure():
            ob = curves.create(context, face, pts, name="Wrinkle Curve")
        _finish(context, ob)
        return {"FINISHED"}


class WRINKLE_OT_curve_from_stroke(bpy.types.Operator):
    """Make a wrinkle curve from the last annotation stroke drawn on the face (Annotate tool,
    placement Surface), snapped to the skin"""

    bl_idname = "wrinkle.curve_from_stroke"
    bl_label = "Wrinkle Curve from Stroke"
    bl_options = {"REGISTER", "UNDO"}

    poll = face_poll(lists=True)

    @guarded
    def execute(self, context):
        face = _face(context)
        strokes = curves.annotation_strokes(context.scene)
        if not strokes:
            raise WrinkleError("No annotation stroke: draw one on the face with the Annotate tool "
                               "(placement: Surface) first")
        snapper, _s = _snapper(face)
        pts = _snap(snapper, _to_local(face, strokes[-1]))
        step = max(1, len(pts) // 12)  # a Bézier point every few stroke points
        keep = np.unique(np.r_[np.arange(0, len(pts), step), len(pts) - 1])
        pts = pts[keep]
        if len(pts) < 2 or np.linalg.norm(np.diff(pts, axis=0), axis=1).sum() < 1e-9:
            raise WrinkleError("The annotation stroke is a single point: draw a line")
        with nothing_left_on_failure():
            ob = curves.create(context, face, pts, name="Wrinkle Curve")
        _finish(context, ob)
        return {"FINISHED"}


class WRINKLE_OT_use_curve(bpy.types.Operator):
    """Make the selected curve objects wrinkle curves of the active face"""

    bl_idname = "wrinkle.use_curve"
    bl_label = "Use Selected Curves"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        ob = context.active_object
        if ob is None or ob.type != "MESH":
            cls.poll_message_set("Select the curves, then the face mesh last (active)")
            return False
        if not any(o.type == "CURVE" for o in context.selected_objects):
            cls.poll_message_set("Select one or more curve objects too")
            return False
        return True

    @guarded
    def execute(self, context):
        face = context.active_object
        why = faces.problem(face, lists=True)
        if why:
            raise WrinkleError(why)
        lst = face.ewrinkles_face.wrinkle_curves
        have = {r.object for r in lst.items}
        added = 0
        for ob in context.selected_objects:
            if ob.type != "CURVE" or ob in have:
                continue
            ob.ewrinkles_curve.is_curve = True
            lst.items.add().object = ob
            added += 1
        lst.active = len(lst.items) - 1
        pipeline.refresh_all(context)
        self.report({"INFO"}, f"{added} wrinkle curve(s) added to \"{face.name}\"")
        return {"FINISHED"}


def _active_curve(context):
    face = _face(context)
    if face is None or face.type != "MESH":
        return face, None
    lst = face.ewrinkles_face.wrinkle_curves
    if 0 <= lst.active < len(lst.items):
        return face, lst.items[lst.active].object
    return face, None


class WRINKLE_OT_snap_curve(bpy.types.Operator):
    """Move the active wrinkle curve's points onto the face's surface (their handles move
    with them)"""

    bl_idname = "wrinkle.snap_curve"
    bl_label = "Snap to Face"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        _f, ob = _active_curve(context)
        if ob is None:
            cls.poll_message_set("Select a wrinkle curve in the face's list")
        return ob is not None

    @guarded
    def execute(self, context):
        face, ob = _active_curve(context)
        why = faces.problem(face, local=False)
        if why:
            raise WrinkleError(why)
        snapper, _s = _snapper(face)
        m = np.array(face.matrix_world.inverted_safe() @ ob.matrix_world, np.float64)
        if not abs(np.linalg.det(m[:3, :3])) > 1e-18:  # NaN too
            raise WrinkleError(f'"{ob.name}" is scaled to zero along an axis: give it a scale other '
                               "than 0 before snapping it")
        back = np.linalg.inv(m)
        for spline in ob.data.splines:
            if spline.type != "BEZIER":
                raise WrinkleError(f'"{ob.name}" has a {spline.type.lower()} spline: wrinkle curves '
                                   "snap Bézier splines (Curve > Set Spline Type > Bézier)")
            data = {k: curve_objects.spline_points(spline, k) for k in ("co", "handle_left", "handle_right")}
            local = data["co"] @ m[:3, :3].T + m[:3, 3]
            delta = _snap(snapper, local) - local
            for k, v in data.items():
                moved = (v @ m[:3, :3].T + m[:3, 3]) + delta
                spline.bezier_points.foreach_set(k, (moved @ back[:3, :3].T + back[:3, 3]).ravel())
        ob.data.update_tag()
        pipeline.refresh_all(context)
        return {"FINISHED"}


class WRINKLE_OT_remove_curve(bpy.types.Operator):
    """Remove the active wrinkle curve from the face's list and delete it"""

    bl_idname = "wrinkle.remove_curve"
    bl_label = "Remove Wrinkle Curve"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        face = _face(context)
        ok = face is not None and face.type == "MESH" and len(face.ewrinkles_face.wrinkle_curves.items) > 0
        if not ok:
            cls.poll_message_set("The face has no wrinkle curves")
        return ok

    @guarded
    def execute(self, context):
        face = _face(context)
        lst = face.ewrinkles_face.wrinkle_curves
        i = min(lst.active, len(lst.items) - 1)
        ob = lst.items[i].object
        lst.items.remove(i)
        lst.active = max(0, i - 1)
        if ob is not None and ob.users_scene and not any(
                r.object == ob for o in bpy.data.objects if o.type == "MESH"
                for r in o.ewrinkles_face.wrinkle_curves.items):
            data = ob.data
            bpy.data.objects.remove(ob)
            if data.users == 0:
                bpy.data.curves.remove(data)
        pipeline.refresh_all(context)
        return {"FINISHED"}


class WRINKLE_OT_carve_fine(bpy.types.Operator):
    """Carve the face's fine wrinkles (Bando 2002 §5): furrows along two direction fields into
    two height images, bump-mapped in the face's material and deepened where the skin shrinks
    across them. Takes a few seconds"""

    bl_idname = "wrinkle.carve_fine"
    bl_label = "Carve Fine Wrinkles"
    bl_options = {"REGISTER", "UNDO"}

    poll = face_poll(object_mode=True, uv=True)

    @guarded
    def execute(self, context):
        face = _face(context)
        with Progress(context, self.bl_label, total=fine.STEPS) as progress:
            results = fine.carve(context, face, progress)
        pipeline.refresh_all(context)
        fs = face.ewrinkles_face.fine_wrinkles
        self.report({"INFO"}, f"Carved {fs.furrows} furrows in two {results[0].height.shape[0]} px images "
                              f"({fs.coverage:.0%} of the UV islands covered)")
        return {"FINISHED"}


class WRINKLE_OT_remove_fine(bpy.types.Operator):
    """Remove the face's fine wrinkles from its material (the images stay in the file until
    it is saved without users)"""

    bl_idname = "wrinkle.remove_fine"
    bl_label = "Remove Fine Wrinkles"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        face = _face(context)
        ok = (face is not None and face.type == "MESH"
              and face.ewrinkles_face.fine_wrinkles.image_1 is not None)
        if not ok:
            cls.poll_message_set("The face has no fine wrinkles")
        return ok

    @guarded
    def execute(self, context):
        fine.remove(_face(context))
        pipeline.refresh_all(context)
        return {"FINISHED"}


class WRINKLE_OT_fine_direction(bpy.types.Operator):
    """Give the selected vertices a fine-wrinkle direction (a guide for Directions: From
    Guides). Its length is the magnitude m: longer, deeper, straighter furrows near 1"""

    bl_idname = "wrinkle.fine_direction"
    bl_label = "Set Direction"
    bl_options = {"REGISTER", "UNDO"}

    direction: FloatVectorProperty(
        name="Direction", description="The direction of the furrows, in the face's space (X: across "
        "the face); its length (at most 1) is the magnitude m", default=(0.5, 0.0, 0.0), size=3,
    )

    poll = face_poll(object_mode=False)

    @guarded
    def execute(self, context):
        face = _face(context)
        if face.mode == "EDIT":
            face.update_from_editmode()
        me = face.data
        sel = np.zeros(len(me.vertices), bool)
        me.vertices.foreach_get("select", sel)
        if not sel.any():
            raise WrinkleError(f'Select vertices of "{face.name}" first (Edit Mode)')
        if np.linalg.norm(self.direction) < 1e-9:
            raise WrinkleError("The direction must not be zero")
        edit = face.mode == "EDIT"
        if edit:
            bpy.ops.object.mode_set(mode="OBJECT")
        fine.set_guides(face, np.flatnonzero(sel), np.array(self.direction, np.float64))
        if edit:
            bpy.ops.object.mode_set(mode="EDIT")
        face.ewrinkles_face.fine_wrinkles.field_source = "GUIDES"
        self.report({"INFO"}, f"Direction set on {int(sel.sum())} vertices; Carve Fine Wrinkles to use it")
        return {"FINISHED"}


class WRINKLE_OT_add_pigment(bpy.types.Operator):
    """Add the Skin Pigment node group (Bando 2002 eq. 6) in front of the face material's
    Base Color: paint or animate melanin and hemoglobin (tan, blush, pallor)"""

    bl_idname = "wrinkle.add_pigment"
    bl_label = "Add Skin Pigment"
    bl_options = {"REGISTER", "UNDO"}

    poll = face_poll()

    @guarded
    def execute(self, context):
        face = _face(context)
        mat = face.active_material
        if mat is None:
            mat = bpy.data.materials.new(f"{face.name} Skin")
            face.data.materials.append(mat)
        shading.add_pigment(mat)
        return {"FINISHED"}


classes = (WRINKLE_OT_add_pigment, WRINKLE_OT_carve_fine, WRINKLE_OT_remove_fine, WRINKLE_OT_fine_direction,
           WRINKLE_OT_add_curve, WRINKLE_OT_curve_from_edges, WRINKLE_OT_curve_from_stroke,
           WRINKLE_OT_use_curve, WRINKLE_OT_snap_curve, WRINKLE_OT_remove_curve)
register, unregister = bpy.utils.register_classes_factory(classes)
