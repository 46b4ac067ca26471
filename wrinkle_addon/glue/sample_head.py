# SPDX-License-Identifier: GPL-3.0-or-later
"""The sample head: the ICT Face Model Light, shipped in ``wrinkle_addon/data/``.

``ict_head.npz`` is the skin with ICT's 53 ARKit-named expressions, ``ict_head_parts.npz``
its eyes, lacrimal fluid, lashes, teeth, gums and tongue with the same expressions
(``tools/ict_to_npz.py`` writes both and describes their layout; (c) 2020 USC Institute for
Creative Technologies, MIT licence, ``ict_head.LICENSE`` beside them).

:func:`add` builds two objects: the skin, with a Basis and one shape key per expression and
the skin material (:mod:`.skin_materials`), and its parts, parented to it, one mesh with a
material slot per kind of part and a shape key for each expression that moves a part
(the blinks move the lashes and the lacrimal fluid, the jaw the teeth, gums and tongue).
Each part key follows the skin's key of the same name through a one-variable driver, so the
parts follow every pose, on a farm too, with no add-on.  ICT's eye-occlusion meshes are left
out: they need the shadow texture ICT does not ship.

ICT stores centimetres with Y up and the face toward +Z; Blender wants metres, Z up and the
face toward -Y: ``(x, y, z) -> (x, -z, y) * 0.01``, a proper rotation that keeps the
character's left at +X.
"""

from pathlib import Path

import bpy
import numpy as np

from ..core import landmark_finder, skin_age
from ..core import skin as core_skin
from . import meshio, skin_materials
from .errors import WrinkleError

DATA = Path(__file__).resolve().parents[1] / "data"
SKIN_FILE = DATA / "ict_head.npz"
PARTS_FILE = DATA / "ict_head_parts.npz"

REST_ATTR = "ewrinkles_rest"  # the skin's neutral positions, for textures that stay on the skin
REGIONS_ATTR = "ewrinkles_skin"  # (oil, red, lip) of core.skin.regions
EYE_ATTR = "ewrinkles_eye"  # an eyeball's directions in its own frame (core.skin.eye_directions)

#: part kind -> (its parts, its material)
PART_KINDS = (
    ("Eyes", ("iris_L", "iris_R"), skin_materials.eye),
    ("Corneas", ("sclera_L", "sclera_R"), skin_materials.cornea),
    ("Lacrimal", ("lacrimal_L", "lacrimal_R"), skin_materials.lacrimal),
    ("Lashes", ("eyelashes_L", "eyelashes_R"), skin_materials.lashes),
    ("Teeth", ("teeth",), skin_materials.teeth),
    ("Mouth", ("gums_tongue",), skin_materials.mouth),
    ("Lower Lashes", (), skin_materials.lower_lashes),  # the lash faces below the eye's centre
)
MOVE_TOLERANCE = 1e-5  # metres: a part key is made for an expression that moves a part more


def to_blender(a):
    """ICT (cm, Y up, face +Z) -> Blender (m, Z up, face -Y), float32."""
    a = np.asarray(a, dtype=np.float32)
    out = np.empty_like(a)
    out[..., 0], out[..., 1], out[..., 2] = a[..., 0], -a[..., 2], a[..., 1]
    return out * np.float32(0.01)


def _read(path):
    try:
        with np.load(path) as data:
            return {k: data[k] for k in data.files}
    except (OSError, ValueError, KeyError) as exc:
        raise WrinkleError(f"The sample head's data cannot be read ({path.name}: {exc}); "
                           "reinstall the Expression Wrinkles extension") from None


def load(skin_file=None, parts_file=None):
    """The sample head in Blender's units and axes: ``skin`` (``positions`` (N, 3),
    ``quads`` (F, 4), ``corner_uvs`` (F, 4, 2), ``names``, ``deltas`` (E, N, 3)) and
    ``parts`` (name -> the same with ``face_sizes``, ``corner_verts`` and per-corner
    ``corner_uvs``)."""
    s, p = _read(Path(skin_file or SKIN_FILE)), _read(Path(parts_file or PARTS_FILE))
    try:
        skin = {"positions": to_blender(s["positions"]), "quads": s["quads"].astype(np.int32),
                "corner_uvs": s["corner_uvs"].astype(np.float32),
                "names": [str(n) for n in s["expression_names"]],
                "deltas": to_blender(s["expression_deltas"])}
        parts = {}
        for name in (str(n) for n in p["part_names"]):
            parts[name] = {"positions": to_blender(p[f"{name}/positions"]),
                           "face_sizes": p[f"{name}/face_sizes"].astype(np.int32),
                           "corner_verts": p[f"{name}/corner_verts"].astype(np.int32),
                           "corner_uvs": p[f"{name}/corner_uvs"].astype(np.float32),
                           "deltas": to_blender(p[f"{name}/expression_deltas"])}
    except KeyError as exc:
        raise WrinkleError(f"The sample head's data lacks {exc}; reinstall the Expression Wrinkles "
                           "extension") from None
    return {"skin": skin, "parts": parts}


def _mesh(name, positions, sizes, corner_verts, corner_uvs):
    me = bpy.data.meshes.new(name)
    me.vertices.add(len(positions))
    me.vertices.foreach_set("co", np.ascontiguousarray(positions, np.float32).ravel())
    me.loops.add(len(corner_verts))
    me.loops.foreach_set("vertex_index", np.ascontiguousarray(corner_verts, np.int32))
    me.polygons.add(len(sizes))
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int32)
    me.polygons.foreach_set("loop_start", starts)
    me.polygons.foreach_set("loop_total", np.ascontiguousarray(sizes, np.int32))
    me.update(calc_edges=True)
    uvs = np.ascontiguousarray(corner_uvs, np.float32).ravel()
    me.uv_layers.new(name="UVMap").uv.foreach_set("vector", uvs)
    me.polygons.foreach_set("use_smooth", np.ones(len(sizes), bool))
    me.validate()
    return me


def _point_attribute(me, name, values):
    """Write (N, 3) ``values`` as the point vector attribute ``name`` (``meshio.point_attribute``)."""
    values = np.ascontiguousarray(values, np.float32)
    meshio.point_attribute(me, name, "FLOAT_VECTOR").data.foreach_set("vector", values.ravel())


def _shape_keys(ob, base, names, deltas):
    ob.shape_key_add(name="Basis", from_mix=False)
    for name, delta in zip(names, deltas):
        kb = ob.shape_key_add(name=name, from_mix=False)
        kb.points.foreach_set("co", (base + delta).astype(np.float32).ravel())
        kb.value = 0.0


def _follow(parts_ob, skin_ob):
    """Drive each key of ``parts_ob`` by the skin's key of the same name (one variable)."""
    for kb in parts_ob.data.shape_keys.key_blocks[1:]:
        fc = kb.driver_add("value")
        drv = fc.driver
        drv.type = "AVERAGE"
        var = drv.variables.new()
        var.name = "value"
        var.type = "SINGLE_PROP"
        var.targets[0].id_type = "KEY"
        var.targets[0].id = skin_ob.data.shape_keys
        var.targets[0].data_path = f'key_blocks["{kb.name}"].value'


def add(collection, name="Sample Head", parts=True, progress=None):
    """Build the sample head in ``collection``; return ``(skin, parts)`` objects (``parts``
    None without them).  ``progress(fraction, message)`` is called along the way."""
    step = progress or (lambda *_: None)
    step(0.0, "reading the sample head")
    data = load()
    s = data["skin"]
    step(0.15, "building the skin")
    sizes = np.full(len(s["quads"]), 4, np.int32)
    me = _mesh(name, s["positions"], sizes, s["quads"].ravel(), s["corner_uvs"].reshape(-1, 2))
    skin_ob = bpy.data.objects.new(name, me)
    collection.objects.link(skin_ob)
    skin_ob.ewrinkles_face.skin_age = skin_age.YOUNG  # young skin: no fine crackle at rest
    step(0.3, "adding the 53 expressions")
    _shape_keys(skin_ob, s["positions"], s["names"], s["deltas"])
    step(0.6, "the skin material" + (", the eyes, lashes and teeth" if parts else ""))
    return skin_ob, dress(skin_ob, collection, parts=parts, data=data)


def paint_skin(skin_ob, landmarks=None):
    """Write the skin's rest positions and regions (oil, red, lip) as the point attributes
    the skin material reads, from its mesh as it is (after a refinement too); ``landmarks``
    (face space) default to the add-on's finder's."""
    me = skin_ob.data
    co = np.empty(len(me.vertices) * 3, np.float32)
    me.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    if landmarks is None:
        landmarks, _method, _message = landmark_finder.find_landmarks(co, meshio.read_polygons(me))
    regions = core_skin.regions(co, landmarks)
    _point_attribute(me, REST_ATTR, co)
    _point_attribute(me, REGIONS_ATTR, regions)


def dress(skin_ob, collection, parts=True, data=None, landmarks=None):
    """Give the sample head's skin object (ICT's vertices, in ICT's order, with its
    expression shape keys) the skin material, and with ``parts`` its eyes, lashes and teeth,
    parented and driven by its keys; return the parts object (or None)."""
    paint_skin(skin_ob, landmarks)
    skin_ob.data.materials.clear()
    skin_ob.data.materials.append(skin_materials.skin())
    if not parts:
        return None
    data = data or load()
    names = data["skin"]["names"]
    parts_ob = _parts_object(f"{skin_ob.name} Eyes and Mouth", data["parts"], names, collection)
    parts_ob.parent = skin_ob
    _follow(parts_ob, skin_ob)
    return parts_ob


def _parts_object(name, parts, names, collection):
    chosen = [(slot, part) for slot, (_kind, members, _mat) in enumerate(PART_KINDS) for part in members]
    offsets = np.cumsum([0] + [len(parts[p]["positions"]) for _s, p in chosen])
    positions = np.concatenate([parts[p]["positions"] for _s, p in chosen])
    sizes = np.concatenate([parts[p]["face_sizes"] for _s, p in chosen])
    corner_verts = np.concatenate([parts[p]["corner_verts"] + o for (_s, p), o in zip(chosen, offsets)])
    corner_uvs = np.concatenate([parts[p]["corner_uvs"] for _s, p in chosen])
    slots = np.concatenate([np.full(len(parts[p]["face_sizes"]), s, np.int32) for s, p in chosen])
    deltas = np.concatenate([parts[p]["deltas"] for _s, p in chosen], axis=1)
    me = _mesh(name, positions, sizes, corner_verts, corner_uvs)
    for _kind, _members, material in PART_KINDS:
        me.materials.append(material())
    eye = np.zeros((len(positions), 3), np.float32)
    names_in_order = [p for _s, p in chosen]
    face_at = np.cumsum([0] + [len(parts[p]["face_sizes"]) for _s, p in chosen])
    for side in ("L", "R"):
        at = names_in_order.index(f"iris_{side}")
        apex = core_skin.cornea_apex(parts[f"sclera_{side}"]["positions"])
        eye[offsets[at]:offsets[at + 1]] = core_skin.eye_directions(parts[f"iris_{side}"]["positions"], apex)
        centre_z = core_skin.sphere_centre(parts[f"iris_{side}"]["positions"])[2]
        lash = parts[f"eyelashes_{side}"]
        card = core_skin.components(len(lash["positions"]), lash["face_sizes"], lash["corner_verts"])
        card_z = np.bincount(card, lash["positions"][:, 2]) / np.bincount(card)
        lower_vertex = card_z[card] < centre_z  # a card hanging below the eye's centre
        at = names_in_order.index(f"eyelashes_{side}")
        first_corner = np.concatenate([[0], np.cumsum(lash["face_sizes"])[:-1]])
        lower_face = lower_vertex[lash["corner_verts"][first_corner]]
        slots[face_at[at]:face_at[at + 1]][lower_face] = len(PART_KINDS) - 1
    me.polygons.foreach_set("material_index", slots)
    _point_attribute(me, EYE_ATTR, eye)
    ob = bpy.data.objects.new(name, me)
    collection.objects.link(ob)
    keep = core_skin.moving(deltas, MOVE_TOLERANCE)
    _shape_keys(ob, positions, [names[i] for i in keep], deltas[keep])
    return ob
