# SPDX-License-Identifier: GPL-3.0-or-later
"""The animated, wrinkled face as USD, written by Blender's own USD exporter.

The exporter steps through the frames with a RENDER depsgraph and calls the frame-change
handlers on each, so our frame stage writes that frame's offsets back into the mesh
(``wrinkle_offset``) and the Wrinkles modifier adds them before the exporter reads the
evaluated mesh: every frame's wrinkles are in the file as time samples of the mesh's
``points`` (checked against the live evaluation in the tests, on bpy 4.5 and 5.2).

Deformations are written as points, never as UsdSkel.  With ``export_shapekeys`` the
exporter writes the shape keys as blend shapes of the mesh *before* its modifiers and no
time samples of the points, so the Geometry Nodes stage - the wrinkles - is lost (measured
on bpy 4.5 and 5.2); ``export_armatures`` likewise writes a mesh with an Armature modifier
as a skinned mesh.  So both are off, and the file holds the face as it renders, frame by
frame, whatever deforms it.

The exporter writes every generic attribute of the evaluated mesh as a primvar, and no
option leaves one out.  The add-on's own (``wrinkle_*``: the stage's skin, offsets, pull
and frame stamp; ``ewrinkles_*``: the fine wrinkles' fields and shrinkage, the sample
skin's rest positions and regions) are of no use outside Blender and are about half of
the file, some time-sampled on every frame (the sample head over 48 frames: 213 MB with
them, 109 MB without).  So by default the export puts a temporary
Geometry Nodes modifier at the end of the face's stack (above a final Subdivision Surface,
which stays the mesh's scheme) that removes them from what the exporter reads, and takes it
away afterwards; ``keep_attributes`` writes them all.

The materials are written as a ``UsdPreviewSurface`` consumer reads them: the exporter
reads temporary plain copies (``materials``: the base normal map or none as the normal, no
procedural chains such as the sample skin's colour from its rest positions, a Principled
BSDF for the corneas' film), under the materials' own names, and writes the textures they
read into ``textures/`` beside the file (its ``NEW`` mode); the UV reader asks for the UV
map the mesh is written with (``st``, the exporter's name for the render-active UV map).

The file keeps Blender's axes and units (Z up, 1 metre per unit: the stage's ``upAxis``
and ``metersPerUnit`` say so); the points are the face's own (object space), under an
Xform prim that holds its transform.  A Catmull-Clark Subdivision Surface that is the last
modifier is written as the mesh's subdivision scheme rather than applied (the exporter's
``BEST_MATCH``), as the Alembic bake does.

The exporter reports nothing and writes an empty Xform for a selected face that its
RENDER depsgraph leaves out (disabled in renders, itself or through its collections), and
a face hidden in the viewport cannot be selected: :func:`problem` refuses both.
"""

import contextlib
import os
import time

import bpy

from .. import faces, pipeline, stage, status
from ..errors import WrinkleError
from ..progress import Progress
from . import materials, sample

EXTENSIONS = (".usd", ".usda", ".usdc", ".usdz")
_NEEDED = ("filepath", "selected_objects_only", "export_animation", "evaluation_mode")
INTERNAL_PREFIXES = ("wrinkle_", "ewrinkles_")  # the add-on's attributes (module doc)
STRIP_NAME = "Export: Leave Out Wrinkle Attributes"  # the temporary modifier and its group


class USDExportError(WrinkleError):
    """A problem the user must fix before (or while) exporting USD; shown as is."""


def options(filepath):
    """The keyword arguments for ``bpy.ops.wm.usd_export``, only those that this Blender's
    exporter has (their names differ between versions: ``visible_objects_only`` and
    ``export_textures`` are gone in 5.x, ``incremental_frames`` is new)."""
    wanted = {
        "filepath": filepath,
        "check_existing": False,
        "selected_objects_only": True,
        "visible_objects_only": False,  # 4.x: the face is selected, which is what counts
        "export_animation": True,
        "evaluation_mode": "RENDER",
        "export_shapekeys": False,  # blend shapes would drop the modifiers (module doc)
        "export_armatures": False,
        "export_uvmaps": True,
        "export_normals": True,
        "export_materials": True,  # plain copies of the face's materials (module doc)
        "generate_preview_surface": True,
        "export_textures_mode": "NEW",  # the textures the materials read, into textures/ beside the file
        "export_textures": True,  # 4.x's older name for writing them
        "overwrite_textures": True,
        "relative_paths": True,
        "rename_uvmaps": True,  # the render-active UV map as "st", USD's convention
        "export_subdivision": "BEST_MATCH",
        "export_hair": False,
        "export_custom_properties": False,  # our property groups are no use outside Blender
        "use_instancing": False,
        "triangulate_meshes": False,
        "convert_orientation": False,  # Blender's Z up, recorded as the stage's upAxis
        "convert_scene_units": "METERS",
        "meters_per_unit": 1.0,
    }
    have = set(bpy.ops.wm.usd_export.get_rna_type().properties.keys())
    missing = [name for name in _NEEDED if name not in have]
    if missing:
        raise USDExportError("This Blender's USD exporter has no " + ", ".join(missing)
                             + " option: the wrinkled face cannot be exported to USD with it")
    return {k: v for k, v in wanted.items() if k in have}


def _path_problem(filepath):
    if not filepath:
        return "No file to export to: choose a .usd, .usda, .usdc or .usdz file"
    if filepath.startswith("//") and not bpy.data.filepath:
        return "Save the .blend file first, or choose an absolute path: the path is relative to it"
    path = bpy.path.abspath(filepath)
    if not path.lower().endswith(EXTENSIONS):
        return f'"{path}" is not a USD file name: end it in .usd, .usda, .usdc or .usdz'
    if os.path.isdir(path):
        return f'"{path}" is a folder: choose a file name inside it'
    folder = os.path.dirname(os.path.abspath(path))
    existing = folder
    while existing and not os.path.isdir(existing):  # the folders made on export
        parent = os.path.dirname(existing)
        if parent == existing or os.path.exists(existing):
            return f'"{path}" cannot be written: "{existing}" is a file, not a folder'
        existing = parent
    if not os.access(existing, os.W_OK | os.X_OK):
        return f'"{path}" cannot be written: the folder "{existing}" is not writable'
    if os.path.exists(path) and not os.access(path, os.W_OK):
        return f'"{path}" cannot be written: the file exists and is read-only'
    return None


def problem(context, face, filepath, frame_start, frame_end):
    """Why ``face`` cannot be exported to ``filepath`` over the frame range, or None.
    Checked before anything changes."""
    why = faces.problem(face, object_mode=True)
    if why:
        return why
    mod = stage.find_modifier(face)
    if mod is None:
        return f'"{face.name}" has no Wrinkles modifier: enable wrinkles first'
    if not mod.show_render:
        return (f'The Wrinkles modifier of "{face.name}" is disabled in renders, which the export '
                "evaluates: enable it for renders (the camera icon in the modifier's header)")
    layer = context.view_layer
    if layer.objects.get(face.name) != face:
        return (f'"{face.name}" is not in the view layer "{layer.name}" (its collection is excluded, '
                "or it is in another scene): the exporter cannot see it")
    if not face.visible_get(view_layer=layer):
        return (f'"{face.name}" is hidden in the viewport, and the exporter writes selected objects '
                "only, which a hidden one cannot be: unhide it (or its collection)")
    hidden = _hidden_in_renders(face, layer)
    if hidden:
        return hidden
    if frame_end < frame_start:
        return f"The frame range {frame_start}-{frame_end} is empty: set End at or after Start"
    return _path_problem(filepath)


def _hidden_in_renders(face, view_layer):
    """Why the exporter's RENDER depsgraph leaves ``face`` out, or None: the object, or every
    collection that holds it in the view layer, is disabled in renders.  The exporter then
    writes an empty Xform and no mesh, and reports nothing (measured on bpy 4.5 and 5.2)."""
    if face.hide_render:
        return (f'"{face.name}" is disabled in renders, and the export evaluates the scene as a render '
                "does: enable it (Object Properties > Visibility > Renders), or Free Bake if Bake for "
                "Farm hid it behind its stand-in")
    holders = set(face.users_collection)
    hidden_in = []

    def walk(layer, hidden):
        hidden = hidden or layer.exclude or layer.collection.hide_render
        if layer.collection in holders:
            if not hidden:
                return True
            hidden_in.append(layer.collection.name)
        return any(walk(child, hidden) for child in layer.children)

    if walk(view_layer.layer_collection, False):
        return None
    names = ", ".join(f'"{n}"' for n in dict.fromkeys(hidden_in)) or "its collections"
    return (f'"{face.name}" is only in {names}, disabled in renders (or inside a collection that is), '
            "and the export evaluates the scene as a render does: enable it in renders (the camera "
            "icon in the Outliner)")


class _Watch:
    """A temporary ``frame_change_post`` handler, after ours: counts the exported frames (for
    the progress), and on each whether the frame stage ran without a problem and stamped the
    face's offsets with it, that is, whether this frame's wrinkles went into the mesh the
    exporter reads."""

    def __init__(self, face, frames, progress):
        self.uid = face.session_uid
        self.frames = frames
        self.progress = progress
        self.seen = {}  # frame -> whether the stage stamped the offsets with it
        self.why = ""  # the frame stage's message on a frame it did not stamp
        self.points = None  # the exported mesh's point count, once the exporter evaluated the face

    def __call__(self, scene, depsgraph=None):
        if depsgraph is None or depsgraph.mode != "RENDER":
            return  # our own handler's frame sync, or another depsgraph
        try:
            current = scene.frame_current
            face = next((ob for ob in scene.objects if ob.session_uid == self.uid), None)
            if face is None or current not in self.frames:
                return
            new = current not in self.seen
            # the stage's status is set on every run: a message means it wrote nothing this
            # frame, even where the mesh holds offsets stamped with it from an earlier run
            why = status.get(face, pipeline.CHANNEL)
            self.seen[current] = not why and stage.holds_frame(face.data, depsgraph)
            self.why = self.why or why
            ev = face.evaluated_get(depsgraph)
            if self.points is None and ev.is_evaluated:  # else not in the exporter's depsgraph
                self.points = len(ev.data.vertices)
            if new:
                self.progress(len(self.seen), current)
        except Exception as exc:  # a handler must never raise into Blender
            print(f"Expression Wrinkles: USD export: {exc!r}")


def export(context, face, filepath, frame_start, frame_end, progress=None, keep_attributes=False):
    """Export ``face`` alone, animated over ``frame_start``..``frame_end``, to the USD file
    ``filepath`` (a ``//`` path is relative to the .blend), without the add-on's own
    attributes unless ``keep_attributes`` (module doc).  ``progress(fraction, message)``
    is called once per exported frame, as a ``glue.progress.Progress`` is (default: one of
    those, with a console line every 25 frames in background mode).

    Returns ``{"file", "frames", "points", "wrinkled_frames", "seconds"}``: the absolute
    path, the number of frames, the number of points of the exported mesh, the number of
    frames on which the frame stage wrote that frame's wrinkles before the exporter read
    the mesh (all of them, else this raises), and the time the export took.  The scene's
    frame range, its current frame, the selection and the active object are as before, even
    when the export fails.  Raises ``USDExportError`` (a ``WrinkleError``)."""
    why = problem(context, face, filepath, frame_start, frame_end)
    if why:
        raise USDExportError(why)
    path = os.path.abspath(bpy.path.abspath(filepath))
    kwargs = options(path)
    n = frame_end - frame_start + 1
    if progress is None:
        with Progress(context, f"Export USD {face.name}", total=n, every=25) as bar:
            return _export(context, face, path, kwargs, frame_start, frame_end,
                           lambda done, current: bar(done, f"frame {current}"), keep_attributes)
    return _export(context, face, path, kwargs, frame_start, frame_end,
                   lambda done, current: progress(done / n, f"frame {current}"), keep_attributes)


def _internal_names(context, face):
    """The add-on's attributes on the face as the exporter will read it (evaluated)."""
    ev = face.evaluated_get(context.evaluated_depsgraph_get())
    return sorted(a.name for a in ev.data.attributes if a.name.startswith(INTERNAL_PREFIXES))


@contextlib.contextmanager
def _without_attributes(context, face):
    """A temporary modifier that removes the add-on's attributes (module doc), above a
    final Subdivision Surface; removed on exit with its group."""
    names = _internal_names(context, face)
    if not names:
        yield
        return
    ng = bpy.data.node_groups.new(STRIP_NAME, "GeometryNodeTree")
    mod = None
    try:
        ng.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
        ng.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
        prev = ng.nodes.new("NodeGroupInput").outputs[0]
        for name in names:
            node = ng.nodes.new("GeometryNodeRemoveAttribute")
            node.inputs["Name"].default_value = name
            ng.links.new(prev, node.inputs["Geometry"])
            prev = node.outputs["Geometry"]
        ng.links.new(prev, ng.nodes.new("NodeGroupOutput").inputs[0])
        mod = face.modifiers.new(STRIP_NAME, "NODES")
        mod.node_group = ng
        mod.show_viewport = False  # only the exporter's RENDER evaluation reads it
        last = len(face.modifiers) - 1
        if last >= 1 and face.modifiers[last - 1].type == "SUBSURF":
            face.modifiers.move(last, last - 1)
        yield
    finally:
        if mod is not None:
            face.modifiers.remove(mod)
        bpy.data.node_groups.remove(ng)


@contextlib.contextmanager
def _plain_materials(face):
    """The face's material slots read plain copies of its materials (``materials``) under
    their names while the exporter runs; the originals are back on exit."""
    swapped, copies = [], {}
    try:
        for slot in face.material_slots:
            mat = slot.material
            if mat is None or not materials.needs_copy(mat):
                continue
            if mat not in copies:
                copies[mat] = materials.plain_copy(mat, face)
                name = mat.name
                mat.name = name + ".source"
                copies[mat].name = name
            swapped.append((slot, mat))
            slot.material = copies[mat]
        yield
    finally:
        for slot, mat in swapped:
            slot.material = mat
        for mat, copy in copies.items():
            name = copy.name
            bpy.data.materials.remove(copy)
            mat.name = name


def _export(context, face, path, kwargs, frame_start, frame_end, progress, keep_attributes=False):
    watch = _Watch(face, range(frame_start, frame_end + 1), progress)
    start = time.perf_counter()
    try:
        os.makedirs(os.path.dirname(path), exist_ok=True)
    except OSError as exc:
        raise USDExportError(f'"{path}" cannot be written: {exc.strerror}') from exc
    bpy.app.handlers.frame_change_post.append(watch)
    try:
        with sample.exporting(context, face, frame_start, frame_end), _plain_materials(face), \
                (contextlib.nullcontext() if keep_attributes else _without_attributes(context, face)):
            try:
                result = bpy.ops.wm.usd_export(**kwargs)
            except RuntimeError as exc:
                raise USDExportError(f"Blender's USD exporter failed: {exc}") from exc
        if "FINISHED" not in result or not os.path.isfile(path):
            raise USDExportError(f"Blender's USD exporter did not write {path}")
    finally:
        if watch in bpy.app.handlers.frame_change_post:
            bpy.app.handlers.frame_change_post.remove(watch)
    missing = [f for f in watch.frames if not watch.seen.get(f)]
    if missing:
        # the file is written, but some frame's points lack its wrinkles: never a silent loss
        listed = ", ".join(map(str, missing[:8])) + (", ..." if len(missing) > 8 else "")
        reason = watch.why or "the add-on's frame handler did not run on them"
        raise USDExportError(f"{path} was written without the wrinkles of frame(s) {listed}: {reason}")
    return {
        "file": path,
        "frames": len(watch.frames),
        "points": watch.points if watch.points is not None else len(face.data.vertices),
        "wrinkled_frames": sum(watch.seen.values()),
        "seconds": time.perf_counter() - start,
    }
