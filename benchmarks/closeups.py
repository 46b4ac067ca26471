# SPDX-License-Identifier: GPL-3.0-or-later
"""Close-ups of the muscle wrinkles where people look at them, without and with wrinkles.

Run:  .venv45/bin/python benchmarks/closeups.py --out DIR   [--npz PATH] [--size 320]
      [--samples 24] [--shots forehead,glabella,anger,eye,mouth]

Builds the face as ``benchmarks/realism.py`` builds it (the ICT head, or ``--npz`` for any
head with its layout; the facial muscle set, wrinkles only, the regions refined), poses it
with its ARKit shape keys and renders, in Cycles with the sample scenes' portrait lights, one
orthographic close-up per shot, first with *Enable Wrinkles* off and then on:

* ``forehead``: brow raise, the forehead from the brows to the hairline;
* ``glabella``: brow down, between the brows;
* ``anger``: brow down and nose sneer, between the brows and the root of the nose;
* ``eye``: squint (eyeSquint + cheekSquint), the character's left outer eye corner, seen from
  30 degrees to that side;
* ``mouth``: smile, the character's left mouth corner;
* ``eye_R``, ``mouth_R``: the same of the character's right side, mirrored (a symmetric
  expression on a symmetric head should look the same on both).

Writes ``DIR/<face>_<shot>_{off,on}.png`` and a contact sheet ``DIR/<face>_closeups.png``
(a row per shot: without, with).  Prints one JSON line per shot (face, shot, files, render
seconds) on stdout; progress goes to stderr.
"""

import argparse
import json
import math
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402, I001
import addon_utils  # noqa: E402
import numpy as np  # noqa: E402
from mathutils import Vector  # noqa: E402

POSES = {
    "forehead": {"browInnerUp_L": 1, "browInnerUp_R": 1, "browOuterUp_L": 1, "browOuterUp_R": 1},
    "glabella": {"browDown_L": 1, "browDown_R": 1},
    "anger": {"browDown_L": 1, "browDown_R": 1, "noseSneer_L": 1, "noseSneer_R": 1},
    "eye": {"eyeSquint_L": 1, "eyeSquint_R": 1, "cheekSquint_L": 1, "cheekSquint_R": 1},
    "mouth": {"mouthSmile_L": 1, "mouthSmile_R": 1},
}
POSES["eye_R"], POSES["mouth_R"] = POSES["eye"], POSES["mouth"]  # the character's right side


def log(msg):
    print(f"[closeups] {msg}", file=sys.stderr, flush=True)


def shot_view(name, lm):
    """(centre (3,), ortho width, azimuth in degrees toward the character's left) of a shot,
    from the face-local landmarks ``lm`` (metres); a ``_R`` shot is its left one mirrored
    about the glabella."""
    g, eye, mouth = lm["glabella"], lm["eye_L"], lm["mouth_corner_L"]
    if name.endswith("_R"):
        centre, width, azimuth = shot_view(name[:-2], lm)
        centre = centre.copy()
        centre[0] = 2.0 * g[0] - centre[0]
        return centre, width, -azimuth
    e = 2.0 * abs(eye[0] - g[0])
    if name == "forehead":
        top = lm["hairline_center"]
        return np.array([g[0], g[1], 0.5 * (g[2] + top[2]) + 0.1 * e]), 1.9 * e, 0.0
    if name in ("glabella", "anger"):
        return np.array([g[0], g[1], g[2] - 0.15 * e]), 0.8 * e, 0.0
    if name == "eye":
        return np.array([eye[0] + 0.45 * e, eye[1] + 0.2 * e, eye[2]]), 0.8 * e, 30.0
    return np.array([mouth[0] + 0.1 * e, mouth[1], mouth[2] + 0.1 * e]), 0.8 * e, 10.0


def camera_for(scene, face, centre, width, azimuth):
    cam = scene.camera
    if cam is None:
        cam = bpy.data.objects.new("CloseupCamera", bpy.data.cameras.new("CloseupCamera"))
        scene.collection.objects.link(cam)
        scene.camera = cam
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = float(width)
    cam.data.clip_start, cam.data.clip_end = 0.001, 10.0
    a = math.radians(azimuth)
    direction = Vector((math.sin(a), -math.cos(a), 0.0))  # from the face toward the camera
    target = face.matrix_world @ Vector(centre)
    cam.location = target + 0.5 * direction
    cam.rotation_mode = "QUATERNION"
    cam.rotation_quaternion = (-direction).to_track_quat("-Z", "Y")


def render(scene, path):
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)


def main(argv):
    from benchmarks import realism
    from sample_scenes.lib import ict, rendering, scene_setup

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", required=True, help="the folder for the PNGs")
    ap.add_argument("--npz", default=None, help="a head file with the ICT layout (default: the ICT head)")
    ap.add_argument("--size", type=int, default=320, help="pixels per close-up")
    ap.add_argument("--samples", type=int, default=24, help="Cycles samples")
    ap.add_argument("--shots", default=",".join(POSES), help="comma-separated: " + ", ".join(POSES))
    args = ap.parse_args(argv)
    shots = [s.strip() for s in args.shots.split(",") if s.strip()]
    bad = [s for s in shots if s not in POSES]
    if bad:
        log(f"unknown shots {bad}: choose from {list(POSES)}")
        sys.exit(2)
    path = Path(args.npz) if args.npz else ict.DEFAULT_PATH
    if not path.exists():
        log(f"{path} not found")
        sys.exit(2)
    name = "ict" if args.npz is None else path.stem
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    addon_utils.enable("wrinkle_addon", default_set=True)
    realism.ICT_POSES = {s: POSES[s] for s in shots}
    try:
        bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
        face, landmarks, frames = realism.build_ict(path)[:3]
        scene = bpy.context.scene
        scene_setup.setup_cycles(scene, (args.size, args.size), samples=args.samples)
        scene_setup.add_portrait_rig(scene, face)
        lm = {k: np.asarray(v, float) for k, v in landmarks.items()}
        rows = []
        for i, shot in enumerate(shots):
            centre, width, azimuth = shot_view(shot, lm)
            camera_for(scene, face, centre, width, azimuth)
            files = []
            t = time.perf_counter()
            for state in ("off", "on"):
                face.ewrinkles_face.enabled = state == "on"
                scene.frame_set(frames[shot])
                f = out / f"{name}_{shot}_{state}.png"
                render(scene, f)
                files.append(f)
            rows.append(files)
            secs = time.perf_counter() - t
            log(f"{i + 1}/{len(shots)} {shot}: {secs:.1f} s")
            print(json.dumps({"face": name, "shot": shot, "files": [str(f) for f in files],
                              "render_s": round(secs, 1)}), flush=True)
        rendering.contact_sheet(rows, out / f"{name}_closeups.png", gap=4)
        log(f"contact sheet {out / f'{name}_closeups.png'}")
    finally:
        bpy.ops.wm.read_factory_settings(use_empty=True)  # bpy 4.5 hangs at exit otherwise


if __name__ == "__main__":
    main(sys.argv[1:])
