# SPDX-License-Identifier: GPL-3.0-or-later
"""The wrinkle-map package: a face's wrinkle maps for engines that shade wrinkles.

One folder holds ``wrinkles.json`` and the images (docs/wrinkle_package.md documents the
layout, version 1): the base normal map, the K wrinkle maps and the two zone masks as
16-bit PNG (or 32-bit EXR), linear data; the encoding (partial-derivative or difference
maps); the expression table (what drives each expression - a shape key, a muscle, any
property - and its weight in each zone of its map); each zone's Strength and Response;
and, for a frame range, the zone weights of every map on every frame, exactly as the
face's weights group computes them for the shader (``maps.map_material.zone_weights``).

:func:`read` puts a package on a face: the images, the table bound to the face's own
shape keys (or muscles and objects of the same names), and the zones' settings; the
face then renders as the exporting one.
"""

import json
import os

import bpy
import numpy as np

from ...core.maps.jimenez import N_ZONES, ZONES
from .. import faces, images, nodes
from ..maps import map_material
from . import sample

FORMAT = "expression-wrinkles/wrinkle-maps"
VERSION = 1
JSON_NAME = "wrinkles.json"
# (settings property, file stem)
SLOTS = (("base_image", "base_normal"),
         *((prop, f"map_{k + 1}") for k, prop in enumerate(map_material.MAP_PROPS)),
         ("mask_a", "mask_a"), ("mask_b", "mask_b"))
IMAGE_FORMATS = {"PNG": ("PNG", "16", ".png"), "OPEN_EXR": ("OPEN_EXR", "32", ".exr")}


class PackageError(sample.ExportError):
    """A problem the user must fix; the message is shown as is."""


def zones():
    """The zone list of ``wrinkles.json``: index, name, colour, mask and channel."""
    return [{"zone": z + 1, "name": name, "colour": colour, "mask": "AB"[z // 4], "channel": "RGBA"[z % 4]}
            for z, (colour, name) in enumerate(ZONES)]


def _driver(ex):
    if ex.source == "SHAPE_KEY":
        return {"source": "SHAPE_KEY", "shape_key": ex.shape_key}
    if ex.source == "MUSCLE":
        return {"source": "MUSCLE", "muscle": ex.muscle.name if ex.muscle else ""}
    if ex.source == "PROPERTY":
        target = ex.target.name if ex.target else ""
        return {"source": "PROPERTY", "object": target, "data_path": ex.data_path}
    return {"source": "MANUAL", "value": float(ex.value)}


def describe(face, image_names):
    """The table part of ``wrinkles.json`` (also the glTF material's extras); ``image_names``
    maps each settings property of :data:`SLOTS` to what the file calls its image."""
    maps = face.ewrinkles_face.maps
    k = map_material.n_maps(maps)
    return {
        "encoding": "difference" if maps.difference else "partial-derivative",
        "tangent_space": "OpenGL: +X is +U, +Y is +V",
        "uv_map": maps.uv_map,
        "strength": float(maps.strength),
        "images": {
            "base": image_names.get("base_image"),
            "maps": [image_names.get(prop) for prop in map_material.MAP_PROPS[:k]],
            "masks": [image_names.get("mask_a"), image_names.get("mask_b")],
        },
        "zones": zones(),
        "zone_strength": [float(v) for v in maps.zone_strength],
        "zone_response": [float(v) for v in maps.zone_power],
        "weight_mode": maps.weight_mode,
        "tension_gain": float(maps.tension_gain),
        "expressions": [{"name": ex.name, "map": int(ex.map_index), "weights": [float(w) for w in ex.weights],
                         **_driver(ex)} for ex in maps.expressions],
    }


def check_face(face):
    maps = face.ewrinkles_face.maps
    if maps.weights_group is None or maps.material is None:
        raise PackageError(f'"{face.name}" has no wrinkle maps set up: there is nothing to package')
    if maps.map_a is None:
        raise PackageError(f'"{face.name}" has no Wrinkle Map 1: bake or pick one first')


def write(context, face, folder, frame_start, frame_end, image_format="PNG", progress=None):
    """Write ``face``'s package into ``folder`` (made if missing; files of the same names
    are replaced).  Returns a report: the folder, the files, the frames."""
    check_face(face)
    sample.check_range(frame_start, frame_end)
    if image_format not in IMAGE_FORMATS:
        raise PackageError(f"Images can be PNG or OPEN_EXR, not {image_format!r}")
    folder = os.path.dirname(sample.check_path(os.path.join(folder, JSON_NAME), (".json",)))
    file_format, depth, ext = IMAGE_FORMATS[image_format]
    maps = face.ewrinkles_face.maps
    for prop, _stem in SLOTS:
        img = getattr(maps, prop)
        if img is not None:
            try:
                images.check_loaded(img)
            except images.ImageError as exc:
                raise PackageError(str(exc)) from None
    frames = sample.read(context, face, frame_start, frame_end, maps=True, progress=progress)
    names = {}
    for prop, stem in SLOTS:
        img = getattr(maps, prop)
        if img is not None:
            written = images.save(img, os.path.join(folder, stem + ext), file_format, depth)
            names[prop] = os.path.basename(written)
    scene = context.scene
    doc = {
        "format": FORMAT,
        "version": VERSION,
        "generator": "Expression Wrinkles",
        "face": face.name,
        **describe(face, names),
        "animation": {
            "fps": scene.render.fps / scene.render.fps_base,
            "frames": frames.frames,
            "zone_weights": np.round(frames.zone_weights, 6).tolist(),
        },
    }
    path = os.path.join(folder, JSON_NAME)
    tmp = path + ".partial"
    with open(tmp, "w", encoding="utf-8") as fh:
        json.dump(doc, fh, indent=1)
    os.replace(tmp, path)
    return {"folder": folder, "files": [JSON_NAME, *names.values()], "frames": len(frames.frames),
            "maps": len(doc["images"]["maps"]), "expressions": len(doc["expressions"])}


# ---------------------------------------------------------------------------------------
# import


def load(folder):
    """The checked contents of ``folder``'s ``wrinkles.json``.  Raises PackageError."""
    path = os.path.join(bpy.path.abspath(folder), JSON_NAME)
    try:
        with open(path, encoding="utf-8") as fh:
            doc = json.load(fh)
    except FileNotFoundError:
        raise PackageError(f"{folder!r} holds no {JSON_NAME}: it is not a wrinkle-map package") from None
    except (OSError, ValueError) as exc:
        raise PackageError(f"Cannot read {path!r}: {exc}") from None
    if not isinstance(doc, dict) or doc.get("format") != FORMAT:
        raise PackageError(f"{path!r} is not a wrinkle-map package ({FORMAT})")
    version = doc.get("version")
    if not isinstance(version, int) or version > VERSION:
        raise PackageError(f"{path!r} is package version {version}; this add-on reads up to {VERSION}: "
                           "update the add-on")
    try:
        _validate(doc)
    except (KeyError, TypeError, ValueError) as exc:
        raise PackageError(f"{path!r} is damaged: {exc}") from None
    return doc


def _validate(doc):
    imgs = doc["images"]
    if not isinstance(imgs["maps"], list) or not 1 <= len(imgs["maps"]) <= len(map_material.MAP_PROPS):
        raise ValueError("it must list 1 to 8 wrinkle maps")
    for e in doc["expressions"]:
        if len(e["weights"]) != N_ZONES or not 1 <= int(e["map"]) <= len(map_material.MAP_PROPS):
            raise ValueError(f"the expression {e.get('name')!r} needs 8 weights and a map from 1 to 8")
        [float(w) for w in e["weights"]]
    for key in ("zone_strength", "zone_response"):
        if len(doc[key]) != N_ZONES:
            raise ValueError(f"{key} needs 8 values")
        [float(v) for v in doc[key]]


def _load_image(folder, name):
    path = os.path.join(folder, os.path.basename(name))
    if not os.path.isfile(path):
        raise PackageError(f"The package lacks its image {name!r}")
    try:
        img = bpy.data.images.load(path, check_existing=False)
    except RuntimeError as exc:
        raise PackageError(f"Cannot load {path!r}: {exc}") from None
    img.colorspace_settings.name = images.NON_COLOR
    return img


def _bind(face, ex, entry):
    """Bind the expression ``ex`` as ``entry`` says, to what ``face``'s file has; returns
    a message when it had to fall back to Manual."""
    source = entry.get("source", "MANUAL")
    keys = face.data.shape_keys
    if source == "SHAPE_KEY":
        name = entry.get("shape_key", "")
        if keys is not None and name in keys.key_blocks:
            ex.source, ex.shape_key = "SHAPE_KEY", name
            return None
        why = f'no shape key "{name}"'
    elif source == "MUSCLE":
        ob = bpy.data.objects.get(entry.get("muscle", ""))
        if ob is not None and ob.ewrinkles_muscle.is_muscle:
            ex.source, ex.muscle = "MUSCLE", ob
            return None
        why = f'no muscle "{entry.get("muscle", "")}"'
    elif source == "PROPERTY":
        ob = bpy.data.objects.get(entry.get("object", ""))
        if ob is not None:
            ex.source, ex.target, ex.data_path = "PROPERTY", ob, entry.get("data_path", "")
            return None
        why = f'no object "{entry.get("object", "")}"'
    else:
        why = None
    ex.source = "MANUAL"
    ex.value = float(entry.get("value", 0.0))
    return f'{ex.name}: {why}, so it is Manual' if why else None


def read(context, face, folder):
    """Set ``face``'s wrinkle maps up from the package in ``folder``.  Returns the
    expressions that could not be bound (messages).  Raises PackageError, and then
    changes nothing on the face (images it loaded are removed)."""
    doc = load(folder)
    folder = bpy.path.abspath(folder)
    why = faces.problem(face, polygons=False, uv=True)
    mat = face.ewrinkles_face.maps.material or face.active_material
    if why is None and (mat is None or mat.node_tree is None or nodes.principled(mat.node_tree) is None):
        why = f'"{face.name}" has no material with a Principled BSDF for the wrinkle maps to feed'
    if why:
        raise PackageError(why)
    uv = doc.get("uv_map") or ""
    if uv and uv not in face.data.uv_layers:
        raise PackageError(f'"{face.name}" has no UV map "{uv}", which the package\'s maps use')
    wanted = {"base_image": doc["images"].get("base")}
    wanted.update({prop: name for prop, name in zip(map_material.MAP_PROPS, doc["images"]["maps"])})
    wanted.update(zip(("mask_a", "mask_b"), doc["images"].get("masks") or (None, None)))
    loaded = {}
    try:
        for prop, name in wanted.items():
            if name:
                loaded[prop] = img = _load_image(folder, name)
                if prop.startswith("mask"):
                    img.alpha_mode = "CHANNEL_PACKED"  # alpha is zone 4 or 8, not coverage
        squares = [img for prop, img in loaded.items() if prop != "base_image"]
        for img in squares:
            images.check_square(img)
        images.check_same_size([img for prop, img in loaded.items() if prop.startswith("map")])
        images.check_same_size([img for prop, img in loaded.items() if prop.startswith("mask")])
    except (PackageError, images.ImageError) as exc:
        for img in loaded.values():
            bpy.data.images.remove(img)
        raise PackageError(str(exc)) from None
    maps = face.ewrinkles_face.maps
    if maps.weights_group is not None:
        map_material.remove(face)
    for prop, _stem in SLOTS:
        setattr(maps, prop, loaded.get(prop))
    maps.uv_map = uv
    maps.difference = doc.get("encoding") == "difference"
    maps.strength = float(doc.get("strength", 1.0))
    maps.weight_mode = doc.get("weight_mode") if doc.get("weight_mode") in ("TABLE", "TENSION") else "TABLE"
    maps.tension_gain = float(doc.get("tension_gain", 5.0))
    maps.zone_strength = [float(v) for v in doc["zone_strength"]]
    maps.zone_power = [float(v) for v in doc["zone_response"]]
    maps.expressions.clear()
    unbound = []
    for entry in doc["expressions"]:
        ex = maps.expressions.add()
        ex.name = str(entry.get("name", "Expression"))
        ex.map_index = int(entry["map"])
        ex.weights = [float(w) for w in entry["weights"]]
        message = _bind(face, ex, entry)
        if message:
            unbound.append(message)
    map_material.setup(face)
    return unbound
