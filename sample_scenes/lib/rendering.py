"""What the demo and the scenes that render on their own share: enabling the add-on, the log
with progress (renders done of all, elapsed time and ETA), Blender's render chatter sent to a
file, renders of a scene without and with its wrinkles, and contact sheets.  The scenes sit
below the demo and import this, never the demo."""

import contextlib
import os
import sys
import time

import bpy
import numpy as np

from . import labels, scene_setup

_T0 = time.perf_counter()


def enable_addon():
    """Enable the add-on the way Blender does, before any scene imports its modules:
    ``addon_utils.enable()`` on an add-on already imported the ordinary way prints "module
    changed on disk: ... reloading..." and runs its ``__init__`` a second time."""
    import addon_utils  # importable once bpy is

    if addon_utils.enable("wrinkle_addon", default_set=True) is None:
        raise SystemExit("demo: the wrinkle_addon add-on did not load (see the message above)")


def log(msg):
    print(f"[demo {time.perf_counter() - _T0:6.1f}s] {msg}", flush=True)


class Progress:
    """Counts the renders of a run that knows how many it will make: ``progress.done(what,
    seconds)`` logs ``render j/M`` with the elapsed time and an ETA from the mean so far."""

    def __init__(self, total):
        self.total, self.count, self.spent = int(total), 0, 0.0

    def done(self, what, seconds):
        self.count += 1
        self.spent += seconds
        left = max(self.total - self.count, 0)
        eta = self.spent / self.count * left
        log(f"render {self.count}/{self.total}: {what} ({seconds:.1f}s; about {eta:.0f}s of "
            f"rendering to go)")


@contextlib.contextmanager
def quiet(log_path):
    """Send Blender's own per-tile render chatter (C-level stdout/stderr) to a log file."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    with open(log_path, "ab") as f:
        os.dup2(f.fileno(), 1)
        os.dup2(f.fileno(), 2)
        try:
            yield
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])


def render_still(path, progress=None, what=None):
    """Render the scene's camera to ``path`` (chatter to ``render.log`` beside it)."""
    scene = bpy.context.scene
    scene.render.filepath = str(path)
    t = time.perf_counter()
    with quiet(path.parent / "render.log"):
        bpy.ops.render.render(write_still=True)
    seconds = time.perf_counter() - t
    if progress is not None:
        progress.done(what or path.name, seconds)
    else:
        log(f"{what or path.name} ({seconds:.1f}s)")
    return seconds


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
    (group, word) per image) are drawn into the sheet; see sample_scenes/lib/labels.py.
    Blender's bottom-up pixel order is handled here."""
    tiles = [[load_rgba(p)[::-1] for p in row] for row in rows]  # top row first
    save_rgba(labels.sheet(tiles, gap=gap, row_names=row_names, captions=captions)[::-1], path)


def geometric_toggle(face, on):
    face.ewrinkles_face.strength = 1.0 if on else 0.0


def render_scene(name, builder, out, size, samples, toggle=geometric_toggle, progress=None):
    """Build a scene into an empty file, save ``name.blend``, and render each of its shots
    without and with wrinkles; returns ``(paths, captions)``."""
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
            render_still(path, progress, f"{name}: {shot} {label} wrinkles -> {path.name}")
            row.append(path)
            captions.append((shot, label))
    toggle(face, True)
    return row, captions
