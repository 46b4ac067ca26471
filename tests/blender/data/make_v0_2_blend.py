"""Writes ``wrinkles_v0_2.blend``: a scene saved by version 0.2 of the add-on, for the
migration test (tests/blender/test_migration.py).

Version 0.2 stored its settings as ``Object.wrinkles`` and ``Object.wrinkle_muscle``.
Run it with the bpy module and a checkout of version 0.2 (commit 9a46ebe):

    python tests/blender/data/make_v0_2_blend.py /path/to/checkout-of-0.2 [out.blend]

Everything the test checks is set here: the face's switches and strength, two muscles
with edited parameters, a keyed contraction, a contraction driven by a shape key, and a
wrinkle-map expression table whose rows are driven by a muscle and by a shape key.
"""

import sys
from pathlib import Path

OLD = Path(sys.argv[1]).resolve()
OUT = Path(sys.argv[2] if len(sys.argv) > 2 else Path(__file__).with_name("wrinkles_v0_2.blend")).resolve()
sys.path.insert(0, str(OLD))

import bpy  # noqa: E402, I001  (bpy first: it makes addon_utils importable)
import addon_utils  # noqa: E402

addon_utils.enable("wrinkle_addon", default_set=True)
from tests.blender import scenes  # noqa: E402  (the 0.2 checkout's own helpers)

bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
scene = bpy.context.scene
scene.frame_start, scene.frame_end = 1, 5
face = scenes.make_face()
scenes.animate_shape_key(face, [(1, 0.0), (5, 1.0)])
bpy.ops.wrinkle.enable()
face.wrinkles.strength = 1.25
sheet = scenes.add_sheet(face, lambda_w=0.35, n_wrinkles=5, contraction=0.0)
for frame, value in ((1, 0.0), (5, 1.0)):
    sheet.wrinkle_muscle.contraction = value
    sheet.keyframe_insert("wrinkle_muscle.contraction", frame=frame)
bpy.context.view_layer.objects.active = face
bpy.ops.wrinkle.add_muscle(kind="LINEAR", use_points=True, points=(0.03, 0, 0.06, 0.01, 0, 0.03) + (0,) * 6,
                           name="Corrugator")
linear = bpy.context.view_layer.objects.active
linear.wrinkle_muscle.wrinkles_only = True
linear.wrinkle_muscle.role = "CORRUGATOR"
linear.wrinkle_muscle.side = "L"
bpy.ops.wrinkle.drive_contraction(shape_key="BrowsUp", gain=0.8)
bpy.context.view_layer.objects.active = face

face.data.uv_layers.new(name="UVMap")
mat = bpy.data.materials.new("Skin")
mat.use_nodes = True
face.data.materials.append(mat)
maps = face.wrinkles.maps
maps.tension_gain = 7.0
maps.strength = 0.9
for name, source, weights in (("Raise", "MUSCLE", (1, 1, 1, 1, 0, 0, 0, 0)),
                              ("Brows", "SHAPE_KEY", (0, 0, 0, 0, 0.5, 0.5, 0, 0))):
    ex = maps.expressions.add()
    ex.name = name
    ex.weights = weights
    ex.source = source
    if source == "MUSCLE":
        ex.muscle = sheet
    else:
        ex.shape_key = "BrowsUp"
bpy.ops.wrinkle.setup_wrinkle_maps()
scene.frame_set(3)
bpy.ops.wm.save_as_mainfile(filepath=str(OUT), compress=True)
print(f"wrote {OUT} ({OUT.stat().st_size} bytes)")
bpy.ops.wm.read_factory_settings(use_empty=True)
