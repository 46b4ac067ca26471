"""The Deadline Cloud bundle (farm/deadline/): in the shape of the job bundles that AWS
Deadline Cloud's Blender submitter writes (deadline-cloud-for-blender, pinned in
requirements/), validated by `openjd check`, and run locally with `openjd run` through that
package's real adaptor, `blender-openjd`: one Blender session for the step, a frame per task.
The baked farm.blend renders there without the add-on, the same pixels as a direct render
with it.

There is no Blender executable here (only the pip bpy module): the adaptor starts
tests/tools/bpy_blender.py as its Blender (BLENDER_EXECUTABLE, which the adaptor reads),
with no add-on in reach.  The adaptor runs with Deadline Cloud's telemetry off and a HOME
and temporary folder of the test's own."""

import json
import os
import re
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
BUNDLE = ROOT / "farm" / "deadline"
BIN = Path(sys.executable).parent
ADAPTOR = BIN / "blender-openjd"
INSTALLED = ("openjd-cli and deadline-cloud-for-blender are pinned in requirements/ and installed by "
             "tools/setup_env.sh")


def _package():
    """The installed deadline-cloud-for-blender: its adaptor's folder, and its submitter's own
    job template (the shape the bundle follows)."""
    assert ADAPTOR.is_file(), INSTALLED
    from deadline import blender_adaptor

    root = Path(blender_adaptor.__file__).parent
    submitter = root.parent / "blender_submitter" / "addons" / "deadline_cloud_blender_submitter"
    return root / "BlenderAdaptor", yaml.safe_load((submitter / "default_blender_template.yaml").read_text())


def _env(tmp_path, blender):
    """The environment of `openjd run`: the adaptor on PATH, the stand-in as its Blender, no
    add-on, no PYTHONPATH, telemetry off, HOME and TMPDIR in the test's folder."""
    home = tmp_path / "home"
    (home / "tmp").mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, PATH=f"{BIN}{os.pathsep}{os.environ.get('PATH', '')}", PYTHONPATH="",
               BLENDER_EXECUTABLE=str(blender), DEADLINE_CLOUD_TELEMETRY_OPT_OUT="true", HOME=str(home),
               TMPDIR=str(home / "tmp"), BLENDER_USER_RESOURCES=str(tmp_path / "farm_user"))
    env.pop("EWRINKLES_ADDON_ROOT", None)
    return env


def _blender(tmp_path):
    """A `blender` for the adaptor: the stand-in on this interpreter, with no add-on."""
    exe = tmp_path / "bin" / "blender"
    exe.parent.mkdir()
    shim = ROOT / "tests" / "tools" / "bpy_blender.py"
    exe.write_text(f'#!/bin/sh\nexec "{sys.executable}" "{shim}" "$@"\n')
    exe.chmod(exe.stat().st_mode | stat.S_IEXEC)
    return exe


def _keys(text):
    """The keys of an embedded YAML file whose values are format strings."""
    return [line.split(":", 1)[0] for line in text.splitlines() if line.strip()]


def _action(action):
    return [action["command"], *(re.sub(r"\{\{\s*(\S+?)\s*\}\}", r"{{\1}}", a) for a in action["args"])]


def test_the_template_is_valid_and_in_the_shape_of_the_submitters():
    farmjobs.openjd("check", BUNDLE / "template.yaml")
    adaptor, stock = _package()
    template = yaml.safe_load((BUNDLE / "template.yaml").read_text())
    names = {p["name"] for p in template["parameterDefinitions"]}
    assert all(p.get("description") for p in template["parameterDefinitions"])
    defaults = yaml.safe_load((BUNDLE / "parameter_values.yaml").read_text())["parameterValues"]
    assert {d["name"] for d in defaults} <= names
    (step,) = template["steps"]  # one step
    (stock_step,) = stock["steps"]
    (env,) = step["stepEnvironments"]  # one environment: one Blender for every task
    (stock_env,) = stock_step["stepEnvironments"]
    for when in ("onEnter", "onExit"):
        assert _action(env["script"]["actions"][when]) == _action(stock_env["script"]["actions"][when]), when
    assert _action(step["script"]["actions"]["onRun"]) == _action(stock_step["script"]["actions"]["onRun"])
    assert step["parameterSpace"] == stock_step["parameterSpace"]  # a task per frame of Param.Frames
    # the init and run data: fields of the installed adaptor's schemas, its required ones included
    schema = {k: json.loads((adaptor / "schemas" / f"{k}.schema.json").read_text())
              for k in ("init_data", "run_data")}
    (init,) = env["script"]["embeddedFiles"]
    (run,) = step["script"]["embeddedFiles"]
    for data, kind in ((init["data"], "init_data"), (run["data"], "run_data")):
        keys = set(_keys(data))
        assert keys <= set(schema[kind]["properties"]), (kind, keys - set(schema[kind]["properties"]))
        assert set(schema[kind]["required"]) <= keys, kind
    assert "ewrinkles" not in json.dumps(template["steps"])  # no add-on on the workers


@pytest.mark.render
def test_one_adaptor_session_renders_the_baked_frames_as_a_direct_render(tmp_path):
    _package()
    scene, _face = scenes.animated_render_scene(2)
    scenes.setup_cycles(scene, size=32, samples=2)
    shot = tmp_path / "shot.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(shot))
    farm = tmp_path / "job"
    assert cli.execute(["bake", str(shot), "--save-as", str(farm / "farm.blend"), "--engine", "CYCLES",
                        "--samples", "2", "--resolution", "32", "30"]) == 0
    out = tmp_path / "frames"
    # strict: a line of Blender's with an error or a warning (opening the baked file without the
    # add-on, say) fails the task
    params = [f"FarmDir={farm}", f"OutputDir={out}", "Frames=1-2", "RenderEngine=cycles",
              "StrictErrorChecking=true"]
    args = [a for p in params for a in ("-p", p)]
    log = farmjobs.openjd("run", BUNDLE / "template.yaml", "--step", "Render", *args,
                  env=_env(tmp_path, _blender(tmp_path)), log=tmp_path / "Render.log")
    assert "Frame(INT) = 1" in log and "Frame(INT) = 2" in log
    assert log.count(f"Running command: {tmp_path / 'bin' / 'blender'} --background") == 1  # one session
    assert log.count("BlenderClient: Finished Rendering Frame") == 2
    assert log.count("bpy_blender: add-on loaded: False") == 1  # that session had no add-on
    # the direct render with the add-on: the same frames, the same samples and seed
    assert cli.execute(["render", str(shot), "--out", str(tmp_path / "direct"), "--frames", "1-2",
                        "--engine", "CYCLES", "--samples", "2", "--resolution", "32", "30"]) == 0
    frames = []
    for f in (1, 2):
        got = scenes.load_png(out / f"ViewLayer_frame_{f:04d}.png")  # the adaptor's names
        direct = scenes.load_png(tmp_path / "direct" / f"frame_{f:04d}.png")
        assert got.shape == (32 * 30, 3)
        np.testing.assert_array_equal(got, direct, err_msg=f"frame {f}")
        frames.append(direct)
    assert np.abs(frames[1] - frames[0]).max() > 0.1  # the wrinkles change over the shot
