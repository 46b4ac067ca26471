# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators of the animated wrinkle maps: set up, remove, and edit the expression table."""

import bpy
from bpy.props import BoolProperty, EnumProperty

from ..core.maps import jimenez
from ..core.muscles import presets
from ..glue import faces
from ..glue.maps import map_material
from ..glue.muscles import muscle_objects
from .common import face_ok, face_poll, guarded

# ARKit shape keys that carry each of Table 1.1's expressions, best first (a face's own
# names are tried with and without the _L suffix).
ARKIT_SOURCES = {
    "Joy": ("mouthSmile_L", "mouthSmileLeft", "cheekSquint_L"),
    "Surprise": ("browInnerUp_L", "browInnerUp", "browOuterUp_L", "browOuterUpLeft"),
    "Fear": ("eyeWide_L", "eyeWideLeft"),
    "Anger": ("browDown_L", "browDownLeft"),
    "Disgust": ("noseSneer_L", "noseSneerLeft"),
    "Sad": ("mouthFrown_L", "mouthFrownLeft"),
}
PRESETS = [
    ("TABLE_1_1", "Jimenez Table 1.1", "Joy, Surprise, Fear, Anger, Disgust and Sad with the "
     "paper's weights; bound to ARKit shape keys when the face has them"),
    ("MUSCLES", "From Muscles", "Surprise, Frowning and Fear (Zhang §3) with weights derived from "
     "which muscles each contracts, each bound to its strongest muscle"),
]


_face = faces.active


def _sync(face):
    map_material.sync(face, rebind=True)


class WRINKLE_OT_setup_wrinkle_maps(bpy.types.Operator):
    """Wire animated wrinkle maps into the face material, in front of the Principled BSDF's
    normal input (Jimenez et al. 2011): base map, wrinkle maps, two masks and zone weights"""

    bl_idname = "wrinkle.setup_wrinkle_maps"
    bl_label = "Set Up Wrinkle Maps"
    bl_options = {"REGISTER", "UNDO"}

    poll = face_poll(polygons=False)

    @guarded
    def execute(self, context):
        face = _face(context)
        packed = []
        mat = map_material.setup(face, packed=packed)
        if packed:
            names = ", ".join(f'"{n}"' for n in packed)
            self.report({"INFO"}, f"Packed {names} into the .blend file, so the pixels made in "
                                  "Blender are kept (as data, Non-Color) and saved with it")
        maps = face.ewrinkles_face.maps
        if maps.mask_a is None and maps.mask_b is None:
            self.report({"WARNING"}, f'Wrinkle maps wired into "{mat.name}", but there are no masks '
                                     "yet: generate or pick them, or nothing shows")
        else:
            self.report({"INFO"}, f'Wrinkle maps wired into "{mat.name}"')
        return {"FINISHED"}


class WRINKLE_OT_remove_wrinkle_maps(bpy.types.Operator):
    """Take the wrinkle maps out of the face material and restore its previous normal input;
    the expression table is kept"""

    bl_idname = "wrinkle.remove_wrinkle_maps"
    bl_label = "Remove Wrinkle Maps"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        if not face_ok(cls, context, polygons=False):
            return False
        if _face(context).ewrinkles_face.maps.material is None:
            cls.poll_message_set("This face has no wrinkle maps set up")
            return False
        return True

    @guarded
    def execute(self, context):
        face = _face(context)
        mat = face.ewrinkles_face.maps.material
        if mat.library is not None:
            self.report({"ERROR"}, f'The material "{mat.name}" is linked and read-only')
            return {"CANCELLED"}
        map_material.remove(face)
        return {"FINISHED"}


class WRINKLE_OT_add_map_expression(bpy.types.Operator):
    """Add an expression row to the wrinkle-map table"""

    bl_idname = "wrinkle.add_map_expression"
    bl_label = "Add Expression"
    bl_options = {"REGISTER", "UNDO"}

    poll = face_poll(polygons=False)

    @guarded
    def execute(self, context):
        face = _face(context)
        maps = face.ewrinkles_face.maps
        ex = maps.expressions.add()
        ex.name = f"Expression {len(maps.expressions)}"
        maps.active_expression = len(maps.expressions) - 1
        _sync(face)
        return {"FINISHED"}


class WRINKLE_OT_remove_map_expression(bpy.types.Operator):
    """Remove the selected expression row from the wrinkle-map table"""

    bl_idname = "wrinkle.remove_map_expression"
    bl_label = "Remove Expression"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        if not face_ok(cls, context, polygons=False):
            return False
        if len(_face(context).ewrinkles_face.maps.expressions) == 0:
            cls.poll_message_set("The table is empty")
            return False
        return True

    @guarded
    def execute(self, context):
        face = _face(context)
        maps = face.ewrinkles_face.maps
        i = min(maps.active_expression, len(maps.expressions) - 1)
        maps.expressions.remove(i)
        maps.active_expression = max(0, i - 1)
        _sync(face)
        return {"FINISHED"}


def _shape_key(face, candidates):
    keys = face.data.shape_keys
    if keys is None:
        return ""
    return next((c for c in candidates if c in keys.key_blocks), "")


def load_preset(face, preset, replace=True):
    """Fill the table from a preset; returns how many rows got a source bound."""
    maps = face.ewrinkles_face.maps
    if replace:
        maps.expressions.clear()
    bound = 0
    if preset == "TABLE_1_1":
        rows = [(name, weights, ("SHAPE_KEY", _shape_key(face, ARKIT_SOURCES[name])))
                for name, weights in jimenez.TABLE_1_1.items()]
    else:
        muscles = muscle_objects.live_muscles(face)
        expressions = {k: v for k, v in presets.EXPRESSIONS.items() if v}
        table = jimenez.table_from_expressions(expressions)
        rows = []
        for (key, contractions), weights in zip(expressions.items(), table):
            role = max(contractions, key=contractions.get)
            muscle = next((m for m in muscles if m.ewrinkles_muscle.role == role
                           and m.ewrinkles_muscle.side in ("L", "C")), None)
            rows.append((key.title().replace("Frown", "Frowning"), weights, ("MUSCLE", muscle)))
    for name, weights, (source, what) in rows:
        ex = maps.expressions.add()
        ex.name = name
        ex.weights = [float(w) for w in weights]
        if what:
            ex.source = source
            if source == "SHAPE_KEY":
                ex.shape_key = what
            else:
                ex.muscle = what
            bound += 1
    maps.active_expression = 0
    return bound


class WRINKLE_OT_load_map_preset(bpy.types.Operator):
    """Fill the expression table from a preset"""

    bl_idname = "wrinkle.load_map_preset"
    bl_label = "Load Expression Preset"
    bl_options = {"REGISTER", "UNDO"}

    preset: EnumProperty(name="Preset", description="Which table to load", items=PRESETS,
                         default="TABLE_1_1")
    replace: BoolProperty(name="Replace", description="Replace the current rows instead of "
                          "adding to them", default=True)

    poll = face_poll(polygons=False)

    @guarded
    def execute(self, context):
        face = _face(context)
        if self.preset == "MUSCLES" and not muscle_objects.live_muscles(face):
            self.report({"ERROR"}, "This face has no muscles: add the facial muscle set first")
            return {"CANCELLED"}
        bound = load_preset(face, self.preset, self.replace)
        _sync(face)
        n = len(face.ewrinkles_face.maps.expressions)
        if bound < n:
            self.report({"WARNING"}, f"{n - bound} of {n} expressions have no source yet: bind them "
                                     "in the table (they are Manual until then)")
        return {"FINISHED"}


classes = (
    WRINKLE_OT_setup_wrinkle_maps,
    WRINKLE_OT_remove_wrinkle_maps,
    WRINKLE_OT_add_map_expression,
    WRINKLE_OT_remove_map_expression,
    WRINKLE_OT_load_map_preset,
)
_register, _unregister = bpy.utils.register_classes_factory(classes)


def register():
    _register()


def unregister():
    _unregister()
