"""The wrinkle-source contract: a source registered in the test alone appears in the
render, in the farm bake and in the panel, with no edit to the frame stage, the bake or
the panel (they loop over ``glue.registry``)."""

import bpy
import numpy as np
import pytest
from bpy.props import FloatProperty

from tests.blender import scenes
from tests.blender.test_ui_contract import _Layout
from wrinkle_addon import sources
from wrinkle_addon.core import combine
from wrinkle_addon.glue import registry
from wrinkle_addon.glue.registry import WrinkleSource
from wrinkle_addon.ui import panels

CENTRE = np.array([0.0, 0.0, scenes.HEIGHT / 2])
SIGMA = 0.015


class BumpSettings(bpy.types.PropertyGroup):
    height: FloatProperty(name="Bump Height", description="Height of the test bump", default=0.0)


class Bump(WrinkleSource):
    """A round bump of animatable height in the middle of the face."""

    name = "test_bump"
    label = "Bump"
    properties = (("test_bump", BumpSettings),)
    sigma = SIGMA  # static: a change rebuilds the static data

    def active(self, face):
        return True

    def static_key(self, face, in_scene):
        return len(face.data.vertices), self.sigma

    def build(self, face, mesh, in_scene):
        r2 = ((mesh.rest - CENTRE) ** 2).sum(axis=1)
        verts = np.flatnonzero(r2 < (3 * self.sigma) ** 2)
        profile = np.exp(-r2[verts] / self.sigma**2).astype(np.float32)
        return type("Static", (), {"footprint": combine.Footprint(height_verts=verts), "profile": profile})

    def inputs(self, face, static):
        return (face.ewrinkles_face.test_bump.height,)

    def contribute(self, face, static, skin, inputs):
        (height,) = inputs
        return combine.Contribution(height=static.profile * np.float32(height))

    def draw(self, layout, context, face):
        layout.prop(face.ewrinkles_face.test_bump, "height")


@pytest.fixture
def bump():
    source = Bump()
    sources.add(source)
    yield source
    sources.remove(source)


def _bump_face(heights=((1, 0.0), (3, 0.004))):
    scene = bpy.context.scene
    face = scenes.make_face()
    bpy.ops.wrinkle.enable()
    settings = face.ewrinkles_face.test_bump
    for frame, h in heights:
        settings.height = h
        face.keyframe_insert("ewrinkles_face.test_bump.height", frame=frame)
    scene.frame_start, scene.frame_end = 1, 3
    return scene, face


def _raised(face):
    """How far each vertex stands off its skin along the offset (N,)."""
    return np.linalg.norm(scenes.offsets(face), axis=1)


def test_the_bump_is_in_the_stage_frame_by_frame(bump):
    scene, face = _bump_face()
    assert bump in registry.sources()
    for frame, top in ((1, 0.0), (3, 0.004), (2, 0.002)):
        scene.frame_set(frame)
        raised = _raised(face)
        assert raised.max() == pytest.approx(top, rel=0.05, abs=1e-7), frame
    ev = scenes.evaluated_positions(face)
    skin = np.empty_like(ev)
    face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data.attributes["wrinkle_skin"].data.foreach_get(
        "vector", skin.ravel())
    assert (ev - skin)[:, 1].min() < -0.0015  # out of the face, which looks toward -Y


def test_the_bump_sums_with_the_muscles(bump):
    scene, face = _bump_face(((1, 0.003),))
    scene.frame_set(1)
    alone = scenes.offsets(face).copy()
    scenes.add_sheet(face, contraction=1.0)
    scene.frame_set(2)
    scene.frame_set(1)
    both = scenes.offsets(face)
    sources.remove(bump)
    try:
        scene.frame_set(2)
        scene.frame_set(1)
        muscles = scenes.offsets(face).copy()
    finally:
        sources.add(bump)
    assert np.abs(muscles).max() > 1e-4 and np.abs(alone).max() > 1e-4
    # heights add along one normal: the sum of the two separately, to first order
    np.testing.assert_allclose(both, alone + muscles, atol=2e-4)


def test_rebuilt_static_data_always_rebuilds_the_plan(bump):
    """Each rebuild of a source's static data gets a new combined plan, however often it
    happens: the raised vertices are exactly the current footprint's."""
    scene, face = _bump_face(((1, 0.003),))
    rest = np.empty((len(face.data.vertices), 3), np.float32)
    face.data.attributes["position"].data.foreach_get("vector", rest.ravel())
    r2 = ((rest - CENTRE) ** 2).sum(axis=1)
    for i, sigma in enumerate((0.01, 0.02) * 6):
        bump.sigma = sigma
        scene.frame_set(1 + i % 2)
        scene.frame_set(1)
        moved = np.flatnonzero(np.abs(scenes.offsets(face)).max(axis=1) > 0)
        np.testing.assert_array_equal(moved, np.flatnonzero(r2 < (3 * sigma) ** 2), err_msg=f"sigma {sigma}")


@pytest.mark.render
def test_the_bump_renders(bump, tmp_path):
    scene, face = _bump_face()
    scenes.add_camera_and_light(scene)
    scenes.setup_cycles(scene)
    images = {}
    for frame in (1, 3):
        scene.frame_set(frame)
        scene.render.filepath = str(tmp_path / f"f{frame}.png")
        bpy.ops.render.render(write_still=True)
        images[frame] = scenes.load_png(tmp_path / f"f{frame}.png")
    assert np.abs(images[3] - images[1]).max() > 0.05  # the bump's shading


def test_the_bump_is_in_the_farm_bake(bump, tmp_path):
    scene, face = _bump_face()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))
    live = {}
    for frame in (1, 2, 3):
        scene.frame_set(frame)
        live[frame] = scenes.evaluated_positions(face).copy()
    bpy.context.view_layer.objects.active = face
    bpy.ops.wrinkle.bake()
    baked = face.ewrinkles_face.bake_object
    assert baked is not None
    for frame in (1, 3, 2):
        scene.frame_set(frame)
        np.testing.assert_allclose(scenes.evaluated_positions(baked), live[frame], atol=1e-6)
    assert np.abs(live[3] - live[1]).max() > 0.003


def test_the_bump_draws_its_part_of_the_panel(bump):
    scenes.make_face()
    layout = _Layout()
    panels.VIEW3D_PT_wrinkle_face.draw(type("P", (), {"layout": layout})(), bpy.context)
    assert "height" in layout.drawn
    assert {"wrinkle.enable", "wrinkle.bake", "strength"} <= set(layout.drawn)


def test_a_source_name_is_unique(bump):
    with pytest.raises(ValueError, match="already registered"):
        registry.add(Bump())
