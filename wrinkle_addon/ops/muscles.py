# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators of the muscle-driven wrinkles (Zhang, Sim & Tan 2005; Waters' muscles).

Every operator that changes data is undoable; bad input is reported with a
clear message and the operator is cancelled, never a traceback.
"""

import math

import bpy
import numpy as np
from bpy.props import (
    BoolProperty,
    EnumProperty,
    FloatProperty,
    FloatVectorProperty,
    IntProperty,
    StringProperty,
)
from bpy_extras import view3d_utils
from mathutils import Vector

from ..core.muscles import presets
from ..glue import drivers, faces, landmarks, pipeline
from ..glue.errors import WrinkleError
from ..glue.muscles import muscle_objects, muscle_set
from .common import face_poll, guarded, select_only

MUSCLE_KINDS = [
    ("LINEAR", "Linear", "A linear muscle: attachment point and insertion point"),
    ("SHEET", "Sheet", "A sheet muscle: attachment line and insertion line"),
    ("SPHINCTER", "Sphincter", "A sphincter muscle: an ellipse round an opening, from its centre "
     "and the ends of its two axes (the first toward its wrinkles)"),
]
NEEDED = {"LINEAR": 2, "SHEET": 4, "SPHINCTER": 3}  # end points of each kind
POINT_NAMES = {"LINEAR": ["attachment", "insertion"],
               "SHEET": ["attachment 1", "attachment 2", "insertion 2", "insertion 1"],
               "SPHINCTER": ["centre", "end of the first axis (toward the wrinkles)",
                             "end of the second axis"]}
_face = faces.active


class WRINKLE_OT_add_muscle(bpy.types.Operator):
    """Add a muscle to the active face at the 3D cursor, or between points you pick on the
    surface (linear: attachment then insertion; sheet: two attachment then two insertion points;
    sphincter: its centre, then the ends of its two axes)"""

    bl_idname = "wrinkle.add_muscle"
    bl_label = "Add Muscle"
    bl_options = {"REGISTER", "UNDO"}

    kind: EnumProperty(name="Type", description="Muscle type", items=MUSCLE_KINDS, default="LINEAR")
    pick: BoolProperty(
        name="Pick on Surface",
        description="Click the end points on the face's surface instead of placing at the 3D cursor",
        default=False, options={"SKIP_SAVE"},
    )
    use_points: BoolProperty(
        name="Use Given Points",
        description="Use the points below (world space) instead of the 3D cursor",
        default=False, options={"SKIP_SAVE"},
    )
    points: FloatVectorProperty(
        name="Points",
        description="World-space end points: attachment, insertion (linear); attachment 1, "
        "attachment 2, insertion 2, insertion 1 (sheet); centre, end of the first axis, end of the "
        "second axis (sphincter)",
        size=12, subtype="NONE", options={"SKIP_SAVE"},
    )
    name: StringProperty(name="Name", description="Name of the new muscle object", default="")

    poll = face_poll()

    def _points(self, context, face):
        if self.use_points:
            p = np.array(self.points, dtype=float).reshape(4, 3)
            return [Vector(v) for v in p[:NEEDED[self.kind]]]
        size = landmarks.surface_scale(face)
        cursor = context.scene.cursor.location
        if self.kind == "LINEAR":
            return muscle_objects.linear_points_at(cursor, (0, 0, -1), 0.25 * size)
        if self.kind == "SPHINCTER":
            return [Vector(cursor), Vector(cursor) + Vector((0.15 * size, 0, 0)),
                    Vector(cursor) + Vector((0, 0, 0.12 * size))]
        return muscle_objects.sheet_points_at(cursor, (0, 0, 1), (1, 0, 0), 0.3 * size, 0.25 * size)

    @guarded
    def execute(self, context):
        face = _face(context)
        pts = self._points(context, face)
        if (pts[1] - pts[0]).length < 1e-9 or any(not math.isfinite(c) for p in pts for c in p):
            self.report({"ERROR"}, "The attachment and insertion must be distinct, finite points"
                        if self.kind != "SPHINCTER" else
                        "The centre and the end of the first axis must be distinct, finite points")
            return {"CANCELLED"}
        if self.kind == "SPHINCTER":
            a, b = pts[1] - pts[0], pts[2] - pts[0]
            if a.cross(b).length < 1e-9 * max(a.length * b.length, 1e-30) or b.length < 1e-9:
                self.report({"ERROR"}, "The sphincter's two axes must not lie on one line")
                return {"CANCELLED"}
        ob = muscle_objects.create(context, face, self.kind, pts, name=self.name or None)
        select_only(context, ob)
        pipeline.refresh_all(context)
        return {"FINISHED"}

    def invoke(self, context, event):
        if not self.pick:
            return self.execute(context)
        if context.area is None or context.area.type != "VIEW_3D":
            self.report({"ERROR"}, "Picking points needs a 3D Viewport")
            return {"CANCELLED"}
        self._face = _face(context).name
        self._picked = []
        self._needed = NEEDED[self.kind]
        context.window_manager.modal_handler_add(self)
        context.workspace.status_text_set(self._hint())
        return {"RUNNING_MODAL"}

    def _hint(self):
        names = POINT_NAMES[self.kind]
        return f"Click the {names[len(self._picked)]} on the face (Esc/right-click cancels)"

    def modal(self, context, event):
        if event.type in {"ESC", "RIGHTMOUSE"}:
            context.workspace.status_text_set(None)
            return {"CANCELLED"}
        if event.type == "LEFTMOUSE" and event.value == "PRESS":
            hit = self._ray_cast(context, event)
            if hit is None:
                self.report({"WARNING"}, "Click on the face's surface")
                return {"RUNNING_MODAL"}
            self._picked.append(hit)
            if len(self._picked) == self._needed:
                context.workspace.status_text_set(None)
                flat = [c for p in self._picked for c in p] + [0.0] * (12 - 3 * self._needed)
                self.points = flat
                self.use_points = True
                return self.execute(context)
            context.workspace.status_text_set(self._hint())
            return {"RUNNING_MODAL"}
        return {"PASS_THROUGH"}

    def _ray_cast(self, context, event):
        region, rv3d = context.region, context.region_data
        coord = (event.mouse_region_x, event.mouse_region_y)
        origin = view3d_utils.region_2d_to_origin_3d(region, rv3d, coord)
        direction = view3d_utils.region_2d_to_vector_3d(region, rv3d, coord)
        face = bpy.data.objects.get(self._face)
        if face is None:
            return None
        dg = context.evaluated_depsgraph_get()
        inv = face.matrix_world.inverted()
        ok, loc, _n, _i = face.evaluated_get(dg).ray_cast(inv @ origin, inv.to_3x3() @ direction)
        return tuple(face.matrix_world @ loc) if ok else None


class WRINKLE_OT_add_muscle_set(bpy.types.Operator):
    """Add the facial muscle set: Zhang's ten muscles as mirrored pairs (Frontalis inner,
    major and outer, Corrugator, Nasalis, Zygomaticus minor and major, Risorius, Depressor
    anguli, Mentalis), the Orbicularis Oculi round each eye, the Orbicularis Oris and the
    Procerus, placed from the landmarks (Place Landmarks first, or they are guessed from the face's size)"""

    bl_idname = "wrinkle.add_muscle_set"
    bl_label = "Add Facial Muscle Set"
    bl_options = {"REGISTER", "UNDO"}

    poll = face_poll()

    @guarded
    def execute(self, context):
        face = _face(context)
        marks = landmarks.landmark_positions(face)
        guessed = marks is None
        if guessed:
            marks = landmarks.guess_landmarks(face)
        existing = {(r.object.ewrinkles_muscle.role, r.object.ewrinkles_muscle.side)
                    for r in face.ewrinkles_face.muscles if r.object is not None}
        if any(role != "CUSTOM" for role, _s in existing):
            self.report({"ERROR"}, "This face already has a facial muscle set; delete it first")
            return {"CANCELLED"}
        made = muscle_set.build_muscle_set(context, face, marks)
        pipeline.refresh_all(context)
        note = " from guessed landmarks: check them with Place Landmarks" if guessed else ""
        self.report({"INFO"}, f"Added {len(made)} muscles{note}")
        return {"FINISHED"}


class WRINKLE_OT_expression(bpy.types.Operator):
    """Key an expression preset (Zhang §3) on the active face's muscles at the current frame"""

    bl_idname = "wrinkle.expression"
    bl_label = "Key Expression"
    bl_options = {"REGISTER", "UNDO"}

    expression: EnumProperty(name="Expression", description="Which expression to key",
                             items=presets.EXPRESSION_ITEMS, default="SURPRISE")
    ramp: IntProperty(
        name="Ramp Frames",
        description="Also key the previous state this many frames earlier, so the expression "
        "builds up (0 keys the current frame only)",
        default=0, min=0, soft_max=100,
    )
    intensity: FloatProperty(name="Intensity", description="Scale of the preset's contractions",
                             default=1.0, min=0.0, max=1.0, subtype="FACTOR")

    poll = face_poll()

    @guarded
    def execute(self, context):
        face = _face(context)
        muscles = muscle_objects.live_muscles(face)
        if not muscles:
            raise WrinkleError("This face has no muscles: add the facial muscle set first")
        table = presets.EXPRESSIONS[self.expression]
        roles = {m.ewrinkles_muscle.role for m in muscles}
        if self.expression != "NEUTRAL" and not roles & set(table):
            raise WrinkleError("None of this face's muscles has a role used by this expression")
        frame = context.scene.frame_current
        for m in muscles:
            s = m.ewrinkles_muscle
            if self.ramp:
                m.keyframe_insert("ewrinkles_muscle.contraction", frame=frame - self.ramp)
            s.contraction = table.get(s.role, 0.0) * self.intensity
            m.keyframe_insert("ewrinkles_muscle.contraction", frame=frame)
        pipeline.refresh_all(context)
        return {"FINISHED"}


class WRINKLE_OT_remove_muscle(bpy.types.Operator):
    """Remove the selected muscle from the face's list, and delete its object"""

    bl_idname = "wrinkle.remove_muscle"
    bl_label = "Remove Muscle"
    bl_options = {"REGISTER", "UNDO"}

    delete_object: BoolProperty(name="Delete Object", description="Also delete the muscle object",
                                default=True)

    @classmethod
    def poll(cls, context):
        face = _face(context)
        if face is None or face.type != "MESH" or not len(face.ewrinkles_face.muscles):
            cls.poll_message_set("The face has no muscles")
            return False
        return True

    @guarded
    def execute(self, context):
        face = _face(context)
        s = face.ewrinkles_face
        i = min(s.active_muscle, len(s.muscles) - 1)
        ob = s.muscles[i].object
        s.muscles.remove(i)
        s.active_muscle = max(0, i - 1)
        if self.delete_object and ob is not None and ob.library is None:
            bpy.data.objects.remove(ob)
        pipeline.refresh_all(context)
        return {"FINISHED"}


class WRINKLE_OT_drive_contraction(bpy.types.Operator):
    """Drive the active muscle's contraction from a shape key of the face, with a simple
    expression that evaluates without trusted Python"""

    bl_idname = "wrinkle.drive_contraction"
    bl_label = "Drive from Shape Key"
    bl_options = {"REGISTER", "UNDO"}

    shape_key: StringProperty(name="Shape Key", description="Name of the face's shape key")
    gain: FloatProperty(name="Gain", description="Contraction per unit of shape key value",
                        default=1.0, soft_min=0.0, soft_max=2.0)

    @classmethod
    def poll(cls, context):
        ob = context.active_object
        if ob is None or not ob.ewrinkles_muscle.is_muscle or ob.parent is None:
            cls.poll_message_set("Select a muscle that belongs to a face")
            return False
        return True

    @guarded
    def execute(self, context):
        muscle = context.active_object
        face = muscle.parent
        keys = face.data.shape_keys if face.type == "MESH" else None
        if keys is None or self.shape_key not in keys.key_blocks:
            raise WrinkleError(f'"{face.name}" has no shape key named "{self.shape_key}"')
        if not math.isfinite(self.gain):
            raise WrinkleError("The gain must be a finite number")
        if muscle.library is not None:
            raise WrinkleError(f'"{muscle.name}" is linked and read-only')
        try:
            drivers.drive(muscle, "ewrinkles_muscle.contraction", "KEY", keys,
                          drivers.shape_key_path(self.shape_key), gain=self.gain)
        except ValueError as exc:
            raise WrinkleError(str(exc)) from None
        return {"FINISHED"}


classes = (
    WRINKLE_OT_add_muscle,
    WRINKLE_OT_add_muscle_set,
    WRINKLE_OT_expression,
    WRINKLE_OT_remove_muscle,
    WRINKLE_OT_drive_contraction,
)
register, unregister = bpy.utils.register_classes_factory(classes)
