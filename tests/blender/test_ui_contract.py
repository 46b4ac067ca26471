"""What an artist relies on: tooltips everywhere, undo on every operator, a drawn overlay."""

import bpy
import numpy as np

from tests.blender import scenes
from wrinkle_addon import draw, operators, props


def _own_properties(cls_or_rna):
    rna = getattr(cls_or_rna, "bl_rna", cls_or_rna)
    return [p for p in rna.properties if p.identifier not in {"rna_type", "name"}]


def test_every_property_has_a_tooltip():
    for cls in props.classes:
        for prop in _own_properties(cls):
            assert prop.description.strip(), f"{cls.__name__}.{prop.identifier} has no description"
    for cls in operators.classes:
        assert cls.__doc__ and cls.__doc__.strip(), f"{cls.__name__} has no tooltip"
        category, name = cls.bl_idname.split(".")
        rna = getattr(getattr(bpy.ops, category), name).get_rna_type()
        for prop in _own_properties(rna):
            assert prop.description.strip(), f"{cls.__name__}.{prop.identifier} has no description"


def test_every_operator_is_undoable():
    for cls in operators.classes:
        assert {"REGISTER", "UNDO"} <= set(cls.bl_options), cls.__name__


def test_operator_undo_restores_the_scene():
    face = scenes.make_face()
    bpy.ops.ed.undo_push(message="start")
    bpy.ops.wrinkle.enable()
    bpy.ops.ed.undo_push(message="enabled")
    scenes.add_sheet(face)
    bpy.ops.ed.undo_push(message="muscle")
    bpy.ops.ed.undo()
    assert "Frontalis" not in bpy.data.objects
    bpy.ops.ed.undo()
    face = bpy.data.objects["Face"]
    assert not face.modifiers and not face.wrinkles.enabled


def test_overlay_segments_follow_the_muscles():
    face, muscle = scenes.wrinkled_face()
    segs = draw._segments(bpy.context)
    assert len(segs["aoi"]) and len(segs["region"]) and len(segs["aoi"]) % 2 == 0
    # drawn where the muscle is: the region lies inside the face patch's extent
    assert np.all(np.abs(segs["region"][:, 0]) <= scenes.WIDTH)
    muscle.location.x += 0.5  # moving the muscle moves the overlay
    bpy.context.view_layer.update()
    moved = draw._segments(bpy.context)
    assert np.allclose(moved["aoi"][:, 0].mean() - segs["aoi"][:, 0].mean(), 0.5, atol=1e-4)
    muscle.wrinkle_muscle.show_region = False
    assert not len(draw._segments(bpy.context)["aoi"])
