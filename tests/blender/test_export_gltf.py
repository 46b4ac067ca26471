"""glTF export: wrinkle morph targets by Blender's glTF exporter, round-tripped through
Blender's glTF importer."""

import json
import os
import shutil
import struct
import subprocess
from pathlib import Path

import bpy
import numpy as np
import pytest

from tests.blender import exportscenes, scenes
from wrinkle_addon.glue import images
from wrinkle_addon.glue.errors import WrinkleError
from wrinkle_addon.glue.export import glb, gltf


def _glb_json(path):
    data = path.read_bytes()
    n = struct.unpack("<I", data[12:16])[0]
    return json.loads(data[20:20 + n])


def _live(face, frames):
    """The wrinkled face's evaluated positions (object space) on each frame."""
    out = {}
    for f in frames:
        bpy.context.scene.frame_set(f)
        out[f] = scenes.evaluated_positions(face)
    return out


def _rest(face):
    co = np.empty((len(face.data.vertices), 3), np.float32)
    face.data.vertices.foreach_get("co", co.ravel())
    return co


def _import(path):
    before = set(bpy.data.objects)
    assert bpy.ops.import_scene.gltf(filepath=str(path), import_unused_materials=True) == {"FINISHED"}
    new = [o for o in bpy.data.objects if o not in before and o.type == "MESH"]
    assert len(new) == 1
    return new[0]


def _matching(imported_rest, rest):
    """For each imported vertex the original vertex at the same rest position (the
    exporter splits vertices along UV seams; every copy sits where its original is)."""
    from mathutils.kdtree import KDTree

    tree = KDTree(len(rest))
    for i, p in enumerate(rest):
        tree.insert(p, i)
    tree.balance()
    idx = np.array([tree.find(p)[1] for p in imported_rest])
    gap = np.linalg.norm(rest[idx] - imported_rest, axis=1).max()
    assert gap < 1e-6
    return idx


@pytest.fixture
def exported(tmp_path):
    face, _muscle = exportscenes.wrinkled_face_with_maps()
    path = tmp_path / "face.glb"
    frames = (1, 5, exportscenes.LAST)
    live = _live(face, frames)
    rest = _rest(face)
    report = gltf.export(bpy.context, face, str(path), 1, exportscenes.LAST)
    return face, path, report, live, rest, frames


def test_round_trip_matches_the_live_face(exported):
    face, path, report, live, rest, frames = exported
    assert report["targets"] >= 1 and report["within_tolerance"]
    assert report["max_error_mm"] <= 0.05
    wrinkle = max(np.abs(live[f] - scenes.squash_vertical(rest, 1.0, scenes.HEIGHT)).max() for f in frames)
    assert wrinkle > 0
    # the face itself is as it was: its names, its material, no leftover copy
    assert face.name == "Face" and face.data.name == "Face"
    assert [o.name for o in bpy.data.objects if o.name.startswith("Face")] == ["Face"]
    assert [m.name for m in face.data.materials] == ["Skin"] and "ewrinkles" not in face.data.materials[0]

    ob = _import(path)
    keys = ob.data.shape_keys.key_blocks
    names = [kb.name for kb in keys[1:]]
    assert names[0] == "BrowsUp" and len(names) == 1 + report["targets"]
    assert all(n.startswith("Wrinkle ") for n in names[1:])
    idx = _matching(_rest(ob), rest)
    scale = 1000.0  # metres to mm (unit scale 1, object scale 1)
    # the file's animation starts at time 0 on the first frame (1), which the importer puts on frame 0
    for f in frames:
        bpy.context.scene.frame_set(f - 1)
        got = scenes.evaluated_positions(ob)
        err = np.linalg.norm(got - live[f][idx], axis=1).max() * scale
        assert err <= 0.05 + 1e-3, (f, err)
    # the wrinkles are in the file: without the wrinkle targets the error is far larger
    bpy.context.scene.frame_set(5 - 1)
    for kb in keys:
        if kb.name.startswith("Wrinkle"):
            kb.mute = True
    bare = np.linalg.norm(scenes.evaluated_positions(ob) - live[5][idx], axis=1).max() * scale
    assert bare > 10 * 0.05


def test_an_engine_shades_with_the_live_normals(exported):
    """The engine's normal, NORMAL plus the weighted morph-target normals read from the file,
    against the live wrinkled face's vertex normals: the wrinkle targets' normals are refit
    (Blender's own deltas of each shape key alone are several degrees off)."""
    face, path, report, _live, rest, frames = exported
    assert report["normals"] == "refit"
    assert report["normal_error_deg"][0] < report["normal_error_deg_before"][0] / 2
    doc = glb.Glb(str(path))
    prim, _names = doc.mesh("Face")
    weights = doc.weights(len(prim["targets"]))
    where = glb.vertex_map(doc.accessor(prim["attributes"]["POSITION"]), rest)
    assert where is not None and len(weights) == exportscenes.LAST
    for f in frames:
        normal = doc.accessor(prim["attributes"]["NORMAL"]).astype(np.float64)
        for w, target in zip(weights[f - 1], prim["targets"]):
            normal += w * doc.accessor(target["NORMAL"])
        normal = normal @ glb.TO_GLTF  # Blender's axes
        normal /= np.linalg.norm(normal, axis=1, keepdims=True)
        bpy.context.scene.frame_set(f)
        ev = face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
        live = np.empty((len(ev.vertices), 3), np.float32)
        ev.vertex_normals.foreach_get("vector", live.ravel())
        angle = np.degrees(np.arccos(np.clip(np.sum(normal * live[where], axis=1), -1, 1)))
        assert angle.max() < 2.0, (f, angle.max())


def test_the_textures_and_the_table_arrive(exported):
    face, path, report, _live_, _rest_, _frames = exported
    doc = _glb_json(path)
    assert {i["name"] for i in doc["images"]} >= {"Wrinkle PD", "Mask A", "Mask B"}
    extras = json.loads(doc["materials"][0]["extras"]["ewrinkles"])
    assert extras["images"]["maps"][0] == "Wrinkle PD" and extras["images"]["masks"] == ["Mask A", "Mask B"]
    assert extras["expressions"][0]["shape_key"] == "BrowsUp"
    assert len(extras["animation"]["zone_weights"]) == exportscenes.LAST
    sources = {n: images.read(bpy.data.images[n]) for n in ("Wrinkle PD", "Mask A", "Mask B")}
    before = set(bpy.data.images)
    ob = _import(path)
    new = {img.name.split(".")[0]: img for img in bpy.data.images if img not in before}
    for name, px in sources.items():
        img = new[name]
        assert tuple(img.size) == (exportscenes.MAP_SIZE,) * 2
        got = images.read(img)  # the stored numbers, whatever the importer's colour tag
        assert np.abs(got - px).max() <= 1.0 / 65535 + 1e-6, name  # 16-bit copies
    assert json.loads(ob.data.materials[0]["ewrinkles"])["format"] == "expression-wrinkles/wrinkle-maps"


VALIDATOR = Path(__file__).resolve().parents[1] / "tools" / "gltf_validator"


def test_the_khronos_validator_finds_no_error(exported):
    """The file is valid glTF 2.0 by the Khronos validator (tests/tools/gltf_validator/, run
    under Node): what an engine's importer expects."""
    _face, path, report, *_rest = exported
    node = shutil.which("node")
    if node is None or not (VALIDATOR / "node_modules" / "gltf-validator").is_dir():
        if os.environ.get("CI", "").lower() not in ("", "0", "false"):
            pytest.fail("the glTF validator is missing: tools/setup_system.sh installs it (npm ci)")
        pytest.skip("the glTF validator is not installed: bash tools/setup_system.sh")
    run = subprocess.run([node, str(VALIDATOR / "validate.js"), str(path)], capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 0, run.stderr
    result = json.loads(run.stdout)
    assert result["errors"] == 0, result["messages"]
    # only "may be unused" notes for the wrinkle textures, which no glTF material slot reads,
    # and for the tangents, which the wrinkle maps' shader reads (the material has no normal texture)
    codes = {m["code"] for m in result["messages"]}
    assert codes <= {"UNUSED_OBJECT", "UNUSED_MESH_TANGENT"}, result["messages"]
    info = result["info"]
    assert info["hasMorphTargets"] and info["animationCount"] == 1 and info["hasTextures"]
    assert {r["image"]["bits"] for r in info["resources"] if "image" in r} == {16}  # the package's depth


def test_gltf_separate_gets_its_normals_refit_too(tmp_path):
    face, _muscle = exportscenes.wrinkled_face_with_maps()
    report = gltf.export(bpy.context, face, str(tmp_path / "face.gltf"), 1, exportscenes.LAST)
    assert report["normals"] == "refit" and (tmp_path / "face.bin").is_file()
    assert report["normal_error_deg"][0] < report["normal_error_deg_before"][0] / 2
    ob = _import(tmp_path / "face.gltf")
    assert ob.data.shape_keys.key_blocks[-1].name.startswith("Wrinkle")


def test_k_follows_the_tolerance(tmp_path):
    face, _muscle = exportscenes.wrinkled_face_with_maps()
    face.ewrinkles_face.muscles[0].object.ewrinkles_muscle.contraction = 0.0
    m = face.ewrinkles_face.muscles[0].object
    for f, c in ((1, 0.0), (3, 1.0), (6, 0.2), (9, 0.8)):
        m.ewrinkles_muscle.contraction = c
        m.keyframe_insert("ewrinkles_muscle.contraction", frame=f)
    loose = gltf.export(bpy.context, face, str(tmp_path / "a.glb"), 1, 9, tolerance_mm=1.0)
    tight = gltf.export(bpy.context, face, str(tmp_path / "b.glb"), 1, 9, tolerance_mm=1e-4)
    capped = gltf.export(bpy.context, face, str(tmp_path / "c.glb"), 1, 9, tolerance_mm=0.0, max_targets=1)
    assert loose["targets"] < tight["targets"]
    assert capped["targets"] == 1 and not capped["within_tolerance"]
    assert capped["max_error_mm"] > tight["max_error_mm"]


def test_refusals(tmp_path):
    face, _muscle = exportscenes.wrinkled_face_with_maps()
    with pytest.raises(WrinkleError, match="not a .glb or .gltf"):
        gltf.export(bpy.context, face, str(tmp_path / "face.fbx"), 1, 9)
    with pytest.raises(WrinkleError, match="ends before it starts"):
        gltf.export(bpy.context, face, str(tmp_path / "face.glb"), 9, 1)
    plain = scenes.make_face("Plain")
    with pytest.raises(WrinkleError, match="no wrinkles"):
        gltf.export(bpy.context, plain, str(tmp_path / "plain.glb"), 1, 2)
    assert not list(tmp_path.iterdir())


def test_the_operator_reports_k_and_refuses_with_a_message(tmp_path):
    face, _muscle = exportscenes.wrinkled_face_with_maps()
    bpy.context.view_layer.objects.active = face
    selected = {o.name for o in bpy.context.selected_objects}
    path = tmp_path / "op.glb"
    assert bpy.ops.wrinkle.export_gltf(filepath=str(path), frame_start=1, frame_end=5) == {"FINISHED"}
    assert path.is_file()
    with pytest.raises(RuntimeError, match="not a .glb or .gltf"):
        bpy.ops.wrinkle.export_gltf(filepath=str(tmp_path / "op.obj"))
    assert bpy.context.scene.frame_current == 1  # the scene as it was
    assert {o.name for o in bpy.context.selected_objects} == selected
    assert bpy.context.view_layer.objects.active == face
