# SPDX-License-Identifier: GPL-3.0-or-later
"""The batch commands: render, bake, check, sheet and export (README, "The batch command and
render farms"; export: "Wrinkles in game engines and other tools").

Each returns an exit code (``args``: 0 done, 1 a failure during the work, 2 a usage error,
3 not farm-ready, 130 stopped by Ctrl-C) and says what went wrong in one line on stderr.
Progress goes to stderr, JSON lines to stdout.  No command saves over the shot.
"""

import json
import os
import signal
import sys
import tempfile
import time
from pathlib import Path

import bpy

from ..glue import farm_bake, pipeline, registry, stage, status
from . import args, files
from .args import FAILED, NOT_READY, OK, STOPPED, USAGE, UsageError


def say(line):
    print(f"ewrinkles: {line}", file=sys.stderr, flush=True)


def _open(blend):
    path = files.argument_path(blend, "the shot")
    if not os.path.isfile(path):
        raise UsageError(f"cannot read {files.shown(blend)}: no such file")
    if not os.access(path, os.R_OK):
        raise UsageError(f"cannot read {files.shown(blend)}: permission denied")
    try:
        bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
    except RuntimeError as exc:
        raise UsageError(f"cannot open {files.shown(blend)}: {_op_message(exc)}") from None
    return path


def faces(scene):
    """The objects of ``scene`` that a wrinkle source works on (or with wrinkles on)."""
    return [ob for ob in scene.objects if ob.type == "MESH" and (
        ob.ewrinkles_face.enabled or any(s.active(ob) or s.bakes(ob) or s.has_bake(ob)
                                         for s in registry.sources()))]


def _frames(ns, scene):
    text = ns.frames or f"{scene.frame_start}-{scene.frame_end}"
    return args.frames(text), text


def _engine(name):
    if name == "EEVEE":
        return "BLENDER_EEVEE_NEXT" if bpy.app.version < (5, 0, 0) else "BLENDER_EEVEE"
    return name


def apply_look(scene, ns):
    """--engine, --samples and --resolution on ``scene`` (in memory)."""
    if ns.engine:
        scene.render.engine = _engine(ns.engine)
    if ns.samples:
        cycles = scene.render.engine == "CYCLES"
        settings, prop = (scene.cycles, "samples") if cycles else (scene.eevee, "taa_render_samples")
        most = settings.bl_rna.properties[prop].hard_max
        if ns.samples > most:
            raise UsageError(f"--samples {ns.samples} is more than {'Cycles' if cycles else 'EEVEE'} allows: "
                             f"give 1 to {most}")
        setattr(settings, prop, ns.samples)
    if ns.resolution:
        scene.render.resolution_x, scene.render.resolution_y = ns.resolution
        scene.render.resolution_percentage = 100


def _clock(seconds):
    m, s = divmod(int(round(seconds)), 60)
    return f"{m // 60}:{m % 60:02d}:{s:02d}" if m >= 60 else f"{m}:{s:02d}"


class _Stop:
    """Ctrl-C while rendering: the first stops after the current frame, the second at once
    (Blender's default).  The handler only sets a flag, so a frame is never cut short by it."""

    def __init__(self):
        self.asked = False
        self.old = None

    def __enter__(self):
        try:
            self.old = signal.signal(signal.SIGINT, self._asked)
        except ValueError:  # not the main thread: no Ctrl-C handling
            self.old = None
        return self

    def _asked(self, *_):
        self.asked = True
        say("Ctrl-C: stopping after this frame (Ctrl-C again to stop at once)")
        signal.signal(signal.SIGINT, signal.SIG_DFL)

    def __exit__(self, *exc):
        if self.old is not None:
            signal.signal(signal.SIGINT, self.old)
        return False


_TMP_PREFIX = ".ewrinkles-"  # the temporary folder of the frames: a prefix and 8 random characters


def _render_one(scene, f, final, tmpdir):
    """Render frame ``f`` as Blender's own ``-f`` does (an animation render of one frame)
    into ``tmpdir``, then move it to ``final``: a frame file is whole or absent."""
    scene.frame_start = scene.frame_end = f
    scene.render.filepath = str(Path(tmpdir) / "frame_####")
    written = Path(scene.render.frame_path(frame=f))
    bpy.ops.render.render(animation=True)
    if not written.is_file():
        raise RuntimeError(f"Blender wrote no image for frame {f}")
    os.replace(written, final)


def render(ns):
    with _Results(ns.json) as emit:
        return _render(ns, emit)


def _render(ns, emit):
    path = _open(ns.blend)
    scene = bpy.context.scene
    if not faces(scene):
        raise UsageError(f"{path.name} has no face with wrinkles: render it with `blender -b {path.name} -a`")
    frame_list, text = _frames(ns, scene)
    if ns.chunk:
        k, n = args.chunk(ns.chunk)
        frame_list = args.chunk_of(frame_list, k, n)
        if not frame_list:
            raise UsageError(f"chunk {k}/{n} of the frames {text} is empty: use fewer parts")
    if scene.render.is_movie_format:
        raise UsageError(f"{path.name} renders to a movie ({scene.render.image_settings.file_format}); "
                         "ewrinkles render writes one image per frame: choose an image format in "
                         "Output Properties > Output, then encode the frames")
    out = files.argument_path(ns.out, "--out", path.parent)
    files.not_a_file("--out", ns.out, out, "the frames")
    # the longest path Blender gets: a frame in the temporary folder (_render_frames)
    name = f"frame_{max(frame_list):04d}{scene.render.file_extension}"
    files.fits("--out", ns.out, out, out / (_TMP_PREFIX + "x" * 8) / name)
    apply_look(scene, ns)  # in memory; its refusals come before anything is written
    out = files.writable_folder(out)
    scene.render.use_overwrite, scene.render.use_placeholder = True, False  # frames go to a temp folder
    scene.render.filepath = str(out / "frame_####")
    finals = {f: Path(scene.render.frame_path(frame=f)) for f in frame_list}
    size = files.render_size(scene)  # a kept frame is whole and of the size this render writes
    todo = [f for f in frame_list
            if not (ns.resume and finals[f].is_file() and files.complete(finals[f], size))]
    if len(todo) < len(frame_list):
        say(f"--resume: {len(frame_list) - len(todo)} of {len(frame_list)} frames already done, skipped")
    return _render_frames(scene, ns, frame_list, todo, finals, out, emit)


class _Results:
    """stdout holds only the command's results (``render --json``'s lines, ``check``'s
    report): Blender's own log, which it prints on the C level's stdout, goes to stderr
    meanwhile (file descriptor 1 is pointed at 2; the results go to a copy of the old 1).
    The context gives ``emit(record)``: a dict as one JSON line, a string as is."""

    def __init__(self, on=True):
        self.on, self.saved, self.out, self.python_stdout = on, None, None, None

    def __enter__(self):
        if not self.on:
            return lambda record: None
        sys.stdout.flush()
        self.saved = os.dup(1)
        self.out = os.fdopen(os.dup(self.saved), "w", buffering=1)
        os.dup2(2, 1)
        self.python_stdout, sys.stdout = sys.stdout, sys.stderr  # print() of Blender's Python exporters
        return self._emit

    def _emit(self, record):
        self.out.write((record if isinstance(record, str) else json.dumps(record)) + "\n")
        self.out.flush()

    def __exit__(self, *exc):
        if self.saved is not None:
            sys.stdout.flush()
            sys.stdout = self.python_stdout
            os.dup2(self.saved, 1)
            os.close(self.saved)
            self.out.close()
        return False


def _render_frames(scene, ns, frame_list, todo, finals, out, emit):
    started = time.perf_counter()
    done = 0
    with _Stop() as stop, tempfile.TemporaryDirectory(dir=out, prefix=_TMP_PREFIX) as tmpdir:
        for i, f in enumerate(todo, 1):
            pipeline.stage_seconds[0] = 0.0
            t0 = time.perf_counter()
            try:
                _render_one(scene, f, finals[f], tmpdir)
            except (RuntimeError, OSError) as exc:
                say(f"the render of frame {f} failed: {str(exc).removeprefix('Error: ').strip()}")
                return FAILED
            seconds = time.perf_counter() - t0
            done += 1
            elapsed = time.perf_counter() - started
            eta = elapsed / i * (len(todo) - i)
            say(f"frame {f} ({i}/{len(todo)}) in {seconds:.1f} s, "
                f"elapsed {_clock(elapsed)}, ETA {_clock(eta)}")
            emit({"frame": f, "file": str(finals[f]), "seconds": round(seconds, 3),
                  "stage_ms": round(pipeline.stage_seconds[0] * 1000, 2)})
            if stop.asked and i < len(todo):
                say(f"stopped by Ctrl-C after {done} frames; the frames written are kept, "
                    "--resume renders the rest")
                return STOPPED
    if ns.contact_sheet:
        sheet = files.contact_sheet([finals[f] for f in frame_list], out / "contact_sheet.png")
        say(f"contact sheet: {sheet}")
    say(f"rendered {done} frames to {out} in {_clock(time.perf_counter() - started)}")
    return OK


def _op_message(exc):
    return str(exc).removeprefix("Error: ").strip()


def bake(ns):
    path = _open(ns.blend)
    scene = bpy.context.scene
    found = [ob for ob in faces(scene)
             if farm_bake.has_stage(ob) or any(s.bakes(ob) for s in registry.sources())]
    if not found:
        raise UsageError(f"{path.name} has no face with wrinkles or wrinkle maps to bake")
    frame_list, text = _frames(ns, scene)
    start, end = args.contiguous(frame_list, text)
    option, given = ("--save-as", ns.save_as) if ns.save_as else ("the shot", ns.blend)
    if ns.save_as:
        target = files.argument_path(ns.save_as, option, path.parent)
        files.not_a_folder(option, given, target, f"{path.stem}_farm.blend")
    else:
        target = path.with_name(f"{path.stem}_farm.blend")
    if target == path:
        raise UsageError(f"--save-as {files.shown(ns.save_as)} is the shot itself: the baked file must be "
                         "another file, so that the live shot is kept")
    # Blender saves through FILE@, and the bake writes its caches in wrinkle_bake/ beside
    prefix, suffix = f".{target.stem}.", ".partial.blend"
    files.fits(option, given, target, f"{target.parent / (prefix + 'x' * 8 + suffix)}@",
               *(target.parent / farm_bake.default_path(ob).removeprefix("//") for ob in found))
    apply_look(scene, ns)
    files.writable_folder(target.parent)
    # The session moves to a copy in the target's folder first, so that the bake's files
    # (written next to the .blend: //wrinkle_bake/) land beside the baked file, in the folder
    # a farm's workers read; the shot itself is never written.  The copy has a name of its
    # own (made here, so no other file is ever replaced or removed), hidden beside the target.
    try:
        handle, name = tempfile.mkstemp(dir=target.parent, prefix=prefix, suffix=suffix)
    except OSError as exc:
        raise UsageError(f"cannot write beside {option} {files.shown(str(target))}: "
                         f"{exc.strerror or exc}") from None
    os.close(handle)
    partial = Path(name)
    prefs = bpy.context.preferences.filepaths
    versions, prefs.save_version = prefs.save_version, 0  # no .blend1 beside the farm file
    try:
        bpy.ops.wm.save_as_mainfile(filepath=str(partial), relative_remap=True)
        code = _bake_faces(found, start, end)
        if code == OK:
            bpy.ops.wm.save_as_mainfile(filepath=str(target), relative_remap=True)
            say(f"saved the baked shot as {target}; it renders with no add-on: blender -b {target.name} -a")
        return code
    finally:
        partial.unlink(missing_ok=True)
        prefs.save_version = versions


def _bake_faces(found, start, end):
    for ob in found:
        for other in bpy.context.view_layer.objects:
            other.select_set(False)
        bpy.context.view_layer.objects.active = ob
        ob.select_set(True)
        say(f'baking "{ob.name}", frames {start}-{end}')
        try:
            bpy.ops.wrinkle.bake(frame_start=start, frame_end=end)
        except RuntimeError as exc:  # the same message as in the panel
            message = _op_message(exc)
            say(f'"{ob.name}": {message}')
            # a bake that began and failed is a failure; one the operator refused, a usage error
            return FAILED if farm_bake.FAILED_ENDING in message else USAGE
        missing = _unbaked(ob)
        if missing:
            say(f'the bake of "{ob.name}" did not finish ({missing}); nothing was saved')
            return FAILED
    return OK


def _unbaked(ob):
    """What of ``ob`` still renders live (needs the add-on), as a phrase, or ""."""
    why = []
    if farm_bake.has_stage(ob) and farm_bake.stand_in(ob) is None:
        why.append("its geometric wrinkles are not baked")
    why += [f"{s.label} is not baked" for s in registry.sources() if s.bakes(ob) and not s.has_bake(ob)]
    return "; ".join(why)


def _cache_missing(ob):
    baked = farm_bake.stand_in(ob)
    for mod in baked.modifiers if baked is not None else ():
        cache = getattr(mod, "cache_file", None)
        if cache is not None and not Path(bpy.path.abspath(cache.filepath)).is_file():
            return f"its cache {cache.filepath} is missing"
    return ""


def _python_drivers():
    """Drivers that call Python (not simple expressions): a farm with auto-run off, or with
    no add-on, does not evaluate them."""
    out = []
    for coll in (bpy.data.objects, bpy.data.meshes, bpy.data.shape_keys, bpy.data.materials,
                 bpy.data.node_groups, bpy.data.scenes):
        for idb in coll:
            ad = getattr(idb, "animation_data", None)
            for fc in ad.drivers if ad is not None else ():
                d = fc.driver
                if d.type == "SCRIPTED" and not d.is_simple_expression:
                    out.append(f'{idb.name}: {fc.data_path} = "{d.expression}"')
    return out


def check(ns):
    with _Results() as emit:
        return _check(ns, emit)


def _check(ns, emit):
    path = _open(ns.blend)
    scene = bpy.context.scene
    found = faces(scene)
    if not found:
        raise UsageError(f"{path.name} has no face with wrinkles")
    scene.frame_set(scene.frame_current)  # the stage runs once: its problems are current
    ready = True
    lines = [f"{path.name}: scene {scene.name!r}, frames {scene.frame_start}-{scene.frame_end}"]
    for ob in found:
        active = [s for s in registry.sources()
                  if (ob.ewrinkles_face.enabled or not s.geometric) and s.active(ob)]
        lines.append(f'face "{ob.name}": {", ".join(s.label for s in active) or "no active source"}')
        stage_problem = status.get(ob, pipeline.CHANNEL)
        if stage_problem:
            lines.append(f"  problem: {stage_problem}")
        for s in active:
            message = status.get(ob, s.name, family=True)
            if message:
                lines.append(f"  {s.label}: {message}")
        why = _unbaked(ob) or (_cache_missing(ob) if farm_bake.stand_in(ob) is not None else "")
        if why:
            ready = False
            lines.append(f"  farm: needs the add-on: {why} (run `ewrinkles bake {path.name}`)")
        elif farm_bake.stand_in(ob) is not None or any(s.has_bake(ob) for s in registry.sources()):
            lines.append("  farm: baked, renders without the add-on")
        elif stage.find_modifier(ob) is None:
            lines.append("  farm: only one-variable drivers, renders without the add-on")
    scripted = _python_drivers()
    for d in scripted:
        lines.append(f"driver calls Python: {d}")
    if scripted:
        ready = False
        lines.append("  farm: drivers that call Python need the add-on or auto-run: "
                     "make them simple expressions")
    for line in lines:
        emit(line)
    emit(f"farm-ready: {'yes' if ready else 'no'}")
    return OK if ready else NOT_READY


def sheet(ns):
    folder = files.argument_path(ns.folder, "the folder")
    if not os.path.isdir(folder):
        raise UsageError(f"no folder {files.shown(ns.folder)}")
    option, text = ("--out", ns.out) if ns.out else ("the folder", ns.folder)
    if ns.out:
        out = files.argument_path(ns.out, option)
        files.not_a_folder(option, text, out, "contact_sheet.png")
    else:
        out = folder / "contact_sheet.png"
        if os.path.isdir(out):
            raise UsageError(f"{files.shown(str(out))}, where the sheet goes by default, is a folder: "
                             "name the sheet to write with --out")
    partial = files.sheet_partial(out)
    files.fits(option, text, out, f"{partial}.partial")  # images.write's own temporary name
    if ns.frames:
        paths = [folder / f"frame_{f:04d}.png" for f in args.frames(ns.frames)]
        missing = [p.name for p in paths if not files.complete(p)]
        if missing:
            say(f"{len(missing)} frames are missing or incomplete: {', '.join(missing[:5])}")
            return FAILED
    else:
        paths = sorted(folder.glob("frame_[0-9]*.png"))
    files.writable_folder(out.parent)
    files.contact_sheet(paths, out, ns.width)
    say(f"contact sheet of {len(paths)} frames: {out}")
    return OK


def export(ns):
    with _Results(ns.json) as emit:
        return _export(ns, emit)


def _export(ns, emit):
    from ..glue.errors import WrinkleError
    from ..glue.export import gltf, package, usd
    from ..glue.progress import Progress

    path = _open(ns.blend)
    scene = bpy.context.scene
    found = faces(scene)
    if ns.face:
        found = [ob for ob in found if ob.name == ns.face]
        if not found:
            raise UsageError(f'{path.name} has no face "{ns.face}" with wrinkles or wrinkle maps')
    if not found:
        raise UsageError(f"{path.name} has no face with wrinkles or wrinkle maps")
    if len(found) > 1:
        names = ", ".join(f'"{ob.name}"' for ob in found)
        raise UsageError(f"{path.name} has {len(found)} faces ({names}): pick one with --face")
    face = found[0]
    start, end = args.contiguous(*_frames(ns, scene))
    out = files.argument_path(ns.out, "--out", path.parent)
    if ns.format == "package":  # a folder of wrinkles.json and the images, each written as NAME.partial first
        files.not_a_file("--out", ns.out, out, "the package (wrinkles.json and its images)")
        ext = package.IMAGE_FORMATS[ns.image_format][2]
        names = (package.JSON_NAME, *(stem + ext for _prop, stem in package.SLOTS))
        files.fits("--out", ns.out, out, *(out / f"{name}.partial" for name in names))
    else:  # a file, finished as FILE.partial (glb.py)
        files.not_a_folder("--out", ns.out, out, f"{face.name}.{'glb' if ns.format == 'gltf' else 'usdc'}")
        files.fits("--out", ns.out, out, f"{out}.partial")
    out = str(out)
    say(f'exporting "{face.name}", frames {start}-{end}, as {ns.format} to {out}')
    try:
        with Progress(None, f"Export {ns.format} {face.name}", total=end - start + 1, every=10) as progress:
            if ns.format == "gltf":
                report = gltf.export(bpy.context, face, out, start, end, ns.tolerance, ns.max_targets,
                                     ns.targets, lambda f: progress(f * (end - start + 1)))
            elif ns.format == "usd":
                report = usd.export(bpy.context, face, out, start, end, keep_attributes=ns.keep_attributes)
            else:
                report = package.write(bpy.context, face, out, start, end, ns.image_format, progress)
    except WrinkleError as exc:
        raise UsageError(f'"{face.name}": {exc}') from None
    if ns.format == "gltf":
        say(f"{report['targets']} wrinkle targets, largest error {report['max_error_mm']:.4f} mm, "
            f"mean {report['mean_error_mm']:.4f} mm")
        if not report["within_tolerance"]:
            say(f"warning: {report['max_error_mm']:.4f} mm is more than the tolerance of {ns.tolerance:g} "
                "mm: "
                "raise --max-targets or --tolerance")
    if ns.json:
        emit(json.dumps({"face": face.name, "format": ns.format, **report}))
    say(f"wrote {out}")
    return OK


COMMANDS = {"render": render, "bake": bake, "check": check, "sheet": sheet, "export": export}
