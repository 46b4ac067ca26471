"""The glTF export as engines load it: three.js's and Babylon.js's own glTF loaders under
Node (tests/tools/engines/, pinned by its package-lock.json) read the exported .glb, and
these tests assert what each binds from the materials, the parts and the animation.

A partial-derivative wrinkle map bound as a normal map shades the whole face with a normal
pointing into the skin; so the material's normal must be the base normal map or none, and
the wrinkle maps and masks only in the material's extras (docs/wrinkle_package.md)."""

import json
import os
import shutil
import struct
import subprocess
from pathlib import Path

import bpy
import numpy as np
import pytest

from tests.blender import exportscenes
from wrinkle_addon.glue.export import gltf

ENGINES = Path(__file__).resolve().parents[1] / "tools" / "engines"
WRINKLE_IMAGES = {"Wrinkle PD", "Mask A", "Mask B"}


def _node():
    node = shutil.which("node")
    if node is None or not (ENGINES / "node_modules" / "three").is_dir():
        if os.environ.get("CI", "").lower() not in ("", "0", "false"):
            pytest.fail("the engines' loaders are missing: tools/setup_system.sh installs them (npm ci)")
        pytest.skip("the engines' loaders are not installed: bash tools/setup_system.sh")
    return node


def bindings(engine, path):
    """What ``engine`` ("three" or "babylon") binds from the file: its script's JSON."""
    run = subprocess.run([_node(), str(ENGINES / f"{engine}_bindings.mjs"), str(path)], capture_output=True,
                         text=True, timeout=120)
    assert run.returncode == 0, run.stderr[-3000:]
    return json.loads(run.stdout.strip().splitlines()[-1])


def _glb_json(path):
    data = Path(path).read_bytes()
    n = struct.unpack("<I", data[12:16])[0]
    return json.loads(data[20:20 + n])


def _bound(mesh):
    """{slot: texture name} of the textures bound in any of the mesh's materials."""
    return {slot: name for m in mesh["materials"] for slot, name in m["slots"].items() if name}


@pytest.fixture
def studio_glb(tmp_path):
    face, _muscle = exportscenes.engine_face()
    path = tmp_path / "face.glb"
    report = gltf.export(bpy.context, face, str(path), 1, exportscenes.LAST)
    return face, path, report


def test_three_binds_the_base_normal_map_and_no_wrinkle_map(studio_glb):
    _face, path, report = studio_glb
    three = bindings("three", path)
    face = next(m for m in three["meshes"] if m["name"] == "Face")
    bound = _bound(face)
    assert bound == {"normalMap": "Skin Normal"}, bound  # the base map, and nothing else
    assert not WRINKLE_IMAGES & set(bound.values())
    skin = face["materials"][0]
    assert "ewrinkles" in skin["userData"]  # the wrinkle maps' table, for the engine's shader
    # the colour is the material's own (its chain is procedural), not the exporter's white
    np.testing.assert_allclose(skin["color"], exportscenes.SKIN_COLOUR[:3], atol=1e-6)
    # the file names the base map as the normal texture, the maps only in the extras
    doc = _glb_json(path)
    mat = next(m for m in doc["materials"] if m["name"] == "Skin")
    image = doc["images"][doc["textures"][mat["normalTexture"]["index"]]["source"]]["name"]
    assert image == "Skin Normal"
    extras = json.loads(mat["extras"]["ewrinkles"])
    assert extras["images"]["base"] == "Skin Normal" and extras["images"]["maps"][0] == "Wrinkle PD"
    assert "Wrinkle PD" in report["textures"]


def test_babylon_binds_a_bump_texture_only_from_the_base_map(studio_glb, tmp_path):
    _face, path, _report = studio_glb
    babylon = bindings("babylon", path)
    face = next(m for m in babylon["meshes"] if m["name"].startswith("Face"))
    assert set(_bound(face)) == {"bumpTexture"}
    # and with no base normal map, no normal at all: the skin's own
    plain, _muscle = exportscenes.wrinkled_face_with_maps()
    bare = tmp_path / "bare.glb"
    gltf.export(bpy.context, plain, str(bare), 1, exportscenes.LAST)
    for engine in ("babylon", "three"):
        meshes = bindings(engine, bare)["meshes"]
        assert [_bound(m) for m in meshes] == [{}], (engine, meshes)
    assert "normalTexture" not in _glb_json(bare)["materials"][0]


def test_the_parts_travel_with_the_face_and_their_keys_are_played(studio_glb):
    face, path, report = studio_glb
    assert report["parts"] == ["Eyes"]
    three = bindings("three", path)
    eyes = next(m for m in three["meshes"] if m["name"] == "Eyes")
    assert eyes["parent"] == "Face" and eyes["morphTargets"] == ["BrowsUp"]
    # the film material reads as a blended, nearly clear surface, not an opaque white one
    cornea = eyes["materials"][0]
    np.testing.assert_allclose(cornea["color"], (0.9, 0.9, 0.9), atol=1e-6)
    doc = _glb_json(path)
    film = next(m for m in doc["materials"] if m["name"] == "Cornea")
    assert film["alphaMode"] == "BLEND"
    assert film["pbrMetallicRoughness"]["baseColorFactor"][3] == pytest.approx(0.1)
    # the part's weights are its driver's values on every frame: the face's BrowsUp
    tracks = {t["name"]: t for a in three["animations"] for t in a["tracks"]}
    assert {"Face.morphTargetInfluences", "Eyes.morphTargetInfluences"} <= set(tracks)
    index = {n["name"]: i for i, n in enumerate(doc["nodes"])}
    node = index["Eyes"]
    assert node in doc["nodes"][index["Face"]]["children"]
    keys = face.data.shape_keys
    want = []
    for f in range(1, exportscenes.LAST + 1):
        bpy.context.scene.frame_set(f)
        want.append(keys.key_blocks["BrowsUp"].value)
    channel = next(c for a in doc["animations"] for c in a["channels"] if c["target"].get("node") == node)
    sampler = next(a for a in doc["animations"] if channel in a["channels"])["samplers"][channel["sampler"]]
    got = _accessor(path, doc, sampler["output"])
    np.testing.assert_allclose(got.ravel()[: len(want)], want, atol=1e-5)


def test_the_animation_starts_at_time_zero(studio_glb):
    _face, path, _report = studio_glb
    for animation in bindings("three", path)["animations"]:
        for track in animation["tracks"]:
            assert track["first"] == 0.0, track
            assert track["last"] == pytest.approx((exportscenes.LAST - 1) / bpy.context.scene.render.fps)
    assert all(a["from"] == 0 for a in bindings("babylon", path)["animations"])


def _accessor(path, doc, index):
    """The float data of accessor ``index`` in the .glb at ``path``."""
    data = Path(path).read_bytes()
    n = struct.unpack("<I", data[12:16])[0]
    binary = data[20 + n + 8:]
    acc = doc["accessors"][index]
    view = doc["bufferViews"][acc["bufferView"]]
    width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[acc["type"]]
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    return np.frombuffer(binary, np.float32, acc["count"] * width, start).reshape(acc["count"], width)


def test_the_sample_head_reads_right_in_both_engines(tmp_path):
    """The sample head as Add Sample Head makes it, with wrinkles on: its skin's normal is a
    bump of procedural pores, its colour a procedural chain, its corneas a film.  No engine
    binds any of it as a texture; the eyes, lashes and teeth come along, each with its own
    material, and no material is the exporter's opaque white."""
    assert bpy.ops.wrinkle.add_sample_head() == {"FINISHED"}
    face = bpy.context.active_object
    assert bpy.ops.wrinkle.enable() == {"FINISHED"}
    path = tmp_path / "head.glb"
    report = gltf.export(bpy.context, face, str(path), 1, 2)
    assert report["parts"] == [face.name + " Eyes and Mouth"]
    three = bindings("three", path)
    assert all(_bound(m) == {} for m in three["meshes"]), [_bound(m) for m in three["meshes"]]
    materials = {m["name"]: m for mesh in three["meshes"] for m in mesh["materials"]}
    assert {"Sample Skin", "Sample Eye", "Sample Cornea", "Sample Teeth", "Sample Lashes"} <= set(materials)
    assert all(m["color"] != [1.0, 1.0, 1.0] for m in materials.values()), materials
    babylon = bindings("babylon", path)
    assert all(_bound(m) == {} for m in babylon["meshes"])


# --------------------------------------------------------------------------- one frame rendered by three.js
RENDER_SIZE = 128


def _chromium():
    exe = shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        if os.environ.get("CI", "").lower() not in ("", "0", "false"):
            pytest.fail("Chromium is missing: tools/setup_system.sh installs it (apt: chromium)")
        pytest.skip("Chromium is not installed: bash tools/setup_system.sh")
    _node()  # and three.js
    return exe


def three_render(glb, out, time, camera, light, size=RENDER_SIZE):
    """``glb`` at ``time`` (s) rendered by three.js in headless Chromium (software WebGL) to
    ``out``: ``camera`` (cx, cy, half) and ``light`` (direction towards it, strength) in the
    file's axes (tests/tools/engines/render.html).  Returns the (size, size, 3) pixels, row 0
    at the top, in [0, 1]."""
    import functools
    import http.server
    import threading

    exe = _chromium()
    root = out.parent / "www"
    root.mkdir(exist_ok=True)
    for name in ("node_modules", "render.html"):
        if not (root / name).exists():
            (root / name).symlink_to(ENGINES / name)
    shutil.copy(glb, root / "face.glb")
    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *_args):  # no line per request on stderr
            pass

    handler = functools.partial(Quiet, directory=str(root))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    try:
        (cx, cy, half), ((lx, ly, lz), sun) = camera, light
        url = (f"http://127.0.0.1:{server.server_address[1]}/render.html?file=face.glb&time={time}"
               f"&size={size}&cx={cx}&cy={cy}&half={half}&lx={lx}&ly={ly}&lz={lz}&sun={sun}&ambient=0")
        run = subprocess.run([exe, "--headless=new", "--no-sandbox", "--use-angle=swiftshader",
                              "--enable-unsafe-swiftshader", "--hide-scrollbars",
                              f"--window-size={size},{size}", "--virtual-time-budget=60000",
                              f"--screenshot={out}", url],
                             capture_output=True, text=True, timeout=180)
        assert run.returncode == 0 and out.is_file(), run.stderr[-3000:]
    finally:
        server.shutdown()
        server.server_close()
    return _pixels(out)


def _pixels(path):
    """The PNG's stored values (sRGB-encoded, as written), (H, W, 3), row 0 at the top: read
    as Non-Color, so that an 8-bit and a 16-bit file give the same numbers."""
    img = bpy.data.images.load(str(path), check_existing=False)
    try:
        img.colorspace_settings.name = "Non-Color"
        w, h = img.size
        px = np.empty(w * h * 4, np.float32)
        img.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(img)
    return px.reshape(h, w, 4)[::-1, :, :3]


def blender_render(scene, frame, out):
    scene.frame_set(frame)
    scene.render.filepath = str(out)
    bpy.ops.render.render(write_still=True)
    return _pixels(out)


@pytest.mark.render
def test_three_renders_the_wrinkles_as_blender_does(tmp_path):
    """One wrinkled frame and the rest frame, rendered by Cycles from the live face and by
    three.js from the exported .glb with the same orthographic camera and the same grazing
    sun: the face covers the same pixels, its brightness is Blender's, and the wrinkles (the
    wrinkled frame less the rest frame) shade the same places."""
    from tests.blender import scenes

    face, _muscle = scenes.wrinkled_face()
    face.data.materials.append(bpy.data.materials.new("Skin"))
    scenes.animate_shape_key(face, [(1, 0.0), (5, 1.0)])
    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, 5
    scenes.add_camera_and_light(scene)
    scenes.setup_cycles(scene, size=RENDER_SIZE, samples=16)
    scene.view_settings.view_transform = "Standard"  # three.js writes plain sRGB
    scene.world = None  # no light but the sun (5.x's new worlds have a grey Background node)
    scene.render.film_transparent = False
    scene.cycles.filter_width = 0.01  # no pixel filter: three.js draws without antialiasing
    glb = tmp_path / "face.glb"
    gltf.export(bpy.context, face, str(glb), 1, 5)
    cam, sun = scene.camera, next(o for o in scene.objects if o.type == "LIGHT")
    # Blender's axes to the file's: (x, y, z) -> (x, z, -y); the sun shines along its -Z
    towards = -(sun.matrix_world.to_3x3() @ __import__("mathutils").Vector((0.0, 0.0, -1.0)))
    light = ((towards.x, towards.z, -towards.y), sun.data.energy)
    camera = (cam.location.x, cam.location.z, cam.data.ortho_scale / 2)
    fps = scene.render.fps
    got = {f: three_render(glb, tmp_path / f"three_{f}.png", (f - 1) / fps, camera, light) for f in (1, 5)}
    want = {f: blender_render(scene, f, tmp_path / f"blender_{f}.png") for f in (1, 5)}
    lum = {k: {f: img.mean(axis=2) for f, img in v.items()} for k, v in (("three", got), ("blender", want))}
    # the silhouettes at rest (the wrinkled frame's furrows are black in places: no light)
    mask_t, mask_b = lum["three"][1] > 0.05, lum["blender"][1] > 0.05
    iou = (mask_t & mask_b).sum() / (mask_t | mask_b).sum()
    both = mask_t & mask_b
    ratio = lum["three"][5][both].mean() / lum["blender"][5][both].mean()
    dt = (lum["three"][5] - lum["three"][1])[both]
    db = (lum["blender"][5] - lum["blender"][1])[both]
    r = float(np.corrcoef(dt, db)[0, 1])
    print(f"three.js against Cycles: silhouette IoU {iou:.3f}, brightness ratio {ratio:.3f}, "
          f"wrinkle shading r {r:.3f} (|wrinkle signal| {np.abs(db).mean():.3f})")
    assert iou > 0.95
    assert 0.75 < ratio < 1.33
    assert np.abs(db).mean() > 0.01  # there are wrinkles to compare
    assert r > 0.8
