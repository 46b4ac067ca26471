"""The Blender test harness itself (tests/conftest.py, tests/blender/conftest.py)."""

import sys

import addon_utils
import bpy
import numpy as np
import pytest

from tests.blender import conftest as harness
from tests.blender.conftest import ADDON
from tests.conftest import USER_RESOURCES


def test_blender_user_folders_are_temporary():
    assert bpy.utils.resource_path("USER").startswith(USER_RESOURCES)
    assert bpy.utils.user_resource("CONFIG").startswith(USER_RESOURCES)


def test_addon_is_registered(wrinkle_addon_enabled):
    assert addon_utils.check(ADDON) == (True, True)
    assert sys.modules[ADDON] is wrinkle_addon_enabled


def test_reset_gives_an_empty_scene_1():
    assert len(bpy.data.objects) == 0
    bpy.ops.mesh.primitive_cube_add()
    bpy.context.scene.render.resolution_x = 123


def test_reset_gives_an_empty_scene_2():
    # Runs after _1: its cube and resolution must be gone, the add-on still registered.
    assert len(bpy.data.objects) == 0
    assert bpy.context.scene.render.resolution_x == 1920
    assert addon_utils.check(ADDON) == (True, True)


def test_disabled_addon_is_re_enabled_1():
    addon_utils.disable(ADDON, default_set=True)
    assert addon_utils.check(ADDON)[1] is False


def test_disabled_addon_is_re_enabled_2():
    assert addon_utils.check(ADDON) == (True, True)


@pytest.mark.render
def test_render_small(render_small, tmp_path):
    scene = bpy.context.scene
    bpy.ops.mesh.primitive_plane_add(size=1.0)
    bpy.ops.object.light_add(type="SUN", location=(0, 0, 3))
    bpy.ops.object.camera_add(location=(0, 0, 3))
    scene.camera = bpy.context.object
    bpy.context.object.data.type = "ORTHO"
    bpy.context.object.data.ortho_scale = 2.0
    scene.render.film_transparent = True

    pixels = render_small(scene, tmp_path / "plane.png", size=32, samples=2)
    assert pixels.shape == (32, 32, 4) and pixels.dtype == np.float32
    centre, corner = pixels[16, 16], pixels[0, 0]
    assert centre[3] == 1.0 and corner[3] == 0.0  # the plane covers the middle only
    assert centre[:3].sum() > 0.1

    again = render_small(scene, tmp_path / "plane.exr", size=32, samples=2)
    assert again.shape == (32, 32, 4)


def test_tmp_blend_save_and_reload(tmp_blend):
    path = tmp_blend("saved")
    assert path.name == "saved.blend" and not path.exists()
    bpy.ops.mesh.primitive_cube_add()
    bpy.ops.wm.save_as_mainfile(filepath=str(path))
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    bpy.ops.wm.open_mainfile(filepath=str(path))
    assert [ob.name for ob in bpy.data.objects] == ["Cube"]
    assert addon_utils.check(ADDON) == (True, True)


class _Item:
    """Enough of a pytest item for ``render_marker_problem``."""

    nodeid = "test_x.py::test_x"

    def __init__(self, mark=None):
        self.mark = mark

    def get_closest_marker(self, name):
        return self.mark if name == "render" else None


def test_render_marker_must_match_the_renders():
    plain, marked = _Item(), _Item(pytest.mark.render.mark)
    assert harness.render_marker_problem(plain, []) is None
    assert "not marked @pytest.mark.render" in harness.render_marker_problem(plain, ["Scene"])
    assert harness.render_marker_problem(marked, ["Scene", "Scene"]) is None
    assert "rendered nothing" in harness.render_marker_problem(marked, [])
    assert harness.render_marker_problem(_Item(pytest.mark.render(subprocess=True).mark), []) is None


def test_renders_are_counted_during_every_test():
    # the handler of this very module object: the hooks and this test see the same list
    assert harness._count_render in bpy.app.handlers.render_init
    assert harness._renders == []
