"""Fixtures for tests that run inside Blender (the bpy module).

tests/conftest.py has already pointed Blender's user folders at a temporary directory and
put the repository root on sys.path; it skips this directory when bpy is missing.

* ``wrinkle_addon_enabled`` (session, autouse): enables the add-on once per session the way
  Blender does, and fails loudly if that raised. Its teardown disables the add-on and
  fails if ``unregister()`` raised.
* ``factory_reset`` (autouse): an empty factory scene before every test, add-on kept.
* ``tmp_blend``: ``tmp_blend("name")`` -> a ``.blend`` path in the test's tmp_path.
* ``render_small``: ``render_small(scene, path, size=64, samples=4)`` renders a small
  Cycles CPU image and returns its pixels (a test that uses it is marked ``render``).

The ``render`` marker (pytest.ini) is kept honest here: a handler on
``bpy.app.handlers.render_init`` counts the renders of each test (every render job, still
or animation, Cycles or EEVEE, through ``render_small`` or ``bpy.ops.render.render``),
from its fixtures' setup to the end of its body. After the body, a test that rendered
without ``@pytest.mark.render`` fails, and so does one marked render that never rendered,
so that ``-m "not render"`` (the fast tier) leaves out exactly the tests that render. A
render in a child process is not seen: a test that renders only there takes
``@pytest.mark.render(subprocess=True)``, which skips the second check.

Reset finding (measured on bpy 4.5.4 and 5.2.3, background mode):
``bpy.ops.wm.read_factory_settings(use_empty=True)`` also resets the preferences, and that
UNREGISTERS every add-on: our ``unregister()`` runs and ``addon_utils.check()`` turns
``(False, False)``. ``bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)``
loads the same empty factory scene but leaves the preferences alone, so the add-on stays
registered (``register()`` is not re-run; operators, properties and persistent handlers
stay; non-persistent handlers are cleared as on any file load). It takes ~5 ms against
~60-100 ms for read_factory_settings. So that is the per-test reset. Preferences are not
reset between tests. If a test disabled the add-on, the reset re-enables it.
"""

from __future__ import annotations

import traceback
from pathlib import Path

import numpy as np
import pytest

try:
    import bpy
except ImportError:  # tests/conftest.py skips this whole directory in that case
    bpy = addon_utils = None
else:
    import addon_utils  # importable only once bpy is (it lives in bpy's scripts/modules)

ADDON = "wrinkle_addon"


def _format(ex: BaseException) -> str:
    return "".join(traceback.format_exception(type(ex), ex, ex.__traceback__))


def enable_addon():
    """Enable the add-on like Blender does; raise with the traceback if that failed.

    addon_utils.enable() catches exceptions from import and register() and only prints
    them, so errors are collected through ``handle_error`` and the result is checked.
    """
    errors: list[str] = []
    mod = addon_utils.enable(ADDON, default_set=True, handle_error=lambda ex: errors.append(_format(ex)))
    loaded_default, loaded_state = addon_utils.check(ADDON)
    if errors or mod is None or not loaded_state:
        details = "\n".join(errors) or "(no exception reported)"
        pytest.fail(
            f"enabling the add-on {ADDON!r} failed (module={mod!r}, "
            f"check={loaded_default, loaded_state}):\n{details}",
            pytrace=False,
        )
    return mod


def disable_addon() -> None:
    """Disable the add-on; raise with the traceback if unregister() failed."""
    errors: list[str] = []
    addon_utils.disable(ADDON, default_set=True, handle_error=lambda ex: errors.append(_format(ex)))
    if errors or addon_utils.check(ADDON)[1]:
        pytest.fail(f"disabling the add-on {ADDON!r} failed:\n" + "\n".join(errors), pytrace=False)


# --- The render marker ---------------------------------------------------------------------
_renders: list[str] = []  # scene names, one per render job of the running test


def _count_render(scene, *_args):
    _renders.append(getattr(scene, "name", "?"))


if bpy is not None:
    # persistent: kept across the file loads of factory_reset and of the tests
    _count_render = bpy.app.handlers.persistent(_count_render)


def render_marker_problem(item, renders) -> str | None:
    """Why ``item``'s render marker does not match the ``renders`` it made, or None."""
    marker = item.get_closest_marker("render")
    if renders and marker is None:
        return (f"{item.nodeid} rendered ({len(renders)} render job(s), scene(s) "
                f"{sorted(set(renders))}) but is not marked @pytest.mark.render; mark it, so "
                "that -m 'not render' leaves it out of the fast tier")
    if marker is not None and not renders and not marker.kwargs.get("subprocess"):
        return (f"{item.nodeid} is marked @pytest.mark.render but rendered nothing; drop the "
                "marker (or use @pytest.mark.render(subprocess=True) if it renders in a child process)")
    return None


@pytest.hookimpl(wrapper=True)
def pytest_runtest_setup(item):
    _renders.clear()
    if _count_render not in bpy.app.handlers.render_init:
        bpy.app.handlers.render_init.append(_count_render)
    return (yield)


@pytest.hookimpl(wrapper=True)
def pytest_runtest_call(item):
    result = yield  # a failure or skip of the test itself propagates from here unchanged
    problem = render_marker_problem(item, _renders)
    if problem:
        pytest.fail(problem, pytrace=False)
    return result


@pytest.hookimpl(wrapper=True)
def pytest_runtest_teardown(item, nextitem):
    try:
        return (yield)
    finally:
        if _count_render in bpy.app.handlers.render_init:
            bpy.app.handlers.render_init.remove(_count_render)


@pytest.fixture(scope="session", autouse=True)
def wrinkle_addon_enabled():
    """The add-on module, registered once for the whole session."""
    mod = enable_addon()
    yield mod
    if addon_utils.check(ADDON)[1]:
        disable_addon()


@pytest.fixture(autouse=True)
def factory_reset(wrinkle_addon_enabled):
    """Empty factory scene before each test, add-on still registered (see module docstring)."""
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    if not addon_utils.check(ADDON)[1]:  # a previous test disabled it
        enable_addon()
    yield


@pytest.fixture
def tmp_blend(tmp_path):
    """``tmp_blend(name="scene")`` -> ``tmp_path / "name.blend"``."""

    def make(name: str = "scene") -> Path:
        return tmp_path / (name if name.endswith(".blend") else f"{name}.blend")

    return make


@pytest.fixture
def render_small():
    """``render_small(scene, path, size=64, samples=4)``: small deterministic Cycles CPU render.

    Writes ``path`` (OpenEXR float if it ends in ``.exr``, else PNG) and returns the
    pixels as float32 of shape (size, size, 4), bottom row first (Blender's order).
    The scene needs a camera. Denoising and adaptive sampling are off, the seed is fixed
    and the view transform is Standard, so the same scene renders the same pixels.
    """

    def render(scene, path, size: int = 64, samples: int = 4) -> np.ndarray:
        path = Path(path)
        if scene.camera is None:
            raise ValueError(f"scene {scene.name!r} has no camera to render with")
        render = scene.render
        render.engine = "CYCLES"
        render.resolution_x = render.resolution_y = size
        render.resolution_percentage = 100
        render.filepath = str(path)
        exr = path.suffix.lower() == ".exr"
        render.image_settings.file_format = "OPEN_EXR" if exr else "PNG"
        render.image_settings.color_mode = "RGBA"
        if exr:
            render.image_settings.color_depth = "32"
        scene.view_settings.view_transform = "Standard"
        cycles = scene.cycles
        cycles.device = "CPU"
        cycles.samples = samples
        cycles.use_adaptive_sampling = False
        cycles.use_denoising = False
        cycles.seed = 0

        bpy.ops.render.render(write_still=True, scene=scene.name)
        if not path.is_file():
            raise RuntimeError(f"render of scene {scene.name!r} wrote no file at {path}")
        image = bpy.data.images.load(str(path), check_existing=False)
        try:
            pixels = np.empty(size * size * 4, dtype=np.float32)
            image.pixels.foreach_get(pixels)
        finally:
            bpy.data.images.remove(image)
        return pixels.reshape(size, size, 4)

    return render
