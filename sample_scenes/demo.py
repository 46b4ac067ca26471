"""The demo: build the sample scenes and render them with Cycles, without and with wrinkles.

    python sample_scenes/demo.py [--out out] [--size 512] [--samples 32] [--quick]

For each scene (the procedural head, the forehead patch, and, when
../shared/data/ict_head.npz exists, the scanned ICT head with geometric wrinkles, its
forehead with wrinkle curves (Bando et al. 2002: three forehead lines raised by the brow
raise; the row above shows the muscles' wrinkles of the same pose, Surprise) and the head
again with generated wrinkle maps, and the back of a wrist with fine wrinkles (Bando et al.
2002, Fig. 15: deeper where the bend folds the skin, fainter where it stretches), and pattern
layers (crow's feet and dimples with the smile, frown furrows with the lowered brows; on the
ICT head when it exists, else on the procedural head)) it saves
the .blend, renders each expression frame twice -
wrinkles off (the same deformation, no wrinkles) and on - and writes
``out/contact_sheet.png``: one row per scene, each expression as a without/with pair,
labelled with the scene's name and the expression's (sample_scenes/lib/labels.py), and
``out/before_after.png``: Surprise and Frowning of the ICT head (or the procedural head),
without / with, and ``out/pattern_frames.png``: close-ups of the pattern layers and the tears
over four frames each (sample_scenes/pattern_frames.py).
Blender's own render log goes to ``out/render.log``.
"""

import argparse
import contextlib
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402, I001  (bpy first: it makes addon_utils importable)
import addon_utils  # noqa: E402
import numpy as np  # noqa: E402

# Enabled before the sample scenes are imported, since they import the add-on's modules:
# addon_utils.enable() on an add-on that was already imported the ordinary way prints
# "module changed on disk: ... reloading..." and executes its __init__ a second time.
if addon_utils.enable("wrinkle_addon", default_set=True) is None:
    raise SystemExit("demo: the wrinkle_addon add-on did not load (see the message above)")

from sample_scenes import (  # noqa: E402
    forehead_curves,
    forehead_patch,
    head,
    pattern_frames,  # noqa: E402
    scanned_head,
    scanned_head_maps,
)
from sample_scenes import hand as hand_scene  # noqa: E402
from sample_scenes import patterns as patterns_scene  # noqa: E402
from sample_scenes.lib import labels, scene_setup  # noqa: E402

_T0 = time.perf_counter()


def log(msg):
    print(f"[demo {time.perf_counter() - _T0:6.1f}s] {msg}", flush=True)


@contextlib.contextmanager
def quiet(log_path):
    """Send Blender's own per-tile render chatter (C-level stdout/stderr) to a log file."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    with open(log_path, "ab") as log:
        os.dup2(log.fileno(), 1)
        os.dup2(log.fileno(), 2)
        try:
            yield
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])


def load_rgba(path):
    img = bpy.data.images.load(str(path), check_existing=False)
    w, h = img.size
    px = np.empty(w * h * 4, np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(h, w, 4)


def save_rgba(pixels, path):
    h, w, _ = pixels.shape
    img = bpy.data.images.new("contact_sheet", w, h, alpha=True)
    img.pixels.foreach_set(np.ascontiguousarray(pixels, np.float32).ravel())
    img.filepath_raw = str(path)
    img.file_format = "PNG"
    img.save()
    bpy.data.images.remove(img)


def contact_sheet(rows, path, gap=8, row_names=None, captions=None):
    """rows: list of lists of image paths. row_names (one per row) and captions (per row, one
    (expression, "without" / "with") per image) are drawn into the sheet; see
    sample_scenes/lib/labels.py. Blender's bottom-up pixel order is handled here."""
    tiles = [[load_rgba(p)[::-1] for p in row] for row in rows]  # top row first
    save_rgba(labels.sheet(tiles, gap=gap, row_names=row_names, captions=captions)[::-1], path)


def geometric_toggle(face, on):
    face.ewrinkles_face.strength = 1.0 if on else 0.0


def render_scene(name, builder, out, size, samples, toggle=geometric_toggle):
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    log(f"{name}: building")
    face, shots = builder()
    scene = bpy.context.scene
    scene_setup.setup_cycles(scene, resolution=(size, size), samples=samples)
    log(f"{name}: {len(face.data.vertices)} vertices, "
        f"{len(face.ewrinkles_face.muscles)} muscles; saving {name}.blend")
    bpy.ops.wm.save_as_mainfile(filepath=str(out / f"{name}.blend"))
    face = bpy.data.objects[face.name]
    scene = bpy.context.scene
    row, captions = [], []
    for shot, frame in shots.items():
        for label, on in (("without", False), ("with", True)):
            toggle(face, on)
            scene.frame_set(frame)
            path = out / f"{name}_{shot.lower().replace(' + ', '_').replace(' ', '_')}_{label}.png"
            scene.render.filepath = str(path)
            t = time.perf_counter()
            with quiet(out / "render.log"):
                bpy.ops.render.render(write_still=True)
            log(f"{name}: {shot} {label} wrinkles -> {path.name} ({time.perf_counter() - t:.1f}s)")
            row.append(path)
            captions.append((shot, label))
    toggle(face, True)
    return row, captions


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=str(ROOT / "out"), help="output folder")
    parser.add_argument("--size", type=int, default=512, help="render size in pixels")
    parser.add_argument("--samples", type=int, default=32, help="Cycles samples")
    parser.add_argument("--quick", action="store_true", help="256 px, 8 samples")
    args = parser.parse_args(argv)
    if args.quick:
        args.size, args.samples = 256, 8
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    jobs = [("forehead_patch", forehead_patch.build, geometric_toggle),
            ("head", head.build, geometric_toggle)]
    if scanned_head.available():
        jobs.append(("scanned_head", scanned_head.build, geometric_toggle))
        jobs.append(("forehead_curves", forehead_curves.build, forehead_curves.toggle))
        jobs.append(("scanned_head_maps", scanned_head_maps.build, scanned_head_maps.toggle))
    else:
        log(f"skipping the ICT head: {scanned_head.DATA} not found")
    jobs.append(("hand", hand_scene.build, hand_scene.toggle))  # fine wrinkles (Bando 2002 Fig. 15)
    jobs.append(("patterns", patterns_scene.build, patterns_scene.toggle))  # pattern functions
    rows, captions = [], []
    for i, (name, builder, toggle) in enumerate(jobs, 1):
        log(f"scene {i}/{len(jobs)}: {name}")
        row, row_captions = render_scene(name, builder, out, args.size, args.samples, toggle)
        rows.append(row)
        captions.append(row_captions)
    sheet = out / "contact_sheet.png"
    contact_sheet(rows, sheet, row_names=[j[0] for j in jobs], captions=captions)
    # README picture: the geometric head's Surprise and Frowning, without / with
    geometric = [r for (name, _b, t), r in zip(jobs, rows) if t is geometric_toggle][-1]
    pick = [p for p in geometric if "surprise" in p.name or "frowning" in p.name]
    contact_sheet([pick[:2], pick[2:4]], out / "before_after.png")
    log(f"contact sheet -> {sheet} (rows: {', '.join(j[0] for j in jobs)}; "
        "each expression as a without / with wrinkles pair)")
    # close-ups of the pattern layers and the tears, four frames each
    frames_out = out / "pattern_frames"
    frames_out.mkdir(exist_ok=True)
    rows, captions = pattern_frames.render(frames_out, args.size, args.samples, log=log, quiet=quiet)
    names = [name for name, *_rest in pattern_frames.cases()]
    contact_sheet(rows, out / "pattern_frames.png", row_names=names, captions=captions)
    log(f"pattern close-ups -> {out / 'pattern_frames.png'} (rows: {', '.join(names)})")
    bpy.ops.wm.read_factory_settings(use_empty=True)  # avoids the bpy 4.5 exit hang


if __name__ == "__main__":
    main(sys.argv[1:] if "--" not in sys.argv else sys.argv[sys.argv.index("--") + 1:])
