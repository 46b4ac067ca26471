# SPDX-License-Identifier: GPL-3.0-or-later
"""Fine-scale wrinkles (Bando, Kuratate & Nishita 2002, §5): how long carving the furrows takes.

Run:  .venv45/bin/python benchmarks/fine_wrinkles.py --carve-only   (no bpy needed)
      .venv45/bin/python benchmarks/fine_wrinkles.py                (or .venv52: + curves_frame_ms)
      options: --mesh face|square  --sizes 512,1024,2048  --repeats 3  --seed 1
               --curves 20  --curve-verts 50000  --curve-frames 40  --curve-warm 5  --curve-repeats 6

``carve_s``
    Wall time (``time.perf_counter``) of ``core.bando.carve.carve`` at each image size,
    everything included: rasterising the mapped mesh, seeding (random and fill phases),
    growing the furrows in lockstep, and drawing the occupancy and height images.  The
    median of ``--repeats`` runs for sizes up to 1024, one run above (2048 takes longest
    and varies least).  The default ``scale = R / 512`` carves the same furrows in texture
    space at every size (the paper's 512 x 512 layout, finer pixels), so the figures
    compare like for like.  The paper reports about 10 s at 512 x 512 (XEON 2 GHz).
``coverage`` / ``furrows``
    Of the last run at each size: the fraction of the mesh's pixels the furrows lower,
    and the number of furrows.

The mapped mesh (``--mesh``):

``face`` (default)
    A face-like UV layout: a 41 x 41 vertex grid cut to an oval with holes for the eyes
    and the mouth, plus a separate small island (an ear); the field runs across the
    forehead and bends around the cheeks, its magnitude 0.25 at the chin to 0.75 on top.
``square``
    Two triangles over the whole unit square, m = 0.5 everywhere, the direction turning
    slowly across it (by 1.5 rad corner to corner).

``curves_frame_ms`` (not with ``--carve-only``: it needs bpy)
    What ``--curves`` (20) large-scale wrinkle curves (§6-7) add to a frame of a
    ``--curve-verts`` (50k) vertex face, on top of the output stage.  The face and its rig
    are ``benchmarks/frame_update.py``'s (``Bench.build``: headgen's head with its UV map,
    the "BrowsUp" shape key and the jaw bone, ``--rig light``), with Enable Wrinkles and the
    curves (``place_curves``: 2 x 5 on the forehead, 2 x 5 on the cheeks, each about 3.5 cm
    long; d 3 mm, w 2.5 mm, r 0.3, snapped to the skin).  Two configurations of that same
    scene: *none*, every curve disabled (the curve source is active and the stage runs:
    skin read, combine, in-place write, with nothing to add), and *curves*, all 20 on.  Each
    block times ``Bench.frame_loop`` (frame_set + evaluated depsgraph + reading the
    positions, the add-on's frame handler in, the viewport's in-place path) over
    ``--curve-frames`` new frames after ``--curve-warm`` warm-up frames; the switch
    between configurations rebuilds the curves' static plan once, before the warm-up (a
    full update: ``set_curves``).  The blocks are interleaved none, curves, then curves,
    none, ... for ``--curve-repeats`` repeats.  ``curves_frame_ms`` is the median over the
    repeats of (median frame of the curves block - median frame of the none block next to
    it); ``curves`` has the detail: both pooled medians, the per-repeat figures, the curves'
    footprint (vertices moved), their (curve, vertex) entries, the mapped patch the
    shrinkage is measured on, the largest offset after the curves blocks (and after the
    none blocks: 0), and the time of one rebuild of the static plan (what an edit of a
    curve costs).
``fine_attributes_frame_ms``
    The per-frame cost of the fine wrinkles' two shrinkage attributes (§5, §7: measured
    across each field at every vertex and written for the shading) on the same face,
    fine wrinkles carved at 512 x 512: the frames with the curves and the fine wrinkles
    against those with the curves alone, in the same interleaved blocks.
``curves_and_fine_frame_ms``
    Both together on top of the stage: the frames with curves and fine wrinkles against
    those with neither (the figure the 0.5 ms goal is about).

Output: progress on stderr (the shared benchmark helpers log theirs on stdout), one JSON
object on the last line of stdout::

    {"carve_s": {"512": ..., "1024": ..., "2048": ...}, "coverage": {...}, "furrows": {...},
     "mesh": "face", "repeats": 3, "curves_frame_ms": ..., "curves": {...},
     "fine_attributes_frame_ms": ..., "curves_and_fine_frame_ms": ..., "bpy": "4.5.4"}

With ``--carve-only`` the script imports no bpy and the keys from ``curves_frame_ms`` on
are left out.
"""

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
for _p in (str(ROOT), str(HERE)):  # the repository, and the benchmarks' shared helpers
    if _p not in sys.path:
        sys.path.insert(0, _p)

import numpy as np  # noqa: E402

# wrinkle_addon is imported in the functions: under bpy, frame_update enables it first (an
# add-on imported the ordinary way before addon_utils.enable would be loaded twice)


def log(msg):
    print(f"[fine_wrinkles] {msg}", file=sys.stderr, flush=True)


def square_mesh():
    """Two triangles over [0, 1]^2; m = 0.5, the direction turning slowly."""
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    tris = np.array([[0, 1, 2], [0, 2, 3]])
    ang = uv[:, 0] + 0.5 * uv[:, 1]
    return uv, tris, 0.5 * np.stack([np.cos(ang), np.sin(ang)], 1)


def face_mesh(n=41):
    """A face-like UV layout with holes and a second island (see the module docstring)."""
    u, v = np.meshgrid(np.linspace(0.02, 0.98, n), np.linspace(0.02, 0.98, n))
    uv = np.stack([u.ravel(), v.ravel()], 1)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    tris = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    cen = uv[tris].mean(axis=1)

    def inside(x, y, ax, ay):
        return ((cen[:, 0] - x) / ax) ** 2 + ((cen[:, 1] - y) / ay) ** 2 < 1.0

    keep = inside(0.45, 0.5, 0.36, 0.46)
    for x, y, ax, ay in ((0.32, 0.58, 0.08, 0.04), (0.58, 0.58, 0.08, 0.04), (0.45, 0.25, 0.12, 0.04)):
        keep &= ~inside(x, y, ax, ay)
    keep |= inside(0.9, 0.5, 0.06, 0.14)  # the ear
    ang = 0.7 * np.sin(2.5 * (uv[:, 0] - 0.45)) * (1.0 - uv[:, 1])
    m = 0.25 + 0.5 * uv[:, 1]
    return uv, tris[keep], m[:, None] * np.stack([np.cos(ang), np.sin(ang)], 1)


MESHES = {"face": face_mesh, "square": square_mesh}


def carve_s(mesh, sizes, repeats, seed):
    """The ``carve_s`` figures (see the module docstring) and, per size, the coverage and
    the furrow count of the last run."""
    from wrinkle_addon.core.bando import carve as bando_carve

    uv, tris, field = MESHES[mesh]()
    times, coverage, furrows = {}, {}, {}
    bando_carve.carve(uv, tris, field, 64, seed=seed)  # warm-up: imports, first allocations
    for R in sizes:
        runs = []
        for _ in range(repeats if R <= 1024 else 1):
            t = time.perf_counter()
            res = bando_carve.carve(uv, tris, field, R, seed=seed)
            runs.append(time.perf_counter() - t)
        times[str(R)] = round(statistics.median(runs), 3)
        coverage[str(R)] = round(res.coverage, 4)
        furrows[str(R)] = res.furrows
        batches = int(res.batches.max(initial=-1)) + 1
        log(f"{mesh} {R}^2: " + ", ".join(f"{x:.3f}" for x in runs) + f" s; coverage {res.coverage:.3f}, "
            f"{res.furrows} furrows, {len(res.segments)} segments, {batches} batches")
    return times, coverage, furrows


# --------------------------------------------------------------------------- curves_frame_ms
CURVE_DEPTH, CURVE_WIDTH, CURVE_REST = 0.003, 0.0025, 0.3


def curve_rows(lm, n_curves):
    """The curves as seen from the front, (x, z) polylines (9 points each): per side, half on
    the forehead (rows 8 mm apart from 12 mm above the glabella) and half on the cheek (rows
    between the mouth corner and 12 mm under the eye), each about 3.5 cm long."""
    mid = float(lm["glabella"][0])
    per_side = n_curves // 2
    fore, cheek = (per_side + 1) // 2, per_side // 2
    rows = []
    g, hair = float(lm["glabella"][2]), float(lm["hairline_center"][2])
    step = min(0.008, (hair - 0.012 - (g + 0.012)) / max(fore - 1, 1))
    for k in range(fore):
        rows.append((0.004, 0.039, g + 0.012 + k * step))
    lo, hi = float(lm["mouth_corner_L"][2]) + 0.004, float(lm["eye_L"][2]) - 0.012
    eye_x = abs(float(lm["eye_L"][0]) - mid)
    for k in range(cheek):
        rows.append((eye_x - 0.012, eye_x + 0.022, lo + (hi - lo) * k / max(cheek - 1, 1)))
    out = []
    for side in (1.0, -1.0):
        for x0, x1, z in rows:
            x = mid + side * np.linspace(x0, x1, 9)
            out.append(np.stack([x, np.full(9, z)], 1))
    return out[:n_curves]


def place_curves(bench, n_curves):
    """``n_curves`` wrinkle curves on ``bench``'s face (:func:`curve_rows`), snapped to its skin."""
    from sample_scenes.forehead_curves import add_curves

    return add_curves(bench.ob, curve_rows(bench.landmarks, n_curves), "Bench Curve", CURVE_DEPTH,
                      CURVE_WIDTH, CURVE_REST)


def add_fine_attributes(bench):
    """Carve fine wrinkles on the bench face (512 x 512, directions from its poses), so the
    frame stage writes both shrinkage attributes every frame.  Returns the first height
    image, whose pointer switches the fine-wrinkle source on and off."""
    import bpy

    fs = bench.ob.ewrinkles_face.fine_wrinkles
    fs.resolution = "512"
    t = time.perf_counter()
    if bpy.ops.wrinkle.carve_fine() != {"FINISHED"}:
        raise RuntimeError("Carve Fine Wrinkles failed on the bench face")
    log(f"fine: carved {fs.furrows} furrows in {time.perf_counter() - t:.1f} s")
    return fs.image_1


def curves_frame_ms(n_curves, target, frames, warm, repeats):
    """The ``curves_frame_ms`` figure and its detail (see the module docstring)."""
    import bpy
    import frame_update as fu  # bpy, the add-on enabled; its Bench builds and times the face

    fu.bs.clear_scene()
    fu.pipeline._cache.clear()
    bench = fu.Bench(target, warm, frames, "light", repeats)
    built = bench.build()
    face = bench.ob
    bench.scene.frame_set(1)
    vl = bpy.context.view_layer
    for o in vl.objects:
        o.select_set(False)
    face.select_set(True)
    vl.objects.active = face
    live = place_curves(bench, n_curves)  # before Enable Wrinkles: no plan is rebuilt per property
    assert bpy.ops.wrinkle.enable() == {"FINISHED"}
    fine_image = add_fine_attributes(bench)
    fine_settings = face.ewrinkles_face.fine_wrinkles

    def set_fine(on):
        """The fine-wrinkle source on (its first image set) or off (no image: not active)."""
        fine_settings.image_1 = fine_image if on else None

    stage_mod = fu.stage.find_modifier(face)

    def set_curves(on):
        """Every curve on or off.  With the stage off meanwhile, each change's refresh stops at
        the stage check instead of rebuilding the plan per curve; one full update then
        rebuilds it."""
        stage_mod.show_viewport = False
        for ob in live:
            if ob.ewrinkles_curve.enabled != on:
                ob.ewrinkles_curve.enabled = on
        stage_mod.show_viewport = True
        fu.pipeline.refresh_all(bpy.context)
        plan = fu.pipeline._cache[face.session_uid].statics["curves"][1].plan
        got = 0 if plan is None else len(plan.curves.lengths)
        if got != (n_curves if on else 0):
            raise RuntimeError(f"{got} curves in the plan after switching them {'on' if on else 'off'}")

    # untimed checks: every curve lies on the skin and is in the plan, and the skin moves
    set_curves(True)
    t = time.perf_counter()
    bench.frame_loop(bench.warm)
    problem = fu.pipeline.status_of(face)
    state = fu.pipeline._cache[face.session_uid]
    static = state.statics["curves"][1]
    if static.plan is None or len(static.plan.curves.lengths) != n_curves:
        raise RuntimeError(f"the {n_curves} curves did not all make it into the plan: "
                           f"{problem or static.problem}")
    plan = static.plan
    detail = {"verts": bench.n, "head": bench.source, "uv_map": built["uv_map"], "curves": n_curves,
              "footprint_verts": int(len(plan.footprint)), "entries": int(len(plan.entry_slot)),
              "edges_measured": int(len(plan.shrink.ends[0]))}
    # one rebuild of the static plan (what an edit of a curve costs): the handler's whole
    # update with the cached static data dropped (the frame stage's internals)
    rebuilds = []
    try:
        for _ in range(3):
            c = time.perf_counter()
            fu.pipeline._cache[face.session_uid].statics.pop("curves")
            fu.pipeline.update_scene(bench.scene, bpy.context.evaluated_depsgraph_get())
            rebuilds.append(time.perf_counter() - c)
    except Exception as exc:  # noqa: BLE001 - the add-on's internals changed: report, go on
        log(f"curves: timing a rebuild failed ({exc!r})")
    detail["rebuild_ms"] = fu.ms(rebuilds)
    log(f"curves: {bench.n} verts ({bench.source}), {n_curves} curves, footprint {len(plan.footprint)} "
        f"verts, {len(plan.entry_slot)} entries, {len(plan.shrink.ends[0])} edges; plan rebuild "
        f"{fu.fmt(detail['rebuild_ms'], '.1f')} ms; set up in {time.perf_counter() - t:.1f} s")
    configs = ("none", "curves", "all")  # all: the curves and both fine shrinkage attributes
    heights = {c: [] for c in configs}
    times = {c: [] for c in configs}
    for rep in range(repeats):
        for config in (configs if rep % 2 == 0 else configs[::-1]):
            set_fine(config == "all")
            set_curves(config != "none")
            bench.frame_loop(bench.warm)
            times[config].append(bench.frame_loop(bench.frames))
            # untimed: the offsets the stage computed on a few more frames
            bench.frame_loop(bench.frames[:3], lambda _ev, c=config: heights[c].append(
                float(np.abs(fu.pipeline._cache[face.session_uid].out).max())))
        log(f"curves: repeat {rep + 1}/{repeats}: none {fu.ms(times['none'][-1]):.2f} ms, "
            f"curves {fu.ms(times['curves'][-1]):.2f} ms, with fine {fu.ms(times['all'][-1]):.2f} ms")
    set_curves(True)
    set_fine(True)
    med = {c: [fu.ms(block) for block in blocks] for c, blocks in times.items()}
    cost = [a - b for a, b in zip(med["curves"], med["none"])]
    fine_cost = [a - b for a, b in zip(med["all"], med["curves"])]
    both_cost = [a - b for a, b in zip(med["all"], med["none"])]
    detail.update({
        "frame_ms": fu.ms([x for b in times["curves"] for x in b]),
        "base_frame_ms": fu.ms([x for b in times["none"] for x in b]),
        "max_height_mm": max(heights["curves"]) * 1000.0,
        "max_height_none_mm": max(heights["none"]) * 1000.0,
        "frames": frames, "warm": warm, "repeats": repeats,
        "all_frame_ms": fu.ms([x for b in times["all"] for x in b]),
        "per_repeat": {"frame_ms": med["curves"], "base_ms": med["none"], "all_ms": med["all"],
                       "cost_ms": cost, "fine_cost_ms": fine_cost},
    })
    result = fu.median_or_none(cost)
    log(f"curves_frame_ms {result:.3f} (per repeat {', '.join(f'{c:.3f}' for c in cost)}); frame "
        f"{detail['frame_ms']:.2f} ms against {detail['base_frame_ms']:.2f} ms; largest offset "
        f"{detail['max_height_mm']:.3f} mm (none: {detail['max_height_none_mm']:.3f} mm)")
    if not detail["max_height_mm"] > 0.0 or detail["max_height_none_mm"] != 0.0:
        raise RuntimeError("the curves blocks did not raise wrinkles, or the none blocks did")
    out = {"curves_frame_ms": fu.clean(result), "curves": fu.clean(detail),
           "fine_attributes_frame_ms": fu.clean(fu.median_or_none(fine_cost)),
           "curves_and_fine_frame_ms": fu.clean(fu.median_or_none(both_cost)),
           "bpy": bpy.app.version_string}
    try:
        bpy.ops.wm.read_factory_settings(use_empty=True)  # bpy 4.5 hangs at exit otherwise
    except Exception as exc:  # noqa: BLE001 - the figures are measured; report and go on
        log(f"read_factory_settings failed: {exc!r}")
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--carve-only", action="store_true",
                    help="measure the carving alone, no bpy (else curves_frame_ms too, under bpy)")
    ap.add_argument("--mesh", choices=sorted(MESHES), default="face")
    ap.add_argument("--sizes", default="512,1024,2048")
    ap.add_argument("--repeats", type=int, default=3, help="runs per size up to 1024 (the median is kept)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--curves", type=int, default=20, help="wrinkle curves for curves_frame_ms")
    ap.add_argument("--curve-verts", type=int, default=50_000, help="vertices of the face they are on")
    ap.add_argument("--curve-frames", type=int, default=40, help="timed frames per block")
    ap.add_argument("--curve-warm", type=int, default=5, help="warm-up frames per block")
    ap.add_argument("--curve-repeats", type=int, default=6, help="interleaved repeats (the median is kept)")
    args = ap.parse_args(argv)
    if args.repeats < 1 or args.curve_repeats < 1:
        ap.error("--repeats and --curve-repeats must be at least 1")
    if args.curves < 1:
        ap.error("--curves must be at least 1")
    sizes = [int(s) for s in args.sizes.split(",") if s.strip()]
    log(f"numpy {np.__version__}, {os.cpu_count()} cpus, load {os.getloadavg()[0]:.2f}, mesh {args.mesh}")
    if not args.carve_only:
        import frame_update  # noqa: F401  (bpy, and the add-on enabled before anything imports it)
    times, coverage, furrows = carve_s(args.mesh, sizes, args.repeats, args.seed)
    result = {"carve_s": times, "coverage": coverage, "furrows": furrows, "mesh": args.mesh,
              "repeats": args.repeats}
    if not args.carve_only:
        result.update(curves_frame_ms(args.curves, args.curve_verts, args.curve_frames, args.curve_warm,
                                      args.curve_repeats))
    print(json.dumps(result), flush=True)


if __name__ == "__main__":
    main()
