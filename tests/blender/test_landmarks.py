"""Place Landmarks: the operator finds the landmarks on the face (core.landmark_finder),
reports the rule it used, warns when it fell back to the bounding box, and is undoable."""

import types
from pathlib import Path

import bpy
import numpy as np
import pytest

from sample_scenes.lib import ict, scene_setup
from wrinkle_addon.core import landmark_finder
from wrinkle_addon.glue import landmarks, meshio
from wrinkle_addon.ops.face import WRINKLE_OT_add_landmarks

ICT = Path(__file__).resolve().parents[2] / "wrinkle_addon" / "data" / "ict_head.npz"
NAMES = [k for k, _l, _d in landmark_finder.LANDMARKS]


def _activate(ob):
    for other in bpy.context.selected_objects:
        other.select_set(False)
    ob.select_set(True)
    bpy.context.view_layer.objects.active = ob


def _run():
    """Run the operator's execute on a stand-in, to see its reports."""
    fake = types.SimpleNamespace(reports=[])
    fake.report = lambda kind, text: fake.reports.append((set(kind), text))
    return WRINKLE_OT_add_landmarks.execute(fake, bpy.context), fake.reports


def _sphere():
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.1)
    return bpy.context.active_object


def _empties(face):
    return {ob["ewrinkles_landmark"]: ob for ob in bpy.data.objects
            if ob.name.startswith(f"{landmarks.LANDMARK_PREFIX}{face.name} ")}


def test_operator_is_undoable():
    assert {"REGISTER", "UNDO"} <= set(WRINKLE_OT_add_landmarks.bl_options)


def test_sphere_falls_back_with_a_warning():
    face = _sphere()
    _activate(face)
    result, reports = _run()
    assert result == {"FINISHED"}
    assert [k for k, _t in reports] == [{"WARNING"}]
    assert reports[0][1] == landmark_finder.FALLBACK_MESSAGE
    marks = _empties(face)
    assert set(marks) == set(NAMES)
    bpy.context.view_layer.update()
    assert landmarks.landmark_positions(face) is not None
    for ob in marks.values():  # projected onto the sphere's front
        assert ob.parent == face
        assert np.linalg.norm(ob.location) == pytest.approx(0.1, abs=0.01)


def test_ict_head_reports_the_rule_and_places_the_found_points():
    data = ict.load_ict(ICT)
    face = ict.ict_object(data)  # the openings, and ARKit shape keys
    face.location = (1.0, 2.0, 0.5)  # the empties are face-local
    _activate(face)
    result, reports = _run()
    assert result == {"FINISHED"} and [k for k, _t in reports] == [{"INFO"}]
    assert landmark_finder.LABELS["openings"] in reports[0][1]
    bpy.context.view_layer.update()  # the empties' world matrices
    local = landmarks.landmark_positions(face)
    expected, method, _m = landmark_finder.find_landmarks(data["positions"], data["quads"])
    assert method == "openings"
    for k in NAMES:
        np.testing.assert_allclose(local[k], expected[k], atol=1e-5)
    # Run again through bpy.ops: the empties move back rather than multiply.
    local_empty = _empties(face)["chin"]
    local_empty.location = (0.0, 0.0, 0.0)
    assert bpy.ops.wrinkle.add_landmarks() == {"FINISHED"}
    assert len(_empties(face)) == len(NAMES)
    bpy.context.view_layer.update()
    np.testing.assert_allclose(local_empty.location, expected["chin"], atol=1e-5)


def test_shape_keys_are_read_for_the_rig_rule():
    data = {"positions": np.zeros((4, 3), np.float32), "quads": np.array([[0, 1, 2, 3]], np.int32)}
    face = scene_setup.mesh_object_from_arrays("Quad", np.array(
        [(0, 0, 0), (1, 0, 0), (1, 0, 1), (0, 0, 1)], np.float32), data["quads"])
    face.shape_key_add(name="Basis", from_mix=False)
    key = face.shape_key_add(name="eyeBlinkLeft", from_mix=False)
    key.data[0].co = (0.0, 0.0, -0.5)
    keys = meshio.shape_keys(face.data, 4)
    assert list(keys) == ["eyeBlinkLeft"] and keys["eyeBlinkLeft"][0, 2] == pytest.approx(-0.5)
