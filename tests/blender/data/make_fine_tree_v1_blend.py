"""Writes ``fine_tree_v1.blend``: a face with fine wrinkles saved by a version whose *Fine
Wrinkle Shrinkage* group (version 1) always stored the shrinkage on the face corners, for the
upgrade test (tests/blender/test_fine_tree.py).

Run it with the bpy module and a checkout of that version (commit aee925c):

    python tests/blender/data/make_fine_tree_v1_blend.py /path/to/checkout [out.blend]

The forehead patch with fine wrinkles carved, its BrowsUp ramping 0 -> 1 over frames 1..3;
the custom property ``v1_shrinkage`` on the face holds the shrinkage (2, N) that version
computed on frame 3.  Saved on frame 1.
"""

import sys
from pathlib import Path

OLD = Path(sys.argv[1]).resolve()
OUT = Path(sys.argv[2] if len(sys.argv) > 2 else Path(__file__).with_name("fine_tree_v1.blend")).resolve()
sys.path.insert(0, str(OLD))

import bpy  # noqa: E402, I001  (bpy first: it makes addon_utils importable)
import addon_utils  # noqa: E402

addon_utils.enable("wrinkle_addon", default_set=True)
from tests.blender import scenes  # noqa: E402  (the checkout's own helpers)
from tests.blender.test_curves import uv_face  # noqa: E402
from wrinkle_addon.glue.bando import fine_tree  # noqa: E402

bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
scene = bpy.context.scene
scene.frame_start, scene.frame_end = 1, 3
face = uv_face()
fs = face.ewrinkles_face.fine_wrinkles
fs.resolution = "512"
bpy.context.view_layer.objects.active = face
assert bpy.ops.wrinkle.carve_fine() == {"FINISHED"}
face.data.shape_keys.key_blocks["BrowsUp"].value = 0.0
scenes.animate_shape_key(face, [(1, 0.0), (3, 1.0)])
scene.frame_set(3)
ev = face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
assert ev.attributes[fine_tree.SHRINKAGE_ATTR].domain == "CORNER"  # version 1
assert fine_tree.find_modifier(face).node_group["ewrinkles_fine_tree_version"] == 1
face["v1_shrinkage"] = fine_tree.shrinkage(face).ravel().tolist()
scene.frame_set(1)
bpy.ops.wm.save_as_mainfile(filepath=str(OUT), compress=True)
print(f"wrote {OUT} ({OUT.stat().st_size} bytes)")
bpy.ops.wm.read_factory_settings(use_empty=True)
