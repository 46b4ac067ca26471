"""Sample scene: animated wrinkle maps (Jimenez et al. 2011) on the scanned ICT head
(the add-on's sample head, wrinkle_addon/data/ict_head.npz), with nothing painted by hand.

The facial muscle set is placed from the head's landmarks; then, with the add-on's own
operators, two wrinkle maps are baked from the muscles' geometric wrinkles of two poses
(Bake Wrinkle Map, Current Pose: the heights the shape keys' compression raises,
rasterised in UV space): map 1 from Anger, the brows drawn down and the nose wrinkled, for
the expressions that light the brows and the nose (Anger, Disgust); map 2 from Surprise,
the brows raised, for those that light the forehead (Surprise, Fear, Sad, Joy).  The 8
zone masks are generated from the muscles' wrinkling regions, the maps are wired into the
skin material, and the paper's Table 1.1 is loaded with its expressions bound to the
head's ARKit shape keys.  The geometric wrinkles themselves are off: the maps alone make
the wrinkles.  (A map baked with Each Muscle Contracted holds every wrinkle at full depth
over each muscle's whole region, far stronger than any pose: ``benchmarks/map_look.py``
measures how far each looks from the geometry.)

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

DATA = ROOT / "wrinkle_addon" / "data" / "ict_head.npz"
SURPRISE = {"browInnerUp_L": 1.0, "browInnerUp_R": 1.0, "browOuterUp_L": 1.0, "browOuterUp_R": 1.0}
ANGER = {"browDown_L": 1.0, "browDown_R": 1.0, "noseSneer_L": 1.0, "noseSneer_R": 1.0,
         "eyeSquint_L": 0.5, "eyeSquint_R": 0.5}  # FACS AU 4 + 9 + 7, as benchmarks/realism.py poses it
# each wrinkle map: (image name, the pose it is baked from, the Table 1.1 expressions it serves)
MAPS = (("Anger", ANGER, ("Anger", "Disgust")),
        ("Surprise", SURPRISE, ("Surprise", "Fear", "Sad", "Joy")))
SHOTS = {"Surprise": 20, "Anger": 40, "Surprise + Anger": 60}
MAP_RESOLUTION = "1024"


def available():
    return DATA.exists() and (ROOT / "sample_scenes" / "lib" / "ict.py").exists()


def toggle(face, on):
    """The demo's without / with switch: the wrinkle maps' overall strength."""
    face.ewrinkles_face.maps.strength = 1.0 if on else 0.0


def _pose(face, values):
    """Set the shape keys to ``values`` (the others to 0) and evaluate."""
    for kb in face.data.shape_keys.key_blocks[1:]:
        kb.value = values.get(kb.name, 0.0)
    bpy.context.view_layer.update()


def set_up_maps(face, resolution=MAP_RESOLUTION):
    """The demo's wrinkle maps on ``face`` (its muscles placed), with the add-on's own
    operators: one map baked from each pose of :data:`MAPS` (Current Pose), the masks from
    the muscles' regions, wired into the material, Table 1.1 bound to the shape keys and each
    expression on the map of its pose; the geometric wrinkles turned off.
    ``benchmarks/map_look.py`` measures exactly this set-up against the geometry."""
    rigging.activate(face)
    bpy.ops.wrinkle.disable()  # maps only; the muscles stay to bake from
    names = []
    for name, pose, _expressions in MAPS:
        _pose(face, pose)
        names.append(f"{face.name} Wrinkle PD {name}")
        bpy.ops.wrinkle.bake_wrinkle_map(resolution=resolution, mode="POSE", image_name=names[-1])
    _pose(face, {})
    maps = face.ewrinkles_face.maps
    maps.map_a, maps.map_b = (bpy.data.images[n] for n in names)  # before Set Up, which wires them
    bpy.ops.wrinkle.generate_masks(source="MUSCLES")
    bpy.ops.wrinkle.setup_wrinkle_maps()
    bpy.ops.wrinkle.load_map_preset(preset="TABLE_1_1")
    for ex in maps.expressions:
        ex.map_index = next((k + 1 for k, m in enumerate(MAPS) if ex.name in m[2]), 1)
    calibrate(face)


def calibrate(face):
    """Each zone's Strength such that the map baked from a pose shows at full weight in
    that pose: Table 1.1 gives Surprise 0.8 on the forehead, which would show 80 % of the
    wrinkles the map holds.  Only the zones a pose clearly lights (weight 0.75 or more: its
    own) are set, each by the first map whose pose lights it; a zone a pose lights only in
    passing (Disgust's 0.5 on the chin) keeps the table's weight."""
    from wrinkle_addon.glue.maps import map_material

    maps = face.ewrinkles_face.maps
    strength, done = list(maps.zone_strength), set()
    for k, (_name, pose, _expressions) in enumerate(MAPS):
        _pose(face, pose)
        w = map_material.zone_weights(face)[k]
        for z in range(len(strength)):
            if w[z] >= 0.75 and z not in done:
                strength[z] = min(2.0, strength[z] / float(w[z]))
                done.add(z)
    _pose(face, {})
    maps.zone_strength = strength


def build(view="front"):
    from sample_scenes.lib import ict

    scene = bpy.context.scene
    data = ict.load_ict(DATA)
    face = ict.ict_object(data, name="ICTHead")
    scene_setup.add_portrait_rig(scene, face, view=view, frame_scale=1.35)
    rigging.wrinkle_face(face, data["landmarks"])  # refined: the bake samples the wrinkles per vertex
    set_up_maps(face)
    rigging.key_shape_keys(face, {1: {}, 20: SURPRISE, 40: ANGER, 60: {**SURPRISE, **ANGER}})
    scene.frame_start, scene.frame_end = 1, 60
    return face, SHOTS


if __name__ == "__main__":
    rigging.save_standalone(build, "ict_maps.blend")
