# SPDX-License-Identifier: GPL-3.0-or-later
"""Every wrinkle source on one face at once, at 50k and 200k vertices: what each costs a frame,
what all together cost, and how that compares with their floors.

Run:  .venv45/bin/python benchmarks/whole_face.py   (or .venv52)
      options: --sizes 50k,200k  --frames 30  --warm 5  --repeats 3

The face and rig are ``benchmarks/frame_update.py``'s ARKit-like one (``Bench.build`` with
``--rig arkit``: headgen's head with its UV map, 52 animated shape keys and the jaw bone), and
on it, as an artist would add them through the operators:

* the full muscle set (``Bench.add_wrinkles``: 24 muscles, their contractions keyed), every
  one pulling (``wrinkles_only`` off);
* 20 wrinkle curves on the forehead and the cheeks (``fine_wrinkles.place_curves``);
* fine wrinkles carved at 512 x 512 (``fine_wrinkles.add_fine_attributes``);
* 10 pattern layers running with the scene (``patterns.places``, ``patterns.KINDS``);
* 2 shedding tears (``patterns.add_tears``);
* wrinkle maps with tension zones: masks generated from the muscles, a wrinkle map baked
  from them (512 x 512), the zone weights measured from the skin's compression every frame
  (``weight_mode`` TENSION).

Configurations, in blocks interleaved within each repeat (the order reversed every other
repeat), each block ``Bench.frame_loop`` (frame_set + evaluated depsgraph + reading the
positions, the add-on's handler in, the viewport's path) over ``--frames`` new frames after
``--warm`` warm-up frames: *base*, Blender alone (the Wrinkles and Fine Wrinkles modifiers
hidden, the tears hidden, the handler out); *floor*, the Wrinkles modifier with
``frame_update.py``'s bare handler (read the skin, write the positions, no maths); *none*, the
stage with every source off; one block per source with that source alone on (*muscles*,
*curves*, *fine*, *patterns*, *tears*, *maps*); *all*, every source on.  Switching sources
rebuilds their static data on the block's first warm-up frame, never in a timed one.

Per size, one JSON object:

``frame_ms``
    Per source and for ``all``: the median over the repeats of (the block's median frame -
    the base block's), what it adds to Blender's own frame.
``playback_ratio``
    The median over the repeats of (all's median frame / base's).  Goal: at most 2.0.
``all_floor_ratio``
    (all - base) / the sum of the sources' floors, per repeat, the median: the bare stage
    (floor - base), plus the NumPy arithmetic of each Python source alone in a tight loop on
    one frame's skin (the muscles' ``core.muscles.system.evaluate``; the curves' edges, heights
    and the normals under them, as ``fine_wrinkles.py``'s floor; the layers' heights and the
    stage's arithmetic for them, as ``patterns.py``'s; the maps' zone tension), plus the cost
    of the sources Blender computes itself, which have no NumPy floor (fine and tears: their
    block - none).  Goal: at most 1.3 at 50k.
``floor_playback_ratio``
    What playback would be at the floors, measured in the same run: per repeat,
    (base + the sum of the floors above) / base, the median.  ``playback_over_floor`` is
    ``playback_ratio`` / ``floor_playback_ratio`` (per repeat, the median): how far all the
    sources together are from their floors as the artist sees it.  Goal: at most 1.3 at 50k
    and at 200k.
``floors_ms``
    Those floors, each; ``per_repeat``: the blocks' median frames.

``tension_write_ms`` / ``tension_write_v1_ms``
    Writing one frame's 8 tension-driven zone values into the weights group: as three
    colours (``nodegroups.set_tension``), and as weights version 1 did, a Value node each
    (eight sets), side by side in the same group (``Face.tension_writes``).
``growth_200k_over_50k``: all's frame_ms at 200k over all's at 50k.  Goal: at most 4.4.
Output: progress on stderr, one JSON line on stdout::

    {"50k": {"frame_ms": {...}, "all_floor_ratio": .., "playback_ratio": .., ...}, "200k": {...},
     "growth_200k_over_50k": .., "bpy": ".."}
"""

import argparse
import json
import sys
import time
import traceback
from pathlib import Path

HERE = Path(__file__).resolve().parent
for _p in (str(HERE.parent), str(HERE)):
    if _p not in sys.path:
        sys.path.insert(0, _p)

import fine_wrinkles as fw  # noqa: E402
import frame_update as fu  # noqa: E402  (bpy, and the add-on enabled first)
import numpy as np  # noqa: E402
import patterns as pt  # noqa: E402

SOURCES = ("muscles", "curves", "fine", "patterns", "tears", "maps")


def log(msg):
    print(f"[whole_face] {msg}", file=sys.stderr, flush=True)


def tight(fn, *args, times=30):
    """Median ms of ``fn(*args)`` called ``times`` times in a row."""
    out = []
    for _ in range(times):
        t = time.perf_counter()
        fn(*args)
        out.append(time.perf_counter() - t)
    return fu.ms(out)


class Face:
    """The bench face with every source, and the switches of the configurations."""

    def __init__(self, target, warm, frames, repeats):
        import bpy
        from mathutils import Vector

        fu.bs.clear_scene()
        fu.pipeline.forget_all()
        t = time.perf_counter()
        self.bench = b = fu.Bench(target, warm, frames, "arkit", repeats)
        b.build()
        b.add_wrinkles()  # Enable Wrinkles, the muscle set, its contractions keyed
        b.set_config("pulling")
        face = self.face = b.ob
        self.stage_mod = b.stage_mod
        b.select_face()
        vl = bpy.context.view_layer
        self.curves = fw.place_curves(b, 20)
        self.fine_image = fw.add_fine_attributes(b)
        from wrinkle_addon.glue.bando import fine_tree

        self.fine_mod = fine_tree.find_modifier(face)
        for kind, point in zip(pt.KINDS, pt.places(b.landmarks)):
            bpy.context.scene.cursor.location = face.matrix_world @ Vector(point.tolist())
            vl.objects.active = face
            if bpy.ops.wrinkle.add_pattern(kind=kind, where="CURSOR") != {"FINISHED"}:
                raise RuntimeError(f"Add Pattern {kind} failed")
        self.layers = face.ewrinkles_face.patterns.layers
        for lay in self.layers:
            lay.follow_scene = True
        self.tears = pt.add_tears(face, b.landmarks, 2)
        vl.objects.active = face
        maps = face.ewrinkles_face.maps
        assert bpy.ops.wrinkle.generate_masks(source="MUSCLES") == {"FINISHED"}
        assert bpy.ops.wrinkle.bake_wrinkle_map(resolution="512", mode="MUSCLES") == {"FINISHED"}
        assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
        maps.weight_mode = "TENSION"
        self.maps = maps
        self.muscle_homes = {m.name: list(m.users_collection) for m in b.muscles}
        log(f"{b.n} verts: {len(b.muscles)} muscles, {len(self.curves)} curves, fine wrinkles, "
            f"{len(self.layers)} layers, {len(self.tears)} tears, tension maps; built in "
            f"{time.perf_counter() - t:.1f} s")

    def set(self, on, stage=True, handler=True, floor=False):
        """The sources in ``on`` switched on, the others off (with the stage hidden meanwhile:
        no static rebuild per property), then the stage, the handler and the bare floor."""
        b, face = self.bench, self.face
        b.handler(False)
        b.floor_handler(False)
        self.stage_mod.show_viewport = False
        for m in b.muscles:
            linked = bool(m.users_collection)
            if ("muscles" in on) != linked:
                for coll in self.muscle_homes[m.name]:
                    (coll.objects.link if not linked else coll.objects.unlink)(m)
        for ob in self.curves:
            if ob.ewrinkles_curve.enabled != ("curves" in on):
                ob.ewrinkles_curve.enabled = "curves" in on
        fine = "fine" in on
        face.ewrinkles_face.fine_wrinkles.image_1 = self.fine_image if fine else None
        self.fine_mod.show_viewport = fine
        for lay in self.layers:
            if lay.show_viewport != ("patterns" in on):
                lay.show_viewport = "patterns" in on
        for ob in self.tears:
            if ob.hide_viewport == ("tears" in on):
                ob.hide_viewport = "tears" not in on
        mode = "TENSION" if "maps" in on else "TABLE"
        if self.maps.weight_mode != mode:
            self.maps.weight_mode = mode
        self.stage_mod.show_viewport = stage
        if stage:  # one full update, as a property change in the interface makes
            import bpy

            fu.pipeline.refresh_all(bpy.context)
        b.handler(handler)
        b.floor_handler(floor)

    def configure(self, config):
        if config == "base":
            self.set((), stage=False, handler=False)
        elif config == "floor":
            self.set((), handler=False, floor=True)
        elif config == "none":
            self.set(())
        elif config == "all":
            self.set(SOURCES)
        else:
            self.set((config,))

    def floors(self):
        """The NumPy floors of the Python sources (see the module docstring), ms, on the
        current frame's skin with every source on."""
        import bpy

        from wrinkle_addon.core import combine
        from wrinkle_addon.core.muscles import system
        from wrinkle_addon.core.patterns import functions as core_patterns
        from wrinkle_addon.glue import registry

        b, face = self.bench, self.face
        self.configure("all")
        b.frame_loop(b.warm)
        state = fu.pipeline.face_state(face)
        statics = {name: data for name, (_key, data, _serial) in state.statics.items()}
        ev = face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
        skin = fu.meshio.read_vector_prefix(ev, fu.stage.SKIN_ATTR, b.n, np.empty((b.n, 3), np.float32))
        out = np.zeros((b.n, 3), np.float32)
        live = fu.muscle_objects.live_muscles(face)
        contraction = np.array([m.ewrinkles_muscle.contraction for m in live], np.float64)
        r = {"muscles": tight(system.evaluate, statics["muscles"].plan, skin, contraction, 1.0, out)}
        floor = fw.Floor(statics["curves"].plan, b.n)
        src = {s.name: s for s in registry.sources()}
        heights = src["curves"].contribute(face, statics["curves"], skin, ())
        geometric = [s for s in registry.sources() if s.geometric and s.active(face)]
        parts = [heights if s.name == "curves" else combine.Contribution() for s in geometric]
        r["curves"] = (tight(floor.edges, skin) + tight(floor.heights)
                       + tight(combine.combine, state.plan, skin, parts, out))
        st = statics["patterns"]
        values = [v[0][:5] for v in src["patterns"].inputs(face, st)]
        _maths, time_combine = pt.layers_maths(face, st, values)
        r["patterns"] = tight(core_patterns.heights, st.plan, values) + time_combine()
        maps_inputs = src["maps"].inputs(face, statics["maps"])
        r["maps"] = tight(src["maps"].contribute, face, statics["maps"], skin, maps_inputs)
        return r

    def tension_writes(self, rounds=5, calls=20):
        """What writing a frame's 8 tension values into the weights group costs (ms a
        frame), as the add-on writes them (three colours, ``nodegroups.set_tension``) and
        as weights version 1 did (a Value node each, eight sets), side by side in the same
        group and material: ``rounds`` interleaved blocks of ``calls`` frames, each frame's
        values new, the medians."""
        ng = self.maps.weights_group
        legacy = []
        for z in range(8):
            node = ng.nodes.new("ShaderNodeValue")
            node.name = f"v1 Tension {z}"
            legacy.append(node.outputs[0])
        from wrinkle_addon.glue.maps import nodegroups

        rng = np.random.default_rng(0)
        frames = rng.random((2 * calls, 8)).astype(np.float32).tolist()

        def packed(i):
            nodegroups.set_tension(ng, frames[i % len(frames)])

        def v1(i):
            for out, v in zip(legacy, frames[i % len(frames)]):
                if out.default_value != v:
                    out.default_value = v

        times = {"packed": [], "v1": []}
        i = 0
        for rnd in range(rounds):
            for name, fn in (("packed", packed), ("v1", v1))[:: 1 if rnd % 2 == 0 else -1]:
                t = time.perf_counter()
                for _ in range(calls):
                    fn(i)
                    i += 1
                times[name].append((time.perf_counter() - t) / calls)
        for out in legacy:
            ng.nodes.remove(out.node)
        return {"tension_write_ms": fu.ms(times["packed"]), "tension_write_v1_ms": fu.ms(times["v1"])}


def run_size(label, target, args):
    import bpy

    f = Face(target, args.warm, args.frames, args.repeats)
    b = f.bench
    configs = ("base", "floor", "none") + SOURCES + ("all",)
    times = {c: [] for c in configs}
    peak = {}
    for rep in range(args.repeats):
        for config in (configs if rep % 2 == 0 else configs[::-1]):
            f.configure(config)
            b.frame_loop(b.warm)
            times[config].append(b.frame_loop(b.frames))
            state = fu.pipeline.face_state(f.face)  # untimed: what the stage wrote on the last frame
            if state is not None and state.out is not None and config not in ("base", "floor"):
                peak[config] = max(peak.get(config, 0.0), float(np.abs(state.out).max()) * 1000.0)
        log(f"{label} repeat {rep + 1}/{args.repeats}: "
            + ", ".join(f"{c} {fu.ms(times[c][-1]):.2f}" for c in configs) + " ms")
    floors = f.floors()
    writes = f.tension_writes()
    med = {c: [fu.ms(block) for block in blocks] for c, blocks in times.items()}
    cost = {c: [a - base for a, base in zip(med[c], med["base"])] for c in configs if c != "base"}
    frame_ms = {c: fu.clean(fu.median_or_none(cost[c])) for c in SOURCES + ("all",)}
    gn = {c: [a - n for a, n in zip(med[c], med["none"])] for c in ("fine", "tears")}
    numpy_floor = sum(floors.values())
    ratios = [fu.ratio(a, fl + numpy_floor + fi + te) for a, fl, fi, te in
              zip(cost["all"], cost["floor"], gn["fine"], gn["tears"])]
    playback = [fu.ratio(a, base) for a, base in zip(med["all"], med["base"])]
    at_floor = [fu.ratio(base + fl + numpy_floor + fi + te, base) for base, fl, fi, te in
                zip(med["base"], cost["floor"], gn["fine"], gn["tears"])]
    over_floor = [fu.ratio(p, q) for p, q in zip(playback, at_floor)]
    r = {"verts": b.n, "frame_ms": frame_ms, "all_floor_ratio": fu.clean(fu.median_or_none(ratios)),
         "playback_ratio": fu.clean(fu.median_or_none(playback)),
         "floor_playback_ratio": fu.clean(fu.median_or_none(at_floor)),
         "playback_over_floor": fu.clean(fu.median_or_none(over_floor)),
         "floors_ms": fu.clean(dict(floors, bare_stage=fu.median_or_none(cost["floor"]),
                                    fine=fu.median_or_none(gn["fine"]),
                                    tears=fu.median_or_none(gn["tears"]))),
         "max_offset_mm": fu.clean(peak), **fu.clean(writes),
         "base_frame_ms": fu.clean(fu.median_or_none(med["base"])),
         "per_repeat": fu.clean({"frame_ms": med, "all_floor_ratio": ratios, "playback_ratio": playback,
                                 "floor_playback_ratio": at_floor, "playback_over_floor": over_floor})}
    log(f"{label}: all {frame_ms['all']} ms over Blender's {r['base_frame_ms']} ms (playback x"
        f"{fu.fmt(r['playback_ratio'])}, x{fu.fmt(r['floor_playback_ratio'])} at the floors: "
        f"{fu.fmt(r['playback_over_floor'])} over), all_floor_ratio {fu.fmt(r['all_floor_ratio'])}; sources "
        + ", ".join(f"{k} {v}" for k, v in frame_ms.items() if k != "all") + f"; floors {r['floors_ms']}; "
        f"largest offset (mm) {r['max_offset_mm']}")
    bpy.ops.wm.read_homefile(use_empty=True)
    return r


def main(argv=None):
    import bpy

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="50k,200k")
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--warm", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args(argv)
    out, failed = {"bpy": bpy.app.version_string}, False
    for label in args.sizes.split(","):
        try:
            out[label] = run_size(label, int(float(label.lower().rstrip("k")) * 1000), args)
        except Exception as exc:  # noqa: BLE001 - keep what was measured, print the JSON anyway
            failed = True
            out[label] = {"error": repr(exc)}
            log(traceback.format_exc())
    a, b = (out.get(k, {}).get("frame_ms", {}).get("all") for k in ("50k", "200k"))
    out["growth_200k_over_50k"] = fu.clean(fu.ratio(b, a)) if a and b else None
    print(json.dumps(out), flush=True)
    try:
        bpy.ops.wm.read_factory_settings(use_empty=True)  # bpy 4.5 hangs at exit otherwise
    except Exception as exc:  # noqa: BLE001
        log(f"read_factory_settings failed: {exc!r}")
    return 1 if failed else 0


if __name__ == "__main__":
    import os

    code = main(sys.argv[1:])
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
