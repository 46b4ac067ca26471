"""The farm road end to end with every source on one face (muscles with Waters' pull, wrinkle
maps in tension mode, a wrinkle curve, fine wrinkles, a pattern layer and a shedding tear):
frames rendered live by `ewrinkles render`, baked by `ewrinkles bake`, then rendered by
Blender's own command line in a fresh process with no add-on (--factory-startup)."""

import os
import subprocess
import sys
from pathlib import Path

import bpy
import numpy as np
import pytest

from tests.blender import scenes
from tests.blender.test_faults_bake import every_source_face
from wrinkle_addon import cli

ROOT = Path(__file__).resolve().parents[2]
SHIM = ROOT / "tests" / "tools" / "bpy_blender.py"


def _farm_render(blend, out):
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(out.parent / "farm_user"))
    env.pop("PYTHONPATH", None)
    env.pop("EWRINKLES_ADDON_ROOT", None)
    run = subprocess.run([sys.executable, str(SHIM), "-b", "--factory-startup", str(blend), "-o",
                          str(out / "frame_####"), "-F", "PNG", "-x", "1", "-s", "2", "-e", "3", "-a"],
                         cwd=str(out.parent), env=env, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, (run.stdout + run.stderr)[-3000:]
    assert "add-on loaded: False" in run.stderr


@pytest.mark.render
def test_every_source_renders_the_same_on_a_farm_with_no_addon(tmp_path):
    """Pixel for pixel: the geometry and the Waters pull from the Alembic cache, the fine
    wrinkles' shrinkage carried by the cache's UV maps to the farm's stand-in, the
    maps' baked weights, the patterns' and the tear's own trees."""
    _scene, face = every_source_face()
    shot = tmp_path / "shot.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(shot))
    assert cli.execute(["render", str(shot), "--frames", "2-3", "--out", str(tmp_path / "live")]) == 0
    farm_blend = tmp_path / "job" / "farm.blend"
    assert cli.execute(["bake", str(shot), "--frames", "1-3", "--save-as", str(farm_blend)]) == 0
    _farm_render(tmp_path / "job" / "farm.blend", tmp_path / "farm")
    live = {f: scenes.load_png(tmp_path / "live" / f"frame_{f:04d}.png") for f in (2, 3)}
    assert np.abs(live[3] - live[2]).max() > 0.1  # the frames differ: a farm showing one fails
    for f in (2, 3):
        farm = scenes.load_png(tmp_path / "farm" / f"frame_{f:04d}.png")
        # identical on bpy 4.5; on 5.2 six values of frame 2 (three pixels) are one step of the
        # 16-bit PNG apart (9e-6), far below what an 8-bit frame can show (1/255)
        diff = np.abs(farm - live[f])
        assert diff.max() < 2e-5 and (diff > 0).sum() <= 8, (f, float(diff.max()), int((diff > 0).sum()))
