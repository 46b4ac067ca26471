"""The batch command `ewrinkles` (render, bake, check, sheet): its exit codes, messages,
progress, --json, --chunk, --resume after Ctrl-C, and that it never writes the shot.

Most calls run in this process through ``wrinkle_addon.cli.execute`` (what
``blender -b -c ewrinkles ...`` calls); Ctrl-C and the pip-bpy entry point
(``python -m wrinkle_addon.cli``) run in a child process."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import bpy
import numpy as np
import pytest

from tests.blender import scenes
from wrinkle_addon import cli
from wrinkle_addon.cli import args as cli_args
from wrinkle_addon.cli import files

ROOT = Path(__file__).resolve().parents[2]


def _shot(path, frames=4, size=32, samples=2):
    scene, _face = scenes.animated_render_scene(frames)
    scenes.setup_cycles(scene, size=size, samples=samples)
    scene.frame_start, scene.frame_end = 1, frames
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    return path


def _run(capfd, *argv):
    capfd.readouterr()  # what came before the command
    code = cli.execute([str(a) for a in argv])
    out, err = capfd.readouterr()
    return code, out, err


def _child(*argv, **kw):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.Popen([sys.executable, "-m", "wrinkle_addon.cli", *map(str, argv)], cwd=str(ROOT),
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


# ------------------------------------------------------------------ arguments (no Blender file)
def test_frame_ranges_chunks_and_their_errors():
    assert cli_args.frames("1-4") == [1, 2, 3, 4]
    assert cli_args.frames("7") == [7]
    assert cli_args.frames("1,3,10-12") == [1, 3, 10, 11, 12]
    assert cli_args.frames("1-9:4") == [1, 5, 9]
    assert cli_args.frames("0-2") == [0, 1, 2]
    assert cli_args.frames("3,1-3") == [3, 1, 2]  # in order, each once
    for bad in ("4-1", "a-b", "", "1-", "1-4:0", "-2-1"):  # no frame before 0 in Blender
        with pytest.raises(cli_args.UsageError):
            cli_args.frames(bad)
    frames = list(range(1, 11))
    parts = [cli_args.chunk_of(frames, k, 3) for k in (1, 2, 3)]
    assert parts == [[1, 4, 7, 10], [2, 5, 8], [3, 6, 9]]
    assert sorted(sum(parts, [])) == frames
    assert cli_args.chunk("2/3") == (2, 3)
    for bad in ("0/3", "4/3", "2", "a/b"):
        with pytest.raises(cli_args.UsageError):
            cli_args.chunk(bad)


def test_the_command_is_registered_with_blender():
    assert cli._handle[0] is not None  # bpy.utils.register_cli_command("ewrinkles", ...)


def test_usage_errors_exit_2_with_one_line_that_says_what_to_fix(tmp_path, capfd):
    shot = _shot(tmp_path / "shot.blend")
    cases = [
        (["render", shot, "--out", tmp_path / "o", "--frames", "9-3"], "ends before it starts"),
        (["render", shot, "--out", tmp_path / "o", "--frames", "one"], "bad frame range"),
        (["render", tmp_path / "missing.blend", "--out", tmp_path / "o"], "no such file"),
        (["render", shot, "--out", tmp_path / "o", "--chunk", "5/4"], "bad chunk"),
        (["render", shot], "--out"),
        (["bake", shot, "--frames", "1,3"], "without gaps"),
        (["bake", shot, "--save-as", shot], "the shot itself"),
        (["sheet", tmp_path / "nowhere"], "no folder"),
        (["frobnicate"], "invalid choice"),
    ]
    (tmp_path / "not_a_folder").write_text("a file")
    cases.append((["render", shot, "--out", tmp_path / "not_a_folder" / "o"],
                  "cannot write into the output folder"))
    settings = bpy.context.scene.render.image_settings
    if hasattr(settings, "media_type"):  # Blender 5: movies are a media type
        settings.media_type = "VIDEO"
    settings.file_format = "FFMPEG"
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "movie.blend"))
    cases.append((["render", tmp_path / "movie.blend", "--out", tmp_path / "o"], "renders to a movie"))
    (tmp_path / "junk.blend").write_bytes(b"not a blend file")
    cases.append((["check", tmp_path / "junk.blend"], "cannot open"))
    for argv, says in cases:
        code, _out, err = _run(capfd, *argv)
        assert code == cli_args.USAGE, (argv, code, err)
        line = [x for x in err.splitlines() if x.startswith("ewrinkles:")]
        assert len(line) == 1 and says in line[0], (argv, err[-500:])


def test_a_scene_without_wrinkles_is_a_usage_error(tmp_path, capfd):
    bpy.ops.mesh.primitive_cube_add()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "plain.blend"))
    plain = tmp_path / "plain.blend"
    for command in (["render", plain, "--out", tmp_path / "o"], ["check", plain], ["bake", plain]):
        code, _out, err = _run(capfd, *command)
        assert code == cli_args.USAGE and "no face with wrinkles" in err, (command, err)


@pytest.mark.render
def test_render_json_chunk_contact_sheet_and_the_shot_untouched(tmp_path, capfd):
    shot = _shot(tmp_path / "shot.blend")
    before = shot.read_bytes()
    out = tmp_path / "frames"
    code, stdout, err = _run(capfd, "render", shot, "--out", out, "--frames", "1-4", "--chunk", "2/2",
                             "--json", "--samples", "2", "--resolution", "24", "20", "--contact-sheet")
    assert code == 0, err
    records = [json.loads(line) for line in stdout.splitlines()]  # stdout holds only JSON lines
    assert [r["frame"] for r in records] == [2, 4]
    assert all(set(r) == {"frame", "file", "seconds", "stage_ms"} for r in records)
    assert all(r["stage_ms"] > 0 and r["seconds"] > 0 for r in records)
    assert sorted(p.name for p in out.iterdir()) == ["contact_sheet.png", "frame_0002.png", "frame_0004.png"]
    assert "frame 4 (2/2)" in err and "ETA" in err and "elapsed" in err
    img = bpy.data.images.load(str(out / "frame_0002.png"))
    assert tuple(img.size) == (24, 20)
    sheet = bpy.data.images.load(str(out / "contact_sheet.png"))
    assert tuple(sheet.size) == (2 * 24 + 3 * 4, 20 + 2 * 4)  # two frames side by side, gutters
    assert shot.read_bytes() == before  # never saved


@pytest.mark.render
def test_a_failure_during_the_render_exits_1(tmp_path, capfd):
    _shot(tmp_path / "shot.blend")
    bpy.data.objects.remove(bpy.data.objects["Cam"])
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "nocam.blend"))
    code, _out, err = _run(capfd, "render", tmp_path / "nocam.blend", "--out", tmp_path / "o",
                           "--frames", "1")
    assert code == cli_args.FAILED
    assert "the render of frame 1 failed" in err and "camera" in err.lower()


def test_complete_images_for_resume(tmp_path):
    px = np.random.default_rng(0).random((6, 5, 4)).astype(np.float32)
    from wrinkle_addon.glue import images

    good = Path(images.write(px, str(tmp_path / "good.png")))
    assert files.complete(good)
    data = good.read_bytes()
    for cut in (len(data) - 1, len(data) - 12, len(data) // 2, 7):
        (tmp_path / "cut.png").write_bytes(data[:cut])
        assert not files.complete(tmp_path / "cut.png"), cut
    flipped = bytearray(data)
    flipped[len(data) // 2] ^= 0xFF
    (tmp_path / "flipped.png").write_bytes(bytes(flipped))
    assert not files.complete(tmp_path / "flipped.png")
    assert not files.complete(tmp_path / "absent.png")


@pytest.mark.render(subprocess=True)
def test_ctrl_c_stops_after_the_frame_and_resume_renders_the_rest(tmp_path):
    shot = _shot(tmp_path / "shot.blend", frames=6, size=48, samples=64)
    out = tmp_path / "frames"
    run = _child("render", shot, "--out", out, "--json")
    deadline = time.monotonic() + 120
    while not list(out.glob("frame_*.png")) and time.monotonic() < deadline and run.poll() is None:
        time.sleep(0.05)
    run.send_signal(signal.SIGINT)
    stdout, stderr = run.communicate(timeout=120)
    assert run.returncode == cli_args.STOPPED, stderr[-2000:]
    kept = sorted(p.name for p in out.glob("frame_*.png"))
    assert 1 <= len(kept) < 6, kept
    assert [json.loads(x)["frame"] for x in stdout.splitlines()] == [int(k[6:10]) for k in kept]
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no partial files left
    assert all(files.complete(out / k) for k in kept)
    assert "stopped by Ctrl-C" in stderr and "--resume" in stderr
    # a truncated frame is rendered again; the complete ones are skipped
    first = out / kept[0]
    first.write_bytes(first.read_bytes()[:100])
    run = _child("render", shot, "--out", out, "--resume", "--json")
    stdout, stderr = run.communicate(timeout=300)
    assert run.returncode == 0, stderr[-2000:]
    again = [json.loads(x)["frame"] for x in stdout.splitlines()]
    assert again == [int(kept[0][6:10])] + [f for f in range(1, 7) if f"frame_{f:04d}.png" not in kept]
    assert f"{len(kept) - 1} of 6 frames already done" in stderr
    assert all(files.complete(out / f"frame_{f:04d}.png") for f in range(1, 7))


def test_check_bake_check_and_the_same_refusal_as_the_panel(tmp_path, capfd):
    shot = _shot(tmp_path / "shot.blend")
    before = shot.read_bytes()
    code, out, _err = _run(capfd, "check", shot)
    assert code == cli_args.NOT_READY
    assert 'face "Face": Muscles' in out and "not baked" in out and out.rstrip().endswith("farm-ready: no")
    code, _out, err = _run(capfd, "bake", shot, "--frames", "1-2", "--save-as", tmp_path / "farm" / "f.blend",
                           "--samples", "3")
    assert code == 0, err
    farm = tmp_path / "farm"
    assert (farm / "f.blend").is_file() and (farm / "wrinkle_bake" / "Face.abc").is_file()
    assert not (tmp_path / "wrinkle_bake").exists()  # the bake's files beside the baked file
    assert sorted(p.name for p in (tmp_path / "farm").iterdir()) == ["f.blend", "wrinkle_bake"]
    assert shot.read_bytes() == before
    code, out, _err = _run(capfd, "check", tmp_path / "farm" / "f.blend")
    assert code == 0 and "baked, renders without the add-on" in out
    assert out.rstrip().endswith("farm-ready: yes")
    assert bpy.context.scene.cycles.samples == 3  # the farm file keeps the render settings
    # a refusal: the same message as the panel's Bake for Farm
    bpy.ops.wm.open_mainfile(filepath=str(shot))
    face = bpy.data.objects["Face"]
    face.modifiers.new("Subdivision", "SUBSURF")
    face.modifiers.new("Smooth", "SMOOTH").factor = 0.0  # the subdivision is not the last modifier
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "refused.blend"))
    bpy.context.view_layer.objects.active = face
    with pytest.raises(RuntimeError) as gui:
        bpy.ops.wrinkle.bake()
    message = str(gui.value).removeprefix("Error: ").strip()
    code, _out, err = _run(capfd, "bake", tmp_path / "refused.blend")
    assert code == cli_args.USAGE and message.splitlines()[0] in err, (message, err)
    assert not (tmp_path / "refused_farm.blend").exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_check_counts_a_python_driver_as_not_farm_ready(tmp_path, capfd):
    _shot(tmp_path / "shot.blend")
    cu = bpy.data.objects["Cam"]
    fc = cu.driver_add("location", 0)
    fc.driver.type = "SCRIPTED"
    fc.driver.expression = "__import__('math').sin(frame)"
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "driven.blend"))
    code, out, _err = _run(capfd, "check", tmp_path / "driven.blend")
    assert code == cli_args.NOT_READY and "driver calls Python" in out and "Cam" in out


@pytest.mark.render(subprocess=True)
def test_the_pip_bpy_entry_point(tmp_path):
    shot = _shot(tmp_path / "shot.blend", frames=2)
    run = _child("render", shot, "--out", tmp_path / "o", "--frames", "2", "--json")
    stdout, stderr = run.communicate(timeout=300)
    assert run.returncode == 0, stderr[-2000:]
    assert json.loads(stdout)["frame"] == 2
    run = _child("render", shot, "--out", tmp_path / "o", "--frames", "x")
    _stdout, stderr = run.communicate(timeout=300)
    assert run.returncode == cli_args.USAGE and "bad frame range" in stderr


def test_check_lists_a_sources_problem(tmp_path, capfd):
    _shot(tmp_path / "shot.blend")
    muscle = bpy.data.objects["Face"].ewrinkles_face.muscles[0].object
    muscle.ewrinkles_muscle.n_wrinkles = 1000  # more than the mesh can show: the panel says so
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "dense.blend"))
    code, out, _err = _run(capfd, "check", tmp_path / "dense.blend")
    assert code == cli_args.NOT_READY
    assert "  Muscles: " in out and "asks for 1000 wrinkles, more than the mesh can show" in out, out
