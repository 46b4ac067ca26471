"""Shared test setup for tests/core (pure NumPy) and tests/blender (needs bpy).

Everything at module level here runs before any test module, and so before bpy is
imported anywhere:

* Blender's user folders go to a fresh temporary directory, so tests never read or write
  the user's own Blender configuration (``BLENDER_USER_RESOURCES``; the per-folder
  overrides are removed so that they all derive from it).
* The repository root goes on ``sys.path``, so ``import wrinkle_addon`` works.
* ``WRINKLE_NO_BPY=1`` makes ``import bpy`` fail, to prove that tests/core needs no
  Blender (tools/test.sh runs tests/core that way once).

tests/blender is skipped as a whole, with the reason, when bpy cannot be imported.

At the end of the session, Blender is reset to factory settings (see ``_shutdown_blender``)
and pytest's exit status is written to the file named by ``WRINKLE_PYTEST_STATUS``, so
tools/test.sh can tell "all tests passed, then bpy crashed at interpreter exit" from a
real failure.
"""

from __future__ import annotations

import atexit
import importlib.abc
import importlib.util
import os
import shutil
import sys
import tempfile
from pathlib import Path

import pytest

TESTS_DIR = Path(__file__).resolve().parent
ROOT = TESTS_DIR.parent
BLENDER_TESTS_DIR = TESTS_DIR / "blender"

# --- Environment, before anything imports bpy ------------------------------------------
USER_RESOURCES = tempfile.mkdtemp(prefix="wrinkle-blender-user-")
atexit.register(shutil.rmtree, USER_RESOURCES, ignore_errors=True)
os.environ["BLENDER_USER_RESOURCES"] = USER_RESOURCES
for _var in (
    "BLENDER_USER_CONFIG",
    "BLENDER_USER_SCRIPTS",
    "BLENDER_USER_DATAFILES",
    "BLENDER_USER_EXTENSIONS",
):
    os.environ.pop(_var, None)

if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


class _BlockBpy(importlib.abc.MetaPathFinder):
    """Import hook that makes bpy unimportable (WRINKLE_NO_BPY=1)."""

    def find_spec(self, fullname, path=None, target=None):
        if fullname == "bpy" or fullname.startswith("bpy."):
            raise ModuleNotFoundError(f"import of {fullname} blocked by WRINKLE_NO_BPY=1", name=fullname)
        return None


if os.environ.get("WRINKLE_NO_BPY") == "1":
    sys.meta_path.insert(0, _BlockBpy())


def _bpy_missing_reason() -> str | None:
    """Why bpy cannot be imported, or None if it can (located, not imported)."""
    try:
        if importlib.util.find_spec("bpy") is None:
            return "the bpy module is not installed (bash tools/setup_env.sh 45)"
    except ImportError as exc:
        return str(exc)
    return None


BPY_MISSING = _bpy_missing_reason()


# --- Skip tests/blender without bpy -------------------------------------------------------
class _SkippedBlenderDir(pytest.Dir):
    """Stands in for tests/blender: collects nothing and reports one skip with the reason."""

    def collect(self):
        pytest.skip(f"tests/blender skipped: {BPY_MISSING}")


def pytest_collect_directory(path, parent):
    if BPY_MISSING and Path(path) == BLENDER_TESTS_DIR:
        return _SkippedBlenderDir.from_parent(parent, path=Path(path))
    return None


def pytest_report_header(config):
    if BPY_MISSING:
        return [f"bpy: not available ({BPY_MISSING})"]
    return [f"bpy: located; BLENDER_USER_RESOURCES={USER_RESOURCES}"]


# --- End of session ---------------------------------------------------------------------
def _shutdown_blender() -> None:
    """Leave Blender in factory state so that the interpreter can exit.

    Measured on bpy 4.5.4: a process that exits after a driver has called a Python
    function deadlocks at exit, forever, pytest included (a plain script also does with
    a non-persistent handler left registered). ``read_factory_settings`` unregisters
    every add-on and frees those objects; after it the same runs exit at once. bpy 5.2.3
    exited cleanly either way. tools/test.sh keeps a watchdog as well.
    """
    if "bpy" not in sys.modules:
        return
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)


@pytest.hookimpl(trylast=True)
def pytest_sessionfinish(session, exitstatus):
    try:
        _shutdown_blender()
    finally:
        status_file = os.environ.get("WRINKLE_PYTEST_STATUS")
        if status_file:
            # Written last: anything after this (bpy's own teardown at interpreter exit)
            # can no longer change the verdict of the tests; see tools/test.sh.
            Path(status_file).write_text(f"{int(session.exitstatus)}\n")
