# SPDX-License-Identifier: GPL-3.0-or-later
"""Per-frame cost of the wrinkle pipeline against Blender's own evaluation.

Run:  .venv45/bin/python benchmarks/frame_update.py   (or .venv52)
      options: --rig light|arkit|both  --sizes 10k,50k  --frames 40  --warm 5  --repeats 3

What it builds, how it measures and what every figure of its JSON means:
docs/benchmarks/frame_update.md.
"""

import argparse
import contextlib
import cProfile
import io
import json
import math
import os
import pstats
import sys
import tempfile
import time
import traceback
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
from wrinkle_addon.glue import meshio, pipeline, stage  # noqa: E402
from wrinkle_addon.glue.muscles import muscle_objects, muscle_set  # noqa: E402

pc = time.perf_counter
_F = np.float32
MUSCLE_LANDMARKS = ("hairline_center", "glabella", "brow_outer_L", "eye_L", "nose_tip",
                    "mouth_corner_L", "chin", "cheekbone_L")
# base, then the configurations each measured next to a base block, in a repeat's order
CONFIGS = ("base", "wrinkles", "tension", "pulling", "displace", "displace_const", "floor", "floor_maths",
           "floor_maths_pulling")
MUSCLE_CONFIGS = (("wrinkles", ""), ("pulling", "_pulling"))
# contraction keys (frame, value) per role; never 0, so every muscle pulls on every frame
CONTRACTION_KEYS = {
    "FRONTALIS_INNER": ((1, 0.05), (21, 1.0), (41, 0.05), (61, 1.0)),
    "FRONTALIS_MAJOR": ((1, 0.05), (21, 1.0), (41, 0.05), (61, 1.0)),
    "FRONTALIS_OUTER": ((1, 0.05), (21, 0.8), (41, 0.05), (61, 0.8)),
    "CORRUGATOR": ((1, 0.05), (11, 1.0), (31, 0.05), (41, 1.0)),
}
OTHER_CONTRACTION_KEYS = ((1, 0.05), (16, 0.6), (36, 0.05), (56, 0.6))


def log(*a):
    print(*a, flush=True)


def ms(values):
    """Median in ms (robust to other processes on a shared 2-core machine); None if empty."""
    return float(np.median(values) * 1000.0) if len(values) else None


def mean_ms(values):
    return float(np.mean(values) * 1000.0) if len(values) else None


def sub(a, b):
    return None if a is None or b is None else a - b


def ratio(num, den):
    """num / den, or None when either is missing or den <= 0 (noise above the reference)."""
    if num is None or den is None or not den > 0.0:
        return None
    return num / den


def median_or_none(values):
    ok = [v for v in values if v is not None and math.isfinite(v)]
    return float(np.median(ok)) if ok else None


def fmt(v, spec=".2f"):
    """``v`` formatted, or "n/a" for a figure that is missing (None) or not finite."""
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "n/a"
    if isinstance(v, (bool, int, np.integer)):
        return str(v)
    try:
        return format(v, spec)
    except (TypeError, ValueError):
        return str(v)


def clean(v):
    """JSON-safe: floats rounded to 4 places, NaN and infinities as null, recursively."""
    if isinstance(v, dict):
        return {k: clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [clean(x) for x in v]
    if isinstance(v, (float, np.floating)):
        return round(float(v), 4) if math.isfinite(v) else None
    if isinstance(v, np.integer):
        return int(v)
    if isinstance(v, np.bool_):
        return bool(v)
    return v


# The parts of the frame handler timed inside its own call (``measure_split``): the module
# and function name of each wrapped call, by part.  "write" is the in-place write and the
# ``Mesh.update()`` after the shading values.
_PARTS = {"read": ((meshio, "read_vector_prefix"),),
          "compute": ((pipeline, "_contributions"), (pipeline.combine, "combine")),
          "write": ((pipeline, "_write_in_place"), (pipeline, "_write_shading"))}


@contextlib.contextmanager
def _timed_parts():
    """Wrap the handler's parts (:data:`_PARTS`) in timers for the block; yields the dict
    part -> seconds that they add to (clear it before each frame)."""
    acc = {}
    saved = []

    def timed(fn, key):
        def call(*a, **k):
            t = pc()
            try:
                return fn(*a, **k)
            finally:
                acc[key] = acc.get(key, 0.0) + pc() - t
        return call

    for key, calls in _PARTS.items():
        for module, name in calls:
            fn = getattr(module, name)
            saved.append((module, name, fn))
            setattr(module, name, timed(fn, key))
    try:
        yield acc
    finally:
        for module, name, fn in saved:
            setattr(module, name, fn)


class Bench:
    def __init__(self, target, warm, frames, rig="light", repeats=3):
        self.target = target
        self.rig_kind = rig
        self.repeats = repeats
        self.warm = list(range(1, warm + 1))
        self.frames = list(range(warm + 1, warm + 1 + frames))
        self.scene = bpy.context.scene
        self.scene.frame_start, self.scene.frame_end = 1, 61
        self.mods = {}
        self.stage_mod = None
        self.muscles = []
        self._floor_skin = self._floor_offset = self._floor_maths = None
        self.handler(True)

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
        self._floor_skin = np.empty(self.n * 3, _F)
        self._floor_offset = np.zeros(self.n * 3, _F)
        # "" / "_pulling" -> the maths of that configuration's muscles (muscle_maths), for the
        # floor_maths configurations
        self.floor_maths = {}
        self.uv_name, made = bs.ensure_uv_map(ob)
        if self.rig_kind == "arkit":
            keys, moved = bs.add_arkit_keys(ob, self.landmarks)
            keyed = f"{len(keys)} shape keys (BrowsUp + {len(keys) - 1} regional), verts moved per " \
                    f"key median {int(np.median(moved))} (min {min(moved)}, max {max(moved)})"
        else:
            _kb, n_key = bs.add_brows_up(ob, self.landmarks)
            keyed = f"BrowsUp moves {n_key} verts"
        self.rig, n_jaw = bs.add_jaw_rig(ob, self.landmarks, self.scene)
        log(f"  head ({source}): {self.n} verts, {len(ob.data.polygons)} faces, UV map "
            f"\"{self.uv_name}\"{' (made: cylindrical)' if made else ''}; {keyed}, "
            f"Jaw group {n_jaw} verts; built in {pc() - t:.1f} s")
        if self.rig_kind == "arkit":
            self.check_keys_live()
        return {"uv_map": self.uv_name, "uv_made": made}

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
        """Times of frame_set + evaluated_depsgraph_get + position read (+ extra), per frame."""
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

    # -- configurations ----------------------------------------------------------
    @staticmethod
    def _hook(fn, on):
        handlers = bpy.app.handlers.frame_change_post
        if on and fn not in handlers:
            handlers.append(fn)
        while not on and fn in handlers:
            handlers.remove(fn)

    def handler(self, on):
        """The add-on's frame handler in or out."""
        self._hook(pipeline.on_frame_change_post, on)

    def set_pulling(self, pulling):
        """Every muscle pulling (``wrinkles_only`` off) or none (on).  Call with the stage
        off: each change runs the add-on's refresh, which then stops at the stage check
        instead of rebuilding the plan per muscle; the next frame rebuilds it once."""
        for m in self.muscles:
            if m.ewrinkles_muscle.wrinkles_only == pulling:
                m.ewrinkles_muscle.wrinkles_only = not pulling

    def floor_handler(self, on, maths=None):
        """The ``floor`` configuration's handler in or out (docs/benchmarks/frame_update.md); with
        ``maths``, a function of the skin (N, 3) that returns the offsets (N, 3), the
        ``floor_maths`` one: the same with those offsets added."""
        self._floor_maths = maths
        self._hook(self._floor, on)

    def muscle_maths(self, plan):
        """The muscles' maths of ``plan`` alone, for :meth:`floor_handler`: their
        contractions read and ``system.evaluate``, into a buffer of its own."""
        live = muscle_objects.live_muscles(self.ob)
        out = np.zeros((self.n, 3), _F)

        def maths(skin):
            contraction = np.array([m.ewrinkles_muscle.contraction for m in live], np.float64)
            return system.evaluate(plan, skin, contraction, self.ob.ewrinkles_face.strength, out=out)
        return maths

    def _floor(self, scene, depsgraph):
        """The bare minimum of a NumPy stage: read the skin the Wrinkles modifier stored,
        add an offset (zero: no wrinkle math at all), write the positions, drop normals."""
        ev = self.ob.evaluated_get(depsgraph).data
        skin = self._floor_skin
        ev.attributes[stage.SKIN_ATTR].data.foreach_get("vector", skin)
        if self._floor_maths is not None:  # floor_maths: the maths alone, no bookkeeping
            np.add(skin, self._floor_maths(skin.reshape(-1, 3)).reshape(-1), out=skin)
        else:
            np.add(skin, self._floor_offset, out=skin)
        ev.attributes["position"].data.foreach_set("vector", skin)
        ev.update()

    def set_config(self, config):
        """One of CONFIGS: which modifiers are on, the handler, the muscles' pull."""
        wrinkles = config in ("wrinkles", "pulling")
        self.handler(False)
        self.floor_handler(False)
        if self.stage_mod is not None:
            self.stage_mod.show_viewport = False
            if wrinkles:
                self.set_pulling(config == "pulling")
        for name, mod in self.mods.items():
            mod.show_viewport = name == config
        if wrinkles or config.startswith("floor"):
            self.stage_mod.show_viewport = True
        if wrinkles:
            self.handler(True)
        if config == "floor":
            self.floor_handler(True)
        elif config.startswith("floor_maths"):
            self.floor_handler(True, self.floor_maths[config[len("floor_maths"):]])

    # -- the references: GN tension and GN displacement by tension (untimed setup) --------
    def add_references(self):
        ob = self.ob
        bs.store_rest_position(ob)
        image = bs.make_height_image()
        self.mods = {"tension": bs.add_tension_modifier(ob),
                     "displace": bs.add_displace_modifier(ob, self.uv_name, image),
                     "displace_const": bs.add_displace_modifier(ob, self.uv_name, None)}
        self.set_config("base")
        r = {}
        # every frame really deforms the mesh
        prev, moved = [None], []

        def track(_ev):
            if prev[0] is not None:
                moved.append(not np.array_equal(prev[0], self.pos_buf))
            prev[0] = self.pos_buf.copy()

        self.frame_loop(self.warm + self.frames, track)
        r["positions_changed_frames"] = int(sum(moved))
        log(f"  evaluated positions changed on {sum(moved)}/{len(moved)} frames")
        # the displacement references move the skin, the textured one by the image
        f = self.frames[len(self.frames) // 2]
        shown = {}
        for config in ("base", "displace", "displace_const"):
            self.set_config(config)
            self.frame_loop([f - 1, f])
            shown[config] = self.pos_buf.reshape(-1, 3).copy()
        self.set_config("base")
        d_tex = np.linalg.norm(shown["displace"] - shown["base"], axis=1)
        d_const = np.linalg.norm(shown["displace_const"] - shown["base"], axis=1)
        both = d_const > 1e-9
        rel = d_tex[both] / d_const[both]
        varies = bool(both.any() and float(rel.std()) > 1e-3 * max(float(rel.mean()), 1e-12))
        r["displace_max_mm"] = float(d_tex.max()) * 1000.0
        r["displace_const_max_mm"] = float(d_const.max()) * 1000.0
        r["displace_moved_verts"] = int(np.count_nonzero(d_tex > 1e-9))
        r["displace_textured_varies"] = varies
        log(f"  GN displacement on frame {f}: textured max {fmt(r['displace_max_mm'], '.3f')} mm on "
            f"{r['displace_moved_verts']} verts, constant max {fmt(r['displace_const_max_mm'], '.3f')} mm; "
            f"texture sampled (textured / constant not constant): {varies}")
        return r

    def select_face(self):
        """The face selected and active, alone: the add-on's operators work on it."""
        vl = bpy.context.view_layer
        for o in vl.objects:
            o.select_set(False)
        self.ob.select_set(True)
        vl.objects.active = self.ob

    # -- the wrinkle stage ---------------------------------------------------
    def add_wrinkles(self):
        t = pc()
        self.set_config("base")
        self.handler(True)
        self.scene.frame_set(1)
        self.select_face()
        res = bpy.ops.wrinkle.enable()
        assert res == {"FINISHED"}, res
        self.stage_mod = stage.find_modifier(self.ob)
        lm = {k: self.landmarks[k] for k in MUSCLE_LANDMARKS}
        self.muscles = muscle_set.build_muscle_set(bpy.context, self.ob, lm)
        self.stage_mod.show_viewport = False  # no plan rebuild per key below
        for m in self.muscles:
            for f, v in CONTRACTION_KEYS.get(m.ewrinkles_muscle.role, OTHER_CONTRACTION_KEYS):
                m.ewrinkles_muscle.contraction = v
                m.keyframe_insert("ewrinkles_muscle.contraction", frame=f)
        self.set_config("wrinkles")
        self.scene.frame_set(2)
        self.scene.frame_set(1)
        low = float("inf")
        for f in self.warm + self.frames:
            self.scene.frame_set(f)
            low = min(low, min(m.ewrinkles_muscle.contraction for m in self.muscles))
        log(f"  wrinkles on, {len(self.muscles)} muscles, in {pc() - t:.1f} s; min contraction of any "
            f"muscle on any frame {low:.3f} (every muscle pulls on every frame in the pulling blocks)")
        if pipeline.status_of(self.ob):
            log(f"  status: {pipeline.status_of(self.ob)}")
        return {"muscles": len(self.muscles), "min_contraction": low}

    def state(self):
        return pipeline.face_state(self.ob)

    def plan(self):
        """The muscle source's static plan, as the frame stage holds it now."""
        return self.state().statics["muscles"][1].plan

    def log_plan(self, plan, config):
        def size(name, axis=None):
            v = getattr(plan, name, None)
            if v is None:
                v = getattr(getattr(plan, "output", None), name, None)
            if v is None:
                return "?"
            return v.shape[axis] if axis is not None else len(v)

        log(f"  [{config}] plan: region_verts {len(plan.verts)} ({100 * len(plan.verts) / self.n:.1f} %), "
            f"rows {size('row_vert')}, pairs {size('pair_edge')}, edges {size('edges', 1)}, "
            f"tris {size('tris', 1)}, pull rows {size('pull_vert')}, "
            f"offset verts {len(plan.footprint.offset_verts)}")

    def region_report(self, plan):
        rest = self.state().mesh.rest
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
        self.handler(False)
        try:
            live = muscle_objects.live_muscles(ob)
            strength = ob.ewrinkles_face.strength
            st = self.state()
            rd, cp, wr, base, uf, full, wb, rev, inside = [], [], [], [], [], [], [], [], []
            refused = [0]

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
                if getattr(st, "positions", None) is not None:  # what _write_in_place compares
                    ev.attributes["position"].data.foreach_get("vector", st.positions.reshape(-1))
                written = pipeline.write_in_place(ob, ev, skin, out)
                t5 = pc()
                if record:
                    base.append(t1 - t0)
                    rd.append(t2 - t1)
                    cp.append(t4 - t3)
                    wr.append(t5 - t4)
                    refused[0] += not written

            for f in self.warm:
                one(f, False)
            for f in self.frames:
                one(f, True)

            # the whole handler call as the viewport makes it: the add-on's own frame handler,
            # by its own clock (pipeline.stage_seconds) around Blender's call with the frame's
            # depsgraph (change detection included); its skin read, maths and in-place write
            # timed inside the same call (wrapped), so the overhead is per frame, not the
            # difference of two loops
            self.handler(True)
            with _timed_parts() as parts:
                for f in self.warm + self.frames:
                    parts.clear()
                    s0 = pipeline.stage_seconds[0]
                    self.scene.frame_set(f)
                    if f in self.frames:
                        uf.append(pipeline.stage_seconds[0] - s0)
                        inside.append(dict(parts))
                    self.read_positions(bpy.context.evaluated_depsgraph_get())
            self.handler(False)
            # the full check that edits and refreshes run (no change list: every key
            # computed, the rest compared), then the write-back path that render and export
            # frames take, with its re-evaluation
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
                    full.append(t1 - t0)
                    wb.append(t2 - t1)
                    rev.append(t3 - t2)
        finally:
            self.handler(True)
        r = {"read_ms": ms(rd), "compute_ms": ms(cp), "write_ms": ms(wr)}
        r["eval_stage_ms"] = ms(base)
        r["update_face_ms"] = ms(uf)
        for key in _PARTS:
            r[f"handler_{key}_ms"] = ms([p.get(key, 0.0) for p in inside])
        r["overhead_ms"] = ms([t - sum(p.values()) for t, p in zip(uf, inside)])
        r["overhead_two_loops_ms"] = sub(r["update_face_ms"], sum(r[k] for k in ("read_ms", "compute_ms",
                                                                                   "write_ms")))
        r["update_scene_full_ms"] = ms(full)
        r["writeback_handler_ms"] = ms(wb)
        r["writeback_reeval_ms"] = ms(rev)
        r["write_refused_frames"] = refused[0]
        log("  split: " + "  ".join(f"{k} {fmt(v, '.3f')}" for k, v in r.items()))
        return r

    # -- the interleaved measurement -------------------------------------------------
    def measure_interleaved(self):
        """``repeats`` rounds of (base block, configuration block) pairs (docs/benchmarks/frame_update.md)."""
        tension = np.empty(self.n, _F)
        tension_min = []

        def read_tension(ev):
            ev.attributes[bs.TENSION_ATTR].data.foreach_get("value", tension)
            tension_min.append(float(tension.min()))

        paired = [c for c in CONFIGS if c != "base"
                  and (not c.startswith("floor_maths") or c[len("floor_maths"):] in self.floor_maths)]
        times = {c: [] for c in paired}  # per configuration: its block's frame times, per repeat
        base = {c: [] for c in paired}  # the same for the base block next to it
        for rep in range(self.repeats):
            t = pc()
            seq = [(config, pair) for pair in paired for config in ("base", pair)]
            for config, pair in (seq if rep % 2 == 0 else seq[::-1]):
                self.set_config(config)
                extra = read_tension if config == "tension" else None
                self.frame_loop(self.warm, extra)
                (base if config == "base" else times)[pair].append(self.frame_loop(self.frames, extra))
            log(f"  repeat {rep + 1}/{self.repeats}: " + "  ".join(
                f"{c} {fmt(ms(times[c][-1]))} (base {fmt(ms(base[c][-1]))})" for c in paired)
                + f"  [{pc() - t:.1f} s]")
        self.set_config("wrinkles")
        log(f"  tension min over frames {fmt(min(tension_min, default=None), '.4f')}, varies: "
            f"{len(set(np.round(tension_min, 6))) > 1}")

        def flat(blocks):
            return [x for block in blocks for x in block]

        pooled = {c: flat(times[c]) for c in paired}
        pooled_base = flat(flat(base.values()))
        med = {c: [ms(block) for block in times[c]] for c in paired}
        med_base = {c: [ms(block) for block in base[c]] for c in paired}
        diff = {c: [sub(a, b) for a, b in zip(med[c], med_base[c])] for c in paired}
        per = {
            "gn_ratio": [ratio(a, b) for a, b in zip(diff["wrinkles"], diff["tension"])],
            "gn_ratio_pulling": [ratio(a, b) for a, b in zip(diff["pulling"], diff["tension"])],
            "gn_displace_ratio": [ratio(a, b) for a, b in zip(diff["wrinkles"], diff["displace"])],
            "floor_ratio": [ratio(a, b) for a, b in zip(diff["floor"], diff["tension"])],
            "floor_displace_ratio": [ratio(a, b) for a, b in zip(diff["floor"], diff["displace"])],
            "playback_ratio": [ratio(a, b) for a, b in zip(med["wrinkles"], med_base["wrinkles"])],
            "playback_ratio_floor": [ratio(a, b) for a, b in zip(med["floor"], med_base["floor"])],
            "playback_ratio_pulling": [ratio(a, b) for a, b in zip(med["pulling"], med_base["pulling"])],
        }
        eval_ms = ms(pooled_base)
        r = {"eval_ms": eval_ms, "eval_mean_ms": mean_ms(pooled_base)}
        for name in ("tension", "displace", "displace_const", "floor", "floor_maths", "floor_maths_pulling"):
            if name in paired:
                r[name + "_frame_ms"] = ms(pooled[name])
                r[("" if name.startswith("floor") else "gn_") + name + "_ms"] = median_or_none(diff[name])
        r["tension_min"] = min(tension_min, default=None)
        for config, sfx in MUSCLE_CONFIGS:
            r["playback_ms" + sfx] = ms(pooled[config])
            r["playback_mean_ms" + sfx] = mean_ms(pooled[config])
            r["stage_ms" + sfx] = median_or_none(diff[config])
        r["playback_base_ms"] = eval_ms
        for k, v in per.items():
            r[k] = median_or_none(v)
        r["per_repeat"] = {"frame_ms": med, "base_ms": med_base, "cost_ms": diff, **per}
        log("  per repeat: " + "  ".join(f"{k} [{', '.join(fmt(x) for x in v)}]" for k, v in per.items()))
        return r

    def check_wrinkles(self, config, sfx):
        """Untimed, handler in: offsets change, and the frame shows its own wrinkles."""
        self.set_config(config)
        self.frame_loop(self.warm)
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
        r = {"offsets_changed_frames": int(sum(changed)), "checked_frames": len(changed),
             "in_place_frames": int(sum(untouched)),
             "max_offset_mm": max(mags) * 1000.0 if mags else None,
             "stage_applied_err": max(acc) if acc else None}
        log(f"  [{config}] offsets changed on {sum(changed)}/{len(changed)} frames, max |offset| per "
            f"frame {fmt(min(mags, default=None) * 1000 if mags else None, '.3f')}.."
            f"{fmt(r['max_offset_mm'], '.3f')} mm, max |pos - (skin + offset)| "
            f"{fmt(r['stage_applied_err'], '.2e')}, original mesh untouched (in place, no second "
            f"evaluation) on {sum(untouched)}/{len(untouched)} frames")
        return {k + sfx: v for k, v in r.items()}

    def profile(self, plan, show, config):
        contraction = np.array([m.ewrinkles_muscle.contraction
                                for m in muscle_objects.live_muscles(self.ob)], np.float64)
        self.scene.frame_set(self.frames[len(self.frames) // 2])
        ev = self.ob.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
        skin = meshio.read_vector_prefix(ev, stage.SKIN_ATTR, self.n, np.empty((self.n, 3), _F))
        out = np.zeros((self.n, 3), _F)
        r = {}
        tight = []
        for _ in range(40):
            c = pc()
            system.evaluate(plan, skin, contraction, 1.0, out=out)
            tight.append(pc() - c)
        r["compute_tight_loop_ms"] = ms(tight)
        try:
            ref = system.evaluate(plan, skin, contraction, 1.0, out=np.zeros((self.n, 3), _F))
            steps = {}
            for _ in range(40):
                got, t = evaluate_steps(plan, skin, contraction, 1.0, np.zeros((self.n, 3), _F))
                for k, v in t.items():
                    steps.setdefault(k, []).append(v)
            same = bool(np.array_equal(got, ref))
            steps = {k: float(np.median(v) * 1000) for k, v in steps.items()}
            r["evaluate_steps_ms"] = {k: round(v, 4) for k, v in steps.items()}
            r["evaluate_replica_exact"] = same
        except Exception as exc:  # noqa: BLE001 - the replica follows the add-on's internals
            steps, same = {}, None
            r["evaluate_steps_ms"], r["evaluate_replica_exact"] = None, None
            r["evaluate_steps_error"] = repr(exc)
            log(f"  evaluate() step replica failed ({exc!r}): the add-on's internals changed")
        if show:
            total = sum(steps.values())
            if steps:
                log(f"  [{config}] evaluate() step by step (median of 40, replica identical to "
                    f"evaluate: {same}), total {total:.3f} ms:")
                for k, v in sorted(steps.items(), key=lambda kv: -kv[1]):
                    log(f"    {k:22s} {v:7.3f} ms  {100 * v / total if total else 0.0:5.1f} %")
            log_profile(f"[{config}] evaluate() calls", 14,
                        lambda: system.evaluate(plan, skin, contraction, 1.0, out=out))
            dg = bpy.context.evaluated_depsgraph_get()
            self.handler(False)
            try:
                log_profile(f"[{config}] pipeline.update_scene(in_place=True) calls (the handler)", 16,
                            lambda: pipeline.update_scene(self.scene, dg, in_place=True))
            finally:
                self.handler(True)
            bpy.context.evaluated_depsgraph_get()
        return r


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
    pulled = s if offset is None else s + offset
    t["waters_pull"] = pc() - c
    c = pc()
    eps = system.compression(plan, pulled)
    t["compression"] = pc() - c
    c = pc()
    a = system.smooth_rows(plan, zhang.anisotropic(eps))
    w = plan.row_amp * a
    height = system.blend(plan, a, w, plan.height_sum.sum(w)) * _F(strength)
    t["anisotropic+heights"] = pc() - c  # with the blend of folds that meet
    c = pc()
    o = plan.output  # the output stage (core.combine) for this plan alone
    c = pc()
    s2 = np.take(np.asarray(skin, dtype=_F).reshape(-1), o.flat)
    total = np.zeros_like(s2)
    if len(o.offset_index[0]) and offset is not None:
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



def run_size(label, target, args, rig, r):
    """Measure one head size on one rig into ``r`` (filled as it goes, so a failure keeps
    what was measured)."""
    log(f"[{rig} {label}] target {target} verts")
    t0 = pc()
    bs.clear_scene()
    pipeline.forget_all()
    b = Bench(target, args.warm, args.frames, rig, args.repeats)
    r.update(b.build())
    r.update({"verts": b.n, "head": b.source})
    r.update(b.add_references())
    r.update(b.add_wrinkles())
    show = label == args.profile_at
    for config, sfx in MUSCLE_CONFIGS:
        # the hand-timed parts reach into the add-on's internals, which change under work:
        # a failure here is recorded and the interleaved measurement still runs
        try:
            b.set_config(config)
            b.frame_loop(b.warm)  # (re)builds the plan of this configuration
            plan = b.plan()
            b.log_plan(plan, config)
            r["region_verts" + sfx] = int(len(plan.verts))
            b.floor_maths[sfx] = b.muscle_maths(plan)
            if not sfx:
                r["region_sizes"] = b.region_report(plan)
            r.update({k + sfx: v for k, v in b.measure_split(plan).items()})
            r.update({k + sfx: v for k, v in b.profile(plan, show, config).items()})
        except Exception as exc:  # noqa: BLE001
            r["split_error" + sfx] = repr(exc)
            log(f"  [{config}] hand-timed parts FAILED (the add-on's internals changed?):")
            log(traceback.format_exc())
            b.handler(True)
    r.update(b.measure_interleaved())
    cost = r["per_repeat"]["cost_ms"]
    for config, sfx in MUSCLE_CONFIGS:
        tight = r.get("compute_tight_loop_ms" + sfx)
        floors = [None if f is None or tight is None else f + tight for f in cost["floor"]]
        per = [ratio(a, f) for a, f in zip(cost[config], floors)]
        r["stage_floor_ratio" + sfx] = median_or_none(per)
        r["per_repeat"]["stage_floor_ratio" + sfx] = per
        if cost.get("floor_maths" + sfx):
            per = [ratio(a, f) for a, f in zip(cost[config], cost["floor_maths" + sfx])]
            r["stage_floor_maths_ratio" + sfx] = median_or_none(per)
            r["per_repeat"]["stage_floor_maths_ratio" + sfx] = per
    for config, sfx in MUSCLE_CONFIGS:
        r.update(b.check_wrinkles(config, sfx))
    g = r.get
    log(f"  => wrinkles-only: stage {fmt(g('stage_ms'))} ms (handler {fmt(g('update_face_ms'), '.3f')}: "
        f"read {fmt(g('read_ms'), '.3f')}, compute {fmt(g('compute_ms'), '.3f')}, write "
        f"{fmt(g('write_ms'), '.3f')}); pulling: stage {fmt(g('stage_ms_pulling'))} ms (handler "
        f"{fmt(g('update_face_ms_pulling'), '.3f')}, compute {fmt(g('compute_ms_pulling'), '.3f')})")
    log(f"  => GN tension {fmt(g('gn_tension_ms'))} ms, GN displace {fmt(g('gn_displace_ms'))} ms "
        f"(constant height {fmt(g('gn_displace_const_ms'))} ms); gn_ratio {fmt(g('gn_ratio'))} "
        f"(pulling {fmt(g('gn_ratio_pulling'))}), gn_displace_ratio {fmt(g('gn_displace_ratio'))}; "
        f"playback {fmt(g('playback_ms'))} vs {fmt(g('playback_base_ms'))} = x{fmt(g('playback_ratio'))} "
        f"(pulling {fmt(g('playback_ms_pulling'))} = x{fmt(g('playback_ratio_pulling'))})  "
        f"[{pc() - t0:.1f} s]")
    log(f"  => stage over its floor: stage_floor_ratio {fmt(g('stage_floor_ratio'))} (pulling "
        f"{fmt(g('stage_floor_ratio_pulling'))}), over the floor with the maths in the frame "
        f"{fmt(g('stage_floor_maths_ratio'))} (pulling {fmt(g('stage_floor_maths_ratio_pulling'))}), "
        f"overhead {fmt(g('overhead_ms'), '.3f')} ms (pulling "
        f"{fmt(g('overhead_ms_pulling'), '.3f')})")
    log(f"  => floor (read + write + GN stage, no math) {fmt(g('floor_ms'))} ms: floor_ratio "
        f"{fmt(g('floor_ratio'))}, floor_displace_ratio {fmt(g('floor_displace_ratio'))}, playback "
        f"x{fmt(g('playback_ratio_floor'))}")


def tree_fingerprint():
    """Short SHA-1 of the add-on and sample-scene sources measured (they change under work)."""
    import hashlib

    h = hashlib.sha1()
    for path in sorted(list((REPO / "wrinkle_addon").rglob("*.py"))
                       + list((REPO / "sample_scenes" / "lib").glob("*.py"))):
        h.update(str(path.relative_to(REPO)).encode())
        h.update(path.read_bytes())
    return h.hexdigest()[:10]


def run_rig(rig, args):
    """{size label: figures} for one rig; True in second place if a size failed."""
    out, failed = {}, False
    for label in args.sizes.split(","):
        target = int(float(label.lower().rstrip("k")) * 1000)
        r = out[label] = {}
        try:
            run_size(label, target, args, rig, r)
        except Exception as exc:  # noqa: BLE001 - keep what was measured, print the JSON anyway
            failed = True
            r["error"] = repr(exc)
            log(f"  [{rig} {label}] FAILED:")
            log(traceback.format_exc())
        out[label] = clean(r)
    return out, failed


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rig", choices=("light", "arkit", "both"), default="light",
                    help="light: BrowsUp + jaw bone; arkit: 52 animated shape keys + jaw bone; "
                    "both: arkit then light, one JSON line")
    ap.add_argument("--sizes", default="10k,50k,200k")
    ap.add_argument("--frames", type=int, default=40)
    ap.add_argument("--warm", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=3,
                    help="interleaved repeats; every ratio is the median of the per-repeat ratios")
    ap.add_argument("--profile-at", default="50k")
    args = ap.parse_args()
    if args.repeats < 3:
        ap.error("--repeats must be at least 3 (every ratio is a median of repeats)")
    rigs = ("arkit", "light") if args.rig == "both" else (args.rig,)
    log(f"bpy {bpy.app.version_string}, numpy {np.__version__}, {os.cpu_count()} cpus, "
        f"rig {args.rig}, {args.repeats} repeats")
    t0 = pc()
    meta = {"bpy": bpy.app.version_string, "rig": args.rig, "tree": tree_fingerprint(),
            "repeats": args.repeats, "frames": args.frames, "warm": args.warm,
            "loadavg_start": round(os.getloadavg()[0], 2)}
    results, loads, failed = {}, {}, False
    try:
        for rig in rigs:
            start = round(os.getloadavg()[0], 2)
            results[rig], bad = run_rig(rig, args)
            failed = failed or bad
            loads[rig] = [start, round(os.getloadavg()[0], 2)]
    except BaseException:  # noqa: BLE001 - interrupted: still print what was measured
        failed = True
        log(traceback.format_exc())
    finally:
        log(f"total {pc() - t0:.1f} s")
        meta["loadavg_end"] = round(os.getloadavg()[0], 2)
        try:
            bpy.ops.wm.read_factory_settings(use_empty=True)  # bpy 4.5 hangs at exit otherwise
        except Exception:  # noqa: BLE001
            log(traceback.format_exc())
    if args.rig == "both":
        meta["rigs"] = list(rigs)
        del meta["rig"]
        meta["loadavg"] = loads
        result = {"meta": meta, **results}
    else:
        end = meta.pop("loadavg_end")
        result = {**meta, **results.get(args.rig, {}), "loadavg_end": end}
    print(json.dumps(clean(result)), flush=True)
    if failed:
        sys.exit(1)


if __name__ == "__main__":
    main()
