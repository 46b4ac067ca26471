"""Sample scene: animated wrinkle maps (Jimenez et al. 2011) on the scanned ICT head
(../shared/data/ict_head.npz, not shipped), with nothing painted by hand.

The facial muscle set is placed from the head's landmarks; then, with the add-on's own
operators, the wrinkle map is baked from the muscles' geometric wrinkles (each muscle at
full contraction, rasterised in UV space), the 8 zone masks are generated from their
wrinkling regions, the maps are wired into the skin material, and the paper's Table 1.1
is loaded with its expressions bound to the head's ARKit shape keys.  The geometric
wrinkles themselves are off: the maps alone make the wrinkles.

Shots: Surprise (brows up: forehead furrows), Anger (brows down: lines between the brows,
the forehead cancelled) and Surprise + Anger (Fig. 1.5: the forehead smooths).
"""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402

from sample_scenes.lib import rigging, scene_setup  # noqa: E402

DATA = ROOT.parent / "shared" / "data" / "ict_head.npz"
SURPRISE = {"browInnerUp_L": 1.0, "browInnerUp_R": 1.0, "browOuterUp_L": 1.0, "browOuterUp_R": 1.0}
ANGER = {"browDown_L": 1.0, "browDown_R": 1.0}
SHOTS = {"Surprise": 20, "Anger": 40, "Surprise + Anger": 60}
MAP_RESOLUTION = "1024"


def available():
    return DATA.exists() and (ROOT / "sample_scenes" / "lib" / "ict.py").exists()


def toggle(face, on):
    """The demo's without / with switch: the wrinkle maps' overall strength."""
    face.ewrinkles_face.maps.strength = 1.0 if on else 0.0


def build(view="front"):
    from sample_scenes.lib import ict

    scene = bpy.context.scene
    data = ict.load_ict(DATA)
    face = ict.ict_object(data, name="ICTHead")
    scene_setup.add_portrait_rig(scene, face, view=view, frame_scale=1.35)
    rigging.wrinkle_face(face, data["landmarks"])  # refined: the bake samples the wrinkles per vertex
    rigging.activate(face)
    bpy.ops.wrinkle.disable()  # maps only; the muscles stay to bake from
    bpy.ops.wrinkle.bake_wrinkle_map(resolution=MAP_RESOLUTION, mode="MUSCLES")
    bpy.ops.wrinkle.generate_masks(source="MUSCLES")
    bpy.ops.wrinkle.setup_wrinkle_maps()
    bpy.ops.wrinkle.load_map_preset(preset="TABLE_1_1")
    rigging.key_shape_keys(face, {1: {}, 20: SURPRISE, 40: ANGER, 60: {**SURPRISE, **ANGER}})
    scene.frame_start, scene.frame_end = 1, 60
    return face, SHOTS


if __name__ == "__main__":
    rigging.save_standalone(build, "ict_maps.blend")
