# SPDX-License-Identifier: GPL-3.0-or-later
"""Does a wrinkle-map package, imported onto a face, render as the face that exported it?

Run:  .venv45/bin/python benchmarks/package_round_trip.py   [--size 512] [--samples 16] [--out DIR]

Builds the ICT head with the demo's wrinkle maps exactly as
``sample_scenes/scanned_head_maps.py`` sets them up (maps baked from the muscles, masks
from their regions, Table 1.1 bound to the ARKit shape keys), keys Surprise on frame 2 and
Anger on frame 3, and exports the wrinkle-map package of frames 1-3
(``glue.export.package``).  Then, in an empty file, it builds the same head with no
muscles and no maps, keys the same shape keys, imports the package
(``package.read``) and renders both, with the same camera, lights and samples.  (The
demo's muscles refine the head's mesh where they wrinkle; the importing head is refined
alike and its muscles deleted, so both faces have the same mesh and shape keys.)

Prints one JSON line per pose: ``max_abs`` and ``mean_abs`` (the difference of the two
renders, display values 0-1, over the face's pixels), ``maps_effect`` (the mean
difference the maps make on the exporting face: its render with Strength 0 against its
render with the maps) and ``ratio`` = mean_abs / maps_effect (0: identical).  With
``--out`` it keeps the renders and ``package_round_trip.png``: a row per pose, the
exporting face without maps, with them, and the importing face.
"""

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402, I001
import addon_utils  # noqa: E402
import numpy as np  # noqa: E402

from benchmarks.map_look import POSES  # noqa: E402

NPZ = ROOT / "wrinkle_addon" / "data" / "ict_head.npz"
FRAMES = {"surprise": 2, "anger": 3}


def log(msg):
    print(f"[package_round_trip] {msg}", file=sys.stderr, flush=True)


def _head(size, samples):
    from sample_scenes.lib import ict, rigging, scene_setup

    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    scene = bpy.context.scene
    scene_setup.setup_cycles(scene, (size, size), samples=samples, denoise=False)
    scene.cycles.seed = 0
    data = ict.load_ict(NPZ)
    face = ict.ict_object(data, name="ICTHead")
    scene_setup.add_portrait_rig(scene, face, view="front", frame_scale=1.35)
    rigging.key_shape_keys(face, {1: {}, **{FRAMES[p]: POSES[p] for p in FRAMES}})
    scene.frame_start, scene.frame_end = 1, 3
    return scene, face, data


def _render(scene, frame, path):
    from sample_scenes.lib import rendering

    scene.frame_set(frame)
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    return rendering.load_rgba(path)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--samples", type=int, default=16)
    parser.add_argument("--out")
    ns = parser.parse_args(argv)
    addon_utils.enable("wrinkle_addon", default_set=True)
    from sample_scenes import scanned_head_maps
    from sample_scenes.lib import rendering, rigging
    from wrinkle_addon.glue.export import package

    out = Path(ns.out or tempfile.mkdtemp(prefix="ewrinkles-package-"))
    out.mkdir(parents=True, exist_ok=True)
    log("the exporting face: muscles, baked maps, Table 1.1 ...")
    scene, face, data = _head(ns.size, ns.samples)
    rigging.wrinkle_face(face, data["landmarks"], wrinkles_only=True)
    scanned_head_maps.set_up_maps(face)
    report = package.write(bpy.context, face, str(out / "package"), 1, 3)
    log(f"package: {report['files']}")
    shots = {}
    for pose, f in FRAMES.items():
        log(f"rendering {pose}, exporting face")
        face.ewrinkles_face.maps.strength = 0.0
        shots[pose, "none"] = _render(scene, f, out / f"{pose}_none.png")
        face.ewrinkles_face.maps.strength = 1.0
        shots[pose, "exporting"] = _render(scene, f, out / f"{pose}_exporting.png")
    log("the importing face: the same head and mesh (refined alike), no muscles, no maps; the package")
    scene, face, data = _head(ns.size, ns.samples)
    rigging.wrinkle_face(face, data["landmarks"], wrinkles_only=True)  # the same refined mesh
    rigging.activate(face)
    bpy.ops.wrinkle.disable(remove_muscles=True)
    unbound = package.read(bpy.context, face, str(out / "package"))
    for pose, f in FRAMES.items():
        log(f"rendering {pose}, importing face")
        shots[pose, "imported"] = _render(scene, f, out / f"{pose}_imported.png")
    for pose in FRAMES:
        a, b, c = (shots[pose, k][..., :3] for k in ("exporting", "imported", "none"))
        where = shots[pose, "exporting"][..., 3] > 0.5 if np.any(shots[pose, "exporting"][..., 3] < 1) else \
            np.ones(a.shape[:2], bool)
        diff = np.abs(a - b)[where]
        effect = float(np.abs(a - c)[where].mean())
        print(json.dumps({"face": "ict", "expression": pose, "max_abs": round(float(diff.max()), 5),
                          "mean_abs": round(float(diff.mean()), 6), "maps_effect": round(effect, 5),
                          "ratio": round(float(diff.mean()) / max(effect, 1e-9), 4), "unbound": unbound,
                          "blender": bpy.app.version_string}), flush=True)
    kinds = ("none", "exporting", "imported")
    words = [("exporting", "no maps"), ("exporting", "maps"), ("imported", "package")]
    rendering.contact_sheet([[out / f"{p}_{k}.png" for k in kinds] for p in FRAMES],
                            out / "package_round_trip.png", row_names=list(FRAMES),
                            captions=[words for _ in FRAMES])
    log(f"sheet: {out / 'package_round_trip.png'}")


if __name__ == "__main__":
    code = 0
    try:
        main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else None)
    except BaseException:  # noqa: BLE001 - printed, then the exit code says it
        import traceback

        traceback.print_exc()
        code = 1
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)  # bpy can hang at interpreter exit (docs/architecture.md, "Exit")
