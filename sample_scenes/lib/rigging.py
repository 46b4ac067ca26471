"""Shared steps of the sample scenes: wrinkles on, muscles from landmarks, expressions keyed."""

import bpy
import numpy as np

LANDMARK_KEYS = ("hairline_center", "glabella", "brow_outer_L", "eye_L", "nose_tip", "mouth_corner_L",
                 "chin", "cheekbone_L")


def activate(ob):
    for other in bpy.context.selected_objects:
        other.select_set(False)
    ob.select_set(True)
    bpy.context.view_layer.objects.active = ob


def wrinkle_face(face, landmarks, wrinkles_only=False, refine=True):
    """Enable wrinkles, add the facial muscle set from the landmarks, refine."""
    activate(face)
    bpy.ops.wrinkle.enable()
    # imported here, after the add-on is enabled, so Blender does not reload it
    from wrinkle_addon.glue.muscles import muscle_set

    local = {k: np.asarray(landmarks[k], float) for k in LANDMARK_KEYS}
    muscles = muscle_set.build_muscle_set(bpy.context, face, local)
    for m in muscles:
        m.ewrinkles_muscle.wrinkles_only = wrinkles_only
    activate(face)
    if refine:
        bpy.ops.wrinkle.refine()
    return muscles


def key_expressions(face, frames):
    """``frames``: {frame: expression id} keyed with the add-on's expression presets."""
    scene = bpy.context.scene
    activate(face)
    for frame, expression in sorted(frames.items()):
        scene.frame_set(frame)
        bpy.ops.wrinkle.expression(expression=expression)


def key_shape_keys(face, frames):
    """``frames``: {frame: {shape key name: value}}; unlisted keys are keyed at 0."""
    blocks = face.data.shape_keys.key_blocks
    names = sorted({n for values in frames.values() for n in values})
    for frame, values in sorted(frames.items()):
        for name in names:
            blocks[name].value = values.get(name, 0.0)
            blocks[name].keyframe_insert("value", frame=frame)


def save_standalone(build, default_name):
    """Run a scene script on its own: build it into an empty scene and save a .blend
    (the last command-line argument if it ends in .blend)."""
    import sys

    import addon_utils  # importable once bpy is

    addon_utils.enable("wrinkle_addon", default_set=True)
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    build()
    target = sys.argv[-1] if sys.argv[-1].endswith(".blend") else default_name
    bpy.ops.wm.save_as_mainfile(filepath=target)
    bpy.ops.wm.read_factory_settings(use_empty=True)  # avoids the bpy 4.5 exit hang
