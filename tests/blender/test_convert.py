"""Wrinkle map converters (Jimenez et al. 2011, §1.2 and §1.2.1) and the image glue.

Tolerances measured on bpy 4.5.4 and 5.2.3, 32x32 maps with slopes up to 0.9, three seeds,
normal -> PD -> normal with both results written to a file of the format and read back,
against the source normal map's stored values:

* 8-bit PNG: 0.0039 (1 / 255); allowed 2 / 255.
* 16-bit PNG: 1.5e-5 (1 / 65535); allowed 5e-5.
* OpenEXR half: 4.9e-4 (one half step just below 1, 2^-11); allowed 1e-3.
* OpenEXR float: 1.2e-7; allowed 1e-6.
"""

import os
import types

import bpy
import numpy as np
import pytest

from wrinkle_addon.core.maps import jimenez as wm
from wrinkle_addon.glue import images
from wrinkle_addon.ops import convert as convert_ops

SIZE = 32


def _normal_map(size=SIZE, max_slope=0.9, seed=0):
    """Encoded normals (size, size, 3) of random slopes inside the 45 degree cone."""
    rng = np.random.default_rng(seed)
    slopes = rng.uniform(-max_slope, max_slope, (size, size, 2))
    n = np.concatenate([slopes, np.ones((size, size, 1))], axis=-1)
    return wm.encode(n / np.linalg.norm(n, axis=-1, keepdims=True))


def _load(path, non_color=True):
    image = bpy.data.images.load(str(path), check_existing=False)
    if non_color:
        image.colorspace_settings.name = "Non-Color"
    return image


def _file_image(tmp_path, name, rgb, fmt=("PNG", "8")):
    """``rgb`` written to a file in tmp_path and loaded back as a Non-Color image."""
    temp = images.store(name + " temp", rgb, float_buffer=fmt != ("PNG", "8"))
    path = images.save(temp, str(tmp_path / name), *fmt)
    bpy.data.images.remove(temp)
    return _load(path)


def _names():
    return {im.name for im in bpy.data.images}


# --- images.py -----------------------------------------------------------------------------
def test_read_gives_rows_bottom_up_and_store_adds_alpha():
    rgb = np.zeros((4, 6, 3), np.float32)
    rgb[0] = 1.0  # bottom row white
    image = images.store("Rows", rgb, float_buffer=True)
    px = images.read(image)
    assert px.shape == (4, 6, 4) and px.dtype == np.float32 and px.flags.c_contiguous
    np.testing.assert_array_equal(px[0, :, :3], 1.0)
    np.testing.assert_array_equal(px[1:, :, :3], 0.0)
    np.testing.assert_array_equal(px[..., 3], 1.0)
    assert image.colorspace_settings.name == "Non-Color" and image.packed_file is not None


def test_store_reuses_an_image_of_the_same_size_and_replaces_one_of_another():
    first = images.store("Map", np.full((8, 8, 3), 0.25, np.float32))
    group = bpy.data.node_groups.new("Uses Map", "ShaderNodeTree")
    tex = group.nodes.new("ShaderNodeTexImage")
    tex.image = first
    again = images.store("Map", np.full((8, 8, 3), 0.75, np.float32))
    assert again == first and len(bpy.data.images) == 1
    np.testing.assert_allclose(images.read(again)[..., :3], 191 / 255, atol=1e-6)
    bigger = images.store("Map", np.full((16, 8, 4), 0.5, np.float32), float_buffer=True)
    assert bigger.name == "Map" and images.size(bigger) == (8, 16) and bigger.is_float
    assert len(bpy.data.images) == 1 and tex.image == bigger  # the node follows the new image


@pytest.mark.parametrize("float_buffer", [False, True])
def test_stored_images_survive_save_and_reopen(tmp_blend, float_buffer):
    rgb = _normal_map(16)
    image = images.store("Kept", rgb, float_buffer=float_buffer)
    before = images.read(image)
    path = str(tmp_blend("kept"))
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    assert "Kept" not in bpy.data.images
    bpy.ops.wm.open_mainfile(filepath=path)
    image = bpy.data.images["Kept"]
    assert image.colorspace_settings.name == "Non-Color" and image.is_float == float_buffer
    after = images.read(image)
    np.testing.assert_array_equal(after, before)
    np.testing.assert_allclose(after[..., :3], rgb, atol=0.5 / 255 + 1e-6 if not float_buffer else 0)


@pytest.mark.parametrize(
    "fmt, bits, tol",
    [(("PNG", "8"), 8, 0.5 / 255 + 1e-6), (("PNG", "16"), 16, 0.5 / 65535 + 1e-6),
     (("OPEN_EXR", "16"), "half", 2.5e-4), (("OPEN_EXR", "32"), "float", 0.0)],
)
def test_save_writes_the_stored_values_at_the_asked_depth(tmp_path, fmt, bits, tol):
    rgb = np.random.default_rng(1).random((8, 12, 3)).astype(np.float32)
    image = images.store("Data", rgb, float_buffer=True)
    path = images.save(image, str(tmp_path / "sub" / "data"), *fmt)
    assert path.endswith(".png" if fmt[0] == "PNG" else ".exr") and os.path.isfile(path)
    with open(path, "rb") as f:
        head = f.read(4096)
    if fmt[0] == "PNG":
        assert head[24] == bits  # IHDR bit depth
    else:  # channel list: pixel type 1 = half, 2 = float
        pixel_type = int.from_bytes(head[head.index(b"R\x00") + 2:][:4], "little")
        assert pixel_type == {"half": 1, "float": 2}[bits]
    back = _load(path)
    assert back.is_float == (bits != 8)
    np.testing.assert_allclose(images.read(back)[..., :3], rgb, atol=tol)
    assert image.source == "FILE" and image.packed_file is not None  # the image is not changed


def test_save_refuses_unknown_formats_and_relative_paths_of_an_unsaved_file():
    image = images.store("Data", np.zeros((4, 4, 3), np.float32))
    with pytest.raises(images.ImageError, match="Cannot write PNG at 32 bits"):
        images.save(image, "/tmp/x.png", "PNG", "32")
    with pytest.raises(images.ImageError, match="not saved yet"):
        images.save(image, "//x.png")


def test_srgb_tagged_maps_read_as_their_stored_values(tmp_path):
    rgb = _normal_map(8)
    byte = _file_image(tmp_path, "byte", rgb)
    half = _file_image(tmp_path, "sixteen", rgb, ("PNG", "16"))
    for image in (byte, half):
        image.colorspace_settings.name = "sRGB"
        assert images.colour_warning(image) and "Non-Color" in images.colour_warning(image)
    # measured: 8-bit pixels are the stored bytes whatever the tag; 16-bit ones are linearised
    np.testing.assert_allclose(_raw_pixels(byte)[..., :3], rgb, atol=0.5 / 255 + 1e-6)
    assert np.abs(_raw_pixels(half)[..., :3] - rgb).max() > 0.1
    np.testing.assert_allclose(images.read(byte)[..., :3], rgb, atol=0.5 / 255 + 1e-6)
    np.testing.assert_allclose(images.read(half)[..., :3], rgb, atol=0.5 / 65535 + 1e-6)
    assert half.colorspace_settings.name == "sRGB"  # the tag is restored
    half.colorspace_settings.name = "Non-Color"
    assert images.colour_warning(half) is None


def _raw_pixels(image):
    w, h = image.size
    buf = np.empty(w * h * 4, np.float32)
    image.pixels.foreach_get(buf)
    return buf.reshape(h, w, 4)


def test_checks_name_the_images(tmp_path):
    a = images.store("A", np.zeros((8, 8, 3), np.float32))
    b = images.store("B", np.zeros((8, 16, 3), np.float32))
    images.check_same_size([a, a])
    with pytest.raises(images.ImageError, match=r"'A' is 8x8, 'B' is 16x8"):
        images.check_same_size([a, b])
    images.check_square(a)
    with pytest.raises(images.ImageError, match=r"'B' is 16x8.*square"):
        images.check_square(b)
    gone = _file_image(tmp_path, "gone", np.zeros((4, 4, 3), np.float32))
    gone.reload()
    os.remove(bpy.path.abspath(gone.filepath))
    gone.reload()
    message = r"'gone\.png' has no pixels: its file .*gone\.png.* is missing"
    with pytest.raises(images.ImageError, match=message):
        images.read(gone)


# --- operators ---------------------------------------------------------------------------
@pytest.mark.parametrize(
    "file_format, tol",
    [("PNG_8", 2 / 255), ("PNG_16", 5e-5), ("EXR_16", 1e-3), ("EXR_32", 1e-6)],
)
def test_normal_pd_normal_round_trip_through_files(tmp_path, file_format, tol):
    rgb = _normal_map()
    fmt = {"PNG_8": ("PNG", "8"), "PNG_16": ("PNG", "16"), "EXR_16": ("OPEN_EXR", "16"),
           "EXR_32": ("OPEN_EXR", "32")}[file_format]
    source = _file_image(tmp_path, "face", rgb, fmt)
    stored = images.read(source)
    ext = ".png" if fmt[0] == "PNG" else ".exr"
    assert bpy.ops.wrinkle.convert_to_derivative(
        source=source.name, filepath=str(tmp_path / "face_pd"), file_format=file_format) == {"FINISHED"}
    pd = bpy.data.images[f"{source.name} PD"]
    assert bpy.path.abspath(pd.filepath) == str(tmp_path / f"face_pd{ext}") and pd.packed_file is None
    assert pd.colorspace_settings.name == "Non-Color" and pd.is_float == (file_format != "PNG_8")
    pd_px = images.read(pd)
    np.testing.assert_array_equal(pd_px[..., 2], 0.0)
    np.testing.assert_allclose(pd_px[..., :3], wm.normal_to_derivative(stored), atol=tol)

    assert bpy.ops.wrinkle.convert_to_normal(
        source=pd.name, output="Face Again", filepath=str(tmp_path / "again"), file_format=file_format,
    ) == {"FINISHED"}
    again = _load(tmp_path / f"again{ext}")
    err = np.abs(images.read(again)[..., :3] - stored[..., :3]).max()
    assert err <= tol, f"round trip error {err} (allowed {tol})"
    assert bpy.data.images["Face Again"].colorspace_settings.name == "Non-Color"


def test_conversion_kept_in_the_blend_file_is_8_bit_for_8_bit_sources_and_float_for_float(tmp_path):
    rgb = _normal_map(16)
    byte = images.store("Byte", rgb)
    flt = images.store("Float", rgb, float_buffer=True)
    bpy.ops.wrinkle.convert_to_derivative(source="Byte")
    bpy.ops.wrinkle.convert_to_derivative(source="Float", output="Float Slopes")
    out8, out32 = bpy.data.images["Byte PD"], bpy.data.images["Float Slopes"]
    assert not out8.is_float and out32.is_float
    for out in (out8, out32):
        assert out.colorspace_settings.name == "Non-Color" and out.packed_file is not None
        assert out.filepath == ""
    np.testing.assert_allclose(images.read(out32)[..., :3], wm.normal_to_derivative(images.read(flt)),
                               atol=1e-6)
    np.testing.assert_allclose(images.read(out8)[..., :3], wm.normal_to_derivative(images.read(byte)),
                               atol=0.5 / 255 + 1e-6)
    # running again reuses the output image
    bpy.ops.wrinkle.convert_to_derivative(source="Byte")
    assert "Byte PD.001" not in bpy.data.images and len(bpy.data.images) == 4


def test_difference_map(tmp_path):
    base = _normal_map(16, seed=1)
    wrinkle = _normal_map(16, seed=2)
    images.store("Base", base, float_buffer=True)
    images.store("Wrinkled", wrinkle, float_buffer=True)
    assert bpy.ops.wrinkle.make_difference_map(base="Base", wrinkle="Wrinkled") == {"FINISHED"}
    diff = bpy.data.images["Wrinkled Diff"]
    assert diff.colorspace_settings.name == "Non-Color" and diff.is_float
    d = images.read(diff)[..., :3]
    np.testing.assert_allclose(d, 0.5 + 0.5 * (wrinkle - base), atol=1e-6)
    np.testing.assert_allclose(wm.decode(base) + 2 * wm.decode(d), wm.decode(wrinkle), atol=1e-5)
    bpy.ops.wrinkle.make_difference_map(base="Base", wrinkle="Base", output="Zero")
    np.testing.assert_array_equal(images.read(bpy.data.images["Zero"])[..., :3], 0.5)


def test_background_progress_lines(capfd):
    images.store("Face", _normal_map(16))
    bpy.ops.wrinkle.convert_to_derivative(source="Face")
    out = capfd.readouterr().out
    assert "Expression Wrinkles: converting Face: 1/8" in out and "converting Face: 8/8 100%" in out


def _direct(cls, **props):
    """Run ``cls.execute`` on a stand-in operator, to see the set it returns (bpy.ops raises
    on an ERROR report in background mode, so the return value is lost there)."""
    fake = types.SimpleNamespace(output="", filepath="", file_format="PNG_8", reports=[])
    fake.__dict__.update(props)
    for name in ("sources", "compute", "_image", "_check_path", "suffix", "verb"):
        attr = getattr(cls, name)
        fake.__dict__[name] = types.MethodType(attr, fake) if callable(attr) else attr
    fake.report = lambda kind, text: fake.reports.append((set(kind), text))
    return cls.execute(fake, bpy.context), fake.reports


def _grey_image(tmp_path):
    scene = bpy.data.scenes.new("grey")
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_mode = "BW"
    temp = images.store("grey temp", np.full((8, 8, 3), 0.5, np.float32))
    path = str(tmp_path / "grey.png")
    temp.save_render(path, scene=scene)
    bpy.data.images.remove(temp)
    bpy.data.scenes.remove(scene)
    return _load(path)


BAD_INPUTS = [
    ("convert_to_derivative", {"source": ""}, "Choose the normal map image"),
    ("convert_to_derivative", {"source": "Nothing"}, "There is no image called 'Nothing'"),
    ("convert_to_normal", {"source": "Missing"}, r"'Missing' has no pixels: its file .*missing\.png"),
    ("convert_to_derivative", {"source": "Grey"}, "Normal map 'Grey' has 1 channel; it needs RGB"),
    ("make_difference_map", {"base": "Base", "wrinkle": "Small"},
     r"same size: 'Base' is 16x16, 'Small' is 8x8"),
    ("make_difference_map", {"base": "Base", "wrinkle": ""}, "Choose the wrinkle normal map image"),
    ("convert_to_derivative", {"source": "Base", "output": "Base"}, "'Base' is one of the sources"),
    ("convert_to_derivative", {"source": "Base", "filepath": "//pd.png"}, "not saved yet"),
]


@pytest.mark.parametrize("op, props, message", BAD_INPUTS,
                         ids=[f"{b[0]}-{i}" for i, b in enumerate(BAD_INPUTS)])
def test_bad_input_is_refused_with_a_clear_message(tmp_path, op, props, message):
    images.store("Base", _normal_map(16))
    images.store("Small", _normal_map(8))
    _grey_image(tmp_path).name = "Grey"
    missing = _file_image(tmp_path, "missing", _normal_map(8))
    missing.name = "Missing"
    os.remove(bpy.path.abspath(missing.filepath))
    missing.reload()
    before = _names()
    with pytest.raises(RuntimeError, match=message):
        getattr(bpy.ops.wrinkle, op)(**props)
    assert _names() == before
    cls = {c.bl_idname: c for c in convert_ops.classes}[f"wrinkle.{op}"]
    result, reports = _direct(cls, **props)
    assert result == {"CANCELLED"}
    assert len(reports) == 1 and reports[0][0] == {"ERROR"}
    assert _names() == before


def test_operators_need_an_image_to_run():
    assert not bpy.ops.wrinkle.convert_to_derivative.poll()
    images.store("Face", _normal_map(4))
    assert bpy.ops.wrinkle.convert_to_derivative.poll()


def test_srgb_tagged_source_gives_a_warning_and_the_right_numbers(tmp_path, capfd):
    rgb = _normal_map(16)
    source = _file_image(tmp_path, "tagged", rgb, ("PNG", "16"))
    source.colorspace_settings.name = "sRGB"
    capfd.readouterr()
    bpy.ops.wrinkle.convert_to_derivative(source=source.name)
    captured = capfd.readouterr()
    assert "tagged 'sRGB'" in captured.out + captured.err
    pd = images.read(bpy.data.images[f"{source.name} PD"])
    np.testing.assert_allclose(pd[..., :3], wm.normal_to_derivative(rgb), atol=1e-4)
    assert source.colorspace_settings.name == "sRGB"


def test_every_property_has_a_name_and_a_tooltip():
    for cls in convert_ops.classes:
        assert cls.__doc__.strip() and {"REGISTER", "UNDO"} <= cls.bl_options
        category, name = cls.bl_idname.split(".")
        rna = getattr(getattr(bpy.ops, category), name).get_rna_type()
        props = [p for p in rna.properties if p.identifier != "rna_type"]
        assert {"output", "filepath", "file_format"} <= {p.identifier for p in props}
        for prop in props:
            assert prop.name.strip() and prop.description.strip(), f"{cls.__name__}.{prop.identifier}"


def test_relative_output_path_next_to_the_saved_blend_file_survives_reopening(tmp_blend):
    rgb = _normal_map(16)
    images.store("Face", rgb)
    path = str(tmp_blend("face"))
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wrinkle.convert_to_derivative(source="Face", filepath="//maps/face_pd", file_format="PNG_16")
    pd = bpy.data.images["Face PD"]
    assert pd.filepath == "//maps/face_pd.png" and pd.packed_file is None and pd.is_float
    expected = images.read(pd)
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    pd = bpy.data.images["Face PD"]
    assert pd.colorspace_settings.name == "Non-Color"
    np.testing.assert_array_equal(images.read(pd), expected)
    source = images.read(bpy.data.images["Face"])
    np.testing.assert_allclose(expected[..., :3], wm.normal_to_derivative(source), atol=1e-4)


def test_undo_removes_the_result():
    images.store("Face", _normal_map(8))
    bpy.ops.ed.undo_push(message="start")
    bpy.ops.wrinkle.convert_to_derivative(source="Face")
    bpy.ops.ed.undo_push(message="converted")  # what the interface does after an UNDO operator
    assert "Face PD" in bpy.data.images
    bpy.ops.ed.undo()
    assert "Face PD" not in bpy.data.images
    face = images.read(bpy.data.images["Face"])
    np.testing.assert_allclose(face[..., :3], _normal_map(8), atol=0.5 / 255 + 1e-6)
    bpy.ops.ed.redo()
    assert "Face PD" in bpy.data.images
    pd = images.read(bpy.data.images["Face PD"])
    np.testing.assert_allclose(pd[..., :3], wm.normal_to_derivative(face), atol=0.5 / 255 + 1e-6)
