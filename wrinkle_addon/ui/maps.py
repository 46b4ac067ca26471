# SPDX-License-Identifier: GPL-3.0-or-later
"""The animated wrinkle maps in the sidebar (drawn in the face panel by the maps source)."""

import bpy

from ..core.maps.jimenez import ZONES
from ..glue.maps import map_material


class WRINKLE_UL_map_expressions(bpy.types.UIList):
    bl_idname = "WRINKLE_UL_map_expressions"

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        face = data.id_data
        row = layout.row(align=True)
        problem = map_material.binding_problem(face, index)
        row.prop(item, "name", text="", emboss=False, icon="ERROR" if problem else "SHAPEKEY_DATA")
        if item.source == "MANUAL":
            row.prop(item, "value", text="")
        else:
            row.label(text={"SHAPE_KEY": item.shape_key, "MUSCLE": item.muscle.name if item.muscle else "",
                            "PROPERTY": item.data_path}[item.source] or "(unbound)")


def draw(layout, context, face):
    """The wrinkle maps' part of the face panel: generation, images, wiring, the
    expression table and the zones."""
    m = face.ewrinkles_face.maps
    col = layout.column(align=True)
    col.label(text="Generate from the muscles")
    row = col.row(align=True)
    row.operator("wrinkle.bake_wrinkle_map", icon="RENDER_STILL")
    row.operator("wrinkle.generate_masks", icon="MOD_MASK")
    col = layout.column()
    col.use_property_split = True
    if face.data.uv_layers:
        col.prop_search(m, "uv_map", face.data, "uv_layers")
    for prop in ("base_image", *map_material.MAP_PROPS[:map_material.n_maps(m)], "mask_a", "mask_b"):
        col.prop(m, prop)
    col = layout.column(align=True)
    col.label(text="Convert maps you already have")
    row = col.row(align=True)
    row.operator("wrinkle.convert_to_derivative", text="To Derivative")
    row.operator("wrinkle.convert_to_normal", text="To Normal")
    row.operator("wrinkle.make_difference_map", text="Difference")
    row = layout.row(align=True)
    row.operator("wrinkle.setup_wrinkle_maps", icon="NODETREE")
    if m.material is not None:
        row.operator("wrinkle.remove_wrinkle_maps", icon="X", text="")
    col = layout.column()
    col.use_property_split = True
    col.prop(m, "strength")
    col.prop(m, "difference")
    col.prop(m, "weight_mode")
    if m.weight_mode == "TENSION":
        col.prop(m, "tension_gain")

    layout.label(text="Expressions")
    row = layout.row()
    row.template_list("WRINKLE_UL_map_expressions", "", m, "expressions", m, "active_expression", rows=4)
    sub = row.column(align=True)
    sub.operator("wrinkle.add_map_expression", icon="ADD", text="")
    sub.operator("wrinkle.remove_map_expression", icon="REMOVE", text="")
    sub.separator()
    sub.operator_menu_enum("wrinkle.load_map_preset", "preset", icon="PRESET", text="")
    if 0 <= m.active_expression < len(m.expressions):
        ex = m.expressions[m.active_expression]
        box = layout.box()
        col = box.column()
        col.use_property_split = True
        col.prop(ex, "source")
        if ex.source == "SHAPE_KEY" and face.data.shape_keys is not None:
            col.prop_search(ex, "shape_key", face.data.shape_keys, "key_blocks")
        elif ex.source == "MUSCLE":
            col.prop(ex, "muscle")
        elif ex.source == "PROPERTY":
            col.prop(ex, "target")
            col.prop(ex, "data_path")
        else:
            col.prop(ex, "value")
        problem = map_material.binding_problem(face, m.active_expression)
        if problem:
            col.label(text=problem, icon="ERROR")
        col.prop(ex, "map_index")
        grid = box.grid_flow(columns=2, align=True)
        for z, (_colour, name) in enumerate(ZONES):
            grid.prop(ex, "weights", index=z, text=name)
    layout.label(text="Zones")
    grid = layout.grid_flow(columns=3, align=True, row_major=True)
    for z, (_colour, name) in enumerate(ZONES):
        grid.label(text=name)
        grid.prop(m, "zone_strength", index=z, text="Strength")
        grid.prop(m, "zone_power", index=z, text="Power")


classes = (WRINKLE_UL_map_expressions,)
register, unregister = bpy.utils.register_classes_factory(classes)
