"""The Open Job Description bundle (farm/openjd/): validated by `openjd check`, then run
locally step by step with `openjd run` on a small shot in two chunks.  Its frames, rendered
without the add-on, match a direct render with the add-on pixel for pixel.

There is no Blender executable here (only the pip bpy module): the bundle's commands run
through tests/tools/bpy_blender.py, which replays Blender's command line on the module."""

import stat
import sys
from pathlib import Path

import bpy
import numpy as np
import pytest
import yaml

from tests.blender import farmjobs, scenes
from wrinkle_addon import cli

ROOT = Path(__file__).resolve().parents[2]
BUNDLE = ROOT / "farm" / "openjd"



def _blender(tmp_path):
    """A `blender` for the bundle: the stand-in on this interpreter, the add-on in reach of -c."""
    exe = tmp_path / "bin" / "blender"
    exe.parent.mkdir()
    exe.write_text(f'#!/bin/sh\nEWRINKLES_ADDON_ROOT="{ROOT}" exec "{sys.executable}" '
                   f'"{ROOT / "tests" / "tools" / "bpy_blender.py"}" "$@"\n')
    exe.chmod(exe.stat().st_mode | stat.S_IEXEC)
    return exe


def test_the_template_is_valid_and_the_defaults_name_its_parameters():
    farmjobs.openjd("check", BUNDLE / "template.yaml")
    template = yaml.safe_load((BUNDLE / "template.yaml").read_text())
    names = {p["name"] for p in template["parameterDefinitions"]}
    assert {"BlendFile", "Frames", "ChunkSize", "OutputDir", "Engine", "Samples", "ResolutionX",
            "ResolutionY"} <= names
    assert all(p.get("description") for p in template["parameterDefinitions"])
    defaults = yaml.safe_load((BUNDLE / "parameter_values.yaml").read_text())["parameterValues"]
    assert {d["name"] for d in defaults} <= names
    steps = {s["name"]: s for s in template["steps"]}
    assert list(steps) == ["Bake", "Render", "Assemble"]
    assert steps["Render"]["dependencies"] == [{"dependsOn": "Bake"}]
    assert steps["Assemble"]["dependencies"] == [{"dependsOn": "Render"}]
    render = steps["Render"]["script"]["embeddedFiles"][0]["data"]
    assert "--factory-startup" in render and "-c ewrinkles" not in render  # no add-on on the render workers


def _pixels(path):
    img = bpy.data.images.load(str(path), check_existing=False)
    px = np.empty(img.size[0] * img.size[1] * 4, np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px


@pytest.mark.render
def test_a_local_run_in_two_chunks_matches_a_direct_render_pixel_for_pixel(tmp_path):
    scene, _face = scenes.animated_render_scene(4)
    scenes.setup_cycles(scene, size=40, samples=3)
    shot = tmp_path / "shot.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(shot))
    out = tmp_path / "job"
    params = [f"BlendFile={shot}", f"OutputDir={out}", "Frames=1-4", "ChunkSize=2", "Engine=CYCLES",
              "Samples=3", "ResolutionX=40", "ResolutionY=36", f"BlenderExecutable={_blender(tmp_path)}"]
    args = [a for p in params for a in ("-p", p)]
    logs = {}
    for step in ("Bake", "Render", "Assemble"):
        logs[step] = farmjobs.openjd("run", BUNDLE / "template.yaml", "--step", step, *args,
                             log=tmp_path / f"{step}.log")
    assert "Frame(CHUNK[INT]) = 1-2" in logs["Render"] and "Frame(CHUNK[INT]) = 3-4" in logs["Render"]
    assert logs["Render"].count("bpy_blender: add-on loaded: False") == 2  # each chunk without the add-on
    assert "bpy_blender: add-on loaded: True" in logs["Bake"]
    assert (out / "farm.blend").is_file() and (out / "wrinkle_bake" / "Face.abc").is_file()
    assert (out / "contact_sheet.png").is_file()
    # the direct render with the add-on: the same frames, the same samples and seed
    assert cli.execute(["render", str(shot), "--out", str(tmp_path / "direct"), "--frames", "1-4",
                        "--engine", "CYCLES", "--samples", "3", "--resolution", "40", "36"]) == 0
    frames = []
    for f in range(1, 5):
        farm = _pixels(out / "frames" / f"frame_{f:04d}.png")
        direct = _pixels(tmp_path / "direct" / f"frame_{f:04d}.png")
        assert farm.size == 40 * 36 * 4
        np.testing.assert_array_equal(farm, direct, err_msg=f"frame {f}")
        frames.append(direct)
    assert np.abs(frames[3] - frames[0]).max() > 0.1  # the wrinkles change over the shot
