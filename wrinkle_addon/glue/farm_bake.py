# SPDX-License-Identifier: GPL-3.0-or-later
"""Farm-safe bake: the animated, wrinkled face as an Alembic cache that renders anywhere.

Blender's Alembic exporter steps through the frames and calls the frame-change
handlers, so every exported frame holds that frame's wrinkles (checked against
the live evaluation in the tests).  The bake then adds a stand-in object,
"<face> Baked": a copy of the face's mesh without shape keys, parented to the
face, whose Mesh Sequence Cache modifier reads the positions back.  The face
itself is hidden from renders, and what follows the face's skin through its evaluated
mesh (a shedding tear: each source's ``skin_handed_over``) follows the stand-in's instead,
which holds the wrinkles.
Nothing of this needs the add-on or Python, so ``blender -b file.blend -a`` on a farm
renders it identically.  The cache also holds the face's UV maps, frame by frame: a
Geometry Nodes tree above the stage leaves its shading values there (the fine wrinkles'
shrinkage, ``glue.bando.fine_tree``), and the stand-in reads them back with the positions.
A bake that fails leaves nothing behind: no cache, no folder it made, the scene as it was
(:class:`Bake`).

The exporter applies the face's whole modifier stack, deformers after the Wrinkles
modifier included, except a Catmull-Clark Subdivision Surface that is the last modifier
enabled for renders: that one is written as a subdivision surface instead (measured on
bpy 4.5 and 5.2).  So the stand-in gets a copy of that modifier only; a copy of a Displace
or an Armature after the stage would apply it a second time.
"""

import contextlib
import os
import zlib

import bpy

from . import registry, stage
from .errors import WrinkleError

BAKE_SUFFIX = " Baked"
MARKER = "ewrinkles_stand_in_of"  # on the stand-in: the face whose bake made it
CACHE_MODIFIER = "Wrinkle Bake"  # the stand-in's Mesh Sequence Cache modifier


# How Bake for Farm ends its message when the bake began and failed (a refusal changes
# nothing and says nothing of undo): what tells the batch command's failure from its refusal
FAILED_ENDING = "Undo brings the file back as it was"


class BakeError(WrinkleError):
    """A problem the user must fix; the message is shown as is."""


def _abc_name(name):
    # Blender's Alembic exporter replaces these characters in object and mesh names; only a
    # hint: the stand-in reads the real paths from the written cache (see _object_path)
    return "".join("_" if c in " .:/" else c for c in name)


def has_stage(face):
    """Whether ``face`` has geometric wrinkles to bake (the Wrinkles modifier)."""
    return stage.find_modifier(face) is not None


def stand_in(face):
    """The baked stand-in of ``face``, or None.  Only an object that this face's bake made
    counts: it carries the marker naming the face and is parented to it.  A pointer copied
    with the face (Shift+D) or set by hand to another object is not a stand-in."""
    ob = face.ewrinkles_face.bake_object
    if ob is None or ob.parent != face:
        return None
    if MARKER not in ob:  # a stand-in baked before the marker: its cache modifier tells it
        ours = any(m.type == "MESH_SEQUENCE_CACHE" and m.name == CACHE_MODIFIER for m in ob.modifiers)
        return ob if ours else None
    return ob if ob[MARKER] == face else None


def has_any_bake(face):
    """Whether ``face`` has a geometry bake (or a pointer to free) or a bake of any wrinkle
    source."""
    return (face.ewrinkles_face.bake_object is not None
            or any(s.has_bake(face) for s in registry.sources()))


def file_stem(face):
    """The stem of the names of ``face``'s bake files (the Alembic cache, the fine wrinkles'
    image sequence): its name made safe for a file name, unique among the objects of the file.
    ``bpy.path.clean_name`` turns "Face.L" and "Face L" both into "Face_L", and a
    case-insensitive file system holds one "face" and "Face": when another object's name
    cleans to the same stem, a short checksum of the exact name keeps the files apart."""
    stem = bpy.path.clean_name(face.name)
    if any(ob != face and bpy.path.clean_name(ob.name).lower() == stem.lower() for ob in bpy.data.objects):
        stem += f"_{zlib.crc32(face.name.encode()):08x}"
    return stem


def default_path(face):
    return f"//wrinkle_bake/{file_stem(face)}.abc"


def _left_to_stand_in(face):
    """The modifier the Alembic exporter does not apply, for the stand-in to apply: a
    Catmull-Clark Subdivision Surface that is the last modifier enabled for renders (the
    exporter's own rule, which skips particle systems), or None."""
    for mod in reversed(face.modifiers):
        if not mod.show_render or mod.type == "PARTICLE_SYSTEM":
            continue
        if mod.type == "SUBSURF" and mod.subdivision_type == "CATMULL_CLARK":
            return mod
        return None
    return None


def _problem(face):
    """Why ``face`` cannot be baked now, or None.  Checked before anything is changed."""
    # Blender's Alembic exporter stores the .blend's path in the archive's metadata, whose
    # format reserves ";" and "=": with either anywhere in that path (folder or file name)
    # it throws and Blender aborts (measured on bpy 4.5 and 5.2; the .abc path is not
    # concerned).  The user must save elsewhere: nothing here can change that path.
    reserved = sorted({c for c in bpy.data.filepath if c in ";="})
    if reserved:
        chars = " and ".join(f'"{c}"' for c in reserved)
        return (f"The path of this .blend file contains {chars}, which Blender's Alembic exporter "
                f"cannot handle (it would crash Blender): save the file in a folder and under a name "
                f"without {chars}, then bake again")
    mod = stage.find_modifier(face)
    if mod is None:
        return f'"{face.name}" has no Wrinkles modifier: enable wrinkles first'
    kept = _left_to_stand_in(face)
    after = list(face.modifiers)[list(face.modifiers).index(mod) + 1:]
    for other in after:
        if other.show_render and other.type == "SUBSURF" and other != kept:
            return (f'The modifier "{other.name}" subdivides the face before other modifiers: '
                    "to bake, move it to the bottom of the modifier stack")
    return None


def problem(face, filepath, frame_start, frame_end):
    """Why the geometry of ``face`` cannot be baked to ``filepath`` over the frame range, or
    None.  Bake for Farm checks it, and every source's own ``check``, before changing
    anything."""
    if not bpy.data.filepath and filepath.startswith("//"):
        return "Save the .blend file first: the bake is written next to it"
    if frame_end < frame_start:
        return "The frame range is empty"
    return _problem(face)


def bake(context, face, filepath, frame_start, frame_end):
    """Export ``face`` over the frame range and switch its renders to the cache: a
    :class:`Bake` run and kept.  When it fails it leaves nothing (:meth:`Bake.run`)."""
    job = Bake(context, face, filepath, frame_start, frame_end)
    baked = job.run()
    job.keep()
    return baked


class Bake:
    """One geometry bake of ``face``, whole or not at all.

    :meth:`run` writes the cache under a temporary name beside ``filepath``, gives it its
    name only once it is written (a file already there is set aside) and makes the stand-in.
    When anything in it fails (the export, the stand-in), it :meth:`undo`-es itself and
    raises.  Until :meth:`keep`, a caller whose own later step fails (a wrinkle source's
    bake after the geometry's) can :meth:`undo` it too."""

    def __init__(self, context, face, filepath, frame_start, frame_end):
        why = problem(face, filepath, frame_start, frame_end)
        if why:
            raise BakeError(why)
        self.context, self.face, self.filepath = context, face, filepath
        self.frames = frame_start, frame_end
        self.path = bpy.path.abspath(filepath)
        folder = os.path.dirname(self.path) or "."
        name = os.path.basename(self.path)
        self.partial = os.path.join(folder, f".{name}.partial.abc")
        self.aside = os.path.join(folder, f".{name}.previous.abc")
        self.folder, self.made = folder, _missing_folders(folder)
        self.previous = _cache_path(stand_in(face))  # the stand-in to make again on undo
        self.hidden = face.hide_render
        self.set_aside = self.replaced = False

    def run(self):
        """Bake; returns the stand-in."""
        try:
            os.makedirs(self.folder, exist_ok=True)
            free(self.face)  # the face itself renders while it is exported
            with contextlib.ExitStack() as stack:  # what each active source needs the cache to carry
                for source in registry.sources():
                    if source.active(self.face):
                        stack.enter_context(source.exporting(self.face))
                _export(self.context, self.face, self.partial, *self.frames)
            if not os.path.exists(self.partial):
                raise BakeError(f"The Alembic export did not write {self.path}")
            if os.path.lexists(self.path):
                os.replace(self.path, self.aside)
                self.set_aside = True
            os.replace(self.partial, self.path)
            self.replaced = True
            return _stand_in(self.face, self.filepath)
        except BaseException:
            self.undo()
            raise

    def undo(self):
        """Remove every file and folder the bake made, put back a file it set aside, and the
        scene as it was: the face's previous stand-in made again from its cache (left
        untouched), or the face rendered live with its render visibility as it was.  The
        export itself puts the frame and the selection back."""
        _remove_file(self.partial)
        if self.replaced:
            _remove_file(self.path)
        if self.set_aside:
            os.replace(self.aside, self.path)
        self.set_aside = self.replaced = False
        for folder in self.made:  # innermost first; only if the bake left them empty
            try:
                os.rmdir(folder)
            except OSError:
                pass
        _restore(self.face, self.previous, self.hidden)

    def keep(self):
        """The bake stays: the file it set aside is removed."""
        if self.set_aside:
            _remove_file(self.aside)
        self.set_aside = False


def _export(context, face, path, frame_start, frame_end):
    """Blender's Alembic exporter on ``face`` alone; the selection and the frame are put back
    whatever happens."""
    view_layer = context.view_layer
    selected = [ob for ob in context.selected_objects]
    active = view_layer.objects.active
    frame = context.scene.frame_current
    try:
        for ob in selected:
            ob.select_set(False)
        face.select_set(True)
        view_layer.objects.active = face
        bpy.ops.wm.alembic_export(
            filepath=path, start=frame_start, end=frame_end, selected=True, flatten=True,
            uvs=True, normals=False, vcolors=False, orcos=False, face_sets=False,
            apply_subdiv=False, export_hair=False, export_particles=False,
            export_custom_properties=False, evaluation_mode="RENDER", as_background_job=False,
        )
    finally:
        context.scene.frame_set(frame)
        face.select_set(False)
        for ob in selected:
            if ob.name in view_layer.objects:
                ob.select_set(True)
        view_layer.objects.active = active


def _cache_path(baked):
    """The cache file (as Blender stores its path) that the stand-in ``baked`` reads, or None."""
    for mod in baked.modifiers if baked is not None else ():
        if mod.type == "MESH_SEQUENCE_CACHE" and mod.cache_file is not None:
            return mod.cache_file.filepath
    return None


def _missing_folders(folder):
    """The folders that making ``folder`` creates, innermost first."""
    out = []
    folder = os.path.abspath(folder)
    while not os.path.isdir(folder):
        out.append(folder)
        parent = os.path.dirname(folder)
        if parent == folder:
            break
        folder = parent
    return out


def _remove_file(path):
    try:
        os.remove(path)
    except FileNotFoundError:
        pass


def _restore(face, previous, hidden):
    """After a failed or undone bake: the face's previous stand-in made again from its cache
    ``previous``, or (None) the face rendered live, hidden from renders as it was.  A
    previous stand-in that cannot be made again (its cache is gone) leaves the face live
    and rendered."""
    free(face)
    if previous is None:
        face.hide_render = hidden
        return
    try:
        _stand_in(face, previous)
    except Exception:  # the face renders live; the bake's own error says what went wrong
        free(face)


def _stand_in(face, filepath):
    """Add the stand-in reading the cache at ``filepath``; on any failure remove all of it
    again, so the face is hidden from renders only when the stand-in works."""
    # a copy of the original mesh with every layer (UVs, materials) and no shape keys:
    # Mesh.copy() copies the shape keys too, and on bpy 4.5 shape_key_clear() then leaves
    # that Key in the file with a dangling owner once the stand-in is freed, which saving
    # reports as an error (measured)
    me = bpy.data.meshes.new_from_object(face, preserve_all_data_layers=True)
    me.name = face.data.name + BAKE_SUFFIX
    baked = bpy.data.objects.new(face.name + BAKE_SUFFIX, me)
    cache = None
    try:
        ours = (stage.OFFSET_ATTR, stage.SKIN_ATTR, stage.PULL_ATTR)
        for name in [a.name for a in me.attributes]:  # the stage's, and what trees of ours read
            if name in ours or name.startswith(".ewrinkles_"):
                me.attributes.remove(me.attributes[name])
        for coll in face.users_collection:
            coll.objects.link(baked)
        baked.parent = face
        baked.matrix_parent_inverse.identity()
        for slot, src in zip(baked.material_slots, face.material_slots):
            slot.link = src.link
            slot.material = src.material
        cache = _open_cache(bpy.path.abspath(filepath))
        mod = baked.modifiers.new(CACHE_MODIFIER, "MESH_SEQUENCE_CACHE")
        mod.cache_file = cache
        mod.read_data = {"VERT", "UV"}  # the UV maps carry the trees' per-frame shading values
        mod.object_path = _object_path(face, cache)
        # the one modifier the exporter left unapplied (a final Subdivision Surface)
        src = _left_to_stand_in(face)
        if src is not None:
            dst = baked.modifiers.new(src.name, src.type)
            for prop in src.bl_rna.properties:
                if not prop.is_readonly and prop.identifier not in {"name", "type"}:
                    setattr(dst, prop.identifier, getattr(src, prop.identifier))
    except Exception:
        bpy.data.objects.remove(baked)
        if me.users == 0:
            bpy.data.meshes.remove(me)
        if cache is not None and cache.users == 0:
            bpy.data.batch_remove([cache])  # cache_files has no remove()
        raise
    baked[MARKER] = face
    face.hide_render = True
    face.ewrinkles_face.bake_object = baked
    _hand_over(face, baked)
    return baked


def _hand_over(old, new):
    """What follows ``old``'s evaluated skin follows ``new``'s (every source's
    ``skin_handed_over``)."""
    for source in registry.sources():
        source.skin_handed_over(old, new)


def _object_path(face, cache):
    """The path of the face's mesh inside the cache, read from the cache itself.

    The exporter rewrites names (" ", ".", ":" and "/" become "_", and that list is not
    documented), so the path is not guessed.  ``cache.object_paths`` is filled only once a
    depsgraph has evaluated a user of the cache (measured on bpy 4.5 and 5.2): the caller
    has assigned it to the stand-in's modifier, and the depsgraph is evaluated here.  The
    bake exports the face alone, flattened, so there is one mesh path.
    """
    bpy.context.view_layer.update()
    paths = [p.path for p in cache.object_paths]
    if len(paths) == 1:
        return paths[0]
    guess = f"/{_abc_name(face.name)}/{_abc_name(face.data.name)}"
    if guess in paths:
        return guess
    found = ", ".join(paths[:5]) or "none"
    raise BakeError(f'The baked cache {cache.filepath} holds no single mesh for "{face.name}" '
                    f"(paths found: {found}); no stand-in was made, the face renders live")


def _open_cache(path):
    """A CacheFile for ``path``, stored relative to the .blend so a farm finds it."""
    before = set(bpy.data.cache_files)
    bpy.ops.cachefile.open(filepath=path, relative_path=bool(bpy.data.filepath))
    new = [c for c in bpy.data.cache_files if c not in before]
    if not new:
        raise BakeError(f"Blender could not open the cache {path}")
    # run without its file browser, the operator leaves the new CacheFile one user that no
    # data-block holds (measured on bpy 4.5 and 5.2): drop it, so that the modifier holds the
    # only one and freeing the stand-in frees the CacheFile too
    new[0].user_clear()
    return new[0]


def free(face):
    """Remove the stand-in and render the live face again.  Only a stand-in that this face's
    bake made is removed (:func:`stand_in`); any other object the pointer names (copied
    with the face, or set by hand) is left as it is and the pointer cleared."""
    baked = stand_in(face)
    if baked is not None:
        _hand_over(baked, face)
        me = baked.data
        cache = next((m.cache_file for m in baked.modifiers if m.type == "MESH_SEQUENCE_CACHE"), None)
        bpy.data.objects.remove(baked)
        if me.users == 0:
            bpy.data.meshes.remove(me)
        if cache is not None and cache.users == 0:
            bpy.data.batch_remove([cache])  # cache_files has no remove()
    face.ewrinkles_face.bake_object = None
    face.hide_render = False
