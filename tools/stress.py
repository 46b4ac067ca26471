# SPDX-License-Identifier: GPL-3.0-or-later
"""Random runs: a seeded harness that does what a user does to a face with every wrinkle
source on, in random order, and checks after every step that the add-on did not break.

Usage (from the repository root)::

    .venv45/bin/python tools/stress.py --runs 100 --actions 15 --seed 1 [--jobs 1] [--timeout 180]
    .venv45/bin/python tools/stress.py --replay SEED RUN --actions 15 [--keep 0,3,7] [--log]

Each run is a fresh child process (this file with ``--child``, under the same Python, so
``.venv52/bin/python`` runs it on bpy 5.2), so that a crash (a signal) or a hang (the
per-run ``--timeout``, in seconds) is caught and reported rather than taking the harness
down. The child enables the add-on the way Blender does (as ``tests/blender/conftest.py``
does), builds the small test forehead of ``tests/blender/scenes.py`` (40 x 24 vertices,
a planar UV map, a ``BrowsUp`` shape key) and turns on every source: a Frontalis sheet
with an animated contraction, wrinkle maps in Tension mode, a wrinkle curve, carved fine
wrinkles, a forehead pattern layer, a dripping teardrop and a shedding tear. Then it
draws ``--actions`` random user actions from ``random.Random("SEED:RUN")``: frame
changes (viewport frames, the interactive-edit update, still and animation renders),
undo and redo (``ed.undo_push`` after every action, as the interface does, then
``ed.undo`` / ``ed.redo``: they work in background mode), save and reload, deleting a
muscle, a curve, a pattern's Empty, a tear or a duplicate, moving, turning and scaling
muscles, curves, Empties and the face (zero, negative and NaN scales included), topology
edits (bmesh subdivision of a few edges, deleted vertices, edit mode), modifiers added
before and after the Wrinkles modifier, moved and removed, Bake for Farm and Free Bake,
duplicating the face (linked or not), hostile property values (NaN, infinities, huge,
negative; crafted raw custom properties, saved and opened again as a crafted file is, and
Geometry Nodes modifier inputs), any of the
add-on's operators with random settings, and Disable / Enable Wrinkles.

Every action's random numbers are drawn before it runs, so ``--keep 0,3,7`` replays only
those actions of a run with the very same settings, and ``--replay SEED RUN --minimize``
cuts a failing run down to the few actions that still show its first problem (dropping
one action at a time, one child process each) and prints them with their ``--keep``.

After every action the child checks:

* no "Internal error" in the status store (``wrinkle_addon.glue.status``: what the
  panel shows; the frame stage writes it when a handler caught an exception);
* no line ``Expression Wrinkles: <face>: <exception>`` (what the frame stage prints with
  it) and no Python traceback in Blender's output (an operator's unexpected failure, an
  update callback, a handler, a panel);
* no exception escaping an operator other than the ``RuntimeError`` of an operator that
  reported an ERROR with a message for the user (a poll that refused is fine too);
* no NaN or infinity in the offsets (``wrinkle_offset`` of the original and the evaluated
  mesh) or the evaluated positions of a face with wrinkles;
* after Disable Wrinkles, when the topology was never edited: the mesh's positions and
  its shape keys are bit-identical to before wrinkles were first enabled, and the
  stage's modifier and attributes are gone.

The child prints one JSON line per action and a summary line. The parent prints one line
per run on stderr and a JSON summary on stdout: runs, actions, seconds, and every internal
error, crash, hang, disable-restore mismatch and harness error with its seed, run index
and the ``--replay`` command. Its exit status is 0 only if every run was clean.
``--replay SEED RUN`` runs one child in the foreground and prints its JSON lines;
``--log`` also prints Blender's output of that run. ``--inject error|crash|hang|restore``
plants a fault after the setup (a source that raises, an abort, a sleep, a moved vertex):
``tests/blender/test_stress.py`` checks with it that each is caught and reported.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import traceback
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ADDON = "wrinkle_addon"
FACE = "Face"
FRAMES = (1, 12)  # the scene's frame range; the contraction and the shape key ramp over it

# --------------------------------------------------------------------------- the parent


def _child_env(user_dir: Path) -> dict:
    """Blender's user folders in a fresh directory, as tests/conftest.py does."""
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(user_dir), PYTHONUNBUFFERED="1")
    for var in ("BLENDER_USER_CONFIG", "BLENDER_USER_SCRIPTS", "BLENDER_USER_DATAFILES",
                "BLENDER_USER_EXTENSIONS"):
        env.pop(var, None)
    return env


def _replay_command(seed, run, actions, keep=None):
    cmd = f"{Path(sys.executable).name} tools/stress.py --replay {seed} {run} --actions {actions}"
    return cmd + (f" --keep {','.join(map(str, keep))}" if keep else "")


def run_child(seed: int, run: int, actions: int, timeout: float, keep=None, echo=False, inject=None):
    """One run in a fresh process: its action lines, its summary and what went wrong."""
    work = Path(tempfile.mkdtemp(prefix=f"wrinkle-stress-{seed}-{run}-"))
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", "--seed", str(seed), "--run",
           str(run), "--actions", str(actions), "--workdir", str(work)]
    if keep is not None:
        cmd += ["--keep", ",".join(map(str, keep))]
    if inject:
        cmd += ["--inject", inject]
    start = time.monotonic()
    proc = subprocess.Popen(cmd, cwd=str(ROOT), env=_child_env(work / "user"), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    hung = False
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        hung = True
        os.killpg(proc.pid, signal.SIGKILL)  # the child and anything it started
        out, err = proc.communicate()
    seconds = time.monotonic() - start
    lines, summary = [], None
    for line in out.splitlines():
        try:
            rec = json.loads(line)
        except ValueError:
            continue
        if rec.get("summary"):
            summary = rec
        else:
            lines.append(rec)
            if echo:
                print(line, flush=True)
    log = work / "blender.log"
    log_text = log.read_text(errors="replace") if log.is_file() else ""
    result = {"seed": seed, "run": run, "seconds": round(seconds, 1),
              "actions": sum(1 for rec in lines if 0 <= rec.get("i", -1) < actions),
              "lines": lines, "summary": summary, "returncode": proc.returncode, "hung": hung,
              "stderr_tail": err[-2000:], "log_tail": log_text[-3000:], "workdir": str(work)}
    if echo:
        if summary is not None:
            print(json.dumps(summary), flush=True)
        result["log"] = log_text
    clean = not hung and proc.returncode == 0 and summary is not None and not summary["problems"]
    if clean:
        shutil.rmtree(work, ignore_errors=True)
    return result


def _classify(res, actions, keep):
    """The run's problems as report entries, by kind."""
    seed, run = res["seed"], res["run"]
    base = {"seed": seed, "run": run, "replay": _replay_command(seed, run, actions, keep)}
    found = []
    for line in res["lines"]:
        for p in line.get("problems", []):
            found.append(dict(base, kind=p["kind"], action_index=line["i"], action=line["action"],
                              message=p["message"]))
    last = res["lines"][-1] if res["lines"] else None
    where = {"last_action": f"{last['i']}: {last['action']}" if last else "setup",
             "log_tail": res["log_tail"][-1500:], "workdir": res["workdir"]}
    if res["hung"]:
        found.append(dict(base, kind="hang", message=f"no end after {res['seconds']} s", **where))
    elif res["returncode"] is not None and res["returncode"] < 0:
        sig = signal.Signals(-res["returncode"]).name
        found.append(dict(base, kind="crash", message=f"killed by {sig}", **where))
    elif res["returncode"] != 0 or res["summary"] is None:
        found.append(dict(base, kind="harness_error",
                          message=f"exit status {res['returncode']}, no summary: {res['stderr_tail'][-800:]}",
                          **where))
    elif res["summary"].get("setup_problem"):
        found.append(dict(base, kind="harness_error", message=res["summary"]["setup_problem"]))
    return found


_GROUPS = {"internal_error": "internal_errors", "traceback": "internal_errors",
           "unexpected_operator_failure": "internal_errors", "operator_exception": "internal_errors",
           "nan": "internal_errors", "crash": "crashes", "hang": "hangs",
           "restore_mismatch": "restore_mismatches", "harness_error": "harness_errors"}


def _signature(p):
    """What makes two problems the same fault: the kind and the message without numbers."""
    message = p["message"]
    if p["kind"] in ("traceback", "harness_error") and "\n" in message:
        message = "\n".join(message.strip().splitlines()[-3:])
    message = re.sub(re.escape(tempfile.gettempdir()) + r"/wrinkle-stress-[^/'\" ]+", "<run>", message)
    text = re.sub(r"0x[0-9a-f]+|\d+(\.\d+)?(e-?\d+)?", "#", message)
    text = re.sub(r'"[^"]*"', '"…"', text)
    return f"{p['kind']}: {text[:300]}"


def minimize(seed, run, actions, timeout, inject=None):
    """The fewest actions of a failing run that still show its first problem: each action is
    dropped in turn, from the last, and stays dropped if the problem remains."""
    probs = _classify(run_child(seed, run, actions, timeout, inject=inject), actions, None)
    if not probs:
        return {"seed": seed, "run": run, "clean": True}
    target = _signature(probs[0])
    keep = list(range(probs[0].get("action_index", actions - 1) + 1))
    for i in reversed(range(len(keep))):
        trial = keep[:i] + keep[i + 1:]
        res = run_child(seed, run, actions, timeout, trial, inject=inject)
        if any(_signature(p) == target for p in _classify(res, actions, trial)):
            keep = trial
    last = run_child(seed, run, actions, timeout, keep, inject=inject)
    steps = [f"{rec['i']}: {rec['action']}: {rec['result']}" for rec in last["lines"]]
    return {"seed": seed, "run": run, "problem": target, "keep": keep, "steps": steps,
            "replay": _replay_command(seed, run, actions, keep)}


def parent(args):
    keep = _parse_keep(args.keep)
    if args.replay and args.minimize:
        print(json.dumps(minimize(*args.replay, args.actions, args.timeout, args.inject), indent=1))
        return 0
    if args.replay:
        seed, run = args.replay
        res = run_child(seed, run, args.actions, args.timeout, keep, echo=True, inject=args.inject)
        if args.log:
            print(res["log"])
        problems = _classify(res, args.actions, keep)
        for p in problems:
            print(json.dumps(p), file=sys.stderr)
        return 0 if not problems else 1
    start = time.monotonic()
    runs = range(args.first, args.first + args.runs)

    def one(run):
        res = run_child(args.seed, run, args.actions, args.timeout, keep, inject=args.inject)
        probs = _classify(res, args.actions, keep)
        print(f"run {run}: {res['actions']} actions, {res['seconds']} s, "
              f"{'clean' if not probs else str(len(probs)) + ' problem(s)'}", file=sys.stderr, flush=True)
        return res, probs

    with ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        results = list(pool.map(one, runs))
    report = {"seed": args.seed, "runs": len(results), "actions": sum(r["actions"] for r, _ in results),
              "seconds": round(time.monotonic() - start, 1),
              "run_seconds_max": max((r["seconds"] for r, _ in results), default=0.0),
              "clean_runs": sum(1 for _, p in results if not p)}
    for group in dict.fromkeys(_GROUPS.values()):
        report[group] = []
    for _, probs in results:
        for p in probs:
            report[_GROUPS[p["kind"]]].append(p)
    distinct = {}
    for _, probs in results:
        for p in probs:
            d = distinct.setdefault(_signature(p), {"count": 0, "first": f"seed {p['seed']} run {p['run']}"
                                                    f" action {p.get('action_index', '-')}",
                                                    "replay": p["replay"]})
            d["count"] += 1
    report["distinct"] = distinct
    print(json.dumps(report, indent=1))
    return 0 if report["clean_runs"] == report["runs"] else 1


def _parse_keep(text):
    return None if text is None else sorted({int(x) for x in text.split(",") if x.strip()})


# --------------------------------------------------------------------------- the child
FLOAT_HOSTILE = (math.nan, math.inf, -math.inf, 1e30, -1e30, -1.0, 0.0, 1e-30, -1e-7)
INT_HOSTILE = (-1, 0, 2 ** 31 - 1, -(2 ** 31), 10 ** 6)
CRAFTED = (5, -1, math.nan, 1e30, "ab", "", [1, 2], [1.5], {"a": 1}, {"a": "x", "b": "y"}, ["a"],
           ["a", "b", "c"], [["a", "b"]], [b"a", b"b"])
STAGE_ATTRS = ("wrinkle_offset", "wrinkle_skin", "wrinkle_frame")
PROGRESS = re.compile(r"^Expression Wrinkles: .*?:( *\d+/\d+)? +\d+%")
MIGRATION = re.compile(r"^Expression Wrinkles: (moved \d+ settings|.*: could not keep |"
                       r".* held a value of the wrong type and was removed$)")
SLOW_OPERATORS = {"refine"}  # drawn less often: each takes seconds


class Problem(Exception):
    """Raised inside an action to stop it and record a problem of ``kind``."""

    def __init__(self, kind, message):
        super().__init__(message)
        self.kind = kind


def _pick(seq, u):
    seq = list(seq)
    return seq[min(int(u * len(seq)), len(seq) - 1)] if seq else None


class Child:
    """One run: the scene, the random actions and the checks after each."""

    def __init__(self, seed, run, workdir, out):
        import bpy

        self.bpy = bpy
        self.rng = random.Random(f"{seed}:{run}")
        self.work = Path(workdir)
        self.out = out
        self.run = run
        self.problems = []
        self.problems_now = []
        self.seen_status = set()
        self.topology_edited = False
        self.snapshot = None
        self.log_path = self.work / "blender.log"
        self.log_pos = 0
        self.libc = None
        try:
            import ctypes

            self.libc = ctypes.CDLL(None)
        except OSError:
            pass

    # ------------------------------------------------------------------ helpers
    @property
    def face(self):
        return self.bpy.data.objects.get(FACE)

    def objects(self, test):
        return [o for o in self.bpy.data.objects if test(o)]

    def muscles(self):
        return self.objects(lambda o: o.ewrinkles_muscle.is_muscle)

    def curves(self):
        return self.objects(lambda o: o.ewrinkles_curve.is_curve)

    def empties(self):
        face = self.face
        if face is None:
            return []
        return [lay.frame for lay in face.ewrinkles_face.patterns.layers if lay.frame is not None]

    def tears(self):
        return self.objects(lambda o: o.name.endswith("Teardrop") or o.name.endswith(" Tear"))

    def duplicates(self):
        return self.objects(lambda o: o.type == "MESH" and o.name.startswith(FACE + "."))

    def activate(self, ob, select=()):
        bpy = self.bpy
        for o in bpy.context.view_layer.objects:
            if o.select_get():
                o.select_set(False)
        for o in (ob, *select):
            if o is not None and o.name in bpy.context.view_layer.objects:
                o.select_set(True)
        if ob is not None and ob.name in bpy.context.view_layer.objects:
            bpy.context.view_layer.objects.active = ob

    def op(self, path, /, override=None, **kwargs):
        """Call ``bpy.ops.<path>``; an ERROR report or a refused poll is a result, anything
        else that escapes is a problem."""
        group, name = path.split(".")
        fn = getattr(getattr(self.bpy.ops, group), name)
        try:
            if override:
                with self.bpy.context.temp_override(**override):
                    ret = fn(**kwargs)
            else:
                ret = fn(**kwargs)
            return f"{path}: {'/'.join(sorted(ret))}"
        except RuntimeError as exc:
            msg = str(exc).strip()
            if "failed unexpectedly" in msg:
                raise Problem("unexpected_operator_failure", f"{path}: {msg}") from None
            if ".poll()" in msg:  # "poll() failed, context is incorrect" or the poll's message
                return f"{path}: poll refused"
            if msg.startswith(("Error:", "Warning:")) or group != "wrinkle":
                return f"{path}: refused: {msg[:240]}"
            raise Problem("operator_exception", f"{path}: RuntimeError without a report: {msg}") from None
        except (TypeError, ValueError) as exc:
            if group == "wrinkle":
                raise Problem("operator_exception", f"{path}{kwargs}: {type(exc).__name__}: {exc}") from None
            return f"{path}: refused: {exc}"

    def update(self):
        """What the interface's depsgraph handler does after an edit (it does nothing in
        background mode, so the harness calls the frame stage the same way)."""
        from wrinkle_addon.glue import pipeline

        bpy = self.bpy
        if bpy.context.scene is None:
            return
        bpy.context.view_layer.update()
        pipeline.update_scene(bpy.context.scene, bpy.context.evaluated_depsgraph_get(), only_if_changed=True)

    def mesh_state(self, ob):
        import numpy as np

        me = ob.data
        pos = np.empty(len(me.vertices) * 3, np.float32)
        me.attributes["position"].data.foreach_get("vector", pos)
        keys = {}
        if me.shape_keys is not None:
            for kb in me.shape_keys.key_blocks:
                co = np.empty(len(kb.points) * 3, np.float32)
                kb.points.foreach_get("co", co)
                keys[kb.name] = co.tobytes()
        return pos.tobytes(), keys

    # ------------------------------------------------------------------ the scene
    def setup(self):
        import numpy as np

        bpy = self.bpy
        from tests.blender import mapscenes, scenes

        bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
        scene = bpy.context.scene
        scene.frame_start, scene.frame_end = FRAMES
        face = scenes.make_face(FACE, nx=40, nz=24)
        me = face.data
        layer = me.uv_layers.new(name="UVMap")
        co = np.empty(len(me.vertices) * 3, np.float32)
        me.vertices.foreach_get("co", co)
        co = co.reshape(-1, 3)
        corner = np.empty(len(me.loops), np.int32)
        me.loops.foreach_get("vertex_index", corner)
        uv = np.stack([(co[:, 0] + scenes.WIDTH / 2) / scenes.WIDTH, co[:, 2] / scenes.HEIGHT], 1)
        layer.uv.foreach_set("vector", uv[corner].astype(np.float32).ravel())
        me.materials.append(mapscenes.node_material("Skin"))
        self.snapshot = self.mesh_state(face)
        steps = []

        def need(label, result):
            steps.append(f"{label}: {result}")
            if not result.endswith("FINISHED"):
                raise RuntimeError(f"setup step {label} did not finish: {result}")

        self.activate(face)
        need("enable", self.op("wrinkle.enable"))
        # the shedding tear first: its path is read from the selected faces of the rest mesh
        cen = np.empty(len(me.polygons) * 3, np.float32)
        me.polygons.foreach_get("center", cen)
        cen = cen.reshape(-1, 3)
        me.polygons.foreach_set("select", (np.abs(cen[:, 0] + 0.03) < 0.004) & (cen[:, 2] > 0.01)
                                & (cen[:, 2] < 0.06))
        need("shedding tear", self.op("wrinkle.add_shedding_tear", path="FACES"))
        self.activate(face)
        muscle = scenes.add_sheet(face)
        for f, c in ((FRAMES[0], 0.0), (FRAMES[1], 1.0)):
            muscle.ewrinkles_muscle.contraction = c
            muscle.keyframe_insert("ewrinkles_muscle.contraction", frame=f)
        scenes.animate_shape_key(face, [(FRAMES[0], 0.0), (FRAMES[1], 1.0)])
        maps = face.ewrinkles_face.maps
        size = 16
        rng = np.random.default_rng(0)
        maps.mask_a = mapscenes.data_image("Mask A", np.tile([1.0, 0.0, 0.0, 0.0], (size, size, 1)))
        maps.mask_b = mapscenes.data_image("Mask B", np.zeros((size, size, 4)))
        maps.map_a = mapscenes.data_image("Wrinkle PD", 0.5 + 0.05 * rng.standard_normal((size, size, 3)))
        maps.weight_mode = "TENSION"
        self.activate(face)
        need("wrinkle maps", self.op("wrinkle.setup_wrinkle_maps"))
        scene.cursor.location = (0.0, 0.0, scenes.HEIGHT / 2)
        need("curve", self.op("wrinkle.add_curve", length=0.4))
        self.activate(face)
        face.ewrinkles_face.fine_wrinkles.resolution = "512"
        need("carve", self.op("wrinkle.carve_fine"))
        scene.cursor.location = (0.0, -0.2, scenes.HEIGHT / 2)
        self.activate(face)
        need("pattern", self.op("wrinkle.add_pattern", kind="FOREHEAD", where="CURSOR"))
        scene.cursor.location = (0.02, -0.1, scenes.HEIGHT / 2)
        self.activate(face)
        need("teardrop", self.op("wrinkle.add_teardrop"))
        scenes.add_camera_and_light(scene)
        scene.render.engine = "BLENDER_WORKBENCH"
        scene.render.resolution_x = scene.render.resolution_y = 16
        scene.render.resolution_percentage = 100
        scene.render.filepath = str(self.work / "render_")
        self.activate(face)
        scene.frame_set(2)
        self.update()
        bpy.ops.ed.undo_push(message="setup")
        return steps

    # ------------------------------------------------------------------ the checks
    def read_log(self):
        sys.stdout.flush()
        sys.stderr.flush()
        if self.libc is not None:
            self.libc.fflush(None)
        with open(self.log_path, "rb") as f:
            f.seek(self.log_pos)
            data = f.read()
        self.log_pos += len(data)
        return data.decode("utf-8", "replace")

    def check(self):
        import numpy as np

        from wrinkle_addon.glue import status

        found = []
        text = self.read_log()
        lines = text.splitlines()
        for k, line in enumerate(lines):
            if line.startswith("Traceback (most recent call last)"):
                tail = lines[k:k + 40]
                end = next((j for j, s in enumerate(tail) if j and s and not s.startswith(" ")),
                           len(tail) - 1)
                found.append(("traceback", "\n".join(tail[:end + 1])))
            elif line.startswith("Expression Wrinkles: ") and not PROGRESS.match(line) \
                    and not MIGRATION.match(line):
                found.append(("internal_error", f"printed: {line}"))
        for uid, per_face in list(status._messages.items()):
            for channel, message in list(per_face.items()):
                if "internal error" in message.lower() and (uid, channel, message) not in self.seen_status:
                    self.seen_status.add((uid, channel, message))
                    found.append(("internal_error", f"status [{channel}]: {message}"))
        bpy = self.bpy
        if bpy.context.scene is not None:
            dg = bpy.context.evaluated_depsgraph_get()
            for ob in bpy.context.scene.objects:
                if ob.type != "MESH" or not ob.ewrinkles_face.enabled:
                    continue
                ev = ob.evaluated_get(dg).data
                for where, me, names in (("original", ob.data, ("wrinkle_offset",)),
                                         ("evaluated", ev, ("wrinkle_offset", "position"))):
                    for name in names:
                        att = me.attributes.get(name)
                        if att is None or att.data_type != "FLOAT_VECTOR" or att.domain != "POINT":
                            continue
                        v = np.empty(len(att.data) * 3, np.float32)
                        att.data.foreach_get("vector", v)
                        if not np.isfinite(v).all():
                            found.append(("nan", f'{where} "{name}" of "{ob.name}" holds '
                                                 f"{int((~np.isfinite(v)).sum())} non-finite values"))
        return found

    # ------------------------------------------------------------------ the actions
    def a_frame(self, u):
        scene = self.bpy.context.scene
        f = int(FRAMES[0] + u[0] * (FRAMES[1] - FRAMES[0] + 3)) - 1
        sub = 0.0 if u[1] < 0.7 else round(u[2], 2)
        scene.frame_set(f, subframe=sub)
        return f"frame_set({f}, subframe={sub})"

    def a_edit_update(self, u):
        """A slider moved in the interface: the contraction or the shape key, then the
        depsgraph handler's update."""
        face, muscles = self.face, self.muscles()
        if u[0] < 0.5 and muscles:
            m = _pick(muscles, u[1])
            m.ewrinkles_muscle.contraction = round(u[2], 3)
            what = f'"{m.name}".contraction = {round(u[2], 3)}'
        elif face is not None and face.data.shape_keys is not None:
            kb = _pick(face.data.shape_keys.key_blocks[1:] or face.data.shape_keys.key_blocks, u[1])
            kb.value = round(u[2], 3)
            what = f'key "{kb.name}" = {round(u[2], 3)}'
        else:
            what = "nothing to edit"
        self.update()
        return what + "; interactive update"

    def a_render(self, u):
        bpy = self.bpy
        scene = bpy.context.scene
        if scene.camera is None:
            return "no camera"
        if u[0] < 0.6:
            return self.op("render.render", write_still=False)
        scene.frame_start, scene.frame_end = FRAMES[0] + int(u[1] * 8), FRAMES[0] + int(u[1] * 8) + 1
        try:
            return "animation " + self.op("render.render", animation=True)
        finally:
            scene.frame_start, scene.frame_end = FRAMES

    def a_undo(self, u):
        return self.op("ed.undo") if u[0] < 0.75 else self.op("ed.redo")

    def a_save_reload(self, u):
        path = str(self.work / "run.blend")
        r = self.op("wm.save_as_mainfile", filepath=path)
        if u[0] < 0.8:
            r += "; " + self.op("wm.open_mainfile", filepath=path)
        return r

    def _delete(self, ob, u):
        if ob is None:
            return "nothing to delete"
        name = ob.name
        if u < 0.5:
            self.activate(ob)
            r = self.op("object.delete")
        else:
            self.bpy.data.objects.remove(ob)
            r = "bpy.data.objects.remove"
        self.update()
        return f'delete "{name}": {r}'

    def a_delete(self, u):
        kind = _pick(("muscle", "curve", "empty", "tear", "duplicate"), u[0])
        pool = {"muscle": self.muscles, "curve": self.curves, "empty": self.empties, "tear": self.tears,
                "duplicate": self.duplicates}[kind]()
        return f"{kind}: " + self._delete(_pick(pool, u[1]), u[2])

    def a_transform(self, u):
        import mathutils

        pool = self.muscles() + self.curves() + self.empties() + ([self.face] if self.face else [])
        ob = _pick(pool, u[0])
        if ob is None:
            return "nothing to move"
        how = _pick(("move", "turn", "scale", "scale0", "scale_neg", "nan"), u[1])
        d = 0.02 * (u[2] - 0.5)
        if how == "move":
            ob.location += mathutils.Vector((d, -d / 2, d))
        elif how == "turn":
            ob.rotation_euler.z += 4 * d
            ob.rotation_euler.x -= 2 * d
        elif how == "scale":
            ob.scale *= 0.5 + 2 * u[3]
        elif how == "scale0":
            ob.scale = (0.0, 0.0, 0.0) if u[3] < 0.5 else (1.0, 0.0, 1.0)
        elif how == "scale_neg":
            ob.scale.x = -ob.scale.x
        else:
            ob.location.x = math.nan
        self.update()
        return f'{how} "{ob.name}" ({d:+.4f})'

    def a_topology(self, u):
        import bmesh

        face = self.face
        if face is None:
            return "no face"
        bm = bmesh.new()
        bm.from_mesh(face.data)
        rng = random.Random(u[1])
        how = _pick(("subdivide", "delete", "edit_mode"), u[0])
        if how == "subdivide":
            bm.edges.ensure_lookup_table()
            edges = rng.sample(list(bm.edges), max(1, len(bm.edges) // 30))
            bmesh.ops.subdivide_edges(bm, edges=edges, cuts=1, use_grid_fill=True)
            what = f"subdivided {len(edges)} edges"
        elif how == "delete":
            bm.verts.ensure_lookup_table()
            verts = rng.sample(list(bm.verts), max(1, int(len(bm.verts) * 0.05 * u[2]) + 1))
            bmesh.ops.delete(bm, geom=verts, context="VERTS")
            what = f"deleted {len(verts)} vertices"
        else:
            bm.free()
            self.activate(face)
            r = self.op("object.mode_set", mode="EDIT")
            self.bpy.context.scene.frame_set(self.bpy.context.scene.frame_current + 1)
            r2 = self.op("object.mode_set", mode="OBJECT")
            self.update()
            return f"edit mode and a frame: {r}; {r2}"
        bm.to_mesh(face.data)
        bm.free()
        face.data.update()
        self.topology_edited = True
        self.update()
        return what

    def a_data(self, u):
        """The user removes or renames data the sources use: an image, the material, a shape
        key, a name, the animation."""
        bpy = self.bpy
        face = self.face
        how = _pick(("image", "material", "shape_key", "rename", "animation", "cursor"), u[0])
        if how == "image":
            ob = _pick(list(bpy.data.images), u[1])
            if ob is None:
                return "no image"
            name = ob.name
            bpy.data.images.remove(ob)
            r = f'removed the image "{name}"'
        elif how == "material":
            ob = _pick(list(bpy.data.materials), u[1])
            if ob is None:
                return "no material"
            name = ob.name
            bpy.data.materials.remove(ob)
            r = f'removed the material "{name}"'
        elif how == "shape_key" and face is not None and face.data.shape_keys is not None:
            kb = _pick(face.data.shape_keys.key_blocks, u[1])
            name = kb.name
            face.shape_key_remove(kb)
            self.topology_edited = True  # the mesh is no longer the one before enabling
            r = f'removed the shape key "{name}"'
        elif how == "rename":
            ob = _pick(self.muscles() + self.curves() + self.empties() + self.tears(), u[1])
            if ob is None:
                return "nothing to rename"
            old = ob.name
            ob.name = _pick(('A "quoted" name', "x/y:z.w", "é" * 30, ""), u[2])
            r = f'renamed "{old}" to "{ob.name}"'
        elif how == "animation":
            keys = [face.data.shape_keys] if face is not None and face.data.shape_keys is not None else []
            ob = _pick(self.muscles() + keys, u[1])
            if ob is None:
                return "no animation"
            ob.animation_data_clear()
            r = f'cleared the animation of "{ob.name}"'
        else:
            bpy.context.scene.cursor.location = (math.nan, 0.0, 0.0) if u[1] < 0.3 else (1e6, -1e6, 0.0)
            r = f"cursor at {tuple(bpy.context.scene.cursor.location)}"
        self.update()
        return r

    MODIFIERS = ("SUBSURF", "DISPLACE", "SMOOTH", "TRIANGULATE", "DECIMATE", "SOLIDIFY", "ARMATURE",
                 "MIRROR", "LAPLACIANSMOOTH")

    def a_modifier(self, u):
        face = self.face
        if face is None:
            return "no face"
        how = _pick(("add_after", "add_before", "remove", "move", "toggle"), u[0])
        mods = list(face.modifiers)
        if how.startswith("add"):
            kind = _pick(self.MODIFIERS, u[1])
            mod = face.modifiers.new(kind.title(), kind)
            if kind == "DISPLACE":
                mod.strength = 0.002
            r = f"added {kind} ({mod.name})"
            if how == "add_before":
                r += " moved first: " + self.op("object.modifier_move_to_index", override={"object": face},
                                                 modifier=mod.name, index=0)
        elif not mods:
            r = "no modifier"
        elif how == "remove":
            mod = _pick(mods, u[1])
            r = f"removed {mod.type} ({mod.name})"
            face.modifiers.remove(mod)
        elif how == "move":
            mod = _pick(mods, u[1])
            index = int(u[2] * len(mods)) % len(mods)
            r = f"moved {mod.name} to {index}: " + self.op("object.modifier_move_to_index",
                                                           override={"object": face},
                                                           modifier=mod.name, index=index)
        else:
            mod = _pick(mods, u[1])
            mod.show_viewport = not mod.show_viewport
            r = f"{mod.name}.show_viewport = {mod.show_viewport}"
        self.update()
        return r

    def a_bake(self, u):
        face = self.face
        if face is None:
            return "no face"
        r = ""
        if u[0] < 0.8:
            r = self.op("wm.save_as_mainfile", filepath=str(self.work / "bake.blend")) + "; "
        self.activate(self.face)
        if u[1] < 0.6:
            start = FRAMES[0] + int(u[2] * 6)
            return r + self.op("wrinkle.bake", frame_start=start, frame_end=start + 1)
        return r + self.op("wrinkle.free_bake")

    def a_duplicate(self, u):
        face = self.face
        if face is None:
            return "no face"
        self.activate(face)
        linked = u[0] < 0.3
        r = self.op("object.duplicate", linked=linked)
        dup = self.bpy.context.view_layer.objects.active
        if dup is not None and dup != face and u[1] < 0.5:
            dup.location.x += 0.2
        self.activate(self.face)
        self.update()
        return f"duplicate(linked={linked}): {r}"

    def _groups(self):
        """Every add-on property group on the scene's objects, nested groups included."""
        out = []

        def walk(group, label, depth=0):
            if group is None or depth > 4:
                return
            out.append((group, label))
            for p in group.bl_rna.properties:
                if p.identifier == "rna_type":
                    continue
                if p.type == "POINTER" and isinstance(p.fixed_type, self.bpy.types.PropertyGroup):
                    walk(getattr(group, p.identifier), f"{label}.{p.identifier}", depth + 1)
                elif p.type == "COLLECTION" and isinstance(p.fixed_type, self.bpy.types.PropertyGroup):
                    for k, item in enumerate(getattr(group, p.identifier)):
                        walk(item, f"{label}.{p.identifier}[{k}]", depth + 1)

        for ob in self.bpy.data.objects:
            for attr in ("ewrinkles_face", "ewrinkles_muscle", "ewrinkles_curve"):
                grp = getattr(ob, attr, None)
                if attr == "ewrinkles_face" and not (ob.type == "MESH" and (
                        ob.name == FACE or ob.name.startswith(FACE + ".") or ob.ewrinkles_face.enabled)):
                    continue
                if attr == "ewrinkles_muscle" and not ob.ewrinkles_muscle.is_muscle:
                    continue
                if attr == "ewrinkles_curve" and not ob.ewrinkles_curve.is_curve:
                    continue
                walk(grp, f'"{ob.name}".{attr}')
        return out

    def a_hostile(self, u):
        props = []
        for group, label in self._groups():
            for p in group.bl_rna.properties:
                if p.type in ("FLOAT", "INT", "BOOLEAN", "ENUM") and not p.is_readonly \
                        and p.identifier not in ("enabled", "is_muscle", "is_curve"):
                    props.append((group, label, p))
        if not props:
            return "no property"
        group, label, p = _pick(props, u[0])
        name = p.identifier
        if p.type == "FLOAT":
            value = _pick(FLOAT_HOSTILE, u[1])
        elif p.type == "INT":
            value = _pick(INT_HOSTILE, u[1])
        elif p.type == "BOOLEAN":
            value = not getattr(group, name) if p.array_length == 0 else None
        else:
            items = [i.identifier for i in p.enum_items]
            value = _pick(items, u[1]) if items else None
            if p.is_enum_flag:
                value = {value} if value else set()
        if value is None:
            return f"{label}.{name}: skipped"
        shown = repr(value)
        try:
            if getattr(p, "array_length", 0) and p.type in ("FLOAT", "INT"):
                arr = list(getattr(group, name))
                if u[2] < 0.5:
                    arr = [value] * len(arr)
                else:
                    arr[int(u[3] * len(arr)) % len(arr)] = value
                setattr(group, name, arr)
                shown = repr(arr)
            else:
                setattr(group, name, value)
            r = f"{label}.{name} = {shown}: now {getattr(group, name)!r}"[:300]
        except (TypeError, ValueError, OverflowError, AttributeError) as exc:
            r = f"{label}.{name} = {shown}: refused by RNA ({exc})"[:300]
        self.update()
        return r

    def a_crafted(self, u):
        """A raw custom property (what another tool or a hand-edited file may hold): one the
        add-on stores on its IDs and nodes, or an input of a Geometry Nodes modifier."""
        bpy = self.bpy
        slots = []
        owners = list(bpy.data.objects) + list(bpy.data.node_groups) + list(bpy.data.meshes)
        for mat in bpy.data.materials:
            if mat.node_tree is not None:
                owners += list(mat.node_tree.nodes)
        for ng in bpy.data.node_groups:
            owners += list(ng.nodes)
        for owner in owners:
            try:
                keys = list(owner.keys())
            except (TypeError, AttributeError):
                continue
            for k in keys:
                if k.startswith(("wrinkle_", "ewrinkles_", "ewrinkles")):
                    slots.append((owner, k))
        for ob in bpy.data.objects:
            for mod in ob.modifiers:
                if mod.type == "NODES" and mod.node_group is not None:
                    for item in mod.node_group.interface.items_tree:
                        if getattr(item, "in_out", "") == "INPUT" \
                                and item.socket_type != "NodeSocketGeometry":
                            slots.append((mod, item.identifier))
        if not slots:
            return "no custom property"
        owner, key = _pick(slots, u[0])
        value = _pick(CRAFTED, u[1])
        inputs = getattr(getattr(owner, "properties", None), "inputs", None)
        if isinstance(owner, bpy.types.Modifier) and inputs is not None:
            # Blender 5 keeps a Geometry Nodes modifier's inputs apart, as RNA values
            label = f'"{owner.id_data.name}".modifiers["{owner.name}"] input {key}'
            try:
                getattr(inputs, key).value = value
                r = f"{label} = {value!r}"
            except (TypeError, ValueError, OverflowError, AttributeError) as exc:
                r = f"{label} = {value!r}: refused ({exc})"
            owner.id_data.update_tag()
            self.update()
            return r[:300]
        current = owner[key]
        label = f"{getattr(owner, 'name', owner)!s}[{key!r}]"
        target, walk = owner, random.Random(u[3])
        while hasattr(current, "keys") and list(current.keys()) and walk.random() < 0.8:  # a stored group
            sub = walk.choice(list(current.keys()))
            target, key, label = current, sub, f"{label}[{sub!r}]"
            current = target[key]
        try:
            target[key] = value
            r = f"{label} = {value!r}"
        except (TypeError, ValueError, OverflowError, KeyError) as exc:
            r = f"{label} = {value!r}: refused ({exc})"
        if hasattr(owner, "id_data") and owner.id_data is not None:
            owner.id_data.update_tag()
        # the value reaches the add-on as a crafted file's does: written by another tool (so
        # saved with none of our handlers, which would read it), then opened.  A raw list of
        # ours replaced at run time can block Blender itself when an item is read (bpy 4.5);
        # on load the add-on removes what has the wrong type.
        path = str(self.work / "crafted.blend")
        ours = [(h, fn) for h in (bpy.app.handlers.save_pre, bpy.app.handlers.depsgraph_update_post,
                                  bpy.app.handlers.frame_change_post)
                for fn in list(h) if getattr(fn, "__module__", "").startswith("wrinkle_addon")]
        for h, fn in ours:
            h.remove(fn)
        try:
            r += "; " + self.op("wm.save_as_mainfile", filepath=path)
        finally:
            for h, fn in ours:
                h.append(fn)
        r += "; " + self.op("wm.open_mainfile", filepath=path)
        self.update()
        return r[:300]

    def _operator_kwargs(self, name, u):
        rna = getattr(self.bpy.ops.wrinkle, name).get_rna_type()
        kwargs = {}
        rng = random.Random(u)
        for p in rna.properties:
            if p.identifier == "rna_type" or p.is_readonly or rng.random() < 0.6:
                continue
            if p.type == "ENUM" and not p.is_enum_flag:
                items = [i.identifier for i in p.enum_items]
                if p.identifier == "resolution":
                    items = sorted(items, key=lambda s: (len(s), s))[:1]  # the smallest: quick
                if items:
                    kwargs[p.identifier] = rng.choice(items)
            elif p.type == "BOOLEAN" and not p.array_length:
                kwargs[p.identifier] = rng.random() < 0.5
            elif p.type == "INT" and not p.array_length:
                lo, hi = max(p.soft_min, -1000), min(p.soft_max, 1000)
                kwargs[p.identifier] = rng.randint(int(lo), int(max(lo, hi)))
            elif p.type == "FLOAT" and not p.array_length:
                lo, hi = max(p.soft_min, -10.0), min(p.soft_max, 10.0)
                kwargs[p.identifier] = round(rng.uniform(lo, max(lo, hi)), 4)
        return kwargs

    def a_operator(self, u):
        bpy = self.bpy
        names = sorted(n for n in dir(bpy.ops.wrinkle) if not n.startswith("_"))
        names = [n for n in names if n not in SLOW_OPERATORS or u[3] < 0.2]
        name = _pick(names, u[0])
        target = self.face
        if u[1] < 0.25:  # some operators act on a selected muscle, curve or pattern
            target = _pick(self.muscles() + self.curves() + self.empties(), u[2]) or target
        curves = self.objects(lambda o: o.type == "CURVE")[:1]
        select = curves if name == "add_shedding_tear" else []
        self.activate(target, select)
        kwargs = self._operator_kwargs(name, u[4])
        on = getattr(target, "name", None)  # the operator may delete it
        call = f"{name}({', '.join(f'{k}={v!r}' for k, v in kwargs.items())}) on {on!r}"
        size = len(self.face.data.vertices) if self.face is not None else None
        try:
            r = self.op(f"wrinkle.{name}", **kwargs)
        except Problem as exc:
            raise Problem(exc.kind, f"{call}: {exc}") from None
        if self.face is not None and len(self.face.data.vertices) != size:
            self.topology_edited = True  # Refine Wrinkling Regions subdivides the mesh: a topology edit
        self.activate(self.face)
        self.update()
        return f"{call}: {r}"

    def a_disable(self, u):
        face = self.face
        if face is None:
            return "no face"
        self.activate(face)
        if not face.ewrinkles_face.enabled:
            r = self.op("wrinkle.enable")
            self.update()
            return r
        r = self.op("wrinkle.disable", remove_muscles=u[0] < 0.2)
        if r.endswith("FINISHED") and not self.topology_edited and face.name == FACE:
            pos, keys = self.mesh_state(face)
            want_pos, want_keys = self.snapshot
            wrong = []
            if pos != want_pos:
                wrong.append("positions differ")
            for k, co in want_keys.items():
                if keys.get(k) != co:
                    wrong.append(f'shape key "{k}" ' + ("missing" if k not in keys else "differs"))
            left = [a for a in STAGE_ATTRS if face.data.attributes.get(a) is not None]
            if left:
                wrong.append(f"stage attributes left: {left}")
            if any(m.type == "NODES" and m.node_group is not None and m.node_group.name.startswith("Wrinkles")
                   for m in face.modifiers):
                wrong.append("a Wrinkles modifier is left")
            if wrong:
                self.problems_now.append(("restore_mismatch", "after Disable Wrinkles: " + "; ".join(wrong)))
        self.update()
        return r

    ACTIONS = (  # (name, weight)
        ("frame", 5.0), ("edit_update", 1.5), ("render", 1.0), ("undo", 2.0), ("save_reload", 1.0),
        ("delete", 2.0), ("transform", 2.0), ("topology", 1.0), ("modifier", 2.0), ("bake", 1.0),
        ("duplicate", 0.6), ("hostile", 3.0), ("crafted", 1.5), ("operator", 4.0), ("disable", 1.2),
        ("data", 1.0),
    )

    def draw(self):
        names, weights = zip(*self.ACTIONS)
        name = self.rng.choices(names, weights)[0]
        return name, [self.rng.random() for _ in range(6)]

    def emit(self, rec):
        self.out.write(json.dumps(rec) + "\n")
        self.out.flush()

    def inject(self, what):
        """A planted fault, for the harness's own test (tests/blender/test_stress.py): a
        source whose ``contribute`` raises (the frame stage's internal error), an abort (a
        crash), a sleep (a hang) or a moved vertex (what a Disable that does not restore the
        mesh leaves)."""
        if what == "crash":
            os.abort()
        if what == "hang":
            time.sleep(3600)
        if what == "restore":  # a mesh that Disable Wrinkles would not give back as it was
            self.face.data.vertices[0].co.y += 1e-6
            self.emit({"i": -1, "action": "inject restore: moved vertex 0", "problems": []})
            return
        from wrinkle_addon.glue import registry

        def broken(*_args, **_kwargs):
            raise RuntimeError("planted by tools/stress.py --inject")

        source = next(s for s in registry.sources() if s.geometric)
        source.contribute = broken
        self.bpy.context.scene.frame_set(3)
        found = self.check()
        self.problems += found
        self.emit({"i": -1, "action": f"inject {what} into {source.name}",
                   "problems": [{"kind": k, "message": m} for k, m in found]})

    def main(self, actions, keep, inject=None):
        try:
            steps = self.setup()
        except Problem as exc:  # an operator of the setup broke: the add-on's fault
            found = [(exc.kind, f"setup: {exc}")] + self.check()
            self.emit({"i": -1, "action": "setup", "result": "problem",
                       "problems": [{"kind": k, "message": m} for k, m in found]})
            self.emit({"summary": True, "run": self.run, "actions": 0,
                       "problems": sorted({k for k, _ in found})})
            return
        except Exception as exc:  # the harness could not build the scene: not a run
            tb = traceback.format_exc()
            self.emit({"summary": True, "run": self.run, "problems": ["harness_error"],
                       "setup_problem": f"{exc!r}\n{tb[-1500:]}"})
            return
        found = self.check()
        self.emit({"i": -1, "action": "setup", "result": steps,
                   "problems": [{"kind": k, "message": m} for k, m in found]})
        self.problems += found
        if inject:
            self.inject(inject)
        for i in range(actions):
            name, u = self.draw()
            if keep is not None and i not in keep:
                continue
            self.problems_now = []
            start = time.monotonic()
            try:
                result = getattr(self, "a_" + name)(u)
            except Problem as exc:
                result = "problem"
                self.problems_now.append((exc.kind, str(exc)))
            except Exception as exc:
                result = "harness error"
                self.problems_now.append(("harness_error", f"{exc!r}\n{traceback.format_exc()[-1500:]}"))
            try:
                self.bpy.ops.ed.undo_push(message=name)
            except RuntimeError:
                pass
            found = self.problems_now + self.check()
            self.problems += found
            self.emit({"i": i, "action": name, "u": [round(x, 4) for x in u], "result": result,
                       "seconds": round(time.monotonic() - start, 2),
                       "problems": [{"kind": k, "message": m} for k, m in found]})
        face = self.face
        if face is not None and face.ewrinkles_face.enabled and not self.topology_edited:
            # every run ends with Disable Wrinkles, so every untouched mesh is checked once
            self.problems_now = []
            try:
                result = self.a_disable([1.0] * 6)
            except Problem as exc:
                result = "problem"
                self.problems_now.append((exc.kind, str(exc)))
            found = self.problems_now + self.check()
            self.problems += found
            self.emit({"i": actions, "action": "final disable", "result": result,
                       "problems": [{"kind": k, "message": m} for k, m in found]})
        self.emit({"summary": True, "run": self.run, "actions": actions,
                   "problems": sorted({k for k, _ in self.problems})})


def child(args):
    work = Path(args.workdir)
    work.mkdir(parents=True, exist_ok=True)
    out = os.fdopen(os.dup(1), "w")  # the JSON lines; Blender's own output goes to the log
    fd = os.open(work / "blender.log", os.O_WRONLY | os.O_CREAT | os.O_APPEND)
    os.dup2(fd, 1)
    os.dup2(fd, 2)
    sys.stdout.reconfigure(line_buffering=True)
    sys.stderr.reconfigure(line_buffering=True)
    if str(ROOT) not in sys.path:
        sys.path.insert(0, str(ROOT))
    import importlib

    import bpy

    addon_utils = importlib.import_module("addon_utils")  # importable only once bpy is

    errors = []
    mod = addon_utils.enable(ADDON, default_set=True, handle_error=lambda ex: errors.append(repr(ex)))
    if errors or mod is None or not addon_utils.check(ADDON)[1]:
        out.write(json.dumps({"summary": True, "run": args.run, "problems": [],
                              "setup_problem": f"enabling the add-on failed: {errors}"}) + "\n")
    else:
        Child(args.seed, args.run, work, out).main(args.actions, _parse_keep(args.keep), args.inject)
    out.flush()
    # Measured on bpy 4.5.4 (tests/conftest.py): the interpreter can deadlock at exit after a
    # driver ran; factory settings first, then leave without Python's own teardown.
    bpy.ops.wm.read_factory_settings(use_empty=True)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=10, help="how many runs (default 10)")
    ap.add_argument("--first", type=int, default=0, help="index of the first run (default 0)")
    ap.add_argument("--actions", type=int, default=15, help="random actions per run (default 15)")
    ap.add_argument("--seed", type=int, default=1, help="the seed of every run's random numbers")
    ap.add_argument("--jobs", type=int, default=1, help="runs at the same time (default 1)")
    ap.add_argument("--timeout", type=float, default=180.0, help="seconds before a run counts as hung")
    ap.add_argument("--replay", type=int, nargs=2, metavar=("SEED", "RUN"), help="replay one run")
    ap.add_argument("--keep", help="replay only these action indices (comma-separated)")
    ap.add_argument("--log", action="store_true", help="with --replay: print Blender's output too")
    ap.add_argument("--minimize", action="store_true",
                    help="with --replay: find the fewest actions that still show the run's first problem")
    ap.add_argument("--inject", choices=("error", "crash", "hang", "restore"), help=argparse.SUPPRESS)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--run", type=int, default=0, help=argparse.SUPPRESS)
    ap.add_argument("--workdir", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        return child(args)
    return parent(args)


if __name__ == "__main__":
    sys.exit(main())
