"""Every expression the realism benchmark measures, rendered without and with wrinkles.

    python sample_scenes/expressions.py [--out out/expressions] [--size 512] [--samples 16]

Rows (``out/expressions.png``, one without / with pair per expression):

* the scanned ICT head (the add-on's sample head), the facial muscle set
  pulling: brow raise (browInnerUp + browOuterUp), brow down (browDown) and smile
  (mouthSmile) by its ARKit shape keys, every muscle relaxed (the wrinkles come from the
  compression the rig causes); then Surprise and Frowning by the muscles alone (the add-on's
  expression presets: the Waters pull and its wrinkles);
* the procedural head (no shape keys): Surprise, Frowning, and smile by both Zygomaticus
  Major contracted.

"Without" is the same deformation (shape keys and pull) with the wrinkle strength at 0.
"""

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402, I001

from sample_scenes.lib import rendering  # noqa: E402

rendering.enable_addon()  # before the scenes import the add-on's modules

from sample_scenes import scanned_head  # noqa: E402
from sample_scenes.lib import headgen, ict, rigging, scene_setup  # noqa: E402

BROW_RAISE = {"browInnerUp_L": 1.0, "browInnerUp_R": 1.0, "browOuterUp_L": 1.0, "browOuterUp_R": 1.0}
BROW_DOWN = {"browDown_L": 1.0, "browDown_R": 1.0}
SMILE = {"mouthSmile_L": 1.0, "mouthSmile_R": 1.0}


def _key_smile(face, frame):
    """Both Zygomaticus Major contracted on ``frame``, every other muscle relaxed."""
    for ref in face.ewrinkles_face.muscles:
        m = ref.object
        m.ewrinkles_muscle.contraction = 1.0 if m.ewrinkles_muscle.role == "ZYGOMATICUS_MAJOR" else 0.0
        m.keyframe_insert("ewrinkles_muscle.contraction", frame=frame)


def build_ict():
    scene = bpy.context.scene
    data = ict.load_ict(scanned_head.DATA)
    face = ict.ict_object(data, name="ICTHead")
    scene_setup.add_portrait_rig(scene, face, view="front", frame_scale=1.35)
    rigging.wrinkle_face(face, data["landmarks"])
    rigging.key_shape_keys(face, {1: {}, 10: BROW_RAISE, 20: BROW_DOWN, 30: SMILE, 40: {}, 50: {}})
    rigging.key_expressions(face, {1: "NEUTRAL", 30: "NEUTRAL", 40: "SURPRISE", 50: "FROWN"})
    scene.frame_start, scene.frame_end = 1, 50
    return face, {"Brow raise": 10, "Brow down": 20, "Smile": 30, "Surprise pulling": 40,
                  "Frowning pulling": 50}


def build_procedural():
    scene = bpy.context.scene
    head = headgen.make_head(40000)
    face = scene_setup.mesh_object_from_arrays("Head", head["positions"], head["quads"], head["corner_uvs"])
    scene_setup.add_portrait_rig(scene, face, view="front", frame_scale=1.35)
    rigging.wrinkle_face(face, head["landmarks"])
    rigging.key_expressions(face, {1: "NEUTRAL", 10: "SURPRISE", 20: "FROWN", 29: "NEUTRAL"})
    _key_smile(face, 30)
    scene.frame_start, scene.frame_end = 1, 30
    return face, {"Surprise pulling": 10, "Frowning pulling": 20, "Smile pulling": 30}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=str(ROOT / "out" / "expressions"), help="output folder")
    parser.add_argument("--size", type=int, default=512, help="render size in pixels")
    parser.add_argument("--samples", type=int, default=16, help="Cycles samples")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    jobs = [("procedural", build_procedural)]
    if scanned_head.available():
        jobs.insert(0, ("ict", build_ict))
    rows, captions = [], []
    for name, builder in jobs:
        row, row_captions = rendering.render_scene(name, builder, out, args.size, args.samples)
        rows.append(row)
        captions.append(row_captions)
    rendering.contact_sheet(rows, out / "expressions.png", row_names=[j[0] for j in jobs], captions=captions)
    rendering.log(f"contact sheet -> {out / 'expressions.png'}")
    bpy.ops.wm.read_factory_settings(use_empty=True)  # avoids the bpy 4.5 exit hang


if __name__ == "__main__":
    main(sys.argv[1:] if "--" not in sys.argv else sys.argv[sys.argv.index("--") + 1:])
