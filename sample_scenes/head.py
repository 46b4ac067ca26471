"""Sample scene: the procedural head with Zhang's ten muscles, keyed Neutral, Surprise, Frowning.

Run alone to save a .blend: ``python sample_scenes/head.py out/head.blend``.
"""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402

from sample_scenes.lib import headgen, rigging, scene_setup  # noqa: E402

FRAMES = {1: "NEUTRAL", 20: "SURPRISE", 40: "FROWN"}
SHOTS = {"Neutral": 1, "Surprise": 20, "Frowning": 40}


def build(target_verts=40000, view="front"):
    scene = bpy.context.scene
    head = headgen.make_head(target_verts)
    face = scene_setup.mesh_object_from_arrays("Head", head["positions"], head["quads"], head["corner_uvs"])
    scene_setup.add_portrait_rig(scene, face, view=view, frame_scale=1.35)
    rigging.wrinkle_face(face, head["landmarks"])
    rigging.key_expressions(face, FRAMES)
    scene.frame_start, scene.frame_end = 1, 40
    return face, SHOTS


if __name__ == "__main__":
    rigging.save_standalone(build, "head.blend")
