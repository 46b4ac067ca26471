# SPDX-License-Identifier: GPL-3.0-or-later
"""The "Wrinkles" sidebar tab: one panel for the face, one for the active muscle."""

import bpy

from . import pipeline, wrinklemaps
from .core.wrinkle_maps import ZONES


def _face(context):
    ob = context.active_object
    if ob is not None and ob.wrinkle_muscle.is_muscle:
        return ob.parent if ob.parent is not None and ob.parent.type == "MESH" else None
    return ob if ob is not None and ob.type == "MESH" else None


class WRINKLE_UL_muscles(bpy.types.UIList):
    bl_idname = "WRINKLE_UL_muscles"

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        ob = item.object
        if ob is None or not ob.users_scene:
            layout.label(text="(deleted muscle)", icon="ERROR")
            return
        s = ob.wrinkle_muscle
        row = layout.row(align=True)
        row.prop(ob, "name", text="", emboss=False,
                 icon="MOD_LATTICE" if s.kind == "SHEET" else "FORCE_CURVE")
        row.prop(s, "contraction", text="")
        row.prop(s, "wrinkles_only", text="", icon="MOD_OCEAN")


class VIEW3D_PT_wrinkle_face(bpy.types.Panel):
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Wrinkles"
    bl_label = "Face Wrinkles"

    @classmethod
    def poll(cls, context):
        return _face(context) is not None

    def draw(self, context):
        layout = self.layout
        face = _face(context)
        s = face.wrinkles
        layout.label(text=face.name, icon="OBJECT_DATA")
        if s.enabled:
            layout.operator("wrinkle.disable", icon="CANCEL")
        else:
            layout.operator("wrinkle.enable", icon="CHECKMARK")
        _status_box(layout, pipeline.status(face))
        layout.prop(s, "strength")
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
        layout.label(text="Facial Muscle Set")
        row = layout.row(align=True)
        row.operator("wrinkle.add_landmarks", icon="EMPTY_AXIS")
        row.operator("wrinkle.add_muscle_set", icon="USER")
        layout.label(text="Expressions")
        grid = layout.grid_flow(columns=2, align=True)
        for key, label in (("SURPRISE", "Surprise"), ("FROWN", "Frowning"), ("FEAR", "Fear"),
                           ("NEUTRAL", "Neutral")):
            grid.operator("wrinkle.expression", text=label).expression = key
        layout.operator("wrinkle.refine", icon="MOD_SUBSURF")
        row = layout.row(align=True)
        row.operator("wrinkle.bake", icon="FILE_CACHE")
        if s.bake_object is not None or wrinklemaps.baked_paths(s.maps.weights_group):
            row.operator("wrinkle.free_bake", icon="TRASH")


class VIEW3D_PT_wrinkle_muscle(bpy.types.Panel):
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Wrinkles"
    bl_label = "Muscle"

    @classmethod
    def poll(cls, context):
        ob = context.active_object
        return ob is not None and ob.wrinkle_muscle.is_muscle

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        ob = context.active_object
        s = ob.wrinkle_muscle
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
        else:
            layout.prop(s, "length")
            layout.prop(s, "width")
            layout.prop(s, "width_c")
            layout.prop(s, "depth")
        layout.separator()
        layout.prop(s, "lambda_w")
        layout.prop(s, "n_wrinkles")
        layout.prop(s, "k0")
        layout.prop(s, "alpha")
        layout.prop(s, "fade_ends")
        layout.prop(s, "show_region")
        layout.operator("wrinkle.drive_contraction", icon="DRIVER")


class WRINKLE_UL_map_expressions(bpy.types.UIList):
    bl_idname = "WRINKLE_UL_map_expressions"

    def draw_item(self, context, layout, data, item, icon, active_data, active_propname, index):
        face = data.id_data
        row = layout.row(align=True)
        problem = wrinklemaps.binding_problem(face, index)
        row.prop(item, "name", text="", emboss=False, icon="ERROR" if problem else "SHAPEKEY_DATA")
        if item.source == "MANUAL":
            row.prop(item, "value", text="")
        else:
            row.label(text={"SHAPE_KEY": item.shape_key, "MUSCLE": item.muscle.name if item.muscle else "",
                            "PROPERTY": item.data_path}[item.source] or "(unbound)")


class VIEW3D_PT_wrinkle_maps(bpy.types.Panel):
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Wrinkles"
    bl_label = "Wrinkle Maps"
    bl_parent_id = "VIEW3D_PT_wrinkle_face"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        face = _face(context)
        m = face.wrinkles.maps
        _status_box(layout, wrinklemaps.status(face))
        col = layout.column(align=True)
        col.label(text="Generate from the muscles")
        row = col.row(align=True)
        row.operator("wrinkle.bake_wrinkle_map", icon="RENDER_STILL")
        row.operator("wrinkle.generate_masks", icon="MOD_MASK")
        col = layout.column()
        col.use_property_split = True
        if face.data.uv_layers:
            col.prop_search(m, "uv_map", face.data, "uv_layers")
        for prop in ("base_image", *wrinklemaps.MAP_PROPS[:wrinklemaps.n_maps(m)], "mask_a", "mask_b"):
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
            problem = wrinklemaps.binding_problem(face, m.active_expression)
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


def _status_box(layout, msg):
    """A problem message in a box: an error icon on the first line, wrapped to the panel."""
    if msg:
        box = layout.box()
        for i, line in enumerate(_wrap(msg, 48)):
            box.label(text=line, icon="ERROR" if i == 0 else "BLANK1")


def _wrap(text, width):
    words, lines, cur = text.split(), [], ""
    for w in words:
        if len(cur) + len(w) + 1 > width and cur:
            lines.append(cur)
            cur = w
        else:
            cur = f"{cur} {w}".strip()
    return lines + [cur] if cur else lines


classes = (WRINKLE_UL_muscles, WRINKLE_UL_map_expressions, VIEW3D_PT_wrinkle_face, VIEW3D_PT_wrinkle_maps,
           VIEW3D_PT_wrinkle_muscle)
register, unregister = bpy.utils.register_classes_factory(classes)
