"""What an artist relies on: tooltips everywhere, undo on every operator, a drawn overlay."""

import bpy
import numpy as np

from tests.blender import scenes
from wrinkle_addon import props
from wrinkle_addon.ops import convert as convert_ops
from wrinkle_addon.ops import export as export_ops
from wrinkle_addon.ops import mapbake
from wrinkle_addon.ops import maps as map_ops
from wrinkle_addon.ops import muscles as operators
from wrinkle_addon.ui import draw, panels
from wrinkle_addon.ui import maps as maps_ui

OPERATORS = [c for mod in (operators, map_ops, convert_ops, mapbake, export_ops) for c in mod.classes
             if issubclass(c, bpy.types.Operator)]


def _own_properties(cls_or_rna):
    rna = getattr(cls_or_rna, "bl_rna", cls_or_rna)
    return [p for p in rna.properties if p.identifier not in {"rna_type", "name"}]


def test_every_property_has_a_tooltip():
    for cls in props.classes:
        for prop in _own_properties(cls):
            assert prop.description.strip(), f"{cls.__name__}.{prop.identifier} has no description"
    for cls in OPERATORS:
        assert cls.__doc__ and cls.__doc__.strip(), f"{cls.__name__} has no tooltip"
        category, name = cls.bl_idname.split(".")
        rna = getattr(getattr(bpy.ops, category), name).get_rna_type()
        for prop in _own_properties(rna):
            assert prop.description.strip(), f"{cls.__name__}.{prop.identifier} has no description"


def test_every_operator_is_undoable():
    assert len(OPERATORS) > len(operators.classes)
    for cls in OPERATORS:
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
    assert not face.modifiers and not face.ewrinkles_face.enabled


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
    muscle.ewrinkles_muscle.show_region = False
    assert not len(draw._segments(bpy.context)["aoi"])


class _Layout:
    """Stands in for a UILayout: every sub-layout is itself, and each drawn property and
    operator is checked to exist, so a panel cannot show a traceback for a typo."""

    def __init__(self):
        self.drawn = []
        self.use_property_split = False
        self.active = True

    def __getattr__(self, name):
        return lambda *a, **k: self

    def prop(self, data, name, **kw):
        assert hasattr(data, name), f"{type(data).__name__} has no property {name!r}"
        self.drawn.append(name)

    def prop_search(self, data, name, search_data, search_name, **kw):
        assert hasattr(data, name) and hasattr(search_data, search_name)
        self.drawn.append(name)

    def operator(self, idname, **kw):
        category, name = idname.split(".")
        getattr(getattr(bpy.ops, category), name).get_rna_type()  # raises if not registered
        self.drawn.append(idname)
        return type("Props", (), {})()

    def operator_menu_enum(self, idname, prop, **kw):
        return self.operator(idname)

    def panel(self, idname, **kw):
        return self, self  # header and body of a collapsible section, both drawn here


def test_wrinkle_maps_panel_draws_every_control():
    face = scenes.make_face()
    face.ewrinkles_face.maps.expressions.add()
    for source in ("SHAPE_KEY", "MUSCLE", "PROPERTY", "MANUAL"):
        face.ewrinkles_face.maps.expressions[0].source = source
        layout = _Layout()
        maps_ui.draw(layout, bpy.context, face)
        assert {"wrinkle.setup_wrinkle_maps", "wrinkle.bake_wrinkle_map", "wrinkle.generate_masks",
                "wrinkle.convert_to_derivative", "wrinkle.make_difference_map",
                "weights", "zone_power", "mask_b"} <= set(layout.drawn)


def test_face_panel_offers_the_exports():
    face = scenes.make_face()
    bpy.context.view_layer.objects.active = face
    layout = _Layout()
    panels.VIEW3D_PT_wrinkle_face.draw(type("P", (), {"layout": layout})(), bpy.context)
    assert {"wrinkle.export_gltf", "wrinkle.export_usd", "wrinkle.export_wrinkle_package",
            "wrinkle.import_wrinkle_package"} <= set(layout.drawn)


def test_converter_dialogs_draw_their_properties():
    for cls in (convert_ops.WRINKLE_OT_convert_to_derivative, convert_ops.WRINKLE_OT_convert_to_normal,
                convert_ops.WRINKLE_OT_make_difference_map):
        layout = _Layout()
        fields = {name: "" for c in cls.__mro__ for name in getattr(c, "__annotations__", {})}
        op = type("Op", (), {**fields, "layout": layout, "source_props": cls.source_props})()
        cls.draw(op, bpy.context)
        assert set(cls.source_props) | {"output", "filepath", "file_format"} <= set(layout.drawn)
