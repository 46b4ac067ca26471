"""Structural snapshots of every node tree the add-on builds in code.

Each test builds one tree in a fixed small configuration with the add-on's own functions
and operators, turns it into plain JSON-able data (:func:`serialise`) and compares that
with ``tests/blender/snapshots/<name>.json``:

* ``stage_wrinkle_output``: the Geometry Nodes output stage ("Wrinkle Output").
* ``map_blend_k1`` .. ``map_blend_k3``: the shared "Wrinkle Map Blend" shader group for
  1, 2 and 3 wrinkle maps.
* ``weights_group``: the per-face "Wrinkle Weights Plane" group for a table of three
  expressions (two shape keys on map 1, one manual expression on map 2), with its drivers.
* ``material`` and ``material_uv_map``: the nodes that Set Up Wrinkle Maps adds to the face
  material (image nodes, UV node, blend and weights group nodes and their links to the
  Principled BSDF), on the render UV map and with the face's own UV map set (which adds a
  Normal Map node).

What a snapshot holds: every node (name, bl_idname, label, the settings in ``SETTINGS``,
custom properties, the default value of every available input that is not linked, and the
value of Value nodes), the group interface in its order (name, identifier, in/out, socket
type, subtype, default, min, max), every link as ``node.socket -> node.socket`` (socket
identifiers, with the name in brackets where it differs; a group's ``Socket_<n>`` are
renumbered in creation order, see ``_interface_ids``), drivers and the tree's custom
properties. Floats are rounded to 6 digits; node locations, socket descriptions and the
sockets a node keeps unavailable (they differ between bpy versions, see ``_available``)
are left out. Nodes and links are sorted; the interface keeps its order, which is part of
the group's API. The same files hold on bpy 4.5 and 5.2: after regenerating, run the
module under .venv52 too.

On a mismatch the test fails with a unified diff of the snapshot against the tree just
built. When the change is intended, regenerate the files and review their diff::

    WRINKLE_UPDATE_SNAPSHOTS=1 .venv45/bin/python -m pytest tests/blender/test_node_snapshots.py

With ``WRINKLE_UPDATE_SNAPSHOTS=1`` a snapshot that differs (or is missing) is written
instead of compared, and its test is reported as skipped with the file's name; snapshots
that match pass as usual.
"""

from __future__ import annotations

import difflib
import json
import os
import re
from pathlib import Path

import bpy
import numpy as np
import pytest

from tests.blender import mapscenes
from wrinkle_addon.glue import stage
from wrinkle_addon.glue.maps import map_material, nodegroups

SNAPSHOTS = Path(__file__).resolve().parent / "snapshots"
UPDATE = os.environ.get("WRINKLE_UPDATE_SNAPSHOTS") == "1"
DIGITS = 6

# Node properties recorded when a node has them (the settings the add-on sets or relies on).
SETTINGS = (
    "data_type", "domain", "operation", "mode", "blend_type", "factor_mode", "use_clamp",
    "clamp_factor", "clamp_result", "space", "uv_map", "interpolation", "extension",
    "projection", "node_tree", "image", "mute",
)
# Nodes whose output sockets hold their value.
VALUE_NODES = {"ShaderNodeValue", "ShaderNodeRGB"}


# --- Serialisation ----------------------------------------------------------------------
def _value(v):
    """A JSON-able copy of a property value: floats rounded, IDs by name, arrays as lists."""
    if v is None or isinstance(v, (bool, int, str)):
        return v
    if isinstance(v, float):
        return round(v, DIGITS) + 0.0  # + 0.0: no "-0.0"
    if isinstance(v, bpy.types.Image):
        return {"name": v.name, "colorspace": v.colorspace_settings.name, "alpha_mode": v.alpha_mode}
    if isinstance(v, bpy.types.ID):
        return v.name
    if hasattr(v, "to_dict"):  # an ID property group
        return _value(v.to_dict())
    if isinstance(v, dict):
        return {str(k): _value(x) for k, x in v.items()}
    return [_value(x) for x in v]


def _interface_ids(tree) -> dict:
    """Interface socket identifier -> the same renumbered 0, 1, 2... in creation order.

    Blender numbers interface sockets ``Socket_<n>`` with a counter that every socket the
    tree ever had advanced: after the weights group was rebuilt five times its sockets are
    Socket_64..79. The history is not the tree's structure, so snapshots show the rank.
    """
    if tree is None:
        return {}
    ids = [item.identifier for item in tree.interface.items_tree if item.item_type == "SOCKET"]
    numbered = sorted((int(i[len("Socket_"):]), i) for i in ids if re.fullmatch(r"Socket_\d+", i))
    return {ident: f"Socket_{rank}" for rank, (_n, ident) in enumerate(numbered)}


def _identifier(s) -> str:
    """The socket's identifier; for a group's sockets the renumbered one (``_interface_ids``)."""
    node = s.node
    if node.bl_idname in ("NodeGroupInput", "NodeGroupOutput"):
        tree = s.id_data
    else:
        tree = getattr(node, "node_tree", None)  # a group node's group
    return _interface_ids(tree).get(s.identifier, s.identifier)


def _socket(s) -> str:
    ident = _identifier(s)
    return ident if s.name == ident else f"{ident} ({s.name})"


def _available(s) -> bool:
    """False for the sockets a node keeps only for other settings (ShaderNodeMix's Vector
    and Color sockets when it mixes floats). They differ between versions: bpy 4.5 gives
    FunctionNodeCompare all of them (A_INT, A_VEC3, A_COL, A_STR, C, Angle ... for a float
    EQUAL), bpy 5.2 only those of its data type and operation."""
    return s.enabled


def _custom(owner) -> dict:
    return {k: _value(owner[k]) for k in owner.keys()}


def _node(node) -> dict:
    out = {"name": node.name, "bl_idname": node.bl_idname}
    if node.label:
        out["label"] = node.label
    for prop in SETTINGS:
        if prop in node.bl_rna.properties:
            value = getattr(node, prop)
            if prop == "mute" and not value:
                continue
            out[prop] = _value(value)
    inputs = {_socket(s): _value(s.default_value) for s in node.inputs
              if _available(s) and not s.is_linked and hasattr(s, "default_value")}
    if inputs:
        out["inputs"] = inputs
    if node.bl_idname in VALUE_NODES:
        out["outputs"] = {_socket(s): _value(s.default_value) for s in node.outputs}
    if node.keys():
        out["properties"] = _custom(node)
    return out


def _interface(tree) -> list:
    items = []
    ids = _interface_ids(tree)
    for item in tree.interface.items_tree:
        if item.item_type == "PANEL":
            items.append({"panel": item.name})
            continue
        entry = {"name": item.name, "identifier": ids.get(item.identifier, item.identifier),
                 "in_out": item.in_out, "socket_type": item.socket_type}
        for key, prop in (("subtype", "subtype"), ("default", "default_value"),
                          ("min", "min_value"), ("max", "max_value")):
            if hasattr(item, prop):
                entry[key] = _value(getattr(item, prop))
        items.append(entry)
    return items


def _drivers(tree) -> list:
    ad = tree.animation_data
    if ad is None:
        return []
    drivers = []
    for fc in ad.drivers:
        drv = fc.driver
        variables = [{"name": var.name, "type": var.type,
                      "targets": [{"id_type": t.id_type, "id": _value(t.id), "data_path": t.data_path}
                                  for t in var.targets]}
                     for var in drv.variables]
        entry = {"data_path": fc.data_path, "array_index": fc.array_index, "type": drv.type,
                 "variables": variables}
        if drv.type == "SCRIPTED":
            entry["expression"] = drv.expression
        drivers.append(entry)
    return sorted(drivers, key=lambda d: (d["data_path"], d["array_index"]))


def serialise(tree, only=None) -> dict:
    """Plain data describing ``tree``; with ``only`` (node names), just those nodes and the
    links that touch them (the add-on's part of a user's material)."""
    nodes = [n for n in tree.nodes if only is None or n.name in only]
    names = {n.name for n in nodes}
    links = [f"{lk.from_node.name}.{_socket(lk.from_socket)} -> {lk.to_node.name}.{_socket(lk.to_socket)}"
             + ("" if lk.is_valid else " [invalid]") + (" [muted]" if lk.is_muted else "")
             for lk in tree.links if lk.from_node.name in names or lk.to_node.name in names]
    data = {
        "tree": {"name": tree.name, "bl_idname": tree.bl_idname},
        "nodes": sorted((_node(n) for n in nodes), key=lambda n: n["name"]),
        "links": sorted(links),
    }
    if hasattr(tree, "interface"):
        interface = _interface(tree)
        if interface:
            data["interface"] = interface
    drivers = _drivers(tree)
    if drivers:
        data["drivers"] = drivers
    if tree.keys():
        data["properties"] = _custom(tree)
    return data


def dump(data: dict) -> str:
    """JSON with one line per node, link, interface socket or driver: a changed setting
    shows as one changed line in a diff, and the files stay small."""
    lines = ["{"]
    keys = sorted(data)
    for i, key in enumerate(keys):
        value = data[key]
        comma = "," if i < len(keys) - 1 else ""
        if isinstance(value, list) and value:
            lines.append(f" {json.dumps(key)}: [")
            lines += [f"  {json.dumps(item, sort_keys=True)}{',' if j < len(value) - 1 else ''}"
                      for j, item in enumerate(value)]
            lines.append(f" ]{comma}")
        else:
            lines.append(f" {json.dumps(key)}: {json.dumps(value, sort_keys=True)}{comma}")
    lines.append("}")
    return "\n".join(lines) + "\n"


def snapshot_diff(name: str, built: str) -> str:
    """A unified diff from the snapshot file to ``built`` ('' when they are equal)."""
    path = SNAPSHOTS / f"{name}.json"
    old = path.read_text() if path.is_file() else ""
    return "".join(difflib.unified_diff(old.splitlines(keepends=True), built.splitlines(keepends=True),
                                        fromfile=f"tests/blender/snapshots/{name}.json",
                                        tofile=f"{name} as built now (bpy {bpy.app.version_string})"))


def check_snapshot(name: str, data: dict) -> None:
    built = dump(data)
    path = SNAPSHOTS / f"{name}.json"
    if path.is_file() and path.read_text() == built:
        return
    if UPDATE:
        SNAPSHOTS.mkdir(exist_ok=True)
        existed = path.is_file()
        path.write_text(built)
        pytest.skip(f"WRINKLE_UPDATE_SNAPSHOTS=1: {'rewrote' if existed else 'created'} "
                    f"tests/blender/snapshots/{name}.json")
    if not path.is_file():
        pytest.fail(f"no snapshot tests/blender/snapshots/{name}.json: create it with "
                    "WRINKLE_UPDATE_SNAPSHOTS=1 (see this module's docstring)", pytrace=False)
    pytest.fail(f"the node tree {name!r} differs from its snapshot; if the change is intended, "
                "regenerate with WRINKLE_UPDATE_SNAPSHOTS=1 and review the diff:\n"
                + snapshot_diff(name, built), pytrace=False)


# --- The trees --------------------------------------------------------------------------
SIZE = 4  # pixels of the data images: only their names and settings reach the snapshots


def _face_with_maps(own_uv_map: bool):
    """The plane of the wrinkle-map tests with a base map, two wrinkle maps, two masks and
    three expressions, set up with the add-on's operators.  Returns the face and the names
    of the nodes that setting up added to its material."""
    rng = np.random.default_rng(0)
    image = rng.uniform(0, 1, (SIZE, SIZE, 4)).astype(np.float32)
    face = mapscenes.skin_plane(SIZE, image, image, image, base=image,
                                keys=("browInnerUp_L", "browDown_L"))
    maps = face.ewrinkles_face.maps
    maps.map_b = mapscenes.data_image("Wrinkle Stretch", image)
    if own_uv_map:
        maps.uv_map = face.data.uv_layers[0].name
    before = {n.name for n in face.active_material.node_tree.nodes}
    assert bpy.ops.wrinkle.setup_wrinkle_maps() == {"FINISHED"}
    rows = (
        ("Surprise", "SHAPE_KEY", "browInnerUp_L", 1, (0.8, 0.8, 0.8, 0.8, 0.0, 0.0, 0.0, 0.0)),
        ("Anger", "SHAPE_KEY", "browDown_L", 1, (-0.6, -0.6, -0.8, -0.8, 0.5, 0.5, 0.0, 0.0)),
        ("Squint", "MANUAL", "", 2, (0.0, 0.0, 0.0, 0.0, 0.3, 0.3, 1.0, 1.0)),
    )
    for name, source, shape_key, map_index, weights in rows:
        assert bpy.ops.wrinkle.add_map_expression() == {"FINISHED"}
        ex = maps.expressions[-1]
        ex.name, ex.source, ex.shape_key = name, source, shape_key
        ex.map_index, ex.weights = map_index, weights
    maps.expressions["Squint"].value = 0.25
    maps.strength = 0.75
    maps.zone_strength[0] = 1.5
    maps.zone_power[1] = 2.0
    assert map_material.status(face) == "", map_material.status(face)
    added = {n.name for n in maps.material.node_tree.nodes} - before
    return face, added


def test_stage_group():
    check_snapshot("stage_wrinkle_output", serialise(stage.ensure_group()))


@pytest.mark.parametrize("k", [1, 2, 3])
def test_map_blend_group(k):
    ng = nodegroups.ensure_blend_group(k)
    assert nodegroups.map_count(ng) == k
    check_snapshot(f"map_blend_k{k}", serialise(ng))


def test_weights_group():
    face, _added = _face_with_maps(own_uv_map=False)
    ng = face.ewrinkles_face.maps.weights_group
    assert ng.name == f"{nodegroups.WEIGHTS_PREFIX} {face.name}"
    check_snapshot("weights_group", serialise(ng))


@pytest.mark.parametrize("own_uv_map", [False, True], ids=["render_uv_map", "own_uv_map"])
def test_material_nodes(own_uv_map):
    face, added = _face_with_maps(own_uv_map)
    nt = face.ewrinkles_face.maps.material.node_tree
    assert (map_material.NORMAL_NODE in added) == own_uv_map
    data = serialise(nt, only=added)
    data["tree"]["material"] = face.ewrinkles_face.maps.material.name
    check_snapshot("material_uv_map" if own_uv_map else "material", data)


def test_every_snapshot_file_has_a_test():
    """A snapshot left behind by a renamed or removed case would never be checked again."""
    names = {"stage_wrinkle_output", "map_blend_k1", "map_blend_k2", "map_blend_k3", "weights_group",
             "material", "material_uv_map"}
    assert {p.stem for p in SNAPSHOTS.glob("*.json")} == names


def test_the_snapshot_catches_drift():
    """One changed default or one removed link makes the serialisation differ, and the
    diff names the change."""
    ng = stage.ensure_group()
    built = dump(serialise(ng))
    assert snapshot_diff("stage_wrinkle_output", built) == "", "the snapshot itself is stale"

    compare = next(n for n in ng.nodes if n.bl_idname == "FunctionNodeCompare")
    compare.inputs["Epsilon"].default_value = 0.01
    diff = snapshot_diff("stage_wrinkle_output", dump(serialise(ng)))
    assert diff and '"Epsilon": 0.001' in diff and '"Epsilon": 0.01' in diff, diff

    compare.inputs["Epsilon"].default_value = 0.001
    assert snapshot_diff("stage_wrinkle_output", dump(serialise(ng))) == ""
    link = next(lk for lk in ng.links if lk.to_node.bl_idname == "GeometryNodeSetPosition"
                and lk.to_socket.identifier == "Offset")
    ng.links.remove(link)
    diff = snapshot_diff("stage_wrinkle_output", dump(serialise(ng)))

    def links(sign):  # the diff's link lines of one side, without the commas between items
        return {line[1:].strip().rstrip(",") for line in diff.splitlines()
                if line.startswith(sign + '  "') and " -> " in line}

    assert links("-") - links("+") == {'"Vector Math.Vector -> Set Position.Offset"'}, diff
    assert '"Offset": [0.0, 0.0, 0.0]' in diff  # the input, unlinked now, shows its default
