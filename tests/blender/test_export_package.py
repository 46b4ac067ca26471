"""The wrinkle-map package: wrinkles.json and its images written, read back onto a face
with the same shape keys, and rendering as the exporting face does."""

import json

import bpy
import numpy as np
import pytest

from tests.blender import exportscenes, scenes
from wrinkle_addon.glue import images
from wrinkle_addon.glue.errors import WrinkleError
from wrinkle_addon.glue.export import package
from wrinkle_addon.glue.maps import map_material


def _write(tmp_path, **kw):
    face, _muscle = exportscenes.wrinkled_face_with_maps()
    folder = tmp_path / "pkg"
    report = package.write(bpy.context, face, str(folder), 1, exportscenes.LAST, **kw)
    return face, folder, report


def test_layout(tmp_path):
    face, folder, report = _write(tmp_path)
    doc = json.loads((folder / "wrinkles.json").read_text())
    assert doc["format"] == "expression-wrinkles/wrinkle-maps" and doc["version"] == package.VERSION
    assert doc["encoding"] == "partial-derivative"
    assert doc["images"] == {"base": None, "maps": ["map_1.png", None], "masks": ["mask_a.png", "mask_b.png"]}
    assert sorted(report["files"]) == sorted(["wrinkles.json", "map_1.png", "mask_a.png", "mask_b.png"])
    assert [z["name"] for z in doc["zones"]][:2] == ["Forehead Outer L", "Forehead Outer R"]
    assert doc["zones"][3]["mask"] == "A" and doc["zones"][3]["channel"] == "A"
    (ex,) = doc["expressions"]
    assert ex == {"name": "Brows", "map": 1, "weights": [1.0, 1.0, 0, 0, 0, 0, 0, 0],
                  "source": "SHAPE_KEY", "shape_key": "BrowsUp"}
    # the zone weights of every frame, as the face's weights group computes them
    w = np.array(doc["animation"]["zone_weights"])
    assert w.shape == (exportscenes.LAST, 2, 8) and doc["animation"]["frames"] == list(range(1, 10))
    for f in (1, 5, 9):
        bpy.context.scene.frame_set(f)
        np.testing.assert_allclose(w[f - 1], map_material.zone_weights(face), atol=1e-6)
    assert w[4, 0, 0] == pytest.approx(1.0) and w[0, 0, 0] == 0.0
    # the images hold the face's numbers (16-bit PNG, linear)
    maps = face.ewrinkles_face.maps
    for name, img in (("map_1.png", maps.map_a), ("mask_a.png", maps.mask_a)):
        back = bpy.data.images.load(str(folder / name), check_existing=False)
        assert np.abs(images.read(back) - images.read(img)).max() < 2.0 / 65535


def test_exr_images(tmp_path):
    _face, folder, report = _write(tmp_path, image_format="OPEN_EXR")
    assert "map_1.exr" in report["files"] and (folder / "mask_b.exr").is_file()


def test_import_binds_to_the_shape_keys(tmp_path):
    _face, folder, _report = _write(tmp_path)
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    face, _muscle = exportscenes.wrinkled_face_with_maps(maps=False)
    unbound = package.read(bpy.context, face, str(folder))
    assert unbound == []
    maps = face.ewrinkles_face.maps
    assert maps.material is not None and maps.map_a is not None and maps.mask_a is not None
    ex = maps.expressions[0]
    assert (ex.name, ex.source, ex.shape_key) == ("Brows", "SHAPE_KEY", "BrowsUp")
    assert tuple(ex.weights)[:2] == (1, 1)
    bpy.context.scene.frame_set(5)
    assert map_material.zone_weights(face)[0, 0] == pytest.approx(1.0)


def test_import_falls_back_to_manual_and_refuses_bad_packages(tmp_path):
    _face, folder, _report = _write(tmp_path)
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    face, _muscle = exportscenes.wrinkled_face_with_maps(maps=False)
    face.data.shape_keys.key_blocks["BrowsUp"].name = "Other"
    assert package.read(bpy.context, face, str(folder)) == ['Brows: no shape key "BrowsUp", so it is Manual']
    with pytest.raises(WrinkleError, match="holds no wrinkles.json"):
        package.read(bpy.context, face, str(tmp_path))
    doc = json.loads((folder / "wrinkles.json").read_text())
    (folder / "wrinkles.json").write_text(json.dumps({**doc, "version": 99}))
    with pytest.raises(WrinkleError, match="version 99"):
        package.read(bpy.context, face, str(folder))
    (folder / "wrinkles.json").write_text(json.dumps({**doc, "zone_strength": [1.0]}))
    with pytest.raises(WrinkleError, match="damaged"):
        package.read(bpy.context, face, str(folder))
    (folder / "wrinkles.json").write_text(json.dumps(doc))
    (folder / "mask_b.png").unlink()
    images_before = len(bpy.data.images)
    with pytest.raises(WrinkleError, match="lacks its image"):
        package.read(bpy.context, face, str(folder))
    assert len(bpy.data.images) == images_before  # nothing left behind


def test_refusals(tmp_path):
    plain = scenes.make_face("Plain")
    with pytest.raises(WrinkleError, match="no wrinkle maps"):
        package.write(bpy.context, plain, str(tmp_path / "p"), 1, 2)
    face, _muscle = exportscenes.wrinkled_face_with_maps()
    with pytest.raises(WrinkleError, match="ends before it starts"):
        package.write(bpy.context, face, str(tmp_path / "p"), 3, 2)


@pytest.mark.render
def test_the_imported_package_renders_as_the_exporting_face(tmp_path, render_small):
    face, folder, _report = _write(tmp_path)
    scene = bpy.context.scene
    scenes.add_camera_and_light(scene)
    face.ewrinkles_face.maps.strength = 3.0  # a visible difference between with and without
    package.write(bpy.context, face, str(folder), 1, exportscenes.LAST)
    scene.frame_set(5)
    exporting = render_small(scene, tmp_path / "a.png", size=48, samples=4)
    face.ewrinkles_face.maps.strength = 0.0
    without = render_small(scene, tmp_path / "b.png", size=48, samples=4)

    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    scene = bpy.context.scene
    face, _muscle = exportscenes.wrinkled_face_with_maps(maps=False)
    scenes.add_camera_and_light(scene)
    assert package.read(bpy.context, face, str(folder)) == []
    scene.frame_set(5)
    imported = render_small(scene, tmp_path / "c.png", size=48, samples=4)
    maps_effect = np.abs(exporting - without)[..., :3].max()
    assert maps_effect > 0.05
    assert np.abs(imported - exporting)[..., :3].max() < 0.02 * maps_effect + 2.0 / 65535


def test_the_operators(tmp_path):
    face, _muscle = exportscenes.wrinkled_face_with_maps()
    bpy.context.view_layer.objects.active = face
    folder = tmp_path / "op"
    assert bpy.ops.wrinkle.export_wrinkle_package(directory=str(folder)) == {"FINISHED"}
    assert (folder / "wrinkles.json").is_file()
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    face, _muscle = exportscenes.wrinkled_face_with_maps(maps=False)
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.import_wrinkle_package(directory=str(folder)) == {"FINISHED"}
    assert face.ewrinkles_face.maps.expressions[0].shape_key == "BrowsUp"
    with pytest.raises(RuntimeError, match="not a wrinkle-map package|holds no wrinkles.json"):
        bpy.ops.wrinkle.import_wrinkle_package(directory=str(tmp_path))
