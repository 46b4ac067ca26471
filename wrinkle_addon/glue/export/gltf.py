# SPDX-License-Identifier: GPL-3.0-or-later
"""The wrinkled face to glTF for game engines, with Blender's own glTF exporter.

An engine plays morph targets with animated weights.  The range's wrinkle offsets (every
source summed, as renders show them: ``sample.read``) become K **wrinkle morph targets**
and their weights per frame (``core.morphs.fit``: a truncated SVD, K the smallest within
the tolerance, capped; every weight in [0, 1], which engines and Blender's importer clamp
to, with one constant target "Wrinkle Base" at weight 1 when a signed weight needs it).
A temporary copy of the face carries them: the face's mesh and its own shape keys, plus
one shape key per wrinkle target, "Wrinkle 01" ..., and every shape key's value keyed on
every frame (drivers, muscles and the wrinkles all become plain weight curves).
Blender's glTF exporter writes that copy: the mesh, its morph targets (with their
normals, so the wrinkles shade in the engine), the animation of all the weights (from
time 0 on the first frame), and its materials.  The copy's faces of more than four corners
(a refinement leaves some) are split into triangles, without which the exporter computes
no tangents for the mesh.  The face's **parts** (``sample.parts``: the eyes, lashes and
teeth parented to it) go along as copies parented to it, their shape keys keyed on every
frame to the values their drivers give.

The copy's materials are copies of the face's made plain for engines (``materials``: the
base normal map or none as the normal, never a wrinkle map) that carry the wrinkle-map
table as a custom property, which the exporter writes as the material's
``extras.ewrinkles``: a JSON text with the layout of ``wrinkles.json``
(docs/wrinkle_package.md), with glTF image names.  The wrinkle maps, masks and base map
are image nodes of the material; the exporter's "unused textures" option writes those that
no BSDF input reads as textures all the same (from 16-bit PNG copies, the package's depth:
``_png_copies``).  Blender's importer reads them back with its "unused materials" option
(the round-trip test does).

The face's armature and other modifiers are not exported: the targets reproduce the
wrinkles on the skin of the face's shape keys.
"""

import contextlib
import json
import os
import tempfile

import bmesh
import bpy
import numpy as np

from ...core import morphs
from .. import drivers, images, pipeline
from . import glb, materials, package, sample

TARGET_PREFIX = "Wrinkle"
EXTRAS = "ewrinkles"  # the material's extras key
PNG_DEPTH = package.IMAGE_FORMATS["PNG"][1]  # the maps at the package's depth: 16 bits


def _exporter_options(filepath, frame_start, frame_end):
    """The glTF exporter's options that exist in this Blender (4.2 to 5.x)."""
    wanted = {
        "filepath": filepath,
        "export_format": "GLTF_SEPARATE" if filepath.lower().endswith(".gltf") else "GLB",
        "use_selection": True,
        "export_apply": False,  # with modifiers applied the exporter drops shape keys
        "export_yup": True,
        "export_texcoords": True,
        "export_normals": True,
        "export_tangents": True,  # the wrinkle maps are tangent-space: Blender's tangents, not the engine's
        "export_materials": "EXPORT",
        "export_unused_textures": True,  # the wrinkle maps and masks: no BSDF input reads them
        "export_extras": True,  # the materials' wrinkle-map table
        "export_morph": True,
        "export_morph_normal": True,
        "export_morph_animation": True,
        "export_animations": True,
        "export_animation_mode": "ACTIONS",
        "export_frame_range": True,
        "export_force_sampling": True,
        "export_anim_slide_to_zero": True,  # the first frame at time 0
        "export_optimize_animation_size": False,
        "export_try_sparse_sk": False,  # dense targets: their normals are refit in place (glb.py)
        "export_try_omit_sparse_sk": False,
        "export_current_frame": False,
        "export_skins": False,
        "export_cameras": False,
        "export_lights": False,
        "will_save_settings": False,
    }
    known = {p.identifier for p in bpy.ops.export_scene.gltf.get_rna_type().properties}
    return {k: v for k, v in wanted.items() if k in known}


def _key_all(key, names, values, frames):
    """Key every shape key of ``names`` on every frame to ``values`` (F, S), linearly."""
    if not names:
        return
    blocks = key.key_blocks
    for name, column in zip(names, values.T):
        kb = blocks[name]
        kb.value = float(column[0])
        kb.keyframe_insert("value", frame=frames[0])
    curves = {fc.data_path: fc for fc in drivers.action_fcurves(key)}
    co = np.empty((len(frames), 2), np.float32)
    co[:, 0] = frames
    for name, column in zip(names, values.T):
        fc = curves[drivers.shape_key_path(name)]
        points = fc.keyframe_points
        points.add(len(frames) - len(points))
        co[:, 1] = column
        points.foreach_set("co", co.ravel())
        points.foreach_set("interpolation", np.full(len(frames), 1, np.int32))  # LINEAR
        fc.update()


def _take_name(original, copy, renamed):
    """``copy`` takes ``original``'s name for the file; ``renamed`` collects it to name back."""
    name = original.name
    renamed.append((original, name))
    original.name = name + ".source"
    copy.name = name


def _png_copies(face, folder, renamed, made):
    """16-bit PNG copies of the face's maps, masks and base map, as the package writes them
    (``package.IMAGE_FORMATS``), written by ``images.write`` (straight alpha: the fourth
    zone of a mask survives) and packed; the exporter embeds a packed PNG's bytes as they
    are (Blender's own PNG writer would divide a mask's colour by its alpha).  Returns
    {original: copy}."""
    maps = face.ewrinkles_face.maps
    out = {}
    for prop, stem in package.SLOTS:
        img = getattr(maps, prop)
        if img is None or img in out:
            continue
        # the exporter names a packed image after its file: the image's own name, in a folder of its own
        file_name = img.name.replace("/", "_").replace("\\", "_") + ".png"
        path = images.write(images.read(img), os.path.join(folder, stem, file_name), "PNG", PNG_DEPTH,
                            name=img.name)
        copy = bpy.data.images.load(path, check_existing=False)
        made.append(copy)
        copy.colorspace_settings.name = images.NON_COLOR
        copy.pack()
        _take_name(img, copy, renamed)
        out[img] = copy
    return out


def _dress(source, copy, extras, renamed, replace, made):
    """Give each material slot of ``copy`` (a copy of ``source``) the material it exports
    with: a copy of ``source``'s (under its name, the original renamed meanwhile) made plain
    for engines (``materials``: the base normal map or none as the normal, no procedural
    chains), carrying ``extras``, its image nodes reading the images of ``replace``; or, for
    a material that needs none of this, the material itself.  Slot by slot, so every face
    keeps its material index (``Mesh.materials.clear`` would reset them all to 0)."""
    for slot, target in zip(source.material_slots, copy.material_slots):
        target.link = slot.link
        mat = slot.material
        if mat is None or mat in replace:  # a material the face and a part share: copied once
            target.material = replace.get(mat) if mat is not None else None
            continue
        if extras is None and not materials.needs_copy(mat):
            target.material = mat
            continue
        new = materials.plain_copy(mat, source)
        made.append(new)
        if extras is not None:
            new[EXTRAS] = json.dumps(extras, separators=(",", ":"))  # an ID property holds no list of str
        for node in new.node_tree.nodes if new.node_tree is not None else ():
            if node.type == "TEX_IMAGE" and node.image in replace:
                node.image = replace[node.image]
        _take_name(mat, new, renamed)
        replace[mat] = new
        target.material = new


def _image_names(face):
    maps = face.ewrinkles_face.maps
    if maps.weights_group is None or maps.material is None:
        return None
    slots = [getattr(maps, prop) for prop, _stem in package.SLOTS]
    return {prop: img.name for (prop, _stem), img in zip(package.SLOTS, slots) if img is not None}


def _triangulate_ngons(me):
    """Split the faces of more than four corners (a refinement leaves some) into triangles,
    shape keys and all: the exporter computes tangents only on triangles and quads, and
    drops them for the whole mesh otherwise.  No vertex is added, moved or renumbered."""
    sizes = np.empty(len(me.polygons), np.int32)
    me.polygons.foreach_get("loop_total", sizes)
    if not np.any(sizes > 4):
        return
    bm = bmesh.new()
    try:
        bm.from_mesh(me)
        bmesh.ops.triangulate(bm, faces=[f for f in bm.faces if len(f.verts) > 4])
        bm.to_mesh(me)
    finally:
        bm.free()


def _copy_object(source, name, scene, strip_attributes=False):
    """A linked copy of ``source``'s object and mesh (its own shape keys, their animation
    cleared: keyed anew), at its place."""
    me = source.data.copy()
    if me.shape_keys is not None:
        me.shape_keys.animation_data_clear()  # drivers and keys: keyed anew
    if strip_attributes:
        for attr in [a.name for a in me.attributes if a.name.startswith("wrinkle_")]:
            me.attributes.remove(me.attributes[attr])
    ob = bpy.data.objects.new(name, me)
    scene.collection.objects.link(ob)
    ob.matrix_world = source.matrix_world
    return ob


@contextlib.contextmanager
def _export_copy(context, face, fit, frames, folder):
    """A temporary copy of ``face`` with its wrinkle targets and every weight keyed, and of
    each of its parts (``frames.parts``) parented to it with their keys keyed, under their
    own names; everything is removed and renamed back on exit.  Yields (face copy, parts'
    copies)."""
    scene = context.scene
    made_objects, made_materials, made_images, renamed = [], [], [], []
    try:
        ob = _copy_object(face, face.name + ".export", scene, strip_attributes=True)
        made_objects.append(ob)
        me = ob.data
        _triangulate_ngons(me)
        if me.shape_keys is None:
            ob.shape_key_add(name="Basis", from_mix=False)
        key = me.shape_keys
        rest = np.empty(len(me.vertices) * 3, np.float32)
        key.reference_key.points.foreach_get("co", rest)
        names = list(frames.key_names)
        for k, target in enumerate(fit.targets):
            constant = fit.constant and k == fit.count - 1
            label = f"{TARGET_PREFIX} Base" if constant else f"{TARGET_PREFIX} {k + 1:02d}"
            kb = ob.shape_key_add(name=label, from_mix=False)  # weights in [0, 1]: the default slider
            kb.points.foreach_set("co", rest + target.ravel())
            names.append(kb.name)
        values = np.concatenate([frames.key_values, fit.weights], axis=1) if fit.count else frames.key_values
        _key_all(key, names, values, frames.frames)
        if key.animation_data is not None and key.animation_data.action is not None:
            key.animation_data.action.name = f"{face.name} Wrinkles"  # the glTF animation's name
        image_names = _image_names(face)
        extras = None
        if image_names is not None:
            extras = {**package.describe(face, image_names), "format": package.FORMAT,
                      "version": package.VERSION,
                      "animation": {"frames": list(frames.frames),
                                    "zone_weights": np.round(frames.zone_weights, 6).tolist()}}
        replace = _png_copies(face, folder, renamed, made_images) if extras is not None else {}
        _dress(face, ob, extras, renamed, replace, made_materials)
        copies = []
        for part, part_names, part_values in frames.parts:
            copy = _copy_object(part, part.name + ".export", scene)
            made_objects.append(copy)
            copy.parent = ob
            copy.matrix_parent_inverse = part.matrix_parent_inverse
            copy.matrix_world = part.matrix_world
            if copy.data.shape_keys is not None and part_names:
                _key_all(copy.data.shape_keys, part_names, part_values, frames.frames)
                copy.data.shape_keys.animation_data.action.name = f"{part.name} Keys"
            _dress(part, copy, None, renamed, replace, made_materials)
            copies.append((part, copy))
        # the exporter names the nodes and the meshes after the objects themselves
        for original, copy in [(face, ob), *copies]:
            _take_name(original, copy, renamed)
            _take_name(original.data, copy.data, renamed)
        yield ob, [copy for _part, copy in copies]
    finally:
        for made in made_objects:
            mesh = made.data
            bpy.data.objects.remove(made)
            bpy.data.meshes.remove(mesh)  # and its shape keys
        for mat in made_materials:
            if mat.users == 0:
                bpy.data.materials.remove(mat)
        for img in made_images:
            bpy.data.images.remove(img)
        for original, original_name in reversed(renamed):
            original.name = original_name


def _angles(normals, live):
    """Degrees between the engine's normals (unnormalised) and the live unit normals."""
    length = np.linalg.norm(normals, axis=-1)
    cos = np.sum(normals * live, axis=-1) / np.maximum(length, 1e-12)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def _refit_normals(path, face, fit, frames):
    """Give the wrinkle targets the normal deltas that make the engine's normals the live
    face's (``glb``'s docstring), in the written file.  Returns the normal error (degrees,
    largest and 99th percentile over the range) with Blender's deltas and with the fitted
    ones; or why it was left alone."""
    if not fit.count:
        return {}
    try:
        doc = glb.Glb(path)
        prim, names = doc.mesh(face.data.name)
        targets = prim["targets"]
        weights = doc.weights(len(targets)).astype(np.float64)
        rest = np.empty((len(face.data.vertices), 3), np.float32)
        face.data.vertices.foreach_get("co", rest.ravel())
        where = glb.vertex_map(doc.accessor(prim["attributes"]["POSITION"]), rest)
        if where is None or len(weights) != len(frames.frames) or len(names) != len(targets):
            return {"normals": "left as Blender's exporter wrote them: the file's vertices or frames do "
                               "not match the face's one to one"}
        live = frames.normals[:, where] @ glb.TO_GLTF.T  # (F, N, 3), the file's axes
        ours = np.arange(len(targets) - fit.count, len(targets))
        deltas = np.stack([doc.accessor(t["NORMAL"]) for t in targets]).astype(np.float64)
        base = doc.accessor(prim["attributes"]["NORMAL"]).astype(np.float64)
        others = [t for t in range(len(targets)) if t not in set(ours)]
        engine = base + np.tensordot(weights[:, others], deltas[others], axes=(1, 0))
        before = _angles(engine + np.tensordot(weights[:, ours], deltas[ours], axes=(1, 0)), live)
        fitted = morphs.fit_normals(weights[:, ours], live - engine)
        after = _angles(engine + np.tensordot(weights[:, ours], fitted, axes=(1, 0)), live)
        for t, values in zip(ours, fitted):
            doc.overwrite(targets[t]["NORMAL"], values)
        doc.save()
    except (KeyError, ValueError, IndexError) as exc:
        return {"normals": f"left as Blender's exporter wrote them ({exc})"}
    return {"normals": "refit",
            "normal_error_deg_before": _summary(before), "normal_error_deg": _summary(after)}


def _summary(angles):
    """[largest, 99th percentile] of angles in degrees."""
    return [round(float(angles.max()), 3), round(float(np.percentile(angles, 99)), 3)]


def export(context, face, filepath, frame_start, frame_end, tolerance_mm=0.05, max_targets=16, count=0,
           progress=None):
    """Export ``face`` over the range to ``filepath`` (.glb or .gltf).  Returns the report:
    the file, K, the largest and mean error (mm) and whether K stayed within the
    tolerance.  Raises ExportError (sample.py) for what the user must fix."""
    path = sample.check_path(filepath, (".glb", ".gltf"))
    sample.check_range(frame_start, frame_end)
    parts = sample.parts(face, context.view_layer)
    frames = sample.read(context, face, frame_start, frame_end, maps=True, normals=True, with_parts=parts,
                         progress=(lambda i, n: progress(0.8 * i / n)) if progress else None)
    mm = 1000.0 * sample.metres_per_unit(face, context.scene)
    try:
        fit = morphs.fit(frames.offsets, tolerance_mm / mm, max_targets, count)
    except ValueError as exc:
        raise sample.ExportError(str(exc)) from None
    with tempfile.TemporaryDirectory(prefix="ewrinkles-gltf-") as folder, \
            _export_copy(context, face, fit, frames, folder) as (ob, others), \
            sample.exporting(context, ob, frame_start, frame_end, others), pipeline.suspended():
        try:
            bpy.ops.export_scene.gltf(**_exporter_options(path, frame_start, frame_end))
        except RuntimeError as exc:
            raise sample.ExportError(f"Blender's glTF exporter failed: {exc}") from None
    if not os.path.isfile(path):
        raise sample.ExportError(f"Blender's glTF exporter wrote no file at {path!r}")
    shading = _refit_normals(path, face, fit, frames)
    if progress:
        progress(1.0)
    return {"file": path, "frames": len(frames.frames), "targets": fit.count,
            "max_error_mm": fit.max_error * mm, "mean_error_mm": fit.mean_error * mm,
            "within_tolerance": fit.within_tolerance, "tolerance_mm": tolerance_mm,
            "frame_max_error_mm": (fit.frame_max_error * mm).round(5).tolist(),
            "textures": sorted(set((_image_names(face) or {}).values())),
            "parts": [p.name for p in parts], **shading}
