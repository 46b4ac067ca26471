"""Tension-driven wrinkle maps: the zone values packed three to a colour (weights version 2),
and files of version 1, with a Value node for each zone, upgraded on load.

``data/weights_v1.blend`` was written by version 1 itself (``data/make_weights_v1_blend.py``):
a face measuring its tension live and a face whose weights are baked for a farm, each with
the zone weights that version computed on frames 1-4 beside it (``v1_zone_weights``)."""

from pathlib import Path

import bpy
import numpy as np

from wrinkle_addon.core.maps.jimenez import N_ZONES
from wrinkle_addon.glue import drivers
from wrinkle_addon.glue.maps import map_material, nodegroups

V1 = Path(__file__).with_name("data") / "weights_v1.blend"
FRAMES = (1, 2, 3, 4)
SAID = "packed three to a colour"


def _open(path, capfd):
    capfd.readouterr()
    bpy.ops.wm.open_mainfile(filepath=str(path))
    return capfd.readouterr().out


def _links(ng):
    return sorted((lk.from_node.name, lk.from_socket.identifier, lk.to_node.name, lk.to_socket.identifier)
                  for lk in ng.links)


def _weights_by_frame(face):
    rows = []
    for frame in FRAMES:
        bpy.context.scene.frame_set(frame)
        rows.append(map_material.zone_weights(face).ravel())
    return np.array(rows)


def _fresh(face):
    """The weights group version 2 builds for the same layout."""
    maps = face.ewrinkles_face.maps
    ng = bpy.data.node_groups.new("fresh", "ShaderNodeTree")
    nodegroups.build_weights(ng, [ex.name for ex in maps.expressions],
                           [ex.map_index - 1 for ex in maps.expressions], map_material.n_maps(maps))
    return ng


def test_a_frame_writes_eight_values_into_three_colours():
    ng = bpy.data.node_groups.new("w", "ShaderNodeTree")
    nodegroups.build_weights(ng, ["A"], [0], 2)
    values = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8]
    nodegroups.set_tension(ng, values)
    np.testing.assert_allclose(nodegroups.read_tension(ng), values, atol=1e-7)
    colours = ((0.1, 0.2, 0.3, 1), (0.4, 0.5, 0.6, 1), (0.7, 0.8, 0, 1))
    assert [tuple(ng.nodes[n].outputs[0].default_value) for n in nodegroups.TENSION_NODES] == [
        tuple(np.float32(v).item() for v in x) for x in colours]
    # each zone's value reaches its own zone through the colour's channel
    for z in range(N_ZONES):
        name, c = nodegroups.tension_slot(z)
        split = ng.nodes[f"{name} Split"]
        assert split.outputs[c].is_linked and split.mode == "RGB"
    before = [tuple(ng.nodes[n].outputs[0].default_value) for n in nodegroups.TENSION_NODES]
    nodegroups.set_tension(ng, values[:3] + [0.9] + values[4:])  # only colour B changes
    after = [tuple(ng.nodes[n].outputs[0].default_value) for n in nodegroups.TENSION_NODES]
    assert [a != b for a, b in zip(before, after)] == [False, True, False]


def test_a_version_1_file_opens_upgraded_with_its_values_links_and_bake(tmp_path, capfd):
    path = tmp_path / "old.blend"
    path.write_bytes(V1.read_bytes())
    out = _open(path, capfd)
    assert out.count(SAID) == 2, out  # both faces, each said once
    for name in ("Live", "Baked"):
        face = bpy.data.objects[name]
        ng = face.ewrinkles_face.maps.weights_group
        legacy = {nodegroups.legacy_tension_node(z) for z in range(N_ZONES)}
        assert not [n.name for n in ng.nodes if n.name in legacy]
        assert all(n in ng.nodes for n in nodegroups.TENSION_NODES)
        assert ng["ewrinkles_layout"].startswith(f"w{nodegroups.WEIGHTS_VERSION}:")  # saved as wrinkle_layout
        assert "wrinkle_layout" not in ng and "wrinkle_baked" not in ng
        assert nodegroups.weights_layout_matches(ng, [0], 2)  # no rebuild follows
        assert _links(ng) == _links(_fresh(face))  # wired as version 2 builds it
        want = np.array(face["v1_zone_weights"]).reshape(len(FRAMES), -1)
        assert want[1:, 0].min() > 0.1 and np.ptp(want[:, 0]) > 0.5  # the file's tension is animated
        np.testing.assert_allclose(_weights_by_frame(face), want, atol=1e-6, err_msg=name)

    baked = bpy.data.objects["Baked"]
    ng = baked.ewrinkles_face.maps.weights_group
    paths = map_material.baked_paths(ng)
    tension_paths = {f'nodes["{n}"].outputs[0].default_value' for n in nodegroups.TENSION_NODES}
    assert tension_paths <= paths and 'nodes["Expression 0"].outputs[0].default_value' in paths
    assert not [p for p in paths if "Tension 0" in p]
    keyed = {(fc.data_path, fc.array_index): len(fc.keyframe_points) for fc in drivers.action_fcurves(ng)}
    for z in range(N_ZONES):
        name, c = nodegroups.tension_slot(z)
        assert keyed[(f'nodes["{name}"].outputs[0].default_value', c)] == len(FRAMES)
    assert not [p for p, _i in keyed if "Tension 0" in p or "Tension 7" in p]
    # the bake keeps its keys on a frame the handler runs: the live tension does not overwrite them
    bpy.context.scene.frame_set(2)
    want = np.array(baked["v1_zone_weights"]).reshape(len(FRAMES), -1)
    np.testing.assert_allclose(map_material.zone_weights(baked).ravel(), want[1], atol=1e-6)
    # freed, the tension is measured live again and written into the colours
    map_material.free_weights(baked)
    assert not map_material.baked_paths(ng) and not drivers.action_fcurves(ng)
    bpy.context.scene.frame_set(4)
    assert nodegroups.read_tension(ng)[0] > 0.1

    # saved and opened again: nothing left to upgrade
    again = tmp_path / "again.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(again))
    assert SAID not in _open(again, capfd)
    np.testing.assert_allclose(_weights_by_frame(bpy.data.objects["Live"]),
                               np.array(bpy.data.objects["Live"]["v1_zone_weights"]).reshape(len(FRAMES), -1),
                               atol=1e-6)


def test_a_bake_keys_each_tension_channel_and_frees_them(tmp_path):
    from tests.blender.test_faults_frames import _maps_face

    face = _maps_face()
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 4
    live = _weights_by_frame(face)
    assert live[:, 0].max() > 0.1
    k = map_material.bake_weights(face, scene, 1, 4)
    assert k == N_ZONES  # a channel a zone
    ng = face.ewrinkles_face.maps.weights_group
    want = {f'nodes["{n}"].outputs[0].default_value' for n in nodegroups.TENSION_NODES}
    assert map_material.baked_paths(ng) == want
    np.testing.assert_allclose(_weights_by_frame(face), live, atol=1e-6)
    map_material.free_weights(face)
    assert not drivers.action_fcurves(ng)
    np.testing.assert_allclose(_weights_by_frame(face), live, atol=1e-6)
