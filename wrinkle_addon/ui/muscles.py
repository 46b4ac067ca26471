# SPDX-License-Identifier: GPL-3.0-or-later
"""The muscle-driven wrinkles in the sidebar: the face's muscle list and muscle set (drawn
in the face panel by the muscle source), and the panel of the active muscle."""

import bpy

from ..core.muscles import presets


class WRINKLE_UL_muscles(bpy.types.UIList):
    bl_idname = "WRINKLE_UL_muscles"

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        ob = item.object
        if ob is None or not ob.users_scene:
            layout.label(text="(deleted muscle)", icon="ERROR")
            return
        s = ob.ewrinkles_muscle
        row = layout.row(align=True)
        row.prop(ob, "name", text="", emboss=False,
                 icon={"SHEET": "MOD_LATTICE", "SPHINCTER": "MESH_CIRCLE"}.get(s.kind, "FORCE_CURVE"))
        row.prop(s, "contraction", text="")
        row.prop(s, "wrinkles_only", text="", icon="MOD_OCEAN")


def draw_face_muscles(layout, context, face):
    """The muscles' part of the face panel."""
    s = face.ewrinkles_face
    layout.label(text="Muscles")
    row = layout.row()
    row.template_list("WRINKLE_UL_muscles", "", s, "muscles", s, "active_muscle", rows=4)
    col = row.column(align=True)
    col.operator("wrinkle.add_muscle", icon="ADD", text="").kind = "LINEAR"
    col.operator("wrinkle.remove_muscle", icon="REMOVE", text="")
    row = layout.row(align=True)
    op = row.operator("wrinkle.add_muscle", text="Linear", icon="FORCE_CURVE")
    op.kind, op.pick = "LINEAR", True
    op = row.operator("wrinkle.add_muscle", text="Sheet", icon="MOD_LATTICE")
    op.kind, op.pick = "SHEET", True
    op = row.operator("wrinkle.add_muscle", text="Sphincter", icon="MESH_CIRCLE")
    op.kind, op.pick = "SPHINCTER", True
    row = layout.row(align=True)  # the furrows' natural irregularity, for every muscle
    row.prop(s, "irregularity")
    row.prop(s, "seed")
    layout.label(text="Facial Muscle Set")
    row = layout.row(align=True)
    row.operator("wrinkle.add_landmarks", icon="EMPTY_AXIS")
    row.operator("wrinkle.add_muscle_set", icon="USER")
    layout.label(text="Expressions")
    grid = layout.grid_flow(columns=2, align=True)
    for key, label, _tip in presets.EXPRESSION_ITEMS:
        grid.operator("wrinkle.expression", text=label).expression = key
    layout.operator("wrinkle.refine", icon="MOD_SUBSURF")


class VIEW3D_PT_wrinkle_muscle(bpy.types.Panel):
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Wrinkles"
    bl_label = "Muscle"

    @classmethod
    def poll(cls, context):
        ob = context.active_object
        return ob is not None and ob.ewrinkles_muscle.is_muscle

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        ob = context.active_object
        s = ob.ewrinkles_muscle
        layout.prop(s, "kind")
        layout.prop(s, "role")
        layout.prop(s, "side")
        layout.prop(s, "contraction")
        layout.prop(s, "wrinkles_only")
        col = layout.column()
        col.active = not s.wrinkles_only
        col.prop(s, "pull")
        layout.separator()
        if s.kind == "LINEAR":
            layout.prop(s, "radius")
            layout.prop(s, "angle")
            layout.prop(s, "angle_c")
        elif s.kind == "SPHINCTER":
            layout.prop(s, "reach")
            layout.prop(s, "angle")
            layout.prop(s, "angle_c")
            layout.prop(s, "depth")
        else:
            layout.prop(s, "length")
            layout.prop(s, "width")
            layout.prop(s, "width_c")
            layout.prop(s, "depth")
            layout.prop(s, "back_reach")
            layout.prop(s, "region_end")
        layout.separator()
        layout.prop(s, "lambda_w")
        layout.prop(s, "n_wrinkles")
        layout.prop(s, "k0")
        layout.prop(s, "alpha")
        layout.prop(s, "fade_ends")
        layout.prop(s, "irregularity")
        layout.prop(s, "show_region")
        layout.operator("wrinkle.drive_contraction", icon="DRIVER")


classes = (WRINKLE_UL_muscles, VIEW3D_PT_wrinkle_muscle)
register, unregister = bpy.utils.register_classes_factory(classes)
