# SPDX-License-Identifier: GPL-3.0-or-later
"""The pattern-function layers' part of the face panel: a stack like Blender's modifiers."""

import bpy

from ..core.patterns import functions
from ..glue.patterns import pattern_layers


class WRINKLE_UL_patterns(bpy.types.UIList):
    bl_idname = "WRINKLE_UL_patterns"

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        row = layout.row(align=True)
        row.prop(item, "name", text="", emboss=False, icon="MOD_WAVE")
        row.prop(item, "show_viewport", text="", emboss=False,
                 icon="RESTRICT_VIEW_OFF" if item.show_viewport else "RESTRICT_VIEW_ON")
        row.prop(item, "show_render", text="", emboss=False,
                 icon="RESTRICT_RENDER_OFF" if item.show_render else "RESTRICT_RENDER_ON")


def draw_face_patterns(layout, context, face):
    st = face.ewrinkles_face.patterns
    row = layout.row()
    row.template_list("WRINKLE_UL_patterns", "", st, "layers", st, "active", rows=3)
    col = row.column(align=True)
    col.operator_menu_enum("wrinkle.add_pattern", "kind", icon="ADD", text="")
    col.operator("wrinkle.remove_pattern", icon="REMOVE", text="")
    col.separator()
    col.operator("wrinkle.duplicate_pattern", icon="DUPLICATE", text="")
    col.operator("wrinkle.mirror_pattern", icon="MOD_MIRROR", text="")
    col.separator()
    col.operator("wrinkle.move_pattern", icon="TRIA_UP", text="").direction = "UP"
    col.operator("wrinkle.move_pattern", icon="TRIA_DOWN", text="").direction = "DOWN"
    row = layout.row(align=True)
    row.operator("wrinkle.add_teardrop", icon="MOD_FLUIDSIM")
    row.operator("wrinkle.add_shedding_tear", icon="MOD_OCEAN")
    if st.layers:
        layout.operator("wrinkle.refine", icon="MOD_SUBSURF")
    if not st.layers:
        return
    lay = st.layers[pattern_layers.active_index(st)]
    col = layout.column()
    col.use_property_split = True
    col.prop(lay, "kind")
    if lay.kind in functions.VARIANTS:
        col.prop(lay, "shape")
    col.prop(lay, "frame")
    col.prop(lay, "region")
    if lay.region == "RADIUS":
        col.prop(lay, "radius")
    else:
        col.prop_search(lay, "vertex_group", face, "vertex_groups")
    col.prop(lay, "border")
    # None: a type this version does not know (the source says so)
    spec = functions.spec(lay.kind, lay.shape) if lay.kind in functions.PATTERNS else None
    for p in spec.params if spec is not None else ():
        col.prop(lay, p.prop, text=p.name)
    if spec is None or spec.uses_time:
        col.prop(lay, "time")
        col.prop(lay, "follow_scene")
        if lay.follow_scene:
            col.prop(lay, "speed")
    col.prop(lay, "strength")
    col.prop(lay, "drive")
    if lay.drive == "SHAPE_KEY" and face.data.shape_keys is not None:
        col.prop_search(lay, "drive_shape_key", face.data.shape_keys, "key_blocks")
    elif lay.drive == "MUSCLE":
        col.prop(lay, "drive_muscle")
    elif lay.drive == "COMPRESSION":
        col.prop(lay, "full_compression")
    col.prop(lay, "fraction")
    if lay.fraction < 1.0:
        col.prop(lay, "seed")
    layout.operator("wrinkle.apply_pattern", icon="CHECKMARK")


classes = (WRINKLE_UL_patterns,)
register, unregister = bpy.utils.register_classes_factory(classes)
