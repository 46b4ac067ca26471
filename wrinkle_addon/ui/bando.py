# SPDX-License-Identifier: GPL-3.0-or-later
"""The large-scale wrinkle curves in the sidebar (Bando, Kuratate & Nishita 2002, §6): the
face's curve list and the active curve's settings, drawn in the face panel by the curve
source."""

import bpy

from ..core import skin_age


class WRINKLE_UL_curves(bpy.types.UIList):
    bl_idname = "WRINKLE_UL_curves"

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        ob = item.object
        if ob is None or not ob.users_scene:
            layout.label(text="(deleted curve)", icon="ERROR")
            return
        s = ob.ewrinkles_curve
        row = layout.row(align=True)
        row.prop(ob, "name", text="", emboss=False, icon="CURVE_BEZCURVE")
        row.prop(s, "depth", text="")
        row.prop(s, "enabled", text="", icon="HIDE_OFF" if s.enabled else "HIDE_ON", emboss=False)


def draw_face_curves(layout, context, face):
    """The wrinkle curves' part of the face panel."""
    lst = face.ewrinkles_face.wrinkle_curves
    row = layout.row()
    row.template_list("WRINKLE_UL_curves", "", lst, "items", lst, "active", rows=3)
    col = row.column(align=True)
    col.operator("wrinkle.add_curve", icon="ADD", text="")
    col.operator("wrinkle.remove_curve", icon="REMOVE", text="")
    row = layout.row(align=True)
    row.operator("wrinkle.curve_from_edges", text="From Edges", icon="EDGESEL")
    row.operator("wrinkle.curve_from_stroke", text="From Stroke", icon="GREASEPENCIL")
    row = layout.row(align=True)
    row.operator("wrinkle.use_curve", icon="CURVE_DATA")
    row.operator("wrinkle.snap_curve", icon="SNAP_FACE")
    layout.operator("wrinkle.refine", icon="MOD_SUBSURF")
    if 0 <= lst.active < len(lst.items) and lst.items[lst.active].object is not None:
        s = lst.items[lst.active].object.ewrinkles_curve
        col = layout.column()
        col.use_property_split = True
        col.prop(s, "depth")
        col.prop(s, "width")
        col.prop(s, "rest_height")
        col.prop(s, "taper")


def draw_face_fine(layout, context, face):
    """The fine wrinkles' part of the face panel."""
    fs = face.ewrinkles_face.fine_wrinkles
    col = layout.column()
    col.use_property_split = True
    col.prop(fs, "field_source")
    if fs.field_source == "GUIDES":
        col.prop(fs, "reference_length")
        col.operator("wrinkle.fine_direction", icon="ORIENTATION_NORMAL")
    else:
        col.prop(fs, "base_magnitude")
    col.prop(fs, "angle")
    col.prop(fs, "resolution")
    col.prop(fs, "seed")
    col.prop(fs, "continue_from")
    row = layout.row(align=True)
    row.operator("wrinkle.carve_fine", icon="MOD_NOISE")
    row.operator("wrinkle.remove_fine", icon="TRASH", text="")
    layout.operator("wrinkle.add_pigment", icon="COLOR")
    if fs.image_1 is not None:
        layout.label(text=f"{fs.furrows} furrows, {fs.coverage:.0%} covered", icon="INFO")
        col = layout.column()
        col.use_property_split = True
        col.prop(fs, "strength")
        col.prop(fs, "distance")
        col.prop(fs, "rest_height")
        age = face.ewrinkles_face.skin_age
        layout.label(text=f"Skin Age {age:.2f}: rest height {skin_age.rest_height(fs.rest_height, age):.2f}, "
                          f"depth x{skin_age.depth_factor(age):.2f}", icon="INFO")


classes = (WRINKLE_UL_curves,)
register, unregister = bpy.utils.register_classes_factory(classes)
