# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators: thin wrappers that check input, call one function and report.

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

from . import bake, muscle_objects, pipeline, refine, stage, wrinklemaps
from .core import presets

MUSCLE_KINDS = [
    ("LINEAR", "Linear", "A linear muscle: attachment point and insertion point"),
    ("SHEET", "Sheet", "A sheet muscle: attachment line and insertion line"),
]
EXPRESSIONS = [
    ("SURPRISE", "Surprise", "Frontalis inner, major and outer contract: raised brows, forehead wrinkles"),
    ("FROWN", "Frowning", "Corrugators contract: lowered brows, vertical wrinkles between them"),
    ("FEAR", "Fear", "Frontalis inner and corrugators contract"),
    ("NEUTRAL", "Neutral", "Every muscle relaxed"),
]
LANDMARK_PREFIX = "WL "


_face = muscle_objects.active_face


def _face_poll(cls, context):
    why = pipeline.check_face(_face(context))
    if why:
        cls.poll_message_set(why)
        return False
    return True


def _wm_progress(context, total):
    wm = context.window_manager
    wm.progress_begin(0, max(total, 1))
    return wm


class WRINKLE_OT_enable(bpy.types.Operator):
    """Switch animated wrinkles on for the active face: adds the Wrinkles output modifier"""

    bl_idname = "wrinkle.enable"
    bl_label = "Enable Wrinkles"
    bl_options = {"REGISTER", "UNDO"}

    poll = classmethod(_face_poll)

    def execute(self, context):
        ob = _face(context)
        try:
            pipeline.enable(ob, context.scene)
        except stage.StageError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        ob.wrinkles.enabled = True
        self.report({"INFO"}, "Wrinkles on. Render > Lock Interface was switched on so that "
                              "renders started from the interface show the right wrinkles")
        return {"FINISHED"}


class WRINKLE_OT_disable(bpy.types.Operator):
    """Switch wrinkles off for the active face and remove the output stage; the mesh is
    restored exactly, muscles and settings are kept"""

    bl_idname = "wrinkle.disable"
    bl_label = "Disable Wrinkles"
    bl_options = {"REGISTER", "UNDO"}

    remove_muscles: BoolProperty(
        name="Delete Muscles",
        description="Also delete this face's muscle objects and forget its settings",
        default=False,
    )

    @classmethod
    def poll(cls, context):
        ob = _face(context)
        if ob is None or ob.type != "MESH":
            cls.poll_message_set("Select a face mesh")
            return False
        return True

    def execute(self, context):
        ob = _face(context)
        if ob.library is not None or ob.data.library is not None:
            self.report({"ERROR"}, f'"{ob.name}" is linked and read-only')
            return {"CANCELLED"}
        ob.wrinkles.enabled = False
        pipeline.disable(ob)
        if self.remove_muscles:
            for m in [r.object for r in ob.wrinkles.muscles if r.object is not None]:
                bpy.data.objects.remove(m)
            ob.wrinkles.muscles.clear()
        return {"FINISHED"}


def _surface_scale(face):
    dims = face.dimensions
    return max(max(dims), 1e-6)


class WRINKLE_OT_add_muscle(bpy.types.Operator):
    """Add a muscle to the active face at the 3D cursor, or between points you pick on the
    surface (linear: attachment then insertion; sheet: two attachment then two insertion points)"""

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
        description="World-space end points: attachment, insertion (linear) or attachment 1, "
        "attachment 2, insertion 2, insertion 1 (sheet)",
        size=12, subtype="NONE", options={"SKIP_SAVE"},
    )
    name: StringProperty(name="Name", description="Name of the new muscle object", default="")

    poll = classmethod(_face_poll)

    def _points(self, context, face):
        if self.use_points:
            p = np.array(self.points, dtype=float).reshape(4, 3)
            return [Vector(v) for v in (p[:2] if self.kind == "LINEAR" else p)]
        size = _surface_scale(face)
        cursor = context.scene.cursor.location
        if self.kind == "LINEAR":
            return muscle_objects.linear_points_at(cursor, (0, 0, -1), 0.25 * size)
        return muscle_objects.sheet_points_at(cursor, (0, 0, 1), (1, 0, 0), 0.3 * size, 0.25 * size)

    def execute(self, context):
        face = _face(context)
        pts = self._points(context, face)
        if (pts[1] - pts[0]).length < 1e-9 or any(not math.isfinite(c) for p in pts for c in p):
            self.report({"ERROR"}, "The attachment and insertion must be distinct, finite points")
            return {"CANCELLED"}
        ob = muscle_objects.create(context, face, self.kind, pts, name=self.name or None)
        for o in context.selected_objects:
            o.select_set(False)
        ob.select_set(True)
        context.view_layer.objects.active = ob
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
        self._needed = 2 if self.kind == "LINEAR" else 4
        context.window_manager.modal_handler_add(self)
        context.workspace.status_text_set(self._hint())
        return {"RUNNING_MODAL"}

    def _hint(self):
        names = (["attachment", "insertion"] if self.kind == "LINEAR"
                 else ["attachment 1", "attachment 2", "insertion 2", "insertion 1"])
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


def _guess_landmarks(face):
    """Face-local landmark guesses from the face's bounding box."""
    bb = np.array([tuple(v) for v in face.bound_box])
    return presets.estimate_landmarks(bb.min(axis=0), bb.max(axis=0))


def _project_front(face, dg, x, z):
    """Project a face-local (x, z) onto the front of the surface by a ray along +Y."""
    ev = face.evaluated_get(dg)
    lo = min(v[1] for v in face.bound_box) - 1.0
    ok, loc, _n, _i = ev.ray_cast(Vector((x, lo, z)), Vector((0.0, 1.0, 0.0)))
    return loc if ok else None


class WRINKLE_OT_add_landmarks(bpy.types.Operator):
    """Place the landmarks the facial muscle set is built from, guessed from the face's size.
    Move them onto the right features, then run Add Facial Muscle Set"""

    bl_idname = "wrinkle.add_landmarks"
    bl_label = "Place Landmarks"
    bl_options = {"REGISTER", "UNDO"}

    poll = classmethod(_face_poll)

    def execute(self, context):
        face = _face(context)
        guess = _guess_landmarks(face)
        dg = context.evaluated_depsgraph_get()
        located = {key: _project_front(face, dg, guess[key][0], guess[key][2]) or Vector(guess[key])
                   for key, _label, _desc in presets.LANDMARKS}  # before any data changes
        coll = muscle_objects.muscle_collection(context.scene)
        for key, _label, desc in presets.LANDMARKS:
            name = f"{LANDMARK_PREFIX}{face.name} {key}"
            ob = bpy.data.objects.get(name)
            if ob is None:
                ob = bpy.data.objects.new(name, None)
                ob.empty_display_type = "SPHERE"
                coll.objects.link(ob)
            ob.empty_display_size = 0.01 * _surface_scale(face)
            ob.parent = face
            ob.matrix_parent_inverse.identity()
            ob.location = located[key]
            ob["wrinkle_landmark"] = key
            ob["description"] = desc
            ob.show_name = True
        self.report({"INFO"}, "Move the landmarks (WL ...) onto the features, then Add Facial Muscle Set")
        return {"FINISHED"}


def _landmark_positions(face):
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
            loc = _project_front(face, dg, x, z)
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
        ob.wrinkle_muscle.role = role
        ob.wrinkle_muscle.side = side
        made.append(ob)
    return made


class WRINKLE_OT_add_muscle_set(bpy.types.Operator):
    """Add Zhang's ten facial muscles as mirrored pairs (Frontalis inner, major and outer,
    Corrugator, Nasalis, Zygomaticus minor and major, Risorius, Depressor anguli, Mentalis),
    placed from the landmarks (Place Landmarks first, or they are guessed from the face's size)"""

    bl_idname = "wrinkle.add_muscle_set"
    bl_label = "Add Facial Muscle Set"
    bl_options = {"REGISTER", "UNDO"}

    poll = classmethod(_face_poll)

    def execute(self, context):
        face = _face(context)
        landmarks = _landmark_positions(face)
        guessed = landmarks is None
        if guessed:
            landmarks = _guess_landmarks(face)
        existing = {(r.object.wrinkle_muscle.role, r.object.wrinkle_muscle.side)
                    for r in face.wrinkles.muscles if r.object is not None}
        if any(role != "CUSTOM" for role, _s in existing):
            self.report({"ERROR"}, "This face already has a facial muscle set; delete it first")
            return {"CANCELLED"}
        made = build_muscle_set(context, face, landmarks)
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
                             items=EXPRESSIONS, default="SURPRISE")
    ramp: IntProperty(
        name="Ramp Frames",
        description="Also key the previous state this many frames earlier, so the expression "
        "builds up (0 keys the current frame only)",
        default=0, min=0, soft_max=100,
    )
    intensity: FloatProperty(name="Intensity", description="Scale of the preset's contractions",
                             default=1.0, min=0.0, max=1.0, subtype="FACTOR")

    poll = classmethod(_face_poll)

    def execute(self, context):
        face = _face(context)
        muscles = muscle_objects.live_muscles(face)
        if not muscles:
            self.report({"ERROR"}, "This face has no muscles: add the facial muscle set first")
            return {"CANCELLED"}
        table = presets.EXPRESSIONS[self.expression]
        roles = {m.wrinkle_muscle.role for m in muscles}
        if self.expression != "NEUTRAL" and not roles & set(table):
            self.report({"ERROR"}, "None of this face's muscles has a role used by this expression")
            return {"CANCELLED"}
        frame = context.scene.frame_current
        for m in muscles:
            s = m.wrinkle_muscle
            if self.ramp:
                m.keyframe_insert("wrinkle_muscle.contraction", frame=frame - self.ramp)
            s.contraction = table.get(s.role, 0.0) * self.intensity
            m.keyframe_insert("wrinkle_muscle.contraction", frame=frame)
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
        if face is None or face.type != "MESH" or not len(face.wrinkles.muscles):
            cls.poll_message_set("The face has no muscles")
            return False
        return True

    def execute(self, context):
        face = _face(context)
        s = face.wrinkles
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
        if ob is None or not ob.wrinkle_muscle.is_muscle or ob.parent is None:
            cls.poll_message_set("Select a muscle that belongs to a face")
            return False
        return True

    def execute(self, context):
        muscle = context.active_object
        face = muscle.parent
        keys = face.data.shape_keys if face.type == "MESH" else None
        if keys is None or self.shape_key not in keys.key_blocks:
            self.report({"ERROR"}, f'"{face.name}" has no shape key named "{self.shape_key}"')
            return {"CANCELLED"}
        if not math.isfinite(self.gain):
            self.report({"ERROR"}, "The gain must be a finite number")
            return {"CANCELLED"}
        fc = muscle.driver_add("wrinkle_muscle.contraction")
        drv = fc.driver
        drv.type = "SCRIPTED"
        for v in list(drv.variables):
            drv.variables.remove(v)
        var = drv.variables.new()
        var.name = "key"
        var.type = "SINGLE_PROP"
        var.targets[0].id_type = "KEY"
        var.targets[0].id = keys
        var.targets[0].data_path = f'key_blocks["{self.shape_key}"].value'
        drv.expression = f"key*{self.gain:.6g}"
        return {"FINISHED"}


class WRINKLE_OT_refine(bpy.types.Operator):
    """Subdivide the faces in the wrinkling regions until every half wrinkle cycle spans at
    least the given number of edges (keeps UVs, shape keys, vertex groups and materials)"""

    bl_idname = "wrinkle.refine"
    bl_label = "Refine Wrinkling Regions"
    bl_options = {"REGISTER", "UNDO"}

    edges_per_half_cycle: FloatProperty(
        name="Edges per Half Cycle",
        description="Minimum number of edge lengths across half a wrinkle (Zhang's u)",
        default=4.0, min=1.0, soft_max=8.0,
    )
    max_vertices: IntProperty(
        name="Vertex Limit",
        description="Stop before the mesh would grow beyond this many vertices",
        default=1_000_000, min=1000,
    )

    poll = classmethod(_face_poll)

    def execute(self, context):
        face = _face(context)
        if face.mode == "EDIT":
            self.report({"ERROR"}, "Leave Edit Mode first")
            return {"CANCELLED"}
        muscles = muscle_objects.live_muscles(face)
        if not muscles:
            self.report({"ERROR"}, "This face has no muscles, so there is no wrinkling region to refine")
            return {"CANCELLED"}
        before = len(face.data.vertices)
        wm = _wm_progress(context, refine.MAX_PASSES)
        try:
            result = refine.refine(face, muscles, self.edges_per_half_cycle, self.max_vertices,
                                   progress=lambda i: (wm.progress_update(i), print(f"refine pass {i}")))
        finally:
            wm.progress_end()
        after = len(face.data.vertices)
        if result.message:
            self.report({"WARNING"}, result.message)
        self.report({"INFO"}, f"Refined {before} -> {after} vertices in {result.passes} passes")
        pipeline.refresh_all(context)
        return {"FINISHED"}


class WRINKLE_OT_bake(bpy.types.Operator):
    """Bake the animated, wrinkled face to an Alembic cache next to the .blend file and render
    a stand-in from it, so the file renders on a farm with no add-on installed"""

    bl_idname = "wrinkle.bake"
    bl_label = "Bake for Farm"
    bl_options = {"REGISTER", "UNDO"}

    filepath: StringProperty(name="File", description="Alembic file to write (// is the .blend's folder)",
                             subtype="FILE_PATH", default="")
    frame_start: IntProperty(name="Start", description="First frame to bake (default: the scene's)",
                             default=-1)
    frame_end: IntProperty(name="End", description="Last frame to bake (default: the scene's)",
                           default=-1)

    poll = classmethod(_face_poll)

    def execute(self, context):
        face = _face(context)
        scene = context.scene
        start = scene.frame_start if self.frame_start < 0 else self.frame_start
        end = scene.frame_end if self.frame_end < 0 else self.frame_end
        geometry = stage.find_modifier(face) is not None
        maps = face.wrinkles.maps.weights_group is not None
        if not geometry and not maps:
            self.report({"ERROR"}, f'"{face.name}" has neither wrinkles nor wrinkle maps to bake')
            return {"CANCELLED"}
        path = self.filepath or bake.default_path(face)
        n = end - start + 1
        wm = _wm_progress(context, 2 * n)
        done = []
        try:
            if geometry:
                print(f"Expression Wrinkles: baking {face.name} frames {start}-{end} to {path}")
                wm.progress_update(1)
                baked = bake.bake(context, face, path, start, end)
                done.append(f'frames {start}-{end} to {path}; "{baked.name}" renders them')
            if maps:
                def progress(i, total):
                    wm.progress_update(n + i)
                    if bpy.app.background and (i == total or i % 25 == 0):
                        print(f"Expression Wrinkles: wrinkle-map weights, frame {i}/{total}")

                k = wrinklemaps.bake_weights(face, scene, start, end, progress)
                if k:
                    done.append(f"{k} wrinkle-map weight channel(s) keyed")
        except (bake.BakeError, RuntimeError, OSError) as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        finally:
            wm.progress_end()
        self.report({"INFO"}, "Baked " + "; ".join(done) if done else
                    "Nothing needed baking: the wrinkle maps' drivers need no add-on")
        return {"FINISHED"}


class WRINKLE_OT_free_bake(bpy.types.Operator):
    """Remove the baked stand-in and render the live wrinkles again (the cache file is kept)"""

    bl_idname = "wrinkle.free_bake"
    bl_label = "Free Bake"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        face = _face(context)
        if face is None or face.type != "MESH" or (
                face.wrinkles.bake_object is None
                and not wrinklemaps.baked_paths(face.wrinkles.maps.weights_group)):
            cls.poll_message_set("This face has no bake")
            return False
        return True

    def execute(self, context):
        face = _face(context)
        bake.free(face)
        wrinklemaps.free_weights(face)
        return {"FINISHED"}


classes = (
    WRINKLE_OT_enable,
    WRINKLE_OT_disable,
    WRINKLE_OT_add_muscle,
    WRINKLE_OT_add_landmarks,
    WRINKLE_OT_add_muscle_set,
    WRINKLE_OT_expression,
    WRINKLE_OT_remove_muscle,
    WRINKLE_OT_drive_contraction,
    WRINKLE_OT_refine,
    WRINKLE_OT_bake,
    WRINKLE_OT_free_bake,
)
register, unregister = bpy.utils.register_classes_factory(classes)
