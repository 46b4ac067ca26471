# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators on the pattern-function layers: add (at the 3D cursor or the selected
vertices), remove, duplicate, move, mirror and apply as a shape key."""

import math

import bpy
from bpy.props import EnumProperty, FloatProperty, IntProperty

from ..core.patterns.functions import KINDS
from ..glue import faces, pipeline
from ..glue.patterns import pattern_layers, shedding, tears
from ..glue.progress import Progress
from ..glue.registry import MeshArrays
from ..glue.surface import Surface
from .common import face_ok, face_poll, guarded, nothing_left_on_failure


def _active_layer(context):
    """The face, its stack and the index of its active layer (-1: none)."""
    face = faces.active(context)
    st = face.ewrinkles_face.patterns
    return face, st, pattern_layers.active_index(st)


class _LayerOperator:
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        if not face_ok(cls, context, lists=True):
            return False
        if not faces.active(context).ewrinkles_face.patterns.layers:
            cls.poll_message_set("The face has no pattern layers")
            return False
        return True


def _where(description):
    return EnumProperty(
        name="Where", description=description,
        items=(("CURSOR", "3D Cursor", "On the skin nearest the 3D cursor"),
               ("SELECTED", "Selected Vertices", "At the centre of the face's selected vertices")),
        default="CURSOR")


def _on_skin(context, face, where):
    """The point (face space) and the skin's normal there: at the selected vertices or on
    the skin nearest the 3D cursor."""
    if face.mode == "EDIT":
        face.update_from_editmode()
    if where == "SELECTED":
        return pattern_layers.selected_point(face)
    return pattern_layers.nearest_on_skin(face, context.scene.cursor.location)


class WRINKLE_OT_add_pattern(bpy.types.Operator):
    """Add a pattern-function layer with a new frame Empty on the skin, at the 3D cursor or at
    the selected vertices, turned to the skin's normal"""

    bl_idname = "wrinkle.add_pattern"
    bl_label = "Add Pattern"
    bl_options = {"REGISTER", "UNDO"}

    kind: EnumProperty(name="Type", description="Which pattern to add", items=KINDS, default="FOREHEAD")
    where: _where("Where to put the pattern's frame")

    poll = face_poll(lists=True)

    @guarded
    def execute(self, context):
        face = faces.active(context)
        point, normal = _on_skin(context, face, self.where)
        with nothing_left_on_failure():
            lay = pattern_layers.add_layer(context, face, self.kind, point, normal)
        pipeline.refresh_all(context)
        self.report({"INFO"}, f'Added the pattern "{lay.name}" to "{face.name}"')
        return {"FINISHED"}


class WRINKLE_OT_remove_pattern(_LayerOperator, bpy.types.Operator):
    """Remove the active pattern layer (its frame Empty stays)"""

    bl_idname = "wrinkle.remove_pattern"
    bl_label = "Remove Pattern"

    @guarded
    def execute(self, context):
        _face, st, i = _active_layer(context)
        st.layers.remove(i)
        st.active = max(0, i - 1)
        pipeline.refresh_all(context)
        return {"FINISHED"}


class WRINKLE_OT_duplicate_pattern(_LayerOperator, bpy.types.Operator):
    """Duplicate the active pattern layer (the copy shares its frame)"""

    bl_idname = "wrinkle.duplicate_pattern"
    bl_label = "Duplicate Pattern"

    @guarded
    def execute(self, context):
        face, st, i = _active_layer(context)
        name = st.layers[i].name
        pattern_layers.copy_layer(face, i).name = name + " Copy"
        pipeline.refresh_all(context)
        return {"FINISHED"}


class WRINKLE_OT_move_pattern(_LayerOperator, bpy.types.Operator):
    """Move the active pattern layer up or down the stack"""

    bl_idname = "wrinkle.move_pattern"
    bl_label = "Move Pattern"

    direction: EnumProperty(name="Direction", description="Which way to move the layer",
                            items=(("UP", "Up", "Toward the top of the stack"),
                                   ("DOWN", "Down", "Toward the bottom of the stack")), default="UP")

    @guarded
    def execute(self, context):
        _face, st, i = _active_layer(context)
        j = i - 1 if self.direction == "UP" else i + 1
        if 0 <= j < len(st.layers):
            st.layers.move(i, j)
            st.active = j
        return {"FINISHED"}


class WRINKLE_OT_mirror_pattern(_LayerOperator, bpy.types.Operator):
    """Add a mirrored copy of the active pattern layer on the other side of the face (across
    the face's own x = 0 plane), with a mirrored frame"""

    bl_idname = "wrinkle.mirror_pattern"
    bl_label = "Mirror Pattern"

    @guarded
    def execute(self, context):
        face, _st, i = _active_layer(context)
        with nothing_left_on_failure():
            pattern_layers.mirror_layer(context, face, i)
        pipeline.refresh_all(context)
        return {"FINISHED"}


class WRINKLE_OT_apply_pattern(_LayerOperator, bpy.types.Operator):
    """Apply the active pattern layer as it is on this frame: bake it into a new shape key at
    value 1 and remove the layer"""

    bl_idname = "wrinkle.apply_pattern"
    bl_label = "Apply Pattern"

    @guarded
    def execute(self, context):
        face, _st, i = _active_layer(context)
        if face.mode == "EDIT":
            raise pattern_layers.PatternError("Leave Edit Mode to apply a pattern")
        s = Surface(face, need_uv=False)
        key = pattern_layers.apply_layer(context, face, i, MeshArrays(s.rest, s.edges, s.tris))
        pipeline.refresh_all(context)
        self.report({"INFO"}, f'Applied as the shape key "{key.name}"')
        return {"FINISHED"}


class WRINKLE_OT_add_teardrop(bpy.types.Operator):
    """Add a dripping tear: a teardrop that forms at the 3D cursor (or the selected vertices,
    such as the lower eyelid), changes shape as it falls, and falls again every few seconds"""

    bl_idname = "wrinkle.add_teardrop"
    bl_label = "Add Teardrop"
    bl_options = {"REGISTER", "UNDO"}

    where: _where("Where the drop forms")
    width: FloatProperty(name="Width", description="The drop's size across, as a fraction of the face's "
                         "size", default=0.01, min=0.0001, soft_max=0.05, subtype="FACTOR")
    every: FloatProperty(name="Every", description="How often a new drop falls, in seconds", default=2.0,
                         min=0.05, soft_max=20.0, subtype="TIME_ABSOLUTE", unit="TIME_ABSOLUTE")
    lasts: FloatProperty(name="Lasts", description="How long each drop shows, in seconds", default=1.2,
                         min=0.0, soft_max=20.0, subtype="TIME_ABSOLUTE", unit="TIME_ABSOLUTE")

    poll = face_poll()

    @guarded
    def execute(self, context):
        face = faces.active(context)
        point, normal = _on_skin(context, face, self.where)
        size = pattern_layers.face_size(face) * pattern_layers.face_unit(face)
        # the drop hangs from its pointed top along the world's gravity, its widest radius about
        # 1.5 Width out from its axis: it forms on the skin, not in it, out along the normal by
        # that radius where the skin is upright, and from the skin itself where it faces down
        n = (face.matrix_world.to_3x3() @ normal).normalized()
        out = n * (tears.REACH * self.width * size * math.sqrt(max(0.0, 1.0 - n.z * n.z)))
        start = face.matrix_world @ point + out
        with nothing_left_on_failure():
            ob = tears.add_teardrop(context, face, start, Width=self.width * size,
                                    Length=0.64 * self.width * size, Speed=8.0 * self.width * size,
                                    Start=(context.scene.frame_current - 1) / _fps(context.scene),
                                    Every=self.every, Lasts=self.lasts)
        if tears.falls_into(context, face, start, tears.reach_down(ob)):
            self.report({"WARNING"}, f'"{ob.name}" falls into the skin: a drop leaves the face where the '
                        "skin faces down, as under the chin or the jaw; put it there")
        else:
            self.report({"INFO"}, f'Added "{ob.name}": its size, speed and timing are in its Teardrop '
                        "modifier")
        return {"FINISHED"}


class WRINKLE_OT_add_shedding_tear(bpy.types.Operator):
    """Add a shedding tear that runs down the skin along a path: a curve drawn on the face
    (selected, with the face active), or the face's selected faces.  It follows the face as it
    deforms and never enters the skin"""

    bl_idname = "wrinkle.add_shedding_tear"
    bl_label = "Add Shedding Tear"
    bl_options = {"REGISTER", "UNDO"}

    path: EnumProperty(
        name="Path", description="What gives the tear's path",
        items=(("AUTO", "Automatic", "A selected curve if there is one, else the face's selected faces"),
               ("CURVE", "Selected Curve", "A curve drawn on the skin (Curve > Draw, Depth: Surface), "
                "selected with the face active; the tear runs from the curve's start"),
               ("FACES", "Selected Faces", "The face's selected faces; the tear runs from their higher end, "
                "as wide as they are")),
        default="AUTO")
    width: FloatProperty(name="Width", description="The tear's width along a curve, as a fraction of the "
                         "face's size (selected faces give their own width)", default=0.008, min=0.0005,
                         soft_max=0.05, subtype="FACTOR")
    thickness: FloatProperty(name="Thickness", description="How far the tear stands off the skin at its "
                             "middle, as a fraction of its width", default=0.2, min=0.02, max=1.0,
                             subtype="FACTOR")
    roughness: FloatProperty(name="Roughness", description="How high the bumps of the tear's top rise, as a "
                             "fraction of its thickness (rougher skin holds more); they only rise",
                             default=0.4, min=0.0, max=2.0, subtype="FACTOR")
    seed: IntProperty(name="Seed", description="Which bumps: another seed, another random pattern",
                      default=0, min=0)
    duration: FloatProperty(name="Run Time", description="How long the tear takes to run its whole path, "
                            "in seconds", default=3.0, min=0.05, soft_max=30.0, subtype="TIME_ABSOLUTE",
                            unit="TIME_ABSOLUTE")
    every: FloatProperty(name="Every", description="Run again every so many seconds, a running cycle; 0: "
                         "run once and stay", default=0.0, min=0.0, soft_max=30.0, subtype="TIME_ABSOLUTE",
                         unit="TIME_ABSOLUTE")

    poll = face_poll()

    @guarded
    def execute(self, context):
        face = faces.active(context)
        if face.mode == "EDIT":
            face.update_from_editmode()
        half = 0.5 * self.width * pattern_layers.face_size(face)  # face units
        curves = [o for o in context.selected_objects if o.type == "CURVE"]
        kind = self.path if self.path != "AUTO" else ("CURVE" if curves else "FACES")
        with Progress(context, self.bl_label) as progress, nothing_left_on_failure():
            progress(0.1, "reading the path")
            if kind == "CURVE":
                if len(curves) != 1:
                    raise tears.TearError(f"Select one curve for the tear's path, with the face active "
                                          f"({len(curves)} selected)")
                path = shedding.curve_path(face, curves[0])
            else:
                path, half = shedding.selected_faces_path(face, half)
            progress(0.3, "building the tear")
            ob = shedding.add_shedding_tear(
                context, face, path, half, self.thickness * 2.0 * half, shedding.GAP * 2.0 * half,
                roughness=self.roughness, seed=self.seed, progress=progress,
                duration=self.duration, Start=context.scene.frame_current / _fps(context.scene),
                Every=self.every)
        self.report({"INFO"}, f'Added "{ob.name}": its timing is in its {shedding.MODIFIER_NAME} modifier')
        return {"FINISHED"}


def _fps(scene):
    return scene.render.fps / (scene.render.fps_base or 1.0)


classes = (WRINKLE_OT_add_teardrop, WRINKLE_OT_add_shedding_tear, WRINKLE_OT_add_pattern,
           WRINKLE_OT_remove_pattern, WRINKLE_OT_duplicate_pattern, WRINKLE_OT_move_pattern,
           WRINKLE_OT_mirror_pattern, WRINKLE_OT_apply_pattern)
register, unregister = bpy.utils.register_classes_factory(classes)
