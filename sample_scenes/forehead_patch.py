"""Sample scene: a forehead patch with a single sheet muscle (Frontalis) contracting."""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402
from mathutils import Vector  # noqa: E402

from sample_scenes.lib import headgen, rigging, scene_setup  # noqa: E402

SHOTS = {"Relaxed": 1, "Contracted": 20}


def build():
    scene = bpy.context.scene
    patch = headgen.make_forehead_patch()
    face = scene_setup.mesh_object_from_arrays("Forehead", patch["positions"], patch["quads"],
                                               patch["corner_uvs"])
    scene_setup.add_portrait_rig(scene, face, view="front")
    lm = patch["landmarks"]
    rigging.activate(face)
    bpy.ops.wrinkle.enable()
    points = [lm["attachment_L"], lm["attachment_R"], lm["insertion_R"], lm["insertion_L"]]
    flat = [c for p in points for c in Vector(p)]
    bpy.ops.wrinkle.add_muscle(kind="SHEET", use_points=True, points=flat, name="Frontalis")
    muscle = bpy.context.view_layer.objects.active
    for frame, value in ((1, 0.0), (20, 1.0)):
        muscle.ewrinkles_muscle.contraction = value
        muscle.keyframe_insert("ewrinkles_muscle.contraction", frame=frame)
    rigging.activate(face)
    bpy.ops.wrinkle.refine()
    scene.frame_start, scene.frame_end = 1, 20
    return face, SHOTS


if __name__ == "__main__":
    rigging.save_standalone(build, "forehead.blend")
