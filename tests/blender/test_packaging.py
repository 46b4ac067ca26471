"""The extension zip: built by tools/build_extension.py, installed like "Install from Disk"."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
EXTENSION_ID = "expression_wrinkles"
INSTALLED_MODULE = f"bl_ext.user_default.{EXTENSION_ID}"

# Runs in a fresh interpreter with its own BLENDER_USER_RESOURCES: installs the zip the
# way Preferences > Get Extensions > Install from Disk does, then reports as JSON.
INSTALL_SCRIPT = r"""
import json, sys, traceback
import bpy
import addon_utils

zip_path, name = sys.argv[1], sys.argv[2]
result = {"install_error": None}
try:
    bpy.ops.extensions.package_install_files(
        filepath=zip_path, repo="user_default", enable_on_install=True
    )
except Exception:
    result["install_error"] = traceback.format_exc()
mod = sys.modules.get(name)
result["check"] = list(addon_utils.check(name))
result["in_preferences"] = name in bpy.context.preferences.addons
result["addon_enabled_flag"] = bool(getattr(mod, "__addon_enabled__", False))
result["module_file"] = getattr(mod, "__file__", None)
# the batch command, as `blender -c ewrinkles ...` reaches it in the installed extension
cli = sys.modules.get(name + ".cli")
result["cli_registered"] = cli is not None and cli._handle[0] is not None
result["cli_help"] = cli.execute(["--help"]) if cli else None
result["cli_missing_file"] = cli.execute(["check", "/nonexistent/shot.blend"]) if cli else None

errors = []
addon_utils.disable(name, default_set=True, handle_error=lambda ex: errors.append(
    "".join(traceback.format_exception(type(ex), ex, ex.__traceback__))))
result["unregister_errors"] = errors
result["check_after_disable"] = list(addon_utils.check(name))
result["cli_after_disable"] = cli is not None and cli._handle[0] is not None
# Leave factory state before exiting: avoids the bpy 4.5 exit hang (tests/conftest.py).
bpy.ops.wm.read_factory_settings(use_empty=True)
print("WRINKLE_RESULT " + json.dumps(result), flush=True)
"""


def expected_files() -> set[str]:
    """What the zip must hold: the manifest plus wrinkle_addon's files, nothing else."""
    package = ROOT / "wrinkle_addon"
    files = {"blender_manifest.toml"}
    for path in package.rglob("*"):
        rel = path.relative_to(package)
        if path.is_file() and "__pycache__" not in rel.parts and path.suffix not in (".pyc", ".pyo"):
            files.add(rel.as_posix())
    return files


@pytest.fixture(scope="module")
def extension_zip(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("dist")
    proc = subprocess.run(
        [sys.executable, str(ROOT / "tools" / "build_extension.py"), "--output-dir", str(out)],
        capture_output=True,
        text=True,
        timeout=300,
        stdin=subprocess.DEVNULL,
    )
    assert proc.returncode == 0, f"build failed:\n{proc.stdout}\n{proc.stderr}"
    zips = list(out.glob("*.zip"))
    assert len(zips) == 1, f"expected one zip in {out}, found {zips}\n{proc.stdout}"
    return zips[0]


def test_zip_holds_only_the_addon(extension_zip):
    with zipfile.ZipFile(extension_zip) as zf:
        names = [n for n in zf.namelist() if not n.endswith("/")]
    assert "__init__.py" in names and "blender_manifest.toml" in names, names
    for name in names:
        top = name.split("/")[0]
        assert top not in ("tests", "sample_scenes", "benchmarks", "tools"), name
        assert "__pycache__" not in name.split("/") and not name.endswith((".pyc", ".pyo")), name
    assert set(names) == expected_files()


def test_manifest(extension_zip):
    with zipfile.ZipFile(extension_zip) as zf:
        manifest = tomllib.loads(zf.read("blender_manifest.toml").decode("utf-8"))
    assert manifest["id"] == EXTENSION_ID
    assert manifest["blender_version_min"] == "4.2.0"
    assert extension_zip.name == f"{EXTENSION_ID}-{manifest['version']}.zip"


def test_install_from_disk_enables_the_addon(extension_zip, tmp_path):
    env = dict(os.environ)
    for folder in ("CONFIG", "SCRIPTS", "DATAFILES", "EXTENSIONS"):
        env.pop(f"BLENDER_USER_{folder}", None)
    user_resources = tmp_path / "blender-user"
    env["BLENDER_USER_RESOURCES"] = str(user_resources)
    # cwd is an empty folder, so the repository's wrinkle_addon cannot be imported by accident.
    work = tmp_path / "cwd"
    work.mkdir()
    proc = subprocess.run(
        [sys.executable, "-c", INSTALL_SCRIPT, str(extension_zip), INSTALLED_MODULE],
        cwd=work,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        stdin=subprocess.DEVNULL,
    )
    output = f"exit status {proc.returncode}\n--- stdout ---\n{proc.stdout}\n--- stderr ---\n{proc.stderr}"
    lines = [line for line in proc.stdout.splitlines() if line.startswith("WRINKLE_RESULT ")]
    assert lines, f"the install subprocess reported nothing:\n{output}"
    result = json.loads(lines[-1].removeprefix("WRINKLE_RESULT "))

    assert result["install_error"] is None, output
    assert result["check"] == [True, True], output
    assert result["in_preferences"], output
    assert result["addon_enabled_flag"], f"register() did not complete:\n{output}"
    assert result["module_file"] and Path(result["module_file"]).is_relative_to(user_resources), output
    # addon_utils prints register()/unregister() tracebacks instead of raising them.
    assert "Exception in module register()" not in proc.stdout + proc.stderr, output
    assert result["unregister_errors"] == [], output
    assert result["check_after_disable"][1] is False, output
    assert result["cli_registered"] and result["cli_help"] == 0 and result["cli_missing_file"] == 2, output
    assert not result["cli_after_disable"], output  # unregister removes the command
