"""Writes ``weights_v1.blend``: two faces with tension-driven wrinkle maps, saved by a
version whose weights group held each zone's tension in a Value node of its own (weights
version 1), for the upgrade test (tests/blender/test_tension_upgrade.py).

Run it with the bpy module and a checkout of that version (commit aee925c):

    python tests/blender/data/make_weights_v1_blend.py /path/to/checkout [out.blend]

"Live" measures its tension every frame; "Baked" has its weights baked for a farm (frames
1-4 keyed: the tension zones and an expression driven by its muscle).  Saved on frame 3.
Beside each face, the file records what that version computed: the custom property
``v1_zone_weights`` on each face holds its zone weights (K * 8) on frames 1-4.
"""

import sys
from pathlib import Path

OLD = Path(sys.argv[1]).resolve()
OUT = Path(sys.argv[2] if len(sys.argv) > 2 else Path(__file__).with_name("weights_v1.blend")).resolve()
sys.path.insert(0, str(OLD))

import bpy  # noqa: E402, I001  (bpy first: it makes addon_utils importable)
import addon_utils  # noqa: E402
import numpy as np  # noqa: E402

addon_utils.enable("wrinkle_addon", default_set=True)
from tests.blender import mapscenes, scenes  # noqa: E402  (the checkout's own helpers)
from tests.blender.test_curves import uv_face  # noqa: E402
from wrinkle_addon.glue.maps import map_material  # noqa: E402

bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
scene = bpy.context.scene
scene.frame_start, scene.frame_end = 1, 4
FRAMES = (1, 2, 3, 4)


def tension_face(name, x):
    face = uv_face()
    face.name = name
    face.location.x = x
    muscle = scenes.add_sheet(face, contraction=0.0)
    for frame, value in ((1, 0.0), (4, 1.0)):
        muscle.ewrinkles_muscle.contraction = value
        muscle.keyframe_insert("ewrinkles_muscle.contraction", frame=frame)
    scenes.animate_shape_key(face, [(1, 0.0), (4, 1.0)])
    face.data.materials.append(mapscenes.node_material(f"Skin {name}"))
    maps = face.ewrinkles_face.maps
    mask = np.zeros((8, 8, 4), np.float32)
    mask[:, :, 0] = mask[:, :4, 1] = 1.0
    maps.mask_a = mapscenes.data_image(f"Mask A {name}", mask)
    maps.mask_b = mapscenes.data_image(f"Mask B {name}", np.full((8, 8, 4), 0.5, np.float32))
    pd = mapscenes.random_normal_map(np.random.default_rng(3), 8, 0.3)
    maps.map_a = mapscenes.data_image(f"PD {name}", pd)
    maps.weight_mode, maps.tension_gain = "TENSION", 4.0
    ex = maps.expressions.add()
    ex.name, ex.source, ex.muscle = "Raise", "MUSCLE", muscle
    ex.weights = (0.2, 0.2, 0.0, 0.0, 0.5, 0.5, 0.3, 0.0)
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    return face


live, baked = tension_face("Live", 0.0), tension_face("Baked", 0.5)
assert map_material.bake_weights(baked, scene, 1, 4) > 8
for face in (live, baked):
    rows = []
    for frame in FRAMES:
        scene.frame_set(frame)
        rows.append(map_material.zone_weights(face).ravel())
    face["v1_zone_weights"] = np.array(rows, np.float64).ravel().tolist()
    assert face.ewrinkles_face.maps.weights_group.nodes.get("Tension 0") is not None  # version 1
scene.frame_set(3)
bpy.ops.wm.save_as_mainfile(filepath=str(OUT), compress=True)
print(f"wrote {OUT} ({OUT.stat().st_size} bytes)")
bpy.ops.wm.read_factory_settings(use_empty=True)
