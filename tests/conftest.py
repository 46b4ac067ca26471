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
real failure. Just before it, the counts of passed, failed and skipped tests and the skip
reasons (grouped, with counts) go to the file named by ``WRINKLE_PYTEST_SUMMARY``, which
tools/test.sh prints in its summary (see ``_summary_lines``).
"""

from __future__ import annotations

import atexit
import collections
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


# --- Outcome counts for tools/test.sh's summary ------------------------------------------
_OUTCOMES = collections.Counter()
_SKIP_REASONS = collections.Counter()
_OUTCOME_ORDER = ("passed", "failed", "error", "skipped", "xfailed", "xpassed")


def _skip_reason(report) -> str:
    longrepr = report.longrepr
    reason = longrepr[2] if isinstance(longrepr, tuple) and len(longrepr) == 3 else str(longrepr)
    return reason.removeprefix("Skipped: ").strip()


def _record(report) -> None:
    if report.skipped:
        if hasattr(report, "wasxfail"):
            _OUTCOMES["xfailed"] += 1
        else:
            _OUTCOMES["skipped"] += 1
            _SKIP_REASONS[_skip_reason(report)] += 1
    elif report.failed:
        _OUTCOMES["failed" if report.when == "call" else "error"] += 1
    elif report.when == "call":
        _OUTCOMES["xpassed" if hasattr(report, "wasxfail") else "passed"] += 1


def pytest_runtest_logreport(report):
    _record(report)


def pytest_collectreport(report):
    if report.failed:
        _OUTCOMES["error"] += 1  # a module that cannot be imported, say
    elif report.skipped:
        _record(report)  # a whole module or folder skipped (tests/blender without bpy)


def _summary_lines() -> list[str]:
    """'12 passed, 6 skipped' then one line per skip reason, most frequent first."""
    counts = [f"{_OUTCOMES[k]} {k}{'s' if k == 'error' and _OUTCOMES[k] > 1 else ''}"
              for k in _OUTCOME_ORDER if _OUTCOMES[k]]
    lines = [", ".join(counts) if counts else "no tests ran"]
    for reason, n in sorted(_SKIP_REASONS.items(), key=lambda item: (-item[1], item[0])):
        lines.append(f"{n} skipped: {reason}")
    return lines


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
        summary_file = os.environ.get("WRINKLE_PYTEST_SUMMARY")
        if summary_file:
            try:
                Path(summary_file).write_text("\n".join(_summary_lines()) + "\n")
            except OSError as exc:  # never let the summary cost the status below
                print(f"conftest: cannot write {summary_file}: {exc}", file=sys.stderr)
        status_file = os.environ.get("WRINKLE_PYTEST_STATUS")
        if status_file:
            # Written last: anything after this (bpy's own teardown at interpreter exit)
            # can no longer change the verdict of the tests; see tools/test.sh.
            Path(status_file).write_text(f"{int(session.exitstatus)}\n")
