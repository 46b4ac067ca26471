# SPDX-License-Identifier: GPL-3.0-or-later
"""Fine-scale wrinkles (Bando, Kuratate & Nishita 2002, §5): how long carving the furrows takes.

Run:  .venv45/bin/python benchmarks/fine_wrinkles.py --carve-only   (no bpy needed)
      .venv45/bin/python benchmarks/fine_wrinkles.py                (or .venv52: + curves_frame_ms)
      options: --mesh face|square  --sizes 512,1024,2048  --repeats 3  --seed 1
               --curves 20  --curve-verts 50000  --curve-frames 40  --curve-warm 5  --curve-repeats 6

What it builds, how it measures and what every figure of its JSON means:
docs/benchmarks/fine_wrinkles.md.
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
    """A face-like UV layout with holes and a second island (docs/benchmarks/fine_wrinkles.md)."""
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
    """The ``carve_s`` figures (docs/benchmarks/fine_wrinkles.md) and, per size, the coverage and
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


class Floor:
    """The floor of the curves' frame (docs/benchmarks/fine_wrinkles.md): the bare minimum NumPy
    work, on the add-on's own static plan (``large.LargePlan``), in preallocated float32
    buffers: each edge the curves need gathered once, a row with s = 0 measuring no edge of
    its own."""

    def __init__(self, large_plan, n):
        self.n = n
        keys, self.curve_coef, self.curve_share, self.curve_none = self._rows(large_plan.shrink, n)
        unique = np.unique(keys.ravel())
        ends = np.stack([unique // n, unique % n]).astype(np.intp)
        self.flat = ends[:, None, :] * 3 + np.arange(3)[:, None]  # (2, 3, E) skin indices
        self.gathered = np.empty(self.flat.shape, np.float32)
        self.length = np.empty(len(unique), np.float32)
        self.curve_slot = np.searchsorted(unique, keys)
        self.curve_q = np.empty(self.curve_slot.shape, np.float32)
        self.curve_s = np.empty(self.curve_slot.shape[1], np.float32)
        self.plan = large_plan
        self.edges_measured = len(unique)

    @staticmethod
    def _rows(slots, n):
        """Per row: its four edges' keys (lo n + hi), coefficients, share, rows with s = 0."""
        a, b = (np.asarray(e, np.int64)[slots.slot_edge] for e in slots.ends)
        keys = np.minimum(a, b) * n + np.maximum(a, b)
        none = np.asarray(slots.none, bool)
        if not none.all():
            keys[:, none] = keys[0, np.argmin(none)]
        return (keys, np.ascontiguousarray(slots.slot_coef, np.float32),
                np.asarray(slots.share, np.float32), np.flatnonzero(none))

    def edges(self, skin):
        """Both ends of every edge, gathered once, and its length."""
        g = self.gathered
        np.take(skin.reshape(-1), self.flat, out=g, mode="clip")
        d = g[1]
        d -= g[0]
        d *= d
        np.add(d[0], d[1], out=self.length)
        self.length += d[2]
        np.sqrt(self.length, out=self.length)

    def heights(self):
        """The curves' shrinkage from the edge lengths, M(s) and the sum at the footprint."""
        s, p, q = self.curve_s, self.plan, self.curve_q
        np.take(self.length, self.curve_slot, out=q, mode="clip")
        np.divide(self.curve_coef, q, out=q)
        side = q[0::2]
        side += q[1::2]
        np.reciprocal(side, out=side)
        side[0] += side[1]
        np.subtract(self.curve_share, side[0], out=s)
        s[self.curve_none] = 0.0
        np.minimum(s, np.float32(1.0), out=s)
        m = np.where(s >= 0, p.growth * s + p.rest_height, p.rest_height * np.exp(p.decay * np.minimum(s, 0)))
        m *= p.static
        return np.bincount(p.entry_slot, m, minlength=len(p.footprint))


def frame_breakdown(bench, face, configure, repeats):
    """The ``frame_breakdown_ms`` figures (docs/benchmarks/fine_wrinkles.md), with the add-on's frame
    handler removed: each part timed alone on freshly evaluated frames of the 50k face.
    ``configure(config)`` switches the scene to ``"none"`` or ``"curves"``."""
    import bpy
    import frame_update as fu

    from wrinkle_addon.core import combine
    from wrinkle_addon.core.bando import large
    from wrinkle_addon.glue import registry

    pipeline, scene, n = fu.pipeline, bench.scene, bench.n
    skin = np.empty((n, 3), np.float32)
    configure("curves")
    active = [s for s in registry.sources() if s.active(face)]
    curve_src = next(s for s in active if s.name == "curves")
    got = {}

    def configure_curves():
        """The curves on; the stage's state and static data (rebuilt by each switch)."""
        configure("curves")
        got["state"] = state = pipeline.face_state(face)
        got["statics"] = {s.name: state.statics[s.name][1] for s in active}
        return got["statics"]

    statics = configure_curves()
    floor = Floor(statics[curve_src.name].plan, n)
    combine_out = np.zeros((n, 3), np.float32)
    times = {k: [] for k in ("curve_heights", "curve_combine", "handler_curves", "handler_none",
                             "floor_edges", "floor_heights")}

    def timed(key, fn, *args):
        t = time.perf_counter()
        out = fn(*args)
        times[key].append(time.perf_counter() - t)
        return out

    def frames(each):
        """``each(ev, record)`` after every frame_set (warm-up frames unrecorded)."""
        for f in bench.warm + bench.frames:
            scene.frame_set(f)
            each(face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data, f in bench.frames)

    def parts(ev, record):
        fu.meshio.read_vector_prefix(ev, fu.stage.SKIN_ATTR, n, skin)
        call = timed if record else (lambda _k, fn, *a: fn(*a))
        statics = got["statics"]
        heights = call("curve_heights", curve_src.contribute, face, statics["curves"], skin, ())
        parts_in = [heights if s is curve_src else combine.Contribution() for s in active if s.geometric]
        call("curve_combine", combine.combine, got["state"].plan, skin, parts_in, combine_out)
        call("floor_edges", floor.edges, skin)
        call("floor_heights", floor.heights)

    def handler(key):
        def each(ev, record):
            dg = bpy.context.evaluated_depsgraph_get()
            t = time.perf_counter()
            pipeline.update_scene(scene, dg, in_place=True, changes=pipeline.updated_ids(dg))
            if record:
                times[key].append(time.perf_counter() - t)
        return each

    bench.handler(False)
    try:
        for rep in range(repeats):
            order = ("curves", "none") if rep % 2 == 0 else ("none", "curves")
            for config in order:
                if config == "curves":
                    configure_curves()
                    frames(parts)
                else:
                    configure(config)
                frames(handler(f"handler_{config}"))
    finally:
        bench.handler(True)
    statics = configure_curves()
    out = {k: fu.ms(v) for k, v in times.items()}
    if not np.allclose(floor.heights(), large.heights(statics["curves"].plan, skin), atol=1e-7):
        raise RuntimeError("the floor's arithmetic differs from the add-on's")
    parts_sum = out["curve_heights"] + out["curve_combine"]
    result = {k: out[k] for k in ("curve_heights", "curve_combine", "handler_curves", "handler_none")}
    result["stage_overhead"] = out["handler_curves"] - out["handler_none"] - parts_sum
    floor_parts = {k[6:]: out[k] for k in ("floor_edges", "floor_heights")}
    result["floor"] = dict(floor_parts, total=sum(floor_parts.values()), edges_measured=floor.edges_measured)
    log("breakdown: " + ", ".join(f"{k} {v:.3f}" for k, v in result.items() if k != "floor") + " ms; floor: "
        + ", ".join(f"{k} {v:.3f}" for k, v in result["floor"].items() if k != "edges_measured")
        + f" ms ({floor.edges_measured} edges)")
    return result


def curves_frame_ms(n_curves, target, frames, warm, repeats):
    """The ``curves_frame_ms`` figure and its detail (docs/benchmarks/fine_wrinkles.md)."""
    import bpy
    import frame_update as fu  # bpy, the add-on enabled; its Bench builds and times the face

    from wrinkle_addon.glue.bando import fine_tree

    fu.bs.clear_scene()
    fu.pipeline.forget_all()
    bench = fu.Bench(target, warm, frames, "light", repeats)
    built = bench.build()
    face = bench.ob
    bench.scene.frame_set(1)
    bench.select_face()
    live = place_curves(bench, n_curves)  # before Enable Wrinkles: no plan is rebuilt per property
    assert bpy.ops.wrinkle.enable() == {"FINISHED"}
    fine_image = add_fine_attributes(bench)
    fine_settings = face.ewrinkles_face.fine_wrinkles
    fine_mod = fine_tree.find_modifier(face)

    def set_fine(on):
        """The fine wrinkles on (their first image set, their modifier shown) or off (no
        image: the source is not active; the modifier hidden)."""
        fine_settings.image_1 = fine_image if on else None
        fine_mod.show_viewport = on

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
        plan = fu.pipeline.face_state(face).statics["curves"][1].plan
        got = 0 if plan is None else len(plan.curves.lengths)
        if got != (n_curves if on else 0):
            raise RuntimeError(f"{got} curves in the plan after switching them {'on' if on else 'off'}")

    # untimed checks: every curve lies on the skin and is in the plan, and the skin moves
    set_curves(True)
    t = time.perf_counter()
    bench.frame_loop(bench.warm)
    problem = fu.pipeline.status_of(face)
    state = fu.pipeline.face_state(face)
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
            fu.pipeline.face_state(face).statics.pop("curves")
            fu.pipeline.update_scene(bench.scene, bpy.context.evaluated_depsgraph_get())
            rebuilds.append(time.perf_counter() - c)
    except Exception as exc:  # noqa: BLE001 - the add-on's internals changed: report, go on
        log(f"curves: timing a rebuild failed ({exc!r})")
    detail["rebuild_ms"] = fu.ms(rebuilds)
    log(f"curves: {bench.n} verts ({bench.source}), {n_curves} curves, footprint {len(plan.footprint)} "
        f"verts, {len(plan.entry_slot)} entries, {len(plan.shrink.ends[0])} edges; plan rebuild "
        f"{fu.fmt(detail['rebuild_ms'], '.1f')} ms; set up in {time.perf_counter() - t:.1f} s")
    # all: the curves and the fine wrinkles; base: Blender alone (no stage, no handler); floor:
    # the stage with frame_update's bare handler (read the skin, write the positions)
    configs = ("none", "curves", "all", "base", "floor")
    bench.stage_mod = stage_mod
    heights = {c: [] for c in configs}
    times = {c: [] for c in configs}
    for rep in range(repeats):
        for config in (configs if rep % 2 == 0 else configs[::-1]):
            set_fine(config == "all")
            set_curves(config not in ("none", "base", "floor"))
            bench.handler(config not in ("base", "floor"))
            bench.floor_handler(config == "floor")
            stage_mod.show_viewport = config != "base"
            bench.frame_loop(bench.warm)
            times[config].append(bench.frame_loop(bench.frames))
            if config in ("base", "floor"):
                continue
            # untimed: the offsets the stage computed on a few more frames
            bench.frame_loop(bench.frames[:3], lambda _ev, c=config: heights[c].append(
                float(np.abs(fu.pipeline.face_state(face).out).max())))
        log(f"curves: repeat {rep + 1}/{repeats}: none {fu.ms(times['none'][-1]):.2f} ms, "
            f"curves {fu.ms(times['curves'][-1]):.2f} ms, with fine {fu.ms(times['all'][-1]):.2f} ms, "
            f"Blender alone {fu.ms(times['base'][-1]):.2f} ms, bare floor {fu.ms(times['floor'][-1]):.2f} ms")
    bench.handler(True)
    bench.floor_handler(False)
    stage_mod.show_viewport = True
    set_curves(True)
    set_fine(False)  # the breakdown is the curves' alone: the fine wrinkles cost Python nothing

    def configure(config):
        set_curves(config != "none")

    breakdown = frame_breakdown(bench, face, configure, repeats)
    med = {c: [fu.ms(block) for block in blocks] for c, blocks in times.items()}
    cost = [a - b for a, b in zip(med["curves"], med["none"])]
    # the curves' stage over its floor: (curves - base) / ((floor - base) + their arithmetic:
    # the floor's edges and heights, and the normals the heights go along, as the muscles' and
    # the patterns' floors count them)
    arithmetic = breakdown["floor"]["total"] + breakdown["curve_combine"]
    floor_ratio = [fu.ratio(c - b, f - b + arithmetic)
                   for c, f, b in zip(med["curves"], med["floor"], med["base"])]
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
    detail["per_repeat"]["floor_ratio"] = floor_ratio
    detail["per_repeat"].update(blender_alone_ms=med["base"], bare_floor_ms=med["floor"])
    log(f"curves_floor_ratio {fu.fmt(fu.median_or_none(floor_ratio))} (per repeat "
        f"{', '.join(fu.fmt(x) for x in floor_ratio)}; arithmetic floor {arithmetic:.3f} ms)")
    out = {"curves_frame_ms": fu.clean(result), "curves": fu.clean(detail),
           "curves_floor_ratio": fu.clean(fu.median_or_none(floor_ratio)),
           "fine_attributes_frame_ms": fu.clean(fu.median_or_none(fine_cost)),
           "curves_and_fine_frame_ms": fu.clean(fu.median_or_none(both_cost)),
           "frame_breakdown_ms": fu.clean(breakdown), "bpy": bpy.app.version_string}
    return out


def fine_gn(target, frames, warm, repeats):
    """The ``fine_gn_ratio`` figure and its detail (docs/benchmarks/fine_wrinkles.md)."""
    import bpy
    import frame_update as fu

    from wrinkle_addon.core.bando import fine as core_fine
    from wrinkle_addon.glue.bando import fine_tree

    fu.bs.clear_scene()
    fu.pipeline.forget_all()
    bench = fu.Bench(target, warm, frames, "light", repeats)
    bench.build()
    face = bench.ob
    bench.select_face()
    image = add_fine_attributes(bench)  # no Enable Wrinkles: the fine wrinkles alone
    fs = face.ewrinkles_face.fine_wrinkles
    fine_mod = fine_tree.find_modifier(face)
    tension = fu.bs.add_tension_modifier(face)

    def configure(config):
        fs.image_1 = image if config in ("fine", "fine_tree") else None
        fine_mod.show_viewport = config in ("fine", "fine_tree")
        tension.show_viewport = config == "tension"

    # untimed: the tree's shrinkage is the NumPy reference's on a posed frame, and it varies
    configure("fine")
    bench.frame_loop(bench.warm)
    seen = []
    for f in bench.frames[:3]:
        bench.scene.frame_set(f)
        got = fine_tree.shrinkage(face)
        plan = fu.pipeline.face_state(face).statics["fine_wrinkles"][1].plan
        skin = fu.meshio.read_vectors(face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data,
                                      "position")
        err = float(np.abs(got - core_fine.shrinkages(plan, skin)).max())
        if err > 1e-6:
            raise RuntimeError(f"the tree's shrinkage is {err} off the NumPy reference on frame {f}")
        seen.append(float(np.abs(got).max()))
    if not seen[-1] > 0.0:
        raise RuntimeError("the fine wrinkles' shrinkage does not vary on the bench frames")
    configs = ("base", "fine", "tension", "fine_tree")  # fine_tree: the modifier, no frame handler
    times = {c: [] for c in configs}
    for rep in range(repeats):
        for config in (configs if rep % 2 == 0 else configs[::-1]):
            configure(config)
            bench.handler(config != "fine_tree")
            bench.frame_loop(bench.warm)
            times[config].append(bench.frame_loop(bench.frames))
            bench.handler(True)
        log(f"fine gn: repeat {rep + 1}/{repeats}: " + ", ".join(
            f"{c} {fu.ms(times[c][-1]):.2f} ms" for c in configs))
    med = {c: [fu.ms(block) for block in blocks] for c, blocks in times.items()}
    fine_cost = [a - b for a, b in zip(med["fine"], med["base"])]
    tree_cost = [a - b for a, b in zip(med["fine_tree"], med["base"])]
    tension_cost = [a - b for a, b in zip(med["tension"], med["base"])]
    ratios = [fu.ratio(a, b) for a, b in zip(fine_cost, tension_cost)]
    result = fu.median_or_none(ratios)
    detail = {"verts": bench.n, "head": bench.source, "frames": frames, "warm": warm, "repeats": repeats,
              "fine_ms": fu.median_or_none(fine_cost), "tension_ms": fu.median_or_none(tension_cost),
              "tree_ms": fu.median_or_none(tree_cost),
              "base_frame_ms": fu.ms([x for b in times["base"] for x in b]),
              "shrinkage_max": max(seen), "per_repeat": {"fine_ms": fine_cost, "tension_ms": tension_cost,
                                                          "ratio": ratios}}
    log(f"fine_gn_ratio {fu.fmt(result, '.3f')}: the fine wrinkles {fu.fmt(detail['fine_ms'], '.3f')} ms a "
        f"frame against the GN tension reference's {fu.fmt(detail['tension_ms'], '.3f')} ms (frame "
        f"{detail['base_frame_ms']:.2f} ms without either)")
    return {"fine_gn_ratio": fu.clean(result), "fine_gn": fu.clean(detail)}


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
        result.update(fine_gn(args.curve_verts, args.curve_frames, args.curve_warm, args.curve_repeats))
        import bpy

        try:
            bpy.ops.wm.read_factory_settings(use_empty=True)  # bpy 4.5 hangs at exit otherwise
        except Exception as exc:  # noqa: BLE001 - the figures are measured; report and go on
            log(f"read_factory_settings failed: {exc!r}")
    print(json.dumps(result), flush=True)


if __name__ == "__main__":
    main()
