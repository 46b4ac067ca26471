"""The demo: build the sample scenes and render them with Cycles.

    python sample_scenes/demo.py [--out out] [--size 384] [--samples 24] [--quick]

First the showcase (``sample_scenes/showcase.py``): every method on the sample head through
six beats, neutral, surprise, anger, surprise with anger, smile, sadness with tears. Each
beat is rendered as four stills (front, three-quarter, the eye corner and the glabella,
``out/showcase_<beat>_<view>.png``) and the whole sequence as a clip, rendered frame by
frame (``out/clip/``), encoded by Blender's own video output (``out/showcase.mp4``) and as a
small looping GIF for the README (``out/showcase.gif``).

Then one scene per method, each on its own, rendered without and with its wrinkles: the
sample head's muscle wrinkles (``scanned_head``), its forehead lines as Bando's wrinkle
curves (``forehead_curves``), its wrinkle maps (``scanned_head_maps``), the fine wrinkles on
the back of a wrist (``hand``; Bando et al. 2002, Fig. 15) and the pattern layers with the
tears (``patterns``); then close-ups of the pattern layers and the tears over four frames
each (``sample_scenes/pattern_frames.py``). Every scene is saved as ``out/<scene>.blend``.

It writes ``out/contact_sheet.png`` (the showcase's beats, three rows, then one row per
scene, every row and column labelled), ``out/before_after.png`` (Surprise and Frowning of
the sample head, without / with) and ``out/pattern_frames.png``. It prints its progress as
it goes (scene i of N, render j of M with an ETA) and ends with the list of what it wrote.
Blender's own render log goes to ``out/render.log``.

``--quick`` renders only the showcase, which holds every method: its beats' front stills at
160 pixels and 6 samples, with 512-pixel map and fine-wrinkle images, no clip.
"""

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402, I001  (bpy first: it makes addon_utils importable)

from sample_scenes.lib import rendering  # noqa: E402

rendering.enable_addon()  # before the scenes import the add-on's modules

from sample_scenes import (  # noqa: E402
    forehead_curves,
    pattern_frames,
    scanned_head,
    scanned_head_maps,
    showcase,
)
from sample_scenes import hand as hand_scene  # noqa: E402
from sample_scenes import patterns as patterns_scene  # noqa: E402
from sample_scenes.lib import ict, scene_setup  # noqa: E402

log = rendering.log

#: (name, builder, without / with switch, its shots) of the scenes of one method each
JOBS = (("scanned_head", scanned_head.build, rendering.geometric_toggle, scanned_head.SHOTS),
        ("forehead_curves", forehead_curves.build, forehead_curves.toggle, forehead_curves.SHOTS),
        ("scanned_head_maps", scanned_head_maps.build, scanned_head_maps.toggle, scanned_head_maps.SHOTS),
        ("hand", hand_scene.build, hand_scene.toggle, hand_scene.SHOTS),
        ("patterns", patterns_scene.build, patterns_scene.toggle, patterns_scene.SHOTS))
CLIP_STEP = 2  # every other frame: a 12 fps clip


def close_up_cases():
    """The pattern close-ups the demo renders: those on the sample head (the procedural
    head's stay for the tests)."""
    return [c for c in pattern_frames.cases() if not c[0].endswith("_procedural")]
CLIP_SIZE = 256
CLIP_SAMPLES = 12


def stage_timings(scene):
    """The wrinkle stage's time per frame over the scene's range, measured around the
    add-on's own frame handlers, and the whole frame change's (``frame_set``), in ms; the
    first frame, which builds every source's static data, is given on its own."""
    handlers = bpy.app.handlers.frame_change_post
    ours = [h for h in handlers if getattr(h, "__module__", "").startswith("wrinkle_addon")]
    spent = []

    def timed(handler):
        def run(*args):
            t = time.perf_counter()
            handler(*args)
            spent[-1] += time.perf_counter() - t
        return run

    wrapped = {h: timed(h) for h in ours}
    for h in ours:
        handlers[handlers.index(h)] = wrapped[h]
    frames = []
    try:
        for f in range(scene.frame_start, scene.frame_end + 1):
            spent.append(0.0)
            t = time.perf_counter()
            scene.frame_set(f)
            frames.append(time.perf_counter() - t)
    finally:
        for h in ours:
            handlers[handlers.index(wrapped[h])] = h
    def median(a):
        return 1000.0 * sorted(a)[len(a) // 2]

    return {"stage_first_ms": 1000.0 * spent[0], "stage_ms_median": median(spent[1:]),
            "stage_ms_max": 1000.0 * max(spent[1:]), "frame_ms_median": median(frames[1:])}


def _showcase(out, size, samples, quick, progress):
    """Build, save and render the showcase; returns (stills by beat, mp4, gif, facts)."""
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    t = time.perf_counter()
    res = "512" if quick else "1024"
    face, lm = showcase.build(map_resolution=res, fine_resolution=res)
    facts = {"build_s": time.perf_counter() - t, "vertices": len(face.data.vertices)}
    scene = bpy.context.scene
    bpy.ops.wm.save_as_mainfile(filepath=str(out / "showcase.blend"))
    face = bpy.data.objects[face.name]
    facts.update(stage_timings(scene))
    log(f"showcase: {facts['vertices']} vertices, built in {facts['build_s']:.0f}s; per frame the "
        f"wrinkle stage takes {facts['stage_ms_median']:.0f} ms (median; {facts['stage_ms_max']:.0f} ms "
        f"at most), the whole frame change {facts['frame_ms_median']:.0f} ms; the first frame, which "
        f"builds the sources' static data, {facts['stage_first_ms'] / 1000:.1f} s")
    scene_setup.setup_cycles(scene, resolution=(size, size), samples=samples)
    stills = showcase.render_stills(face, lm, out, progress, which=["front"] if quick else None)
    mp4 = gif = None
    if not quick:
        scene_setup.setup_cycles(scene, resolution=(CLIP_SIZE, CLIP_SIZE), samples=CLIP_SAMPLES)
        t = time.perf_counter()
        mp4, gif, per_frame = showcase.render_clip(out, progress, step=CLIP_STEP)
        facts.update(clip_s=time.perf_counter() - t, clip_frame_s=per_frame)
        log(f"showcase clip: {len(showcase.clip_frames(CLIP_STEP))} frames in {facts['clip_s']:.0f}s "
            f"({per_frame:.1f}s a frame) -> {mp4.name} ({mp4.stat().st_size // 1024} KB), "
            f"{gif.name} ({gif.stat().st_size // 1024} KB)")
    return stills, mp4, gif, facts


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=str(ROOT / "out"), help="output folder")
    parser.add_argument("--size", type=int, default=384, help="render size in pixels")
    parser.add_argument("--samples", type=int, default=24, help="Cycles samples")
    parser.add_argument("--quick", action="store_true",
                        help="only the showcase's front stills, 160 px, 6 samples (under two minutes)")
    args = parser.parse_args(argv)
    if args.quick:
        args.size, args.samples = 160, 6
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    jobs = () if args.quick else JOBS
    views = 1 if args.quick else len(showcase.VIEWS)
    renders = len(showcase.BEATS) * views
    if not args.quick:
        bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
        renders += sum(2 * len(shots) for *_rest, shots in jobs)
        renders += sum(len(frames) for *_rest, frames in close_up_cases())
        last = showcase.beat_frames()[-1][2] + showcase.TAIL
        renders += len(range(1, last + 1, CLIP_STEP))
    scenes = 1 + len(jobs) + (0 if args.quick else 1)
    progress = rendering.Progress(renders)
    log(f"{scenes} scene(s), {renders} renders at {args.size} px and {args.samples} samples"
        + ("" if args.quick else f" (the clip at {CLIP_SIZE} px, {CLIP_SAMPLES} samples)"))
    ict.DRESS["on"] = True  # the sample head as Add Sample Head makes it: skin, eyes, lashes, teeth
    written = []

    log(f"scene 1/{scenes}: showcase")
    stills, mp4, gif, _facts = _showcase(out, args.size, args.samples, args.quick, progress)
    names = [v for v in showcase.VIEWS if not args.quick or v == "front"]
    rows = [[paths[k] for paths in stills.values()] for k in range(len(names))]
    row_names = [f"showcase: {v.replace('_', ' ')}" for v in names]
    captions = [[(beat, "") for beat in stills] for _ in names]
    written += [p for paths in stills.values() for p in paths] + [p for p in (mp4, gif) if p]

    for i, (name, builder, toggle, _shots) in enumerate(jobs, 2):
        log(f"scene {i}/{scenes}: {name}")
        row, row_captions = rendering.render_scene(name, builder, out, args.size, args.samples, toggle,
                                                   progress)
        rows.append(row)
        row_names.append(name)
        captions.append(row_captions)
    sheet = out / "contact_sheet.png"
    rendering.contact_sheet(rows, sheet, row_names=row_names, captions=captions)
    written.insert(0, sheet)
    if jobs:
        head = rows[len(names)]  # scanned_head: the README's before / after
        pick = [p for p in head if "surprise" in p.name or "frowning" in p.name]
        rendering.contact_sheet([pick[:2], pick[2:4]], out / "before_after.png")
        written.insert(1, out / "before_after.png")
        log(f"scene {scenes}/{scenes}: pattern close-ups")
        frames_out = out / "pattern_frames"
        frames_out.mkdir(exist_ok=True)
        case_names = [name for name, *_rest in close_up_cases()]
        frame_rows, frame_captions = pattern_frames.render(frames_out, args.size, args.samples, progress,
                                                           only=case_names)
        rendering.contact_sheet(frame_rows, out / "pattern_frames.png", row_names=case_names,
                                captions=frame_captions)
        written.insert(2, out / "pattern_frames.png")
    ict.DRESS["on"] = False
    log(f"done: {progress.count} renders, {progress.spent:.0f}s of rendering")
    print("\nThe demo wrote:", flush=True)
    for path in written:
        print(f"  {path}", flush=True)
    print(f"  {out}/*.blend (every scene, to open in Blender)", flush=True)
    bpy.ops.wm.read_factory_settings(use_empty=True)  # avoids the bpy 4.5 exit hang


if __name__ == "__main__":
    main(sys.argv[1:] if "--" not in sys.argv else sys.argv[sys.argv.index("--") + 1:])
