# SPDX-License-Identifier: GPL-3.0-or-later
"""What an export reads off a face, frame by frame: its wrinkle offsets (every source
summed, as the stage writes them for a render), its shape keys' values and its wrinkle
maps' zone weights.  One pass over the range serves the glTF morph targets and the
wrinkle-map package alike."""

import contextlib
import math
import os
from dataclasses import dataclass, field

import bpy
import numpy as np

from .. import meshio, pipeline, stage, status
from ..errors import WrinkleError
from ..maps import map_material


class ExportError(WrinkleError):
    """A problem the user must fix; the message is shown as is."""


@dataclass
class Frames:
    frames: list  # the frame numbers
    offsets: np.ndarray  # (F, V, 3) float32: the wrinkle offsets, object space
    key_names: list = field(default_factory=list)  # the face's shape keys but the basis
    key_values: np.ndarray = None  # (F, S) float32: their evaluated values
    zone_weights: np.ndarray = None  # (F, K, 8) float32, or None without wrinkle maps
    normals: np.ndarray = None  # (F, V, 3) float32: the wrinkled face's vertex normals, if asked
    parts: list = field(default_factory=list)  # [(object, key names, (F, S) values)] of the parts asked for


def parts(face, view_layer):
    """The face's **parts**: the meshes parented to it that render with it (eyes, lashes,
    teeth), which the exports carry along.  Not its muscles, nor the Geometry Nodes objects
    the add-on makes (tears), whose geometry is a modifier's, nor what is hidden in renders
    or not in ``view_layer``."""
    return [ob for ob in face.children
            if ob.type == "MESH" and not ob.ewrinkles_muscle.is_muscle and not ob.hide_render
            and view_layer.objects.get(ob.name) == ob and len(ob.data.polygons)
            and not any(m.type == "NODES" for m in ob.modifiers)]


def check_range(frame_start, frame_end):
    if frame_end < frame_start:
        raise ExportError(f"The frame range {frame_start}-{frame_end} ends before it starts")


def check_path(filepath, extensions):
    """The absolute path of ``filepath``, after checking its extension and its folder."""
    if not filepath:
        raise ExportError("No file path given")
    if filepath.startswith("//") and not bpy.data.filepath:
        raise ExportError(f"The path {filepath!r} is relative to the .blend file, which is not saved "
                          "yet: save it first or give an absolute path")
    path = bpy.path.abspath(filepath)
    if extensions and not path.lower().endswith(tuple(extensions)):
        raise ExportError(f"{os.path.basename(path)!r} is not a {' or '.join(extensions)} file")
    folder = os.path.dirname(path) or "."
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as exc:
        raise ExportError(f"Cannot make the folder {folder!r}: {exc.strerror or exc}") from None
    if not os.access(folder, os.W_OK):
        raise ExportError(f"The folder {folder!r} is not writable")
    return path


@contextlib.contextmanager
def exporting(context, ob, frame_start, frame_end, others=()):
    """``ob`` (and ``others``) the only selected objects, ``ob`` the active one, the scene's
    range the export's (Blender's exporters take both from the scene); the selection, the
    active object, the range and the current frame are put back afterwards, also when the
    export fails."""
    scene, view_layer = context.scene, context.view_layer
    selected = [o for o in view_layer.objects if o.select_get()]
    active = view_layer.objects.active
    saved = scene.frame_start, scene.frame_end, scene.frame_current, scene.frame_subframe
    try:
        for o in selected:
            o.select_set(False)
        for o in (ob, *others):
            o.select_set(True)
        view_layer.objects.active = ob
        # start first: a start after the old end moves the end along, which the next line sets
        scene.frame_start, scene.frame_end = frame_start, frame_end
        yield
    finally:
        scene.frame_start, scene.frame_end = saved[:2]
        scene.frame_set(saved[2], subframe=saved[3])
        for o in (ob, *others):
            if o.name in view_layer.objects:
                o.select_set(False)
        for o in selected:
            if o.name in view_layer.objects:
                o.select_set(True)
        view_layer.objects.active = active


def metres_per_unit(face, scene):
    """Metres per unit of ``face``'s mesh: the scene's unit scale times the object's
    largest scale (an error in mesh units is at most this many metres in the world)."""
    scale = max(abs(s) for s in face.matrix_world.to_scale())
    return float(scene.unit_settings.scale_length) * (scale if math.isfinite(scale) and scale > 0 else 1.0)


def _key_values(face, depsgraph):
    key = face.data.shape_keys
    if key is None:
        return []
    evaluated = key.evaluated_get(depsgraph)
    return [kb.value for kb in evaluated.key_blocks[1:]]


def _vertex_normals(face, out):
    """The wrinkled face's vertex normals now (its evaluated mesh: the stage's offsets
    applied); the base vertices' when a Subdivision Surface follows."""
    ev = face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    if len(ev.vertices) == len(out):
        ev.vertex_normals.foreach_get("vector", out.reshape(-1))
    else:
        full = np.empty((len(ev.vertices), 3), np.float32)
        ev.vertex_normals.foreach_get("vector", full.reshape(-1))
        out[:] = full[: len(out)]


def read(context, face, frame_start, frame_end, maps=False, normals=False, progress=None, with_parts=()):
    """Step ``context.scene`` through the range and read every frame of ``face`` (with
    ``normals``, also its vertex normals, and the shape-key values of ``with_parts``); the
    scene is put back on its frame afterwards.  Raises ExportError."""
    check_range(frame_start, frame_end)
    scene = context.scene
    has_maps = maps and face.ewrinkles_face.maps.weights_group is not None
    if stage.find_modifier(face) is None and not has_maps:
        raise ExportError(f'"{face.name}" has no wrinkles to export: enable wrinkles or set up wrinkle '
                          "maps on it first")
    frames = list(range(frame_start, frame_end + 1))
    me = face.data
    n = len(me.vertices)
    key = me.shape_keys
    names = [kb.name for kb in key.key_blocks[1:]] if key is not None else []
    offsets = np.zeros((len(frames), n, 3), np.float32)
    values = np.zeros((len(frames), len(names)), np.float32)
    zones = None
    if has_maps:
        zones = np.zeros((len(frames), map_material.n_maps(face.ewrinkles_face.maps), 8), np.float32)
    shading = np.zeros((len(frames), n, 3), np.float32) if normals else None
    part_keys = [(ob, [kb.name for kb in ob.data.shape_keys.key_blocks[1:]] if ob.data.shape_keys else [])
                 for ob in with_parts]
    part_values = [np.zeros((len(frames), len(names)), np.float32) for _ob, names in part_keys]
    current = (scene.frame_current, scene.frame_subframe)
    try:
        for i, f in enumerate(frames):
            scene.frame_set(f)
            depsgraph = pipeline.export_frame(scene, face)
            if stage.find_modifier(face) is not None:
                why = status.get(face, pipeline.CHANNEL)
                if why:
                    raise ExportError(f'"{face.name}" on frame {f}: {why}')
                meshio.read_vectors(me, stage.OFFSET_ATTR, offsets[i])
            values[i] = _key_values(face, depsgraph)
            for (ob, _names), out in zip(part_keys, part_values):
                out[i] = _key_values(ob, depsgraph)
            if shading is not None:
                _vertex_normals(face, shading[i])
            if zones is not None:
                zones[i] = map_material.zone_weights(face)
            if progress is not None:
                progress(i + 1, len(frames))
    finally:
        scene.frame_set(current[0], subframe=current[1])
    if not np.all(np.isfinite(offsets)):
        raise ExportError(f'"{face.name}" has wrinkle offsets that are not finite numbers')
    return Frames(frames, offsets, names, values, zones, shading,
                  [(ob, names_, v) for (ob, names_), v in zip(part_keys, part_values)])
