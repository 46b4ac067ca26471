# SPDX-License-Identifier: GPL-3.0-or-later
"""Wrinkle maps on a face material: wiring, the expression table and its drivers.

``setup`` checks everything first and changes nothing when something is wrong; then it
puts the ``Wrinkle Map Blend`` group (:mod:`nodegroups`) in front of the Principled BSDF's
normal input, feeds it the base map, wrinkle maps and masks, and feeds its zone inputs
from the face's ``Wrinkle Weights`` group.  ``sync`` keeps that group in step with the
table in ``Object.ewrinkles_face.maps``: each expression's value comes from a driver with one
variable (type AVERAGE, no Python expression) reading its source, a shape key, a muscle's
contraction or any property, made by the add-on's one driver builder (``glue.drivers``,
which escapes shape-key names).  Custom properties read back from the file (the previous
normal link, the baked paths) are validated: anything malformed counts as absent.
"""

import bpy
import numpy as np

from ...core import mesh
from ...core.maps import jimenez
from ...core.maps.jimenez import N_ZONES
from .. import drivers, faces, images, meshio, nodes, pipeline
from .. import status as status_store
from ..surface import SurfaceError
from . import map_bake, nodegroups

BLEND_NODE = "Wrinkle Map Blend"
WEIGHTS_NODE = "Wrinkle Weights"
UV_NODE = "Wrinkle UV"
NORMAL_NODE = "Wrinkle Normal Map"
# (settings property, image node, blend-group input it feeds)
MAP_PROPS = ("map_a", "map_b", "map_c", "map_d", "map_e", "map_f", "map_g", "map_h")  # maps 1-8
IMAGE_NODES = (("base_image", "Wrinkle Base", "Base Normal"),
               *((prop, f"Wrinkle Map {k + 1}", nodegroups.map_socket(k))
                 for k, prop in enumerate(MAP_PROPS)),
               ("mask_a", "Wrinkle Mask A", "Mask A"),
               ("mask_b", "Wrinkle Mask B", "Mask B"))
_OURS = {BLEND_NODE, WEIGHTS_NODE, UV_NODE, NORMAL_NODE} | {n for _p, n, _s in IMAGE_NODES}
CHANNEL = "maps"  # this method's name: its wrinkle source and its static data in the frame stage
TABLE_CHANNEL = CHANNEL + ".table"  # the status channel of the table's sync
_problems = {}  # face session_uid -> {expression index: message}


MapError = nodegroups.MapError


def status(face):
    return status_store.get(face, TABLE_CHANNEL)


def set_status(face, message):
    status_store.set(face, TABLE_CHANNEL, message)


def binding_problem(face, e):
    return _problems.get(face.session_uid, {}).get(e, "")


def n_maps(maps):
    """How many wrinkle maps the face uses: at least 2, and every map an expression or an
    image slot refers to."""
    slots = [k + 1 for k, prop in enumerate(MAP_PROPS) if getattr(maps, prop) is not None]
    return max([2] + slots + [ex.map_index for ex in maps.expressions])


def table(maps):
    return np.array([list(ex.weights) for ex in maps.expressions], np.float32).reshape(-1, N_ZONES)


def zone_weights(face):
    """The zone weights (K, 8) of each of the face's K wrinkle maps at the evaluated frame,
    as its weights group computes them (``nodegroups.build_weights``): each expression's
    value as the group holds it (driven or Manual), summed with the table's weights of the
    expressions on that map, the tension added on map 1, clamped, then the zones' Response
    and Strength.  Zeros when the maps are not set up."""
    maps = face.ewrinkles_face.maps
    ng = maps.weights_group
    k = n_maps(maps)
    if ng is None:
        return np.zeros((k, N_ZONES), np.float32)

    def value(name):
        node = ng.nodes.get(name)
        return float(node.outputs[0].default_value) if node is not None else 0.0

    values = np.array([value(nodegroups.expr_node(e)) for e in range(len(maps.expressions))], np.float32)
    tension = np.array(nodegroups.read_tension(ng), np.float32)
    on = np.array([ex.map_index - 1 for ex in maps.expressions], np.int64)
    rows = table(maps)
    out = np.zeros((k, N_ZONES), np.float32)
    for m in range(k):
        sums = jimenez.expression_sums(values[on == m], rows[on == m]) + (tension if m == 0 else 0.0)
        out[m] = jimenez.zone_response(sums, np.asarray(maps.zone_strength), np.asarray(maps.zone_power))
    return out


# ---------------------------------------------------------------------------------------
# checks


def _image_problem(label, img, square=True, alpha=False):
    if img is None:
        return None
    try:
        images.check_loaded(img)
    except images.ImageError as exc:
        return f"{label}: {exc}"
    w, h = img.size
    channels = images.channel_count(img)
    if channels < 3:
        return f'{label} "{img.name}" has {channels} channel(s); it needs RGB'
    if alpha and channels < 4:
        return f'{label} "{img.name}" has no alpha channel; the 4th zone of a mask lives in alpha'
    if square and w != h:
        return f'{label} "{img.name}" is {w} x {h}; wrinkle maps and masks must be square'
    return None


def check(face, material=None):
    """Why wrinkle maps cannot be set up on ``face`` (a message), or None."""
    why = faces.problem(face, polygons=False, uv=True)
    if why:
        return why
    me = face.data
    maps = face.ewrinkles_face.maps
    if maps.uv_map and maps.uv_map not in me.uv_layers:
        return f'"{face.name}" has no UV map named "{maps.uv_map}"'
    mat = material or maps.material or face.active_material
    if mat is None:
        return f'"{face.name}" has no material: add one with a Principled BSDF'
    if mat.library is not None:
        return f'The material "{mat.name}" is linked and read-only: make it local'
    if mat.node_tree is None or nodes.principled(mat.node_tree) is None:
        return f'The material "{mat.name}" has no Principled BSDF to feed'
    wrinkle_maps = [(f"Wrinkle map {k + 1}", getattr(maps, prop)) for k, prop in enumerate(MAP_PROPS)]
    for label, img, alpha, square in (
        ("The base normal map", maps.base_image, False, False),
        *((label, img, False, True) for label, img in wrinkle_maps),
        ("Mask A", maps.mask_a, True, True),
        ("Mask B", maps.mask_b, True, True),
    ):
        why = _image_problem(label, img, square, alpha)
        if why:
            return why
    present = [img for _label, img in wrinkle_maps if img is not None]
    pairs = [(present[0], img, "wrinkle maps") for img in present[1:]] + [(maps.mask_a, maps.mask_b, "masks")]
    for a, b, what in pairs:
        if a is not None and b is not None and tuple(a.size) != tuple(b.size):
            return (f'The {what} "{a.name}" ({a.size[0]} x {a.size[1]}) and "{b.name}" '
                    f"({b.size[0]} x {b.size[1]}) differ in size")
    for ng in (bpy.data.node_groups.get(nodegroups.BLEND_GROUP), maps.weights_group):
        if ng is not None and (ng.library is not None or not ng.is_editable):
            return f'The node group "{ng.name}" is linked and read-only: make it local'
    return None


# ---------------------------------------------------------------------------------------
# wiring


def _existing_base(nt, bsdf):
    """The image of a Normal Map node already feeding the BSDF's normal, if any."""
    for lk in bsdf.inputs["Normal"].links:
        node = lk.from_node
        if node.type == "NORMAL_MAP" and node.inputs["Color"].links:
            src = node.inputs["Color"].links[0].from_node
            if src.type == "TEX_IMAGE" and src.image is not None:
                return src.image
    return None


def setup(face, material=None, packed=None):
    """Wire the wrinkle maps into the face material.  Raises MapError, changing nothing.

    Every image is tagged as data (Non-Color; masks also Channel Packed) without losing
    pixels that live only in memory (``images.tag_as_data``): the names of the generated
    images this packed into the .blend are appended to the list ``packed``, if given."""
    why = check(face, material)
    if why:
        raise MapError(why)
    maps = face.ewrinkles_face.maps
    mat = material or maps.material or face.active_material
    nt = mat.node_tree
    bsdf = nodes.principled(nt)
    blend_group = nodegroups.ensure_blend_group(n_maps(maps))
    target = nodes.normal_input(nt, bsdf)  # the BSDF's, or the end of a chain of our layers
    old = [(lk.from_node.name, lk.from_socket.identifier) for lk in target.links
           if lk.from_node.name not in _OURS]
    if maps.base_image is None:
        maps.base_image = _existing_base(nt, bsdf)
    maps.material = mat
    if maps.weights_group is None:
        maps.weights_group = bpy.data.node_groups.new(f"{nodegroups.WEIGHTS_PREFIX} {face.name}",
                                                      "ShaderNodeTree")

    x, y = bsdf.location.x, bsdf.location.y
    blend = nodes.ensure_node(nt, BLEND_NODE, "ShaderNodeGroup", (x - 300, y - 400))
    blend.node_tree = blend_group
    if old and "ewrinkles_previous_normal" not in blend:
        blend["ewrinkles_previous_normal"] = list(old[0])
    weights = nodes.ensure_node(nt, WEIGHTS_NODE, "ShaderNodeGroup", (x - 600, y - 900))
    weights.node_tree = maps.weights_group
    uv = nodes.ensure_node(nt, UV_NODE, "ShaderNodeUVMap", (x - 1100, y - 400))
    uv.uv_map = maps.uv_map
    for i, (prop, name, _socket) in enumerate(IMAGE_NODES):
        img = getattr(maps, prop)
        node = nt.nodes.get(name)
        if img is None:
            if node is not None:
                nt.nodes.remove(node)
            continue
        node = nodes.ensure_node(nt, name, "ShaderNodeTexImage", (x - 850, y - 250 - 280 * i))
        node.image = img
        # every one of them is data; a mask's alpha is zone 4 / 8, not coverage
        mask = prop.startswith("mask")
        if images.tag_as_data(img, "CHANNEL_PACKED" if mask else None) and packed is not None:
            packed.append(img.name)
        if mask:
            # no zone outside the 0-1 square: UVs in other tiles (the ICT head's back of
            # the head) would otherwise wrap around onto the face's zones
            node.extension = "CLIP"
        nt.links.new(uv.outputs["UV"], node.inputs["Vector"])
    normal = blend.outputs["Normal"]
    nmap = nt.nodes.get(NORMAL_NODE)
    if maps.uv_map:  # the shared group's Normal Map node has the render-active UV map's tangents
        nmap = nodes.ensure_node(nt, NORMAL_NODE, "ShaderNodeNormalMap", (x - 150, y - 600))
        nmap.space = "TANGENT"
        nmap.uv_map = maps.uv_map
        nt.links.new(blend.outputs["Color"], nmap.inputs["Color"])
        normal = nmap.outputs["Normal"]
    elif nmap is not None:
        nt.nodes.remove(nmap)
    nt.links.new(normal, nodes.normal_input(nt, bsdf))
    sync(face, rebind=True)
    return mat


def _wire(face):
    """Links from the image nodes and the weights group into the blend node."""
    maps = face.ewrinkles_face.maps
    nt = maps.material.node_tree
    blend, weights = nt.nodes.get(BLEND_NODE), nt.nodes.get(WEIGHTS_NODE)
    if blend is None or weights is None:
        return
    for _prop, src, dst in IMAGE_NODES:
        node = nt.nodes.get(src)
        if node is not None:
            nt.links.new(node.outputs["Color"], blend.inputs[dst])
            if dst.startswith("Mask"):
                nt.links.new(node.outputs["Alpha"], blend.inputs[dst + " Alpha"])
    for out in weights.outputs:
        if out.name in blend.inputs:
            nt.links.new(out, blend.inputs[out.name])
    blend.inputs["Strength"].default_value = maps.strength
    blend.inputs["Difference Maps"].default_value = 1.0 if maps.difference else 0.0


def _strings(value):
    """``value`` read from a file as a list of strings, or None if it is anything else.

    Custom properties come from the file as they were saved, so a crafted or damaged file
    can hold any type under our names: only a list (or tuple) of str is taken."""
    if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
        return None
    return list(value)


def _previous_normal(blend):
    """(node name, socket identifier) of the link that fed the BSDF's normal before the
    wrinkle maps, as ``setup`` stored it on the blend node; [] if absent or malformed."""
    prev = _strings(blend.get("ewrinkles_previous_normal")) if blend is not None else None
    return prev if prev is not None and len(prev) == 2 else []


def remove(face):
    """Take the wrinkle maps out of the material and restore its previous normal link."""
    maps = face.ewrinkles_face.maps
    mat = maps.material
    if mat is not None and mat.node_tree is not None:
        nt = mat.node_tree
        blend = nt.nodes.get(BLEND_NODE)
        prev = _previous_normal(blend)
        for name in _OURS:
            node = nt.nodes.get(name)
            if node is not None:
                nt.nodes.remove(node)
        bsdf = nodes.principled(nt)
        if prev and bsdf is not None and prev[0] in nt.nodes:
            src = next((s for s in nt.nodes[prev[0]].outputs if s.identifier == prev[1]), None)
            if src is not None:
                nt.links.new(src, nodes.normal_input(nt, bsdf))
    ng = maps.weights_group
    maps.weights_group = None
    maps.material = None
    if ng is not None and ng.users == 0 and ng.library is None:
        bpy.data.node_groups.remove(ng)
    set_status(face, "")


# ---------------------------------------------------------------------------------------
# the expression table


def _target(face, ex):
    """(id_type, id, data_path) of the expression's source, or a problem message."""
    if ex.source == "SHAPE_KEY":
        keys = face.data.shape_keys
        if not ex.shape_key:
            return "pick a shape key"
        if keys is None or ex.shape_key not in keys.key_blocks:
            return f'"{face.name}" has no shape key "{ex.shape_key}"'
        return ("KEY", keys, drivers.shape_key_path(ex.shape_key))
    if ex.source == "MUSCLE":
        if ex.muscle is None:
            return "pick a muscle"
        return ("OBJECT", ex.muscle, "ewrinkles_muscle.contraction")
    if ex.source == "PROPERTY":
        if ex.target is None or not ex.data_path:
            return "pick an object and a data path"
        try:
            value = ex.target.path_resolve(ex.data_path)
        except (ValueError, TypeError):
            return f'"{ex.target.name}" has no property "{ex.data_path}"'
        if not isinstance(value, (int, float, bool)):
            return f'"{ex.data_path}" is not a single number'
        return ("OBJECT", ex.target, ex.data_path)
    return None


def _value_path(node_name):
    return f'nodes["{node_name}"].outputs[0].default_value'


def baked_paths(ng):
    """The data paths of the weights group that ``bake_weights`` keyed; empty if there are
    none or what the file holds is not a list of strings."""
    paths = _strings(ng.get("ewrinkles_baked")) if ng is not None else None
    return set(paths or ())


def _bind(face, ng):
    problems = {}
    baked = baked_paths(ng)
    for e, ex in enumerate(face.ewrinkles_face.maps.expressions):
        path = _value_path(nodegroups.expr_node(e))
        if path in baked:
            continue
        ng.driver_remove(path)
        target = _target(face, ex)
        if isinstance(target, str):
            problems[e] = target
            continue
        if target is None:
            continue
        id_type, ident, data_path = target
        try:  # type AVERAGE, one variable, no expression: evaluates without Python
            drivers.drive(ng, path, id_type, ident, data_path)
        except ValueError as exc:
            problems[e] = str(exc)
    _problems[face.session_uid] = problems
    return problems


def sync(face, rebind=False):
    """Bring the weights group and the blend node in step with the table."""
    maps = face.ewrinkles_face.maps
    pipeline.forget(face, CHANNEL)  # masks or UVs may have changed: rebuild the tension statics
    ng = maps.weights_group
    if ng is None or maps.material is None:
        return
    layout = [ex.map_index - 1 for ex in maps.expressions]
    k = n_maps(maps)
    if not nodegroups.weights_layout_matches(ng, layout, k):
        nodegroups.build_weights(ng, [ex.name for ex in maps.expressions], layout, k)
        nodegroups.ensure_blend_group(k)
        rebind = True
    for e, ex in enumerate(maps.expressions):
        node = ng.nodes.get(nodegroups.expr_node(e))
        if node is not None and node.label != ex.name[:60]:
            node.label = ex.name[:60]
    problems = _bind(face, ng) if rebind else _problems.get(face.session_uid, {})
    manual = [ex.value if ex.source == "MANUAL" else (0.0 if e in problems else None)
              for e, ex in enumerate(maps.expressions)]
    nodegroups.set_weights(ng, table(maps), manual, maps.zone_strength, maps.zone_power, k)
    if maps.weight_mode != "TENSION":
        nodegroups.set_tension(ng, [0.0] * N_ZONES)
    _wire(face)


def sync_quietly(face, rebind=False):
    """``sync`` for property updates: a problem becomes a panel message, not an exception."""
    try:
        sync(face, rebind)
    except nodegroups.MapError as exc:
        set_status(face, str(exc))
    else:
        set_status(face, "")


# ---------------------------------------------------------------------------------------
# tension-driven zone weights


def wants_tension(face):
    maps = face.ewrinkles_face.maps
    return maps.weight_mode == "TENSION" and maps.weights_group is not None and maps.material is not None


def tension_key(face):
    """What the tension statics depend on: the topology, the UV map (or why there is none
    to use) and the masks."""
    maps = face.ewrinkles_face.maps
    try:
        uv = map_bake.uv_layer(face).name
    except SurfaceError as exc:  # tension_statics raises it: the source reports it
        uv = (str(exc),)
    return (meshio.topology_key(face.data), uv) + tuple(
        (m.name, tuple(m.size)) if m is not None else None for m in (maps.mask_a, maps.mask_b))


def tension_statics(face):
    """(rest edge lengths, edges, zone masks at the vertices (V, 8)) for
    ``core.maps.jimenez.zone_tension``.  Raises SurfaceError (no UV map, say)."""
    maps = face.ewrinkles_face.maps
    surface = map_bake.Surface(face)
    vertex_uv = np.zeros((len(surface.rest), 2), np.float32)
    vertex_uv[surface.tris.ravel()] = surface.uv.reshape(-1, 2)  # a vertex takes one of its corners' UVs
    vm = np.zeros((len(surface.rest), N_ZONES), np.float32)
    for i, img in enumerate((maps.mask_a, maps.mask_b)):
        if img is not None and img.size[0] and img.size[1]:
            vm[:, 4 * i: 4 * i + 4] = jimenez.sample_nearest(images.read(img), vertex_uv)
    return mesh.edge_lengths(surface.rest, surface.edges), surface.edges, vm


def write_tension(face, values):
    """Write this frame's tension-driven zone values into the weights group (unless baked)."""
    ng = face.ewrinkles_face.maps.weights_group
    if ng is not None and _value_path(nodegroups.TENSION_NODES[0]) not in baked_paths(ng):
        nodegroups.set_tension(ng, values)


def upgrade(face):
    """A weights group of version 1, with a Value node for each zone's tension, gets its
    tension packed into the three colours of version 2 (``nodegroups.TENSION_NODES``) in
    place: the links, the values, the keys of a farm bake and the expressions' drivers stay.
    Returns a line for the console, or "" when there was nothing to do."""
    ng = face.ewrinkles_face.maps.weights_group
    if ng is None or ng.library is not None or ng.nodes.get(nodegroups.legacy_tension_node(0)) is None:
        return ""
    outs = nodegroups.add_tension_nodes(ng)
    curves = drivers.action_fcurves(ng)
    baked = baked_paths(ng)
    for z in range(N_ZONES):
        old = ng.nodes.get(nodegroups.legacy_tension_node(z))
        if old is None:
            continue
        name, c = nodegroups.tension_slot(z)
        new = ng.nodes[name].outputs[0]
        new.default_value[c] = old.outputs[0].default_value
        for link in list(old.outputs[0].links):
            ng.links.new(outs[z], link.to_socket)
        old_path = _value_path(old.name)
        fc = next((f for f in curves if f.data_path == old_path), None)
        if fc is not None:
            keys = np.array([tuple(k.co) for k in fc.keyframe_points], np.float64).reshape(-1, 2)
            curves.remove(fc)
            _key(new, c, keys[:, 0], keys[:, 1])
            curves = drivers.action_fcurves(ng)
        if old_path in baked:
            baked = (baked - {old_path}) | {_value_path(name)}
        ng.nodes.remove(old)
    if baked:
        ng["ewrinkles_baked"] = sorted(baked)
    nodegroups.upgrade_layout_key(ng)
    return "its tension-driven zone values are packed three to a colour (weights group version 2)"


# ---------------------------------------------------------------------------------------
# farm-safe bake of the values that need the add-on


def _muscle_rows(face):
    """The expressions driven by a muscle's contraction (an add-on property, which a farm
    without the add-on cannot resolve)."""
    expressions = face.ewrinkles_face.maps.expressions
    return [e for e, ex in enumerate(expressions) if ex.source == "MUSCLE" and ex.muscle]


def needs_bake(face):
    """Whether the weights group holds a value that only the add-on computes, which
    :func:`bake_weights` keys: an expression driven by a muscle's contraction, or the
    tension-driven zones.  False for maps driven by shape keys, ordinary properties or
    Manual values alone: their drivers have one variable and no Python expression, so a
    farm evaluates them with no add-on and no bake."""
    if face.ewrinkles_face.maps.weights_group is None:
        return False
    return bool(_muscle_rows(face)) or wants_tension(face)


def bake_weights(face, scene, frame_start, frame_end, progress=None):
    """Key, frame by frame, the weights-group values that only the add-on can compute
    (:func:`needs_bake`): expressions driven by a muscle's contraction and the
    tension-driven zones.  Their drivers are removed while baked.  Shape-key and property
    drivers stay: they need no add-on.  Returns the number of baked channels (0: nothing
    needed a bake, and a previous bake is freed)."""
    maps = face.ewrinkles_face.maps
    ng = maps.weights_group
    if ng is None:
        return 0
    free_weights(face)
    muscle_rows = _muscle_rows(face)
    channels = [(nodegroups.expr_node(e), None) for e in muscle_rows]  # (node, index in its colour)
    if wants_tension(face):
        channels += [nodegroups.tension_slot(z) for z in range(N_ZONES)]
    if not channels:
        return 0
    frames = range(frame_start, frame_end + 1)
    values = np.zeros((len(frames), len(channels)), np.float32)
    current = scene.frame_current
    try:
        for i, frame in enumerate(frames):
            scene.frame_set(frame)  # drivers, animation and our handler (tension) run
            dg = bpy.context.evaluated_depsgraph_get()
            for j, e in enumerate(muscle_rows):
                values[i, j] = maps.expressions[e].muscle.evaluated_get(dg).ewrinkles_muscle.contraction
            for j in range(len(muscle_rows), len(channels)):
                name, c = channels[j]
                values[i, j] = ng.nodes[name].outputs[0].default_value[c]
            if progress is not None:
                progress(i + 1, len(frames))
    finally:  # nothing is keyed yet: a failure leaves the live drivers, on the frame it began on
        scene.frame_set(current)
    paths = list(dict.fromkeys(_value_path(name) for name, _c in channels))
    for path in paths:
        ng.driver_remove(path)
    for (name, c), column in zip(channels, values.T):
        _key(ng.nodes[name].outputs[0], c, frames, column)
    ng["ewrinkles_baked"] = paths
    scene.frame_set(current)  # the keyed values, on the frame the bake began on
    return len(channels)


def _key(out, index, frames, column):
    """Key the socket ``out``'s value (channel ``index`` of a colour; None: a float) on
    each of ``frames`` to the value of ``column``."""
    for frame, v in zip(frames, column):
        if index is None:
            out.default_value = float(v)
            out.keyframe_insert("default_value", frame=frame)
        else:
            out.default_value[index] = float(v)
            out.keyframe_insert("default_value", index=index, frame=frame)


def free_weights(face):
    """Undo :func:`bake_weights`: drop the keys and bring the drivers back."""
    ng = face.ewrinkles_face.maps.weights_group
    baked = baked_paths(ng)
    if not baked:
        return
    curves = drivers.action_fcurves(ng)
    for fc in [fc for fc in curves if fc.data_path in baked]:
        curves.remove(fc)
    del ng["ewrinkles_baked"]
    sync(face, rebind=True)
