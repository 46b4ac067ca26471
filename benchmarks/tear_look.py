# SPDX-License-Identifier: GPL-3.0-or-later
"""Does the shedding tear read as water on the skin, or as a dark cut?  Two numbers, in Cycles
and in EEVEE.

Run:  .venv45/bin/python benchmarks/tear_look.py --engine both --out DIR   (or .venv52)
      options: --engine CYCLES|EEVEE|both  --size 512  --samples 32  --frame 20

Prints one JSON line per engine on stdout::

    {"face": "ict", "expression": "tear", "engine": "CYCLES", "tear_luminance_ratio": 0.98,
     "tear_highlight_ratio": 2.1, "closeup": {...}, ...}

The scene is the demo's: the ICT head (the add-on's sample head) as
``sample_scenes/patterns.py`` builds it (``build_ict``: its portrait rig, lights and world,
the pattern layers, the dripping tear and the shedding tear down the left cheek), on frame 20
(the demo's "Smile" shot: the shedding tear halfway down, its head on the cheek; the dripping
tear has not formed yet).  It is rendered at the demo's 512 px through the demo's camera
(``sample_scenes/demo.py``; Cycles at 32 samples as the demo renders, EEVEE at 32 samples),
and again through the demo's close-up of the tear (``sample_scenes/pattern_frames.py``, the
orthographic camera in front of the cheek).  Each view is rendered twice, the tear shown and
the tear hidden from render (``hide_render``), to linear OpenEXR.

How each number is measured, per view:

``tear`` pixels
    A third render of the same view in Cycles, with every object's material swapped for an
    emission: the tear red, the face green, everything else and the world black.  Its red
    channel is how much of each pixel the tear covers, unoccluded; the tear's pixels are
    those it covers at least half of.  (The same camera and geometry in both engines: the
    coverage does not depend on the engine.)
``tear_luminance_ratio``
    The mean linear luminance (Rec. 709: 0.2126 R + 0.7152 G + 0.0722 B) of the tear's
    pixels in the render with the tear, over the mean of the same pixels in the render
    without it.  1: the skin under the tear is as bright as bare skin; a dark cut is well
    below 1; the goal is at least 0.9.
``tear_highlight_ratio``
    The brightest tear pixel (linear luminance, render with the tear) over the brightest skin
    pixel nearby in the render without it.  "Nearby" is a band around the tear: the tear's
    pixels grown by three tear widths (the width is the tear's pixel count over its length,
    the spread of its pixels along their main axis), kept where the face covers the pixel
    (green, with the red, at least half).  Above 1: the film's highlights outshine the
    skin's own around it, as water's do.

The figures of the demo's view are the line's ``tear_luminance_ratio`` and
``tear_highlight_ratio``; ``closeup`` holds the same for the close-up, and each view's
``tear_pixels``.  With ``--out`` the renders are kept there (``<view>_<engine>_with.png`` and
``_without.png``, through the scene's view transform, and the ``.exr`` files).

:func:`measure` is the entry point for ``benchmarks/realism.py``.
"""

import argparse
import json
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

FRAME = 20
SIZE = 512
SAMPLES = 32
LUMA = np.array([0.2126, 0.7152, 0.0722])
BAND_WIDTHS = 3.0  # the band of "skin nearby": three tear widths around it


def log(msg):
    print(f"[tear_look] {msg}", file=sys.stderr, flush=True)


def engine_id(engine):
    """Blender's id of ``engine`` ("CYCLES" or "EEVEE") on this version."""
    import bpy

    if engine.upper() == "CYCLES":
        return "CYCLES"
    return "BLENDER_EEVEE_NEXT" if bpy.app.version < (5, 0, 0) else "BLENDER_EEVEE"


def build():
    """The demo's ICT scene (``sample_scenes/patterns.build_ict``): ``(scene, face, tear)``."""
    import addon_utils
    import bpy

    addon_utils.enable("wrinkle_addon", default_set=True)
    from sample_scenes import patterns

    if not patterns.available():
        raise SystemExit(f"tear_look: {patterns.DATA} not found")
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    face, _shots = patterns.build_ict()
    tear = next(o for o in bpy.data.objects if o.name.endswith(" Tear"))
    return bpy.context.scene, face, tear


def _setup(scene, engine, size, samples):
    from sample_scenes.lib import scene_setup

    scene_setup.setup_cycles(scene, resolution=(size, size), samples=samples)
    scene.render.engine = engine_id(engine)
    if engine.upper() != "CYCLES":
        scene.eevee.taa_render_samples = samples
    settings = scene.render.image_settings
    settings.file_format = "OPEN_EXR"
    settings.color_mode = "RGBA"
    settings.color_depth = "32"


def _render(scene, path, png=None):
    """Render ``scene`` to the EXR ``path``; its linear pixels (H, W, 4), top row first, and
    a PNG through the view transform at ``png``."""
    import bpy

    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    image = bpy.data.images.load(str(path), check_existing=False)
    try:
        w, h = image.size
        px = np.empty(w * h * 4, np.float32)
        image.pixels.foreach_get(px)
        if png is not None:
            settings = scene.render.image_settings
            settings.file_format, settings.color_depth = "PNG", "8"
            try:
                image.save_render(str(png), scene=scene)
            finally:
                settings.file_format, settings.color_depth = "OPEN_EXR", "32"
    finally:
        bpy.data.images.remove(image)
    return px.reshape(h, w, 4)[::-1]


def _emission(name, colour):
    import bpy

    from wrinkle_addon.glue.nodes import use_nodes

    mat = bpy.data.materials.get(name) or bpy.data.materials.new(name)
    use_nodes(mat)
    nt = mat.node_tree
    nt.nodes.clear()
    em = nt.nodes.new("ShaderNodeEmission")
    em.inputs["Color"].default_value = (*colour, 1.0)
    em.inputs["Strength"].default_value = 1.0
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(em.outputs[0], out.inputs["Surface"])
    return mat


def coverage(scene, face, tear, path):
    """(tear, face) coverage (H, W) each in [0, 1] of the current view: a Cycles render with
    emissions only (module docstring)."""
    engine, samples = scene.render.engine, scene.cycles.samples
    red, green, black = (_emission(f"tear_look {n}", c) for n, c in
                         (("tear", (1, 0, 0)), ("face", (0, 1, 0)), ("other", (0, 0, 0))))
    saved = []
    for ob in scene.objects:
        for slot in getattr(ob, "material_slots", ()):
            saved.append((slot, slot.material))
            slot.material = red if ob == tear else green if ob == face else black
    world = scene.world.node_tree.nodes
    background = next(n for n in world if n.type == "BACKGROUND")
    strength = background.inputs["Strength"].default_value
    background.inputs["Strength"].default_value = 0.0
    try:
        scene.render.engine = "CYCLES"
        scene.cycles.samples = 16
        px = _render(scene, path)
    finally:
        for slot, mat in saved:
            slot.material = mat
        background.inputs["Strength"].default_value = strength
        scene.render.engine, scene.cycles.samples = engine, samples
    return np.clip(px[..., 0], 0, 1), np.clip(px[..., 1], 0, 1)


def _grow(mask, r):
    """``mask`` grown by ``r`` pixels (a square neighbourhood)."""
    out = mask.copy()
    for _ in range(int(r)):
        grown = out.copy()
        grown[1:] |= out[:-1]
        grown[:-1] |= out[1:]
        grown[:, 1:] |= out[:, :-1]
        grown[:, :-1] |= out[:, 1:]
        out = grown
    return out


def figures(with_tear, without, tear_cover, face_cover):
    """The view's figures from its renders (linear, (H, W, 4)) and coverages (module
    docstring)."""
    lum_with = with_tear[..., :3] @ LUMA
    lum_without = without[..., :3] @ LUMA
    tear = tear_cover >= 0.5
    n = int(tear.sum())
    if n == 0:
        return {"tear_pixels": 0, "tear_luminance_ratio": None, "tear_highlight_ratio": None}
    yx = np.argwhere(tear).astype(np.float64)
    yx -= yx.mean(axis=0)
    axis = np.linalg.svd(yx, full_matrices=False)[2][0]
    length = max(float(np.ptp(yx @ axis)), 1.0)
    width = n / length
    band = _grow(tear, max(2, round(BAND_WIDTHS * width))) & (tear_cover + face_cover >= 0.5)
    return {
        "tear_pixels": n,
        "tear_width_px": round(width, 2),
        "tear_luminance_ratio": float(lum_with[tear].mean() / max(lum_without[tear].mean(), 1e-12)),
        "tear_highlight_ratio": float(lum_with[tear].max() / max(lum_without[band].max(), 1e-12)),
        "skin_under_tear": float(lum_without[tear].mean()),
        "tear_mean": float(lum_with[tear].mean()),
        "tear_max": float(lum_with[tear].max()),
        "skin_band_max": float(lum_without[band].max()),
    }


def _views(scene, face):
    """The views: the demo's camera as it is, then the demo's close-up of the tear."""
    from sample_scenes import pattern_frames, patterns

    yield "demo"
    centre, width = pattern_frames._spots(patterns.LANDMARKS)["tear"]
    pattern_frames._close_up(scene, face, centre, width)
    yield "closeup"


def measure(engine, out_dir=None, size=SIZE, samples=SAMPLES, frame=FRAME, built=None):
    """The tear's figures in ``engine`` ("CYCLES" or "EEVEE") as a dict (module docstring);
    renders kept in ``out_dir`` when given.  ``built``: a ``(scene, face, tear)`` from
    :func:`build` to reuse (its camera is left on the close-up)."""
    import bpy

    scene, face, tear = built or build()
    tmp = None
    if out_dir is None:
        tmp = tempfile.TemporaryDirectory(prefix="tear_look_")
        out = Path(tmp.name)
    else:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
    camera = scene.camera.matrix_world.copy(), scene.camera.data.type, scene.camera.data.ortho_scale
    result = {"face": "ict", "expression": "tear", "engine": engine.upper(), "frame": frame, "size": size,
              "blender": bpy.app.version_string}
    try:
        _setup(scene, engine, size, samples)
        scene.frame_set(frame)
        for view in _views(scene, face):
            name = f"{view}_{engine.lower()}"
            log(f"{engine} {view}: coverage, with and without the tear")
            tear_cover, face_cover = coverage(scene, face, tear, out / f"{view}_mask.exr")
            tear.hide_render = False
            shown = _render(scene, out / f"{name}_with.exr", out / f"{name}_with.png")
            tear.hide_render = True
            hidden = _render(scene, out / f"{name}_without.exr", out / f"{name}_without.png")
            tear.hide_render = False
            got = figures(shown, hidden, tear_cover, face_cover)
            log(f"{engine} {view}: {got}")
            if view == "demo":
                result.update(got)
            else:
                result[view] = got
    finally:
        tear.hide_render = False
        scene.camera.matrix_world, scene.camera.data.type, scene.camera.data.ortho_scale = camera
        if tmp is not None:
            tmp.cleanup()
    return result


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--engine", default="both", choices=("CYCLES", "EEVEE", "both"))
    parser.add_argument("--out", default=None, help="keep the renders in this folder")
    parser.add_argument("--size", type=int, default=SIZE)
    parser.add_argument("--samples", type=int, default=SAMPLES)
    parser.add_argument("--frame", type=int, default=FRAME)
    args = parser.parse_args(argv)
    import bpy

    built = build()
    for engine in (("CYCLES", "EEVEE") if args.engine == "both" else (args.engine,)):
        out = None if args.out is None else Path(args.out)
        print(json.dumps(measure(engine, out, args.size, args.samples, args.frame, built)), flush=True)
    bpy.ops.wm.read_factory_settings(use_empty=True)  # bpy 4.5 can hang at exit otherwise
    return 0


if __name__ == "__main__":
    sys.exit(main())
