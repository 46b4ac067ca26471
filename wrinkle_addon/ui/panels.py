# SPDX-License-Identifier: GPL-3.0-or-later
"""The "Wrinkles" sidebar tab's face panel: what every face shares, then one collapsible
section per wrinkle source (``glue.registry``), each drawn by its source."""

import bpy

from ..glue import farm_bake, pipeline, registry, status
from .common import panel_face, status_box


class VIEW3D_PT_wrinkle_face(bpy.types.Panel):
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Wrinkles"
    bl_label = "Face Wrinkles"

    @classmethod
    def poll(cls, context):
        return panel_face(context) is not None

    def draw(self, context):
        layout = self.layout
        face = panel_face(context)
        s = face.ewrinkles_face
        layout.label(text=face.name, icon="OBJECT_DATA")
        if s.enabled:
            layout.operator("wrinkle.disable", icon="CANCEL")
        else:
            layout.operator("wrinkle.enable", icon="CHECKMARK")
        status_box(layout, status.get(face, pipeline.CHANNEL))
        layout.prop(s, "strength")
        layout.prop(s, "skin_age", slider=True)
        for source in registry.sources():
            header, body = layout.panel(f"wrinkle_source_{source.name}", default_closed=not source.geometric)
            header.label(text=source.label)
            if body is not None:
                status_box(body, status.get(face, source.name, family=True))
                source.draw(body, context, face)
        row = layout.row(align=True)
        row.operator("wrinkle.bake", icon="FILE_CACHE")
        if farm_bake.has_any_bake(face):
            row.operator("wrinkle.free_bake", icon="TRASH")
        header, body = layout.panel("wrinkle_export", default_closed=True)
        header.label(text="Export")
        if body is not None:
            col = body.column(align=True)
            col.operator("wrinkle.export_gltf", text="glTF for Engines", icon="EXPORT")
            col.operator("wrinkle.export_usd", text="USD", icon="EXPORT")
            col.operator("wrinkle.export_wrinkle_package", text="Wrinkle-Map Package", icon="EXPORT")
            col.operator("wrinkle.import_wrinkle_package", text="Import Wrinkle-Map Package", icon="IMPORT")


class VIEW3D_PT_wrinkle_start(bpy.types.Panel):
    """What the tab shows with no face selected: how to start, and the sample head."""

    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Wrinkles"
    bl_label = "Expression Wrinkles"

    @classmethod
    def poll(cls, context):
        return panel_face(context) is None

    def draw(self, context):
        layout = self.layout
        col = layout.column(align=True)
        col.label(text="Select a face mesh to give it wrinkles,")
        col.label(text="or try them on the sample head:")
        layout.operator("wrinkle.add_sample_head", icon="USER")


classes = (VIEW3D_PT_wrinkle_face, VIEW3D_PT_wrinkle_start)
register, unregister = bpy.utils.register_classes_factory(classes)
