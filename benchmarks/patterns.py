# SPDX-License-Identifier: GPL-3.0-or-later
"""Pattern-function layers and shedding tears: what 10 layers and 2 tears add to a frame of
a 50k-vertex face.

Run:  .venv45/bin/python benchmarks/patterns.py   (or .venv52)
      options: --verts 50000  --layers 10  --tears 2  --frames 40  --warm 5  --repeats 6

Prints one JSON line, ``{"patterns_frame_ms": ..., "frame_empty_rebuild_ms": ...,
"layers_floor_ratio": ..., "patterns": {...}}``:

``patterns_frame_ms``
    What ``--layers`` (10) pattern layers and ``--tears`` (2) shedding tears add to a frame
    on top of the output stage, on the
    face and rig of ``benchmarks/frame_update.py`` (``Bench.build``: headgen's head with its
    UV map, the BrowsUp shape key and the jaw bone, ``--rig light``) with Enable Wrinkles.
    The layers, added by the add-on's own operator at the 3D cursor on the skin, each of
    its default size: a forehead, two eye corners, two cheeks, a frown, two dimples and two
    eye pouches, every one running with the scene (Time follows the frame, so each frame
    computes every layer again; the eye corners and the dimples are switched to run too).
    The tears, added by the add-on's operator along a curve on each cheek from under the eye
    (``sample_scenes/patterns.tear_path``), run their path in 1.5 s and again every 2 s, so
    every frame reveals them anew (Surface Deform and the reveal group, no Python).  Three
    configurations of that scene, in blocks interleaved none, layers, all, then all, layers,
    none, ...: *none*, every layer hidden in the viewport (the source is active and the
    stage runs, with nothing to add) and the tears disabled in the viewport; *layers*, the
    layers shown; *all*, the layers shown and the tears enabled.  Each block times
    ``Bench.frame_loop`` (frame_set + evaluated depsgraph + reading the positions, the
    add-on's frame handler in, the viewport's in-place path) over ``--frames`` new frames
    after ``--warm`` warm-up frames.  ``patterns_frame_ms`` is the median over the repeats of
    (median frame of the all block - median frame of the none block next to it).
``layers_floor_ratio``
    The layers' stage over its floor, from two more configurations in the same blocks:
    *base*, Blender alone (the Wrinkles modifier hidden, the frame handler out), and *floor*,
    the Wrinkles modifier with ``frame_update.py``'s bare handler (read the skin, write the
    positions, no maths).  Per repeat, (layers - base) / ((floor - base) + ``heights_ms`` +
    ``combine_ms``, the layers' arithmetic alone); the median.  Goal: at most 1.5.
``layers_floor_maths_ratio``
    The same over a floor doing the layers' arithmetic in the frame: a seventh configuration,
    *floor_maths*, the bare handler with ``core.patterns.heights`` (one frame's inputs) and
    the output stage's arithmetic run before its write.  Per repeat, (layers - base) /
    (floor_maths - base); the median.  Both then run on the caches Blender's evaluation
    leaves, where the tight loop of ``heights_ms`` and ``combine_ms`` runs on warm ones.
``frame_empty_rebuild_ms``
    What animating the layers' frames costs: a fourth configuration in the same interleaved
    blocks, *moving*, the layers shown with every frame Empty keyed to turn about its normal
    by 0.5 rad and grow by 20 % over the timed frames (``animate_frames``: the pattern lies
    differently every frame, no region moves); the median over the repeats of (moving -
    layers).  Each frame places every layer again (its region's rest positions through the
    frame's matrix); its static data is not rebuilt (``patterns.moving_rebuilt_blocks``
    counts the moving blocks in which it was: 0).
``patterns``
    The detail: the footprint (vertices raised by any layer), the layers' region sizes, both
    pooled medians, the per-repeat figures, the largest height after the layers blocks and
    after the none blocks (0), and ``heights_ms``: ``core.patterns.heights`` alone for all
    the layers (the median over the timed frames' values).
    ``layers_ms`` and ``tears_ms``: the same median of (layers - none) and of (all - layers),
    the two parts of the figure; ``tear_verts``: the tears' vertices.  ``combine_ms``: the
    output stage's arithmetic alone for the layers' heights (the normals over the raised
    vertices' triangles and the sum); with ``heights_ms`` it is the NumPy floor of the
    layers' share.
"""

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
for p in (ROOT, ROOT / "benchmarks"):
    if str(p) not in sys.path:
        sys.path.insert(0, str(p))

import numpy as np  # noqa: E402

KINDS = ("FOREHEAD", "EYE_CORNER", "EYE_CORNER", "CHEEK", "CHEEK", "FROWN", "DIMPLE", "DIMPLE",
         "EYE_POUCH", "EYE_POUCH")


def log(msg):
    print(f"[patterns] {msg}", file=sys.stderr, flush=True)


def places(lm):
    """A point on the face (its space) for each of the ten layers, from the bench landmarks."""
    g, eye, brow = lm["glabella"], lm["eye_L"], lm["brow_outer_L"]
    mouth, cheek, hair = lm["mouth_corner_L"], lm["cheekbone_L"], lm["hairline_center"]

    def mirror(p):
        q = np.array(p, float)
        q[0] = 2 * g[0] - q[0]
        return q

    corner = eye + np.array([0.8 * (brow[0] - eye[0]), 0.0, 0.0])
    dimple = mouth + np.array([0.45 * abs(mouth[0] - g[0]), 0.0, 0.0])
    pouch = eye + np.array([0.0, 0.0, -0.5 * (brow[2] - eye[2])])
    return [0.5 * (g + hair), corner, mirror(corner), cheek, mirror(cheek), g, dimple, mirror(dimple),
            pouch, mirror(pouch)]


def layers_maths(face, static, values):
    """The layers' arithmetic alone, as a function of the skin (N, 3) that returns the offsets
    (N, 3): ``core.patterns.heights`` for the frame inputs ``values``, then the output stage's
    arithmetic for them (``core.combine`` with one footprint: the normals over the raised
    vertices' triangles and the sum).  Also returns a function timing that stage alone (median
    ms of 50 calls): with the heights' own time, the NumPy floor of the layers' frame."""
    from wrinkle_addon.core import combine, mesh
    from wrinkle_addon.core.patterns import functions as core
    from wrinkle_addon.glue import meshio

    me = face.data
    corner, starts, sizes = meshio.read_polygons(me)
    footprint = static.plan.footprint
    plan = combine.build(len(me.vertices), mesh.fan_triangles(corner, starts, sizes),
                         [combine.Footprint(height_verts=np.asarray(footprint, np.int64))])
    out = np.zeros((len(me.vertices), 3), np.float32)

    def part():
        heights = core.heights(static.plan, values)
        return combine.Contribution(height=np.asarray(heights, np.float32).reshape(-1)[:len(footprint)])

    def maths(skin):
        return combine.combine(plan, skin, [part()], out)

    def time_combine():
        skin = meshio.read_vectors(me, "position")
        parts = [part()]
        times = []
        for _ in range(50):
            t = time.perf_counter()
            combine.combine(plan, skin, parts, out)
            times.append(time.perf_counter() - t)
        return float(np.median(times) * 1000.0)

    return maths, time_combine


def animate_frames(layers, end):
    """Key every layer's frame Empty to turn about its own normal by 0.5 rad and grow by 20 %
    between frame 1 and ``end``, staying where it is on the skin; returns each Empty with its
    action (the benchmark switches the animation on and off).  Only where the pattern lies
    changes: no layer's region moves."""
    from mathutils import Matrix

    out = []
    for lay in layers:
        ob = lay.frame
        base = ob.matrix_basis.copy()
        for frame, turn, grow in ((1, 0.0, 1.0), (end, 0.5, 1.2)):
            ob.matrix_basis = base @ Matrix.Rotation(turn, 4, "Z") @ Matrix.Diagonal((grow, grow, grow, 1.0))
            for path in ("location", "rotation_euler", "scale"):
                ob.keyframe_insert(path, frame=frame)
        out.append((ob, ob.animation_data.action))
    return out


def add_tears(face, lm, count):
    """Up to two shedding tears, one under each eye, by the add-on's operator along a curve on
    the skin; each runs its path in 1.5 s and again every 2 s."""
    from sample_scenes import patterns as sample
    from wrinkle_addon.glue.patterns import shedding, tears

    out = []
    for side in range(count):
        marks = dict(lm)
        if side == 1:  # the right cheek: the left's landmarks mirrored across the midline
            mid = lm["glabella"][0]
            marks = {k: np.array([2 * mid - v[0], v[1], v[2]]) for k, v in lm.items()}
        ob = sample.add_shedding_tear(face, marks, 1, 1.5)
        tears.set_input(ob.modifiers[shedding.MODIFIER_NAME], "Every", 2.0)
        out.append(ob)
    return out


def main(argv=None):
    import bpy
    import frame_update as fu  # bpy, the add-on enabled; its Bench builds and times the face
    from mathutils import Vector

    from wrinkle_addon.core.patterns import functions as core

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--verts", type=int, default=50000)
    ap.add_argument("--layers", type=int, default=10, help="up to 10")
    ap.add_argument("--tears", type=int, default=2, help="up to 2")
    ap.add_argument("--frames", type=int, default=40)
    ap.add_argument("--warm", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=6)
    args = ap.parse_args(argv)
    fu.bs.clear_scene()
    fu.pipeline.forget_all()
    bench = fu.Bench(args.verts, args.warm, args.frames, "light", args.repeats)
    bench.build()
    face = bench.ob
    bench.select_face()
    assert bpy.ops.wrinkle.enable() == {"FINISHED"}
    for kind, point in list(zip(KINDS, places(bench.landmarks)))[: args.layers]:
        bpy.context.scene.cursor.location = face.matrix_world @ Vector(point.tolist())
        if bpy.ops.wrinkle.add_pattern(kind=kind, where="CURSOR") != {"FINISHED"}:
            raise RuntimeError(f"Add Pattern {kind} failed")
    layers = face.ewrinkles_face.patterns.layers
    for lay in layers:
        lay.follow_scene = True  # every layer computed again on every frame

    def show(on):
        for lay in layers:
            if lay.show_viewport != on:
                lay.show_viewport = on

    tears = add_tears(face, bench.landmarks, args.tears)

    def show_tears(on):
        for ob in tears:
            if ob.hide_viewport == on:
                ob.hide_viewport = not on

    show(True)
    show_tears(True)
    bench.frame_loop(bench.warm)
    state = fu.pipeline.face_state(face)
    static = state.statics["patterns"][1]
    if static.problem or len(static.plan.layers) != len(layers):
        raise RuntimeError(f"the layers did not all build: {static.problem}")
    detail = {"verts": bench.n, "layers": len(layers), "footprint_verts": int(len(static.plan.footprint)),
              "region_verts": [int(len(lay.verts)) for lay in static.plan.layers],
              "shedding_tears": len(tears), "tear_verts": [len(ob.data.vertices) for ob in tears]}
    from wrinkle_addon.glue import registry

    src = next(s for s in registry.sources() if s.name == "patterns")
    values = [v[0][:5] for v in src.inputs(face, static)]  # (values, the frame's placement)
    ht = []
    for _ in range(50):
        t = time.perf_counter()
        core.heights(static.plan, values)
        ht.append(time.perf_counter() - t)
    detail["heights_ms"] = fu.ms(ht)
    maths, time_combine = layers_maths(face, static, values)
    detail["combine_ms"] = time_combine()
    moves = animate_frames(layers, bench.frames[-1] + 1)

    def animate(on):
        for ob, action in moves:
            ob.animation_data.action = action if on else None

    animate(False)
    # moving: the layers, their Empties animated; base: Blender alone (no stage, no handler);
    # floor: the stage with frame_update's bare handler (read the skin, write the positions)
    configs = ("none", "layers", "all", "moving", "base", "floor", "floor_maths")
    bench.stage_mod = fu.stage.find_modifier(face)
    times = {c: [] for c in configs}
    peak = {c: [] for c in configs}
    rebuilt = []
    for rep in range(args.repeats):
        for config in (configs if rep % 2 == 0 else configs[::-1]):
            show(config in ("layers", "all", "moving"))
            show_tears(config == "all")
            animate(config == "moving")
            bench.handler(config not in ("base", "floor", "floor_maths"))
            bench.floor_handler(config.startswith("floor"), maths if config == "floor_maths" else None)
            bench.stage_mod.show_viewport = config != "base"
            bench.frame_loop(bench.warm)
            serial = fu.pipeline.face_state(face).statics["patterns"][2]
            times[config].append(bench.frame_loop(bench.frames))
            if config == "moving":
                rebuilt.append(fu.pipeline.face_state(face).statics["patterns"][2] != serial)
            if config in ("base", "floor", "floor_maths"):
                continue
            bench.frame_loop(bench.frames[:3], lambda _ev, c=config: peak[c].append(
                float(np.abs(fu.pipeline.face_state(face).out).max())))
        log(f"repeat {rep + 1}/{args.repeats}: "
            + ", ".join(f"{c} {fu.ms(times[c][-1]):.2f} ms" for c in configs))
    med = {c: [fu.ms(b) for b in blocks] for c, blocks in times.items()}
    cost = [a - b for a, b in zip(med["all"], med["none"])]
    detail["layers_ms"] = fu.clean(fu.median_or_none([a - b for a, b in zip(med["layers"], med["none"])]))
    detail["tears_ms"] = fu.clean(fu.median_or_none([a - b for a, b in zip(med["all"], med["layers"])]))
    bench.handler(True)
    bench.floor_handler(False)
    bench.stage_mod.show_viewport = True
    frame_empty = fu.median_or_none([a - b for a, b in zip(med["moving"], med["layers"])])
    arithmetic = detail["heights_ms"] + detail["combine_ms"]
    floor_ratio = [fu.ratio(m - b, f - b + arithmetic)
                   for m, f, b in zip(med["layers"], med["floor"], med["base"])]
    detail["floor_ratio_per_repeat"] = floor_ratio
    maths_ratio = [fu.ratio(m - b, f - b) for m, f, b in zip(med["layers"], med["floor_maths"], med["base"])]
    detail["floor_maths_ratio_per_repeat"] = maths_ratio
    detail["moving_rebuilt_blocks"] = int(sum(rebuilt))
    detail.update({"frame_ms": fu.ms([x for b in times["all"] for x in b]),
                   "base_frame_ms": fu.ms([x for b in times["none"] for x in b]),
                   "max_height_mm": max(peak["layers"]) * 1000.0,
                   "max_height_none_mm": max(peak["none"]) * 1000.0,
                   "per_repeat": {"all_ms": med["all"], "layers_ms": med["layers"], "none_ms": med["none"],
                                  "moving_ms": med["moving"], "cost_ms": cost},
                   "bpy": bpy.app.version_string})
    if not detail["max_height_mm"] > 0.0 or detail["max_height_none_mm"] != 0.0:
        raise RuntimeError("the layers blocks raised nothing, or the none blocks did")
    result = fu.median_or_none(cost)
    log(f"patterns_frame_ms {result:.3f} (layers {detail['layers_ms']}, tears {detail['tears_ms']}); heights "
        f"alone {detail['heights_ms']:.3f} ms; footprint {detail['footprint_verts']} verts")
    log(f"layers_floor_ratio {fu.fmt(fu.median_or_none(floor_ratio))} (per repeat "
        f"{', '.join(fu.fmt(x) for x in floor_ratio)}; arithmetic floor {arithmetic:.3f} ms)")
    log(f"layers_floor_maths_ratio {fu.fmt(fu.median_or_none(maths_ratio))} (per repeat "
        f"{', '.join(fu.fmt(x) for x in maths_ratio)})")
    log(f"frame_empty_rebuild_ms {fu.fmt(frame_empty, '.3f')} (blocks that rebuilt the layers: "
        f"{detail['moving_rebuilt_blocks']} of {len(rebuilt)})")
    print(json.dumps({"patterns_frame_ms": fu.clean(result), "frame_empty_rebuild_ms": fu.clean(frame_empty),
                      "layers_floor_ratio": fu.clean(fu.median_or_none(floor_ratio)),
                      "layers_floor_maths_ratio": fu.clean(fu.median_or_none(maths_ratio)),
                      "patterns": fu.clean(detail)}), flush=True)
    bpy.ops.wm.read_factory_settings(use_empty=True)  # bpy 4.5 hangs at exit otherwise


if __name__ == "__main__":
    main(sys.argv[1:])
