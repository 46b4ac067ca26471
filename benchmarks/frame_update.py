# SPDX-License-Identifier: GPL-3.0-or-later
"""Per-frame cost of the wrinkle pipeline against Blender's own evaluation.

Run:  .venv45/bin/python benchmarks/frame_update.py   (or .venv52)
      options: --rig light|arkit  --sizes 10k,50k  --frames 30  --warm 5

For heads of about 10k, 50k and 200k vertices (``sample_scenes/lib/headgen``)
the script builds one of two facial rigs (``--rig``):

``light`` (the default)
    A "BrowsUp" shape key (brows up 6 mm, forehead compressed, animated
    0 -> 1 -> 0 -> 1) and an armature whose "Jaw" bone (lower face weighted by
    distance from the chin) opens 0 -> 15 deg -> 0 -> 15 deg.
``arkit``
    A production-like face: 52 shape keys (the ARKit blendshape count), i.e.
    "BrowsUp" plus 51 regional keys, each a smooth Gaussian bump of 2-5 mm
    (sigma 6-9 mm) over a different region of the face front, directions
    alternating, built deterministically (fixed seed) in NumPy
    (``_bench_scene.add_arkit_keys``).  All 52 are keyframed on smooth curves
    with different periods and phases that never reach 0 (Blender skips keys at
    0), so every frame blends all of them; plus the same Jaw bone.

Every timed frame is a new frame, after
``--warm`` warm-up frames, timed over ``--frames`` frames
(``time.perf_counter``).  Every ``*_ms`` is the MEDIAN over the frames (this
machine is shared; means are in ``*_mean_ms`` where useful).  What each number
contains:

``eval_ms``
    Blender alone, add-on registered but no face enabled (its handler runs and
    finds nothing): ``scene.frame_set(f)`` + ``evaluated_depsgraph_get()`` +
    reading the evaluated positions with ``foreach_get``.  This is shape
    keys + armature + the animation system for the scene.
``gn_tension_ms``
    The native alternative users build today: a Geometry Nodes modifier after
    the armature that computes, per edge, current length / rest length (rest
    from a ``rest_position`` point attribute stored once on the mesh, fetched
    with Edge Vertices + Evaluate at Index), averaged onto the points
    (Evaluate on Domain EDGE, stored on POINT) as the float attribute
    ``tension``.  ``gn_tension_ms`` = median frame time with the modifier (same
    loop as ``eval_ms``, plus reading ``tension``) minus the median without.
    Base and tension blocks are interleaved (A B A B) to cancel drift.
``read_ms`` / ``compute_ms`` / ``write_ms`` (the handler's parts, timed by hand
    with the add-on's handler removed, calling the same functions it calls):
    ``read_ms``: ``meshio.read_vector_prefix`` of ``wrinkle_skin`` from the
    evaluated mesh.  ``compute_ms``: ``core.muscles.system.evaluate``.  ``write_ms``:
    ``pipeline._write_in_place``: the check that Blender re-evaluated the
    face, the ``foreach_set`` of ``skin + offset`` into the evaluated mesh's
    positions (and its ``wrinkle_offset``), and ``Mesh.update()`` so its
    normals are recomputed.  No second evaluation follows.
``update_face_ms`` / ``overhead_ms``
    The whole ``pipeline.update_scene(in_place=True)`` call, as the viewport
    handler makes it (scene scan, checks, topology key, rest-position comparison, muscle
    signatures, contraction gathering, evaluate, write);
    ``overhead_ms`` = update_face_ms - (read + compute + write).
``writeback_handler_ms`` / ``writeback_reeval_ms``
    The other path, taken by render and export frames: ``update_scene`` writing
    ``wrinkle_offset`` into the original mesh and tagging it, then the second
    evaluation of the whole modifier stack that the tag causes.  Reported for
    comparison; it does not enter playback.
``playback_ms`` / ``playback_base_ms`` / ``stage_ms``
    The same loop as ``eval_ms`` (frame_set + evaluated_depsgraph_get + reading
    positions) with wrinkles (stage modifier on, handler in) and without (stage
    off, handler out), interleaved A B A B like the tension measurement.
    ``stage_ms`` = playback_ms - playback_base_ms: what wrinkles add to a
    frame, measured exactly like ``gn_tension_ms`` (the GN stage inside the
    evaluation, the handler, the in-place write).  ``gn_ratio`` = stage_ms /
    gn_tension_ms; ``playback_ratio`` = playback_ms / playback_base_ms.
    ``in_place_frames`` counts checked frames on which the original mesh was
    not written (so there was no second evaluation).
``eval_stage_ms``
    frame_set + read with the Wrinkles modifier present but the handler
    removed: what the GN output stage alone costs inside the normal evaluation.
``region_verts``
    ``len(plan.verts)``: vertices the per-frame NumPy touches (regions, their
    edges' and triangles' vertices and the Waters areas of influence).
``compute_tight_loop_ms``
    ``core.muscles.system.evaluate`` called 40 times in a row on one frame's skin: the
    same work as ``compute_ms`` with warm caches and no Blender threads
    around.  ``compute_ms`` (measured right after Blender evaluated the frame)
    is the realistic one.
``evaluate_steps_ms``
    ``core.muscles.system.evaluate`` replayed step by step (calling its own parts,
    checked against the real one for equality) to show where its time goes.

Sanity checks printed as it runs: region sizes and bounding boxes per
muscle, offsets changing frame to frame, and evaluated position ==
wrinkle_skin + wrinkle_offset (the frame shows its own wrinkles).

The last line of output is one JSON object, with ``tree`` (a hash of the
add-on and sample-scene sources measured) and the 1-minute load average at
start and end: on a shared 2-core machine, compare runs only at low load.
"""

import argparse
import cProfile
import io
import json
import os
import pstats
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="wrinkle_bench_"))

import bpy  # noqa: E402
import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
for p in (str(REPO), str(HERE)):
    if p not in sys.path:
        sys.path.insert(0, p)

import _bench_scene as bs  # noqa: E402
import addon_utils  # noqa: E402

addon_utils.enable("wrinkle_addon", default_set=True)

from wrinkle_addon.core import mesh as core_mesh  # noqa: E402
from wrinkle_addon.core.muscles import system, zhang  # noqa: E402
from wrinkle_addon.glue import frame as pipeline  # noqa: E402
from wrinkle_addon.glue import meshio, stage  # noqa: E402
from wrinkle_addon.glue.muscles import landmarks as operators  # noqa: E402
from wrinkle_addon.glue.muscles import objects as muscle_objects  # noqa: E402

pc = time.perf_counter
_F = np.float32
MUSCLE_LANDMARKS = ("hairline_center", "glabella", "brow_outer_L", "eye_L", "nose_tip",
                    "mouth_corner_L", "chin", "cheekbone_L")


def log(*a):
    print(*a, flush=True)


def ms(values):
    """Median in ms: robust to other processes on a shared 2-core machine."""
    return float(np.median(values) * 1000.0)


def mean_ms(values):
    return float(np.mean(values) * 1000.0)


class Bench:
    def __init__(self, target, warm, frames, rig="light"):
        self.target = target
        self.rig_kind = rig
        self.warm = list(range(1, warm + 1))
        self.frames = list(range(warm + 1, warm + 1 + frames))
        self.scene = bpy.context.scene
        self.scene.frame_start, self.scene.frame_end = 1, 61

    # -- scene -------------------------------------------------------------
    def build(self):
        t = pc()
        head, source = bs.make_head_data(self.target)
        self.source = source
        self.landmarks = {k: np.asarray(v, float) for k, v in head["landmarks"].items()}
        ob = bs.make_face_object("Face", head)
        self.ob = ob
        self.n = len(ob.data.vertices)
        self.pos_buf = np.empty(self.n * 3, _F)
        if self.rig_kind == "arkit":
            keys, moved = bs.add_arkit_keys(ob, self.landmarks)
            keyed = f"{len(keys)} shape keys (BrowsUp + {len(keys) - 1} regional), verts moved per " \
                    f"key median {int(np.median(moved))} (min {min(moved)}, max {max(moved)})"
        else:
            _kb, n_key = bs.add_brows_up(ob, self.landmarks)
            keyed = f"BrowsUp moves {n_key} verts"
        self.rig, n_jaw = bs.add_jaw_rig(ob, self.landmarks, self.scene)
        log(f"  head ({source}): {self.n} verts, {len(ob.data.polygons)} faces; {keyed}, "
            f"Jaw group {n_jaw} verts; built in {pc() - t:.1f} s")
        if self.rig_kind == "arkit":
            self.check_keys_live()

    def check_keys_live(self):
        """Untimed: every shape key is non-zero on every warm-up and timed frame."""
        kbs = self.ob.data.shape_keys.key_blocks[1:]
        lo = float("inf")
        zero_frames = 0
        for f in self.warm + self.frames:
            self.scene.frame_set(f)
            vals = [kb.value for kb in kbs]
            lo = min(lo, min(vals))
            zero_frames += any(v <= 0.0 for v in vals)
        log(f"  {len(kbs)} animated keys: min value over frames {lo:.3f}, "
            f"frames with a key at 0: {zero_frames}/{len(self.warm + self.frames)}")

    def read_positions(self, dg):
        ev = self.ob.evaluated_get(dg).data
        ev.attributes["position"].data.foreach_get("vector", self.pos_buf)
        return ev

    def frame_loop(self, frames, extra=None):
        """Mean time of frame_set + evaluated_depsgraph_get + position read (+ extra)."""
        times = []
        for f in frames:
            t0 = pc()
            self.scene.frame_set(f)
            dg = bpy.context.evaluated_depsgraph_get()
            ev = self.read_positions(dg)
            if extra is not None:
                extra(ev)
            times.append(pc() - t0)
        return times

    # -- 2 and 3: Blender alone, and the native GN tension ---------------------
    def measure_eval_and_tension(self):
        mod = bs.add_tension_modifier(self.ob)
        tension = np.empty(self.n, _F)
        stats = {}

        def read_tension(ev):
            ev.attributes[bs.TENSION_ATTR].data.foreach_get("value", tension)
            stats.setdefault("min", []).append(float(tension.min()))

        # untimed check that every frame really deforms the mesh
        prev, moved = [None], []

        def track(_ev):
            if prev[0] is not None:
                moved.append(not np.array_equal(prev[0], self.pos_buf))
            prev[0] = self.pos_buf.copy()

        mod.show_viewport = False
        self.frame_loop(self.warm + self.frames, track)
        log(f"  evaluated positions changed on {sum(moved)}/{len(moved)} frames")
        base, tens = [], []
        for _round in range(2):
            for on in (False, True):
                mod.show_viewport = on
                self.frame_loop(self.warm, read_tension if on else None)
                t = self.frame_loop(self.frames, read_tension if on else None)
                (tens if on else base).extend(t)
        eval_ms, with_ms = ms(base), ms(tens)
        log(f"  eval_ms {eval_ms:.2f}   with GN tension {with_ms:.2f}   -> gn_tension_ms "
            f"{with_ms - eval_ms:.2f}   (tension min over frames {min(stats['min']):.4f}, "
            f"varies: {len(set(np.round(stats['min'], 6))) > 1})")
        self.ob.modifiers.remove(mod)
        self.ob.data.attributes.remove(self.ob.data.attributes[bs.REST_ATTR])
        return {"eval_ms": eval_ms, "eval_mean_ms": mean_ms(base),
                "gn_tension_ms": with_ms - eval_ms, "tension_frame_ms": with_ms}

    # -- 4: the wrinkle stage ---------------------------------------------------
    def add_wrinkles(self):
        t = pc()
        self.scene.frame_set(1)
        vl = bpy.context.view_layer
        for o in vl.objects:
            o.select_set(False)
        vl.objects.active = self.ob
        self.ob.select_set(True)
        res = bpy.ops.wrinkle.enable()
        assert res == {"FINISHED"}, res
        lm = {k: self.landmarks[k] for k in MUSCLE_LANDMARKS}
        self.muscles = operators.build_muscle_set(bpy.context, self.ob, lm)
        keys = {
            "FRONTALIS_INNER": ((1, 0.0), (21, 1.0), (41, 0.0), (61, 1.0)),
            "FRONTALIS_MAJOR": ((1, 0.0), (21, 1.0), (41, 0.0), (61, 1.0)),
            "FRONTALIS_OUTER": ((1, 0.0), (21, 0.8), (41, 0.0), (61, 0.8)),
            "CORRUGATOR": ((1, 0.0), (11, 1.0), (31, 0.0), (41, 1.0)),
        }
        for m in self.muscles:
            for f, v in keys.get(m.ewrinkles_muscle.role, ()):
                m.ewrinkles_muscle.contraction = v
                m.keyframe_insert("ewrinkles_muscle.contraction", frame=f)
        self.scene.frame_set(2)
        self.scene.frame_set(1)
        self.state = pipeline._cache[self.ob.session_uid]
        plan = self.state.statics["muscles"][1].plan  # the muscle source's static plan
        log(f"  wrinkles on, {len(self.muscles)} muscles, plan built, in {pc() - t:.1f} s; "
            f"region_verts {len(plan.verts)} ({100 * len(plan.verts) / self.n:.1f} %), "
            f"rows {len(plan.row_vert)}, pairs {len(plan.pair_edge)}, edges {plan.edges.shape[1]}, "
            f"tris {plan.output.tris.shape[1]}, pull rows {len(plan.pull_vert)}")
        if pipeline.status_of(self.ob):
            log(f"  status: {pipeline.status_of(self.ob)}")
        return plan

    def region_report(self, plan):
        rest = self.state.mesh.rest
        live = muscle_objects.live_muscles(self.ob)
        gv = plan.verts[plan.row_vert]
        lm = self.landmarks
        log(f"  landmarks z: eye {lm['eye_L'][2]:.3f} glabella {lm['glabella'][2]:.3f} "
            f"hairline {lm['hairline_center'][2]:.3f}; brow_outer x {lm['brow_outer_L'][0]:.3f}")
        out = {}
        for i, m in enumerate(live):
            sel = gv[plan.row_muscle == i]
            size = int(plan.region_sizes[i])
            if len(sel):
                p = rest[sel]
                box = (f"x [{p[:, 0].min():+.3f},{p[:, 0].max():+.3f}] "
                       f"y [{p[:, 1].min():+.3f},{p[:, 1].max():+.3f}] "
                       f"z [{p[:, 2].min():.3f},{p[:, 2].max():.3f}]")
            else:
                box = "EMPTY"
            cm = muscle_objects.to_core(m, self.ob)
            if cm.kind == 0:
                a, i = cm.attachment[0], cm.insertion[0]
                geo = (f"A ({a[0]:+.3f},{a[2]:.3f}) I ({i[0]:+.3f},{i[2]:.3f}) "
                       f"R {cm.length:.3f} Phi {np.degrees(cm.spread):.0f}")
            else:
                geo = f"Ls {cm.length:.3f} Ws {cm.spread:.3f} depth {cm.depth:.3f}"
            log(f"    {m.name:24s} region {size:6d} (amp!=0 {len(sel):6d})  {box}  {geo}")
            out[m.name] = size
        return out

    def measure_split(self, plan):
        """The handler's parts, timed by hand with the handler removed (same calls it makes)."""
        ob = self.ob
        handlers = bpy.app.handlers.frame_change_post
        handlers.remove(pipeline.on_frame_change_post)
        try:
            live = muscle_objects.live_muscles(ob)
            strength = ob.ewrinkles_face.strength
            st = self.state
            rd, cp, wr, base, uf, wb, rev = [], [], [], [], [], [], []

            def one(f, record):
                t0 = pc()
                self.scene.frame_set(f)
                dg = bpy.context.evaluated_depsgraph_get()
                self.read_positions(dg)
                t1 = pc()
                ev = ob.evaluated_get(dg).data
                skin = meshio.read_vector_prefix(ev, stage.SKIN_ATTR, self.n, st.skin)
                t2 = pc()
                contraction = np.array([m.ewrinkles_muscle.contraction for m in live], np.float64)
                t3 = pc()
                out = system.evaluate(plan, skin, contraction, strength, out=st.out)
                t4 = pc()
                assert pipeline._write_in_place(st, ev, skin, out)
                t5 = pc()
                if record:
                    base.append(t1 - t0)
                    rd.append(t2 - t1)
                    cp.append(t4 - t3)
                    wr.append(t5 - t4)

            for f in self.warm:
                one(f, False)
            for f in self.frames:
                one(f, True)

            # the whole handler call on the in-place path (bookkeeping included), and the
            # write-back path that render and export frames take, with its re-evaluation
            for f in self.warm + self.frames:
                self.scene.frame_set(f)
                dg = bpy.context.evaluated_depsgraph_get()
                t0 = pc()
                pipeline.update_scene(self.scene, dg, in_place=True)
                t1 = pc()
                pipeline.update_scene(self.scene, dg)  # write-back: foreach_set + tag ...
                t2 = pc()
                self.read_positions(bpy.context.evaluated_depsgraph_get())  # ... + re-evaluation
                t3 = pc()
                if f in self.frames:
                    uf.append(t1 - t0)
                    wb.append(t2 - t1)
                    rev.append(t3 - t2)
        finally:
            handlers.append(pipeline.on_frame_change_post)
        r = {"read_ms": ms(rd), "compute_ms": ms(cp), "write_ms": ms(wr)}
        r["eval_stage_ms"] = ms(base)
        r["update_face_ms"] = ms(uf)
        r["overhead_ms"] = r["update_face_ms"] - (r["read_ms"] + r["compute_ms"] + r["write_ms"])
        r["writeback_handler_ms"] = ms(wb)
        r["writeback_reeval_ms"] = ms(rev)
        log("  split: " + "  ".join(f"{k} {v:.3f}" for k, v in r.items()))
        return r

    def measure_playback(self):
        """Frames with wrinkles (stage on, handler in) against frames without (stage off,
        handler out), interleaved A B A B like the tension measurement."""
        mod = stage.find_modifier(self.ob)
        handlers = bpy.app.handlers.frame_change_post
        base, wrinkled = [], []
        for _round in range(2):
            for on in (False, True):
                mod.show_viewport = on
                if on:
                    handlers.append(pipeline.on_frame_change_post)
                else:
                    handlers.remove(pipeline.on_frame_change_post)
                self.frame_loop(self.warm)
                (wrinkled if on else base).extend(self.frame_loop(self.frames))
        # untimed checks with the handler in: offsets change, and the frame shows its own
        me = self.ob.data
        off = np.empty((self.n, 3), _F)
        skin = np.empty((self.n, 3), _F)
        stored = np.empty((self.n, 3), _F)
        me.attributes[stage.OFFSET_ATTR].data.foreach_get("vector", stored.ravel())
        prev, changed, mags, acc, untouched = [None], [], [], [], []

        def check(ev):
            ev.attributes[stage.OFFSET_ATTR].data.foreach_get("vector", off.ravel())
            if prev[0] is not None:
                changed.append(not np.array_equal(prev[0], off))
            prev[0] = off.copy()
            mags.append(float(np.abs(off).max()))
            ev.attributes[stage.SKIN_ATTR].data.foreach_get("vector", skin.ravel())
            acc.append(float(np.abs(self.pos_buf.reshape(-1, 3) - (skin + off)).max()))
            now = np.empty_like(stored)
            me.attributes[stage.OFFSET_ATTR].data.foreach_get("vector", now.ravel())
            untouched.append(np.array_equal(now, stored))

        self.frame_loop(self.warm + self.frames, check)
        b, w = ms(base), ms(wrinkled)
        log(f"  playback_ms {w:.2f} vs {b:.2f} without wrinkles (interleaved); offsets changed on "
            f"{sum(changed)}/{len(changed)} frames, max |offset| per frame {min(mags) * 1000:.3f}.."
            f"{max(mags) * 1000:.3f} mm, max |pos - (skin + offset)| {max(acc):.2e}, original mesh "
            f"untouched (in place, no second evaluation) on {sum(untouched)}/{len(untouched)} frames")
        return {"playback_ms": w, "playback_mean_ms": mean_ms(wrinkled), "playback_base_ms": b,
                "stage_ms": w - b, "offsets_changed_frames": int(sum(changed)),
                "checked_frames": len(changed), "in_place_frames": int(sum(untouched)),
                "max_offset_mm": max(mags) * 1000.0, "stage_applied_err": max(acc)}

    def profile(self, plan, show):
        st = self.state
        contraction = np.array([m.ewrinkles_muscle.contraction
                                for m in muscle_objects.live_muscles(self.ob)], np.float64)
        self.scene.frame_set(self.frames[len(self.frames) // 2])
        ev = self.ob.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
        skin = meshio.read_vector_prefix(ev, stage.SKIN_ATTR, self.n, np.empty((self.n, 3), _F))
        ref = system.evaluate(plan, skin, contraction, 1.0, out=np.zeros((self.n, 3), _F))
        steps = {}
        for _ in range(40):
            got, t = evaluate_steps(plan, skin, contraction, 1.0, np.zeros((self.n, 3), _F))
            for k, v in t.items():
                steps.setdefault(k, []).append(v)
        same = np.array_equal(got, ref)
        tight = []
        for _ in range(40):
            c = pc()
            system.evaluate(plan, skin, contraction, 1.0, out=st.out)
            tight.append(pc() - c)
        steps = {k: float(np.median(v) * 1000) for k, v in steps.items()}
        total = sum(steps.values())
        if show:
            log(f"  evaluate() step by step (median of 40, replica identical to evaluate: {same}), "
                f"total {total:.3f} ms:")
            for k, v in sorted(steps.items(), key=lambda kv: -kv[1]):
                log(f"    {k:22s} {v:7.3f} ms  {100 * v / total:5.1f} %")
            log_profile("evaluate() calls", 14,
                        lambda: system.evaluate(plan, skin, contraction, 1.0, out=st.out))
            dg = bpy.context.evaluated_depsgraph_get()
            log_profile("pipeline.update_scene(in_place=True) calls (the handler)", 16,
                        lambda: pipeline.update_scene(self.scene, dg, in_place=True))
            bpy.context.evaluated_depsgraph_get()
        return steps, same, ms(tight)


def log_profile(what, rows, call, times=40):
    """cProfile ``times`` calls of ``call`` and log the top ``rows`` functions by tottime."""
    prof = cProfile.Profile()
    prof.enable()
    for _ in range(times):
        call()
    prof.disable()
    text = io.StringIO()
    pstats.Stats(prof, stream=text).sort_stats("tottime").print_stats(rows)
    log(f"  cProfile of {times} {what}, by tottime:")
    for line in text.getvalue().splitlines():
        if line.strip() and not line.startswith(("   Ordered", "         ")):
            log("    " + line.rstrip())


def evaluate_steps(plan, skin, contraction, strength, out):
    """``core.muscles.system.evaluate`` split into timed steps, calling its own parts (keep in sync)."""
    t = {}
    c = pc()
    s = np.take(np.asarray(skin, dtype=_F), plan.verts, axis=0).T.copy()
    finite = np.isfinite(s.sum())
    t["gather+finite"] = pc() - c
    c = pc()
    offset = system.waters_pull(plan, s, contraction)
    pulled = s + offset
    t["waters_pull"] = pc() - c
    c = pc()
    eps = system.compression(plan, pulled)
    t["compression"] = pc() - c
    c = pc()
    w = plan.row_amp * zhang.anisotropic(eps)
    height = plan.height_sum.sum(w) * _F(strength)
    t["anisotropic+heights"] = pc() - c
    c = pc()
    o = plan.output  # the output stage (core.combine) for this plan alone
    c = pc()
    s2 = np.take(np.asarray(skin, dtype=_F).reshape(-1), o.flat)
    total = np.zeros_like(s2)
    if len(o.offset_index[0]):
        total[:, o.offset_index[0]] += offset
    normal = core_mesh.normals_at(s2 + total, o.tris, o.normal_sum)
    t["normals"] = pc() - c
    c = pc()
    total[:, o.height_keys] += height * normal
    finite = finite and np.isfinite(total.sum())
    np.put(out.reshape(-1), o.flat, total)
    t["assemble+scatter"] = pc() - c
    assert finite
    return out, t


def run_size(label, target, args):
    log(f"[{label}] target {target} verts")
    t0 = pc()
    bs.clear_scene()
    pipeline._cache.clear()
    b = Bench(target, args.warm, args.frames, args.rig)
    b.build()
    r = {"verts": b.n, "head": b.source}
    r.update(b.measure_eval_and_tension())
    plan = b.add_wrinkles()
    r["region_verts"] = int(len(plan.verts))
    r["region_sizes"] = b.region_report(plan)
    r.update(b.measure_split(plan))
    r.update(b.measure_playback())
    r["gn_ratio"] = r["stage_ms"] / r["gn_tension_ms"] if r["gn_tension_ms"] > 0 else None
    r["playback_ratio"] = r["playback_ms"] / r["playback_base_ms"]
    steps, same, tight = b.profile(plan, show=(label == args.profile_at))
    r["compute_tight_loop_ms"] = tight
    r["evaluate_steps_ms"] = {k: round(v, 4) for k, v in steps.items()}
    r["evaluate_replica_exact"] = bool(same)
    log(f"  => stage {r['stage_ms']:.2f} ms (handler {r['update_face_ms']:.3f}: read {r['read_ms']:.3f}, "
        f"compute {r['compute_ms']:.3f}, write {r['write_ms']:.3f}); gn_tension {r['gn_tension_ms']:.2f} ms, "
        f"gn_ratio {r['gn_ratio']:.2f}; playback {r['playback_ms']:.2f} vs {r['playback_base_ms']:.2f} "
        f"= x{r['playback_ratio']:.2f}  [{pc() - t0:.1f} s]")
    return {k: (round(v, 4) if isinstance(v, float) else v) for k, v in r.items()}


def tree_fingerprint():
    """Short SHA-1 of the add-on and sample-scene sources measured (they change under work)."""
    import hashlib

    h = hashlib.sha1()
    for path in sorted(list((REPO / "wrinkle_addon").rglob("*.py"))
                       + list((REPO / "sample_scenes" / "lib").glob("*.py"))):
        h.update(str(path.relative_to(REPO)).encode())
        h.update(path.read_bytes())
    return h.hexdigest()[:10]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rig", choices=("light", "arkit"), default="light",
                    help="light: BrowsUp + jaw bone; arkit: 52 animated shape keys + jaw bone")
    ap.add_argument("--sizes", default="10k,50k,200k")
    ap.add_argument("--frames", type=int, default=40)
    ap.add_argument("--warm", type=int, default=5)
    ap.add_argument("--profile-at", default="50k")
    args = ap.parse_args()
    log(f"bpy {bpy.app.version_string}, numpy {np.__version__}, {os.cpu_count()} cpus, rig {args.rig}")
    t0 = pc()
    result = {"bpy": bpy.app.version_string, "rig": args.rig, "tree": tree_fingerprint(),
              "loadavg_start": round(os.getloadavg()[0], 2)}
    try:
        for label in args.sizes.split(","):
            target = int(float(label.lower().rstrip("k")) * 1000)
            result[label] = run_size(label, target, args)
    finally:
        log(f"total {pc() - t0:.1f} s")
        result["loadavg_end"] = round(os.getloadavg()[0], 2)
        bpy.ops.wm.read_factory_settings(use_empty=True)  # bpy 4.5 hangs at exit otherwise
    print(json.dumps(result), flush=True)


if __name__ == "__main__":
    main()
