"""Sample scene: the scanned ICT head (the add-on's sample head, wrinkle_addon/data/ict_head.npz), animated by
its ARKit shape keys, with wrinkles-only muscles: the wrinkles come from the measured
compression alone.  Surprise raises the brows (browInnerUp/browOuterUp), Frowning lowers
them (browDown)."""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402

from sample_scenes.lib import rigging, scene_setup  # noqa: E402

DATA = ROOT / "wrinkle_addon" / "data" / "ict_head.npz"
SURPRISE = {"browInnerUp_L": 1.0, "browInnerUp_R": 1.0, "browOuterUp_L": 1.0, "browOuterUp_R": 1.0}
FROWN = {"browDown_L": 1.0, "browDown_R": 1.0}
SHOTS = {"Neutral": 1, "Surprise": 20, "Frowning": 40}


def available():
    return DATA.exists() and (ROOT / "sample_scenes" / "lib" / "ict.py").exists()


def build(view="front"):
    from sample_scenes.lib import ict

    scene = bpy.context.scene
    data = ict.load_ict(DATA)
    face = ict.ict_object(data, name="ICTHead")
    scene_setup.add_portrait_rig(scene, face, view=view, frame_scale=1.35)
    rigging.wrinkle_face(face, data["landmarks"], wrinkles_only=True)
    rigging.key_shape_keys(face, {1: {}, 20: SURPRISE, 40: FROWN})
    scene.frame_start, scene.frame_end = 1, 40
    return face, SHOTS


if __name__ == "__main__":
    rigging.save_standalone(build, "ict.blend")
