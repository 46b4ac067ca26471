# SPDX-License-Identifier: GPL-3.0-or-later
"""The wrinkle stage's share of a batch frame, and the farm bake's cost per frame.

Run:  .venv45/bin/python benchmarks/batch_render.py   (or .venv52)
      options: --size 960 540 --samples 64 --frames 20,44 --rounds 2 --bake-frames 12

The scene is the showcase (``sample_scenes/showcase.py``): the sample head dressed, with every
source active: the muscle set, wrinkle maps, wrinkle curves, fine wrinkles, pattern layers and
the tears.  Frames are rendered as the batch command renders them (``ewrinkles render``: an
animation render of one frame), Cycles on the CPU with a fixed seed.

``batch_overhead``
    The median over rounds and frames of (frame time with the wrinkles) / (frame time
    without) - 1.  *Without*: the same frame with the add-on's frame handler out of
    ``frame_change_post``, so nothing of ours runs; the scene, its materials and its
    topology are the same.  Each round renders every frame both ways, in reversed order
    every other round, so that drift cancels.  Goal: at most 0.02.
``stage_share``
    The handler's own time (timed inside it, as ``--json`` reports ``stage_ms``) over the
    frame time with the wrinkles: the same share without the render's noise.
``bake_s_per_frame``
    Bake for Farm (``wrinkle.bake``, every source) over ``--bake-frames`` frames, per frame.
"""

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402, I001
import addon_utils  # noqa: E402


def log(msg):
    print(f"[batch_render] {msg}", file=sys.stderr, flush=True)


def _render(scene, f, tmp):
    scene.frame_start = scene.frame_end = f
    scene.render.filepath = str(Path(tmp) / "frame_####")
    t = time.perf_counter()
    bpy.ops.render.render(animation=True)
    return time.perf_counter() - t


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, nargs=2, default=(960, 540))
    ap.add_argument("--samples", type=int, default=64)
    ap.add_argument("--frames", default="20,44", help="frames to time (default: surprise and anger held)")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--bake-frames", type=int, default=12)
    args = ap.parse_args(argv)
    # stdout holds only the JSON line: Blender's render log (C level) goes to stderr
    sys.stdout.flush()
    out = os.fdopen(os.dup(1), "w")
    os.dup2(2, 1)
    from sample_scenes import showcase
    from sample_scenes.lib import scene_setup
    from wrinkle_addon.glue import pipeline

    addon_utils.enable("wrinkle_addon", default_set=True)
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    t = time.perf_counter()
    face, _lm = showcase.build()
    log(f"showcase built in {time.perf_counter() - t:.0f} s ({len(face.data.vertices)} vertices)")
    scene = bpy.context.scene
    scene_setup.setup_cycles(scene, resolution=args.size, samples=args.samples, denoise=False)
    frames = [int(f) for f in args.frames.split(",")]
    handler = pipeline.on_frame_change_post
    with_s, without_s, shares = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        _render(scene, frames[0], tmp)  # warm-up: kernels, BVH, images
        for r in range(args.rounds):
            for f in frames:
                pair = {}
                for live in ((True, False) if r % 2 == 0 else (False, True)):
                    if not live:
                        bpy.app.handlers.frame_change_post.remove(handler)
                    pipeline.stage_seconds[0] = 0.0
                    try:
                        pair[live] = _render(scene, f, tmp)
                    finally:
                        if not live:
                            bpy.app.handlers.frame_change_post.append(handler)
                    if live:
                        shares.append(pipeline.stage_seconds[0] / pair[live])
                with_s.append(pair[True])
                without_s.append(pair[False])
                log(f"round {r + 1}, frame {f}: {pair[True]:.1f} s with, {pair[False]:.1f} s without")
        bpy.ops.wm.save_as_mainfile(filepath=str(Path(tmp) / "shot.blend"))
        face = bpy.data.objects[face.name]
        for ob in bpy.context.view_layer.objects:
            ob.select_set(False)
        bpy.context.view_layer.objects.active = face
        face.select_set(True)
        t = time.perf_counter()
        assert bpy.ops.wrinkle.bake(frame_start=1, frame_end=args.bake_frames) == {"FINISHED"}
        bake_s = time.perf_counter() - t
    ratios = [w / wo - 1 for w, wo in zip(with_s, without_s)]
    print(json.dumps({
        "batch_overhead": round(statistics.median(ratios), 4),
        "batch_overhead_each": [round(x, 4) for x in ratios],
        "stage_share": round(statistics.median(shares), 5),
        "frame_s_with": round(statistics.median(with_s), 2),
        "frame_s_without": round(statistics.median(without_s), 2),
        "bake_s_per_frame": round(bake_s / args.bake_frames, 3),
        "vertices": len(face.data.vertices), "size": list(args.size), "samples": args.samples,
        "frames": frames, "rounds": args.rounds, "blender": bpy.app.version_string,
    }), file=out, flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])
    sys.stdout.flush()
    os._exit(0)  # bpy 4.5 can hang at interpreter exit
