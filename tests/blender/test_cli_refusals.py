"""`ewrinkles` refuses bad input with exit 2 and one line on stderr, no traceback: frames
outside Blender's, a tolerance that is not a finite number, an output that is a folder, a
path longer than Blender's paths hold, "//" where there is no .blend file to start from;
"//" is the shot's folder everywhere else; --resume keeps only whole frames of the render's
size; a bake never removes a file it did not make.

The commands run in this process through ``wrinkle_addon.cli.execute``.  Nothing renders:
where a command would, ``commands._render_one`` is replaced by a stand-in that writes a
blank frame of the render's size."""

import os
import struct
import time
import zlib
from pathlib import Path

import bpy
import numpy as np
import pytest

from tests.blender import exportscenes
from tests.blender.test_cli import _run, _shot
from wrinkle_addon.cli import args as cli_args
from wrinkle_addon.cli import commands, files
from wrinkle_addon.glue import images


def _refused(capfd, *argv):
    """The one ``ewrinkles:`` line of a command that must exit 2 with nothing else."""
    code, out, err = _run(capfd, *argv)
    lines = [x for x in err.splitlines() if x.startswith("ewrinkles:")]
    assert code == cli_args.USAGE, (argv, code, err[-2000:])
    assert len(lines) == 1, (argv, err[-2000:])
    assert "Traceback" not in err, (argv, err[-2000:])
    return lines[0].removeprefix("ewrinkles: ")


@pytest.fixture
def rendered(monkeypatch):
    """The frames the render command asks for, each written as a blank image of the render's
    size instead of rendered."""
    frames = []

    def render_one(scene, f, final, tmpdir):
        r = scene.render
        w, h = (n * r.resolution_percentage // 100 for n in (r.resolution_x, r.resolution_y))
        images.write(np.zeros((h, w, 4), np.float32), str(final))
        frames.append(f)

    monkeypatch.setattr(commands, "_render_one", render_one)
    return frames


@pytest.fixture
def no_render(monkeypatch):
    """A command that must refuse never gets to render a frame."""
    def render_one(scene, f, final, tmpdir):
        raise AssertionError(f"frame {f} would be rendered")

    monkeypatch.setattr(commands, "_render_one", render_one)


def _frames_folder(folder, count=1, size=8):
    folder.mkdir(parents=True, exist_ok=True)
    for f in range(1, count + 1):
        images.write(np.full((size, size, 4), 0.5, np.float32), str(folder / f"frame_{f:04d}.png"))
    return folder


def _deep(root, total):
    """A path under ``root`` of ``total`` bytes, of names short enough for the file system."""
    path = str(root)
    while len(path) < total:
        path += "/" + "d" * min(200, total - len(path) - 1)
    return Path(path[:total])


# ------------------------------------------------------------------ frames
def test_the_frame_limits_are_blenders():
    rna = bpy.types.Scene.bl_rna.properties
    for prop in ("frame_start", "frame_end"):
        assert (rna[prop].hard_min, rna[prop].hard_max) == (cli_args.FIRST_FRAME, cli_args.LAST_FRAME)
    res = bpy.types.RenderSettings.bl_rna.properties
    assert res["resolution_x"].hard_max == res["resolution_y"].hard_max == cli_args.MAX_RESOLUTION


def test_frames_outside_blenders_are_refused_before_any_list_is_built():
    assert cli_args.frames("0,1048574") == [0, 1048574]
    assert len(cli_args.frames("0-1048574")) == 1048575
    started = time.perf_counter()
    for bad, says in (("1-2000000000", "frame 2000000000 in"), ("-2-1", "frame -2 in"),
                      ("1048575", "frame 1048575 in"), ("1-9" + "9" * 5000, "bad frame range"),
                      (",".join(["0-1048574"] * 1000), "names more than 1048575 frames"),
                      ("1-4:" + "9" * 5000, "bad frame step"), ("1-4:²", "bad frame step")):
        with pytest.raises(cli_args.UsageError) as refused:
            cli_args.frames(bad)
        assert says in str(refused.value) and len(str(refused.value)) < 400, str(refused.value)
    assert time.perf_counter() - started < 2.0  # nothing was built
    for bad in ("²/3", "1/" + "9" * 5000):
        with pytest.raises(cli_args.UsageError, match="bad chunk"):
            cli_args.chunk(bad)


def test_frames_beyond_blenders_exit_2(tmp_path, capfd, no_render):
    shot = _shot(tmp_path / "shot.blend")
    expected = ('frame 2000000000 in --frames "1-2000000000" is outside Blender\'s frames: '
                "give frames from 0 to 1048574")
    assert _refused(capfd, "render", shot, "--out", tmp_path / "o", "--frames", "1-2000000000") == expected
    assert not (tmp_path / "o").exists()
    assert "frame 1048575 in" in _refused(capfd, "bake", shot, "--frames", "1-1048575")
    assert "frame -1 in" in _refused(capfd, "export", shot, "--format", "usd", "--out", tmp_path / "f.usdc",
                                     "--frames=-1-3")
    assert "frame 2000000000 in" in _refused(capfd, "sheet", _frames_folder(tmp_path / "f"),
                                             "--frames", "2000000000")


def test_samples_resolution_and_chunk_beyond_blenders_exit_2(tmp_path, capfd, no_render):
    shot = _shot(tmp_path / "shot.blend")
    out = tmp_path / "o"
    assert _refused(capfd, "render", shot, "--out", out, "--samples", "99999999999") == (
        "--samples 99999999999 is more than Cycles allows: give 1 to 16777216")
    assert _refused(capfd, "render", shot, "--out", out, "--engine", "EEVEE", "--samples", "3000000000") == (
        "--samples 3000000000 is more than EEVEE allows: give 1 to 2147483647")
    assert _refused(capfd, "render", shot, "--out", out, "--resolution", "100000", "20") == (
        "--resolution 100000 20 is not allowed: W and H must be from 4 to 65536 pixels")
    assert "bad chunk" in _refused(capfd, "render", shot, "--out", out, "--chunk", "²/3")
    assert "more than Cycles allows" in _refused(capfd, "bake", shot, "--samples", "99999999999",
                                                 "--save-as", tmp_path / "farm" / "f.blend")
    assert not out.exists() and not (tmp_path / "farm").exists()  # refused before anything was made


# ------------------------------------------------------------------ --tolerance
def test_a_tolerance_that_is_not_a_finite_number_exits_2(tmp_path, capfd):
    exportscenes.wrinkled_face_with_maps()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))
    for value in ("nan", "inf", "-inf", "-0.5", "NaN"):
        line = _refused(capfd, "export", tmp_path / "shot.blend", "--format", "gltf", "--out",
                        tmp_path / "f.glb", f"--tolerance={value}")  # "-inf" alone would be an option
        assert line == (f"--tolerance {value.lower()} is not allowed: give a finite number of millimetres, "
                        "0 or more (default 0.05)")
    assert not (tmp_path / "f.glb").exists()


# ------------------------------------------------------------------ an output that is a folder
def test_an_output_file_that_is_a_folder_exits_2(tmp_path, capfd, no_render):
    shot = _shot(tmp_path / "shot.blend")
    frames = _frames_folder(tmp_path / "frames")
    (tmp_path / "taken").mkdir()
    assert _refused(capfd, "sheet", frames, "--out", "/") == (
        "--out / is a folder: --out names the file to write, e.g. /contact_sheet.png")
    assert _refused(capfd, "sheet", frames, "--out", tmp_path / "taken") == (
        f"--out {tmp_path / 'taken'} is a folder: --out names the file to write, "
        f"e.g. {tmp_path / 'taken' / 'contact_sheet.png'}")
    assert "is a folder" in _refused(capfd, "sheet", frames, "--out", f"{tmp_path}/new/")
    (frames / "contact_sheet.png").mkdir()  # the default sheet's name taken by a folder
    assert _refused(capfd, "sheet", frames) == (
        f"{frames / 'contact_sheet.png'}, where the sheet goes by default, is a folder: "
        "name the sheet to write with --out")
    assert _refused(capfd, "bake", shot, "--save-as", tmp_path / "taken") == (
        f"--save-as {tmp_path / 'taken'} is a folder: --save-as names the file to write, "
        f"e.g. {tmp_path / 'taken' / 'shot_farm.blend'}")
    for fmt, name in (("gltf", "Face.glb"), ("usd", "Face.usdc")):
        assert _refused(capfd, "export", shot, "--format", fmt, "--out", tmp_path / "taken") == (
            f"--out {tmp_path / 'taken'} is a folder: --out names the file to write, "
            f"e.g. {tmp_path / 'taken' / name}")
    assert sorted(p.name for p in (tmp_path / "taken").iterdir()) == []
    # and a folder to write that is a file
    (tmp_path / "a_file").write_text("a file")
    assert _refused(capfd, "render", shot, "--out", tmp_path / "a_file", "--frames", "1") == (
        f"--out {tmp_path / 'a_file'} is a file: --out names the folder for the frames")
    assert _refused(capfd, "export", shot, "--format", "package", "--out", tmp_path / "a_file") == (
        f"--out {tmp_path / 'a_file'} is a file: --out names the folder for the package "
        "(wrinkles.json and its images)")
    assert (tmp_path / "a_file").read_text() == "a file"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


# ------------------------------------------------------------------ "//"
def test_double_slash_is_the_shots_folder(tmp_path, capfd, rendered):
    shot = _shot(tmp_path / "shot.blend")
    code, _out, err = _run(capfd, "render", shot, "--out", "//frames", "--frames", "2")
    assert code == 0 and rendered == [2], err
    assert (tmp_path / "frames" / "frame_0002.png").is_file()
    assert f"to {tmp_path / 'frames'} in" in err
    assert "is the shot itself" in _refused(capfd, "bake", shot, "--save-as", "//shot.blend")
    assert _refused(capfd, "bake", shot, "--save-as", "//") == (
        f"--save-as // is a folder: --save-as names the file to write, e.g. {tmp_path / 'shot_farm.blend'}")
    (tmp_path / "sub").mkdir()
    assert f"e.g. {tmp_path / 'sub' / 'Face.glb'}" in _refused(capfd, "export", shot, "--format", "gltf",
                                                               "--out", "//sub")
    assert f"e.g. {tmp_path / 'sub' / 'Face.usdc'}" in _refused(capfd, "export", shot, "--format", "usd",
                                                                "--out", "//sub/../sub")


def test_double_slash_without_a_shot_exits_2(tmp_path, capfd, no_render):
    frames = _frames_folder(tmp_path / "frames")
    assert _refused(capfd, "sheet", frames, "--out", "//sheet.png") == (
        '--out //sheet.png starts with "//", which Blender reads as the folder of the .blend file, and there '
        "is none to start from here: give the path from the current folder or from /")
    assert _refused(capfd, "sheet", "//frames").startswith('the folder //frames starts with "//"')
    assert _refused(capfd, "render", "//shot.blend", "--out", tmp_path / "o").startswith(
        'the shot //shot.blend starts with "//"')
    assert not (tmp_path / "o").exists()


# ------------------------------------------------------------------ Blender's path length
def test_paths_longer_than_blenders_exit_2(tmp_path, capfd, no_render):
    shot = _shot(tmp_path / "shot.blend")
    frames = _frames_folder(tmp_path / "frames")
    long = _deep(tmp_path / "long", 1100)
    line = _refused(capfd, "render", shot, "--out", long, "--frames", "1")
    assert line == (f"--out {files.shown(str(long))} is 1100 bytes long as a full path; Blender's file paths "
                    "hold at most 1023 bytes: choose a shorter path")
    assert not (tmp_path / "long").exists()  # nothing made
    # the folder itself fits, a frame in it would not
    near = _deep(tmp_path / "long", 1010)
    line = _refused(capfd, "render", shot, "--out", near, "--frames", "1")
    assert line == (f"--out {files.shown(str(near))} is 1010 bytes long as a full path, too long for the "
                    "files written with it, which take up to 35 bytes more; Blender's file paths hold at "
                    "most 1023 bytes: choose a path of at most 988 bytes")
    assert not (tmp_path / "long").exists()
    assert "as a full path; Blender's file paths hold at most 1023" in _refused(
        capfd, "sheet", frames, "--out", f"{long}.png")
    assert "too long for the files written with it" in _refused(
        capfd, "bake", shot, "--save-as", f"{_deep(tmp_path / 'long', 1000)}.blend")
    for fmt, ext in (("gltf", ".glb"), ("usd", ".usdc"), ("package", "")):
        assert "Blender's file paths hold at most 1023 bytes" in _refused(
            capfd, "export", shot, "--format", fmt, "--out", f"{long}{ext}")
    assert "Blender's file paths hold at most 1023 bytes" in _refused(capfd, "check", f"{long}.blend")
    assert not (tmp_path / "long").exists()
    # multi-byte characters count as the bytes they take
    wide = Path(tmp_path, *["é" * 120] * 5, "x.png")  # about 660 characters, 1270 bytes
    assert "bytes long as a full path; Blender's" in _refused(capfd, "sheet", frames, "--out", wide)


def test_blenders_path_limit():
    rna = bpy.types.RenderSettings.bl_rna.properties["filepath"]
    assert rna.length_max == files.PATH_BYTES + 1  # FILE_MAX, the terminating zero included
    scene = bpy.context.scene
    scene.render.filepath = "/" + "a" * 2000
    assert len(scene.render.filepath) == files.PATH_BYTES  # what Blender keeps of a longer path


# ------------------------------------------------------------------ --resume
def _chunk(kind, data):
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def _png(w, h, rows=None, chunks=None):
    """An 8-bit RGBA PNG of ``w`` x ``h`` whose image data holds ``rows`` rows (all by default)."""
    raw = (b"\0" + b"\x80" * (4 * w)) * (h if rows is None else rows)
    header = _chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0))
    body = chunks if chunks is not None else [_chunk(b"IDAT", zlib.compress(raw))]
    return b"\x89PNG\r\n\x1a\n" + header + b"".join(body) + _chunk(b"IEND", b"")


def test_a_kept_frame_is_a_whole_image_of_the_renders_size(tmp_path):
    def check(data, size=(32, 24), name="f.png"):
        (tmp_path / name).write_bytes(data)
        return files.complete(tmp_path / name, size)

    assert check(_png(32, 24))
    assert check(_png(32, 24), size=None)
    assert not check(_png(16, 24))  # another size
    assert not check(b"\x89PNG\r\n\x1a\n" + _chunk(b"IEND", b""))  # a signature and an end
    assert not check(_png(32, 24, chunks=[]))  # a header and no image
    assert not check(_png(32, 24, rows=23))  # a row short, every CRC good
    assert not check(_png(32, 24, rows=25))
    raw = zlib.compress((b"\0" + b"\x80" * 128) * 24)
    assert check(_png(32, 24, chunks=[_chunk(b"IDAT", raw[:50]), _chunk(b"IDAT", raw[50:])]))  # split data
    assert not check(_png(32, 24, chunks=[_chunk(b"IDAT", raw[:-4])]))  # the stream cut short
    assert not check(_png(32, 24, chunks=[_chunk(b"IDAT", b"garbage")]))
    for cut in (8, 40, len(_png(32, 24)) - 1):
        assert not check(_png(32, 24)[:cut]), cut
    # PNGs Blender writes itself (libpng, 8 and 16 bits, image data in several chunks)
    for depth in ("8", "16"):
        img = bpy.data.images.new("f", 300, 200, alpha=True)
        img.pixels.foreach_set(np.random.default_rng(0).random(300 * 200 * 4).astype(np.float32))
        img.filepath_raw = str(tmp_path / f"blender{depth}.png")
        img.file_format = "PNG"
        scene = bpy.context.scene
        scene.render.image_settings.color_depth = depth
        img.save_render(img.filepath_raw, scene=scene)
        assert files.complete(tmp_path / f"blender{depth}.png", (300, 200)), depth
        assert not files.complete(tmp_path / f"blender{depth}.png", (300, 201)), depth
    # another format: loaded by Blender, its size compared
    exr = images.write(np.zeros((24, 32, 4), np.float32), str(tmp_path / "f.exr"), "OPEN_EXR", "16")
    assert files.complete(exr, (32, 24)) and not files.complete(exr, (24, 32))
    (tmp_path / "junk.exr").write_bytes(b"v/1\x01" + b"\0" * 40)
    assert not files.complete(tmp_path / "junk.exr", (32, 24))


def test_the_render_size():
    r = bpy.context.scene.render
    r.resolution_x, r.resolution_y, r.resolution_percentage = 101, 51, 50
    assert files.render_size(bpy.context.scene) == (50, 25)
    r.use_border, r.use_crop_to_border = True, False
    r.border_min_x, r.border_max_x, r.border_min_y, r.border_max_y = 0.25, 0.75, 0.0, 0.5
    assert files.render_size(bpy.context.scene) == (50, 25)  # the region inside a whole frame
    r.use_crop_to_border = True
    assert files.render_size(bpy.context.scene) == (25, 12)


def test_resume_renders_again_every_frame_that_is_not_whole_or_of_another_size(tmp_path, capfd, rendered):
    shot = _shot(tmp_path / "shot.blend", frames=5, size=32)
    out = tmp_path / "frames"
    out.mkdir()
    (out / "frame_0001.png").write_bytes(_png(32, 32))  # kept
    (out / "frame_0002.png").write_bytes(b"\x89PNG\r\n\x1a\n" + _chunk(b"IEND", b""))
    (out / "frame_0003.png").write_bytes(_png(16, 16))
    (out / "frame_0004.png").write_bytes(_png(32, 32, chunks=[]))
    (out / "frame_0005.png").write_bytes(_png(32, 32)[:-20])
    code, _out, err = _run(capfd, "render", shot, "--out", out, "--resume")
    assert code == 0, err
    assert rendered == [2, 3, 4, 5]
    assert "--resume: 1 of 5 frames already done, skipped" in err
    assert all(files.complete(out / f"frame_{f:04d}.png", (32, 32)) for f in range(1, 6))
    rendered.clear()  # --resolution changes the size a kept frame must have
    code, _out, err = _run(capfd, "render", shot, "--out", out, "--resume", "--resolution", "20", "16",
                           "--frames", "1-2")
    assert code == 0 and rendered == [1, 2], err


# ------------------------------------------------------------------ bake --save-as
def _refused_bake_shot(tmp_path):
    """A shot that the Bake for Farm operator refuses (a Subdivision Surface not last)."""
    _shot(tmp_path / "shot.blend")
    face = bpy.data.objects["Face"]
    face.modifiers.new("Subdivision", "SUBSURF")
    face.modifiers.new("Smooth", "SMOOTH").factor = 0.0
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "refused.blend"))
    return tmp_path / "refused.blend"


def test_a_bake_never_removes_a_file_it_did_not_make(tmp_path, capfd):
    shot = _refused_bake_shot(tmp_path)
    farm = tmp_path / "farm"
    farm.mkdir()
    theirs = farm / ".f.partial.blend"  # another run's, or a file of the user's
    theirs.write_bytes(b"not ours")
    code, _out, err = _run(capfd, "bake", shot, "--save-as", farm / "f.blend")
    assert code == cli_args.USAGE and "Subdivision" in err, err
    assert theirs.read_bytes() == b"not ours"
    assert sorted(p.name for p in farm.iterdir()) == [".f.partial.blend"]  # nothing of ours left
    # a folder as --save-as: refused before anything is written
    assert _refused(capfd, "bake", shot, "--save-as", farm) == (
        f"--save-as {farm} is a folder: --save-as names the file to write, "
        f"e.g. {farm / 'refused_farm.blend'}")
    assert "is a folder" in _refused(capfd, "bake", shot, "--save-as", f"{tmp_path}/later/")
    assert not (tmp_path / "later").exists()
    assert sorted(p.name for p in farm.iterdir()) == [".f.partial.blend"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["farm", "refused.blend", "shot.blend"]


def test_no_partial_frame_sheet_or_folder_is_left_by_a_refusal(tmp_path, capfd, no_render):
    shot = _shot(tmp_path / "shot.blend")
    before = sorted(os.listdir(tmp_path))
    _refused(capfd, "render", shot, "--out", tmp_path / "o", "--frames", "0-1048575")
    _refused(capfd, "sheet", tmp_path, "--out", tmp_path)
    assert sorted(os.listdir(tmp_path)) == before
