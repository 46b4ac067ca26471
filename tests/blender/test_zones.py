"""Nothing on the eyelids or the lips: the muscles' pull and wrinkles, and the wrinkle maps
baked from them, stop at the zones ``core.zones`` builds from the landmark empties."""

import bpy
import numpy as np
import pytest

from sample_scenes.lib import headgen, rigging, scene_setup
from wrinkle_addon.core import zones
from wrinkle_addon.glue import landmarks
from wrinkle_addon.glue.maps import map_bake
from wrinkle_addon.glue.muscles import muscle_objects


@pytest.fixture(scope="module")
def head_data():
    return headgen.make_head(12000)


@pytest.fixture
def head(head_data):
    data = head_data
    face = scene_setup.mesh_object_from_arrays("Head", data["positions"], data["quads"], data["corner_uvs"])
    rigging.wrinkle_face(face, data["landmarks"], refine=False)
    rigging.key_expressions(face, {1: "NEUTRAL", 10: "SURPRISE", 20: "FROWN"})
    rest = np.array([v.co for v in face.data.vertices])
    inside = zones.face_zones(rest, landmarks.landmark_positions(face)).inside
    assert inside.sum() > 100  # the eyelids and lips of a 12k head
    return face, inside


def _offsets(face):
    ev = face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    n = len(face.data.vertices)
    pos = np.empty(n * 3, np.float32)
    skin = np.empty(n * 3, np.float32)
    ev.attributes["position"].data.foreach_get("vector", pos)
    ev.attributes["wrinkle_skin"].data.foreach_get("vector", skin)
    return np.linalg.norm((pos - skin).reshape(-1, 3), axis=1)


@pytest.mark.parametrize("frame", [10, 20])
def test_no_pull_and_no_wrinkle_on_eyelids_and_lips(head, frame):
    face, inside = head
    bpy.context.scene.frame_set(frame)
    moved = _offsets(face)
    assert moved[~inside].max() > 1e-4  # the expression does move and wrinkle the face
    assert moved[inside].max() == 0.0


def test_the_landmark_empties_are_placed_with_the_muscle_set(head):
    face, _inside = head
    assert len(landmarks.landmark_objects(face)) == 8


@pytest.mark.parametrize("mode", ["POSE", "MUSCLES"])
def test_baked_map_heights_stop_at_eyelids_and_lips(head, mode):
    face, inside = head
    bpy.context.scene.frame_set(10)
    fields, _layer, _present = map_bake.bake_layers(face, mode, muscle_objects.live_muscles(face))
    assert np.abs(fields[~inside]).max() > 1e-5
    assert np.abs(fields[inside]).max() == 0.0


def test_moving_a_landmark_moves_the_zones(head):
    face, inside = head
    bpy.context.scene.frame_set(10)
    eye = bpy.data.objects[landmarks.landmark_name(face, "eye_L")]
    old = eye.location.copy()
    try:
        eye.location.z += 0.03  # the eye zone now sits on the forehead
        bpy.context.scene.frame_set(11)
        bpy.context.scene.frame_set(10)
        rest = np.array([v.co for v in face.data.vertices])
        moved_zone = zones.face_zones(rest, landmarks.landmark_positions(face)).inside
        assert (moved_zone & ~inside).any()
        assert _offsets(face)[moved_zone].max() == 0.0
    finally:
        eye.location = old
