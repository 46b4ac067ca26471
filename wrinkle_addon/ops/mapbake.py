# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators that generate wrinkle maps and masks from the face itself (Jimenez et al.
2011 with the muscles' own wrinkles); the work is ``glue.maps.map_bake``."""

import bpy
import numpy as np
from bpy.props import BoolProperty, EnumProperty, FloatProperty, StringProperty

from ..glue import faces, images
from ..glue.maps import map_bake
from ..glue.muscles import muscle_objects
from ..glue.progress import Progress
from .common import face_poll, guarded

_face = faces.active


def _assign_if_empty(face, prop, image):
    """Offer the new image to the face's wrinkle-map settings if that slot is empty."""
    if face.library is not None:
        return
    maps = getattr(face.ewrinkles_face, "maps", None)
    if maps is not None and hasattr(maps, prop) and getattr(maps, prop) is None:
        setattr(maps, prop, image)


class WRINKLE_OT_bake_wrinkle_map(bpy.types.Operator):
    """Bake a partial-derivative wrinkle map from the face's own muscle wrinkles (Zhang 2005
    heights, Jimenez et al. 2011 §1.2): the wrinkle height field is rasterised in UV space
    and turned into tangent-space slopes"""

    bl_idname = "wrinkle.bake_wrinkle_map"
    bl_label = "Bake Wrinkle Map"
    bl_options = {"REGISTER", "UNDO"}

    resolution: EnumProperty(
        name="Resolution",
        description="Width and height of the map in pixels (wrinkles are low frequency: "
        "the paper used 256 x 256)",
        items=map_bake.MAP_RESOLUTIONS,
        default="1024",
    )
    mode: EnumProperty(
        name="Wrinkles",
        description="Which wrinkles to bake",
        items=map_bake.MODES,
        default="MUSCLES",
    )
    smooth: BoolProperty(
        name="Smooth",
        description="Interpolate the slopes between the vertices, as smooth shading does with "
        "the geometric wrinkles; off: slopes per pixel from the height, which show the "
        "triangles as facets",
        default=True,
    )
    uv_map: StringProperty(
        name="UV Map",
        description="UV map to bake into (empty: the UV map of the face's wrinkle maps, else "
        "the active render UV map)",
        default="",
    )
    float_precision: BoolProperty(
        name="Float Precision",
        description="Store the map as 32-bit floats (16 bytes a pixel in memory) instead of 8 bits "
        "per channel (4 bytes a pixel; slopes in steps of 1/127.5, at most 0.004 off)",
        default=False,
    )
    image_name: StringProperty(
        name="Image",
        description="Name of the image to create or replace (empty: \"<face> Wrinkle PD\")",
        default="",
    )

    poll = face_poll(local=False, object_mode=True)

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    @guarded
    def execute(self, context):
        face = _face(context)
        with Progress(context, "Bake Wrinkle Map") as progress:
            pd = map_bake.bake_wrinkle_map(face, int(self.resolution), self.mode, self.uv_map,
                                          progress=progress, smooth=self.smooth)
            name = self.image_name or f"{face.name} Wrinkle PD"
            # 8 bits by default: a quarter of the memory of floats (Blender holds no half
            # floats), slopes within 0.004 of the float bake (docs/model.md)
            image = images.store(name, pd, float_buffer=self.float_precision, non_color=True)
        _assign_if_empty(face, "map_a", image)
        flat = float(np.abs(pd[..., :2] - 0.5).max()) < 1e-6
        if flat:
            why = ("no muscle is contracted and the skin is not compressed" if self.mode == "POSE"
                   else "the muscles compress no skin (is their Pull 0?)")
            self.report({"WARNING"}, f'"{image.name}" is flat: {why}')
        else:
            self.report({"INFO"}, f'Baked "{image.name}" ({self.resolution} x {self.resolution})')
        return {"FINISHED"}


class WRINKLE_OT_generate_masks(bpy.types.Operator):
    """Generate the 8 wrinkle zone masks (Jimenez et al. 2011 §1.1) from the muscles'
    wrinkling regions or from vertex groups, with soft borders, as two RGBA images
    (mask A: zones 1-4, mask B: zones 5-8)"""

    bl_idname = "wrinkle.generate_masks"
    bl_label = "Generate Masks"
    bl_options = {"REGISTER", "UNDO"}

    source: EnumProperty(
        name="Zones From",
        description="Where the 8 zones come from",
        items=map_bake.SOURCES,
        default="MUSCLES",
    )
    group_names: StringProperty(
        name="Vertex Groups",
        description="The 8 vertex groups, comma-separated in zone order (empty: 'Wrinkle Zone 1' "
        "to 'Wrinkle Zone 8'); leave an entry empty to skip its zone",
        default="",
    )
    softness: FloatProperty(
        name="Softness",
        description="Width of the soft border around each zone, measured on the skin",
        default=map_bake.DEFAULT_SOFTNESS, min=0.0, soft_max=0.05, subtype="DISTANCE",
    )
    resolution: EnumProperty(
        name="Resolution",
        description="Width and height of the masks in pixels (masks are low frequency: the "
        "paper used 64 x 64)",
        items=map_bake.MASK_RESOLUTIONS,
        default="256",
    )
    uv_map: StringProperty(
        name="UV Map",
        description="UV map of the masks (empty: the UV map of the face's wrinkle maps, else "
        "the active render UV map)",
        default="",
    )
    image_name: StringProperty(
        name="Images",
        description="Base name of the two images, which get \" A\" and \" B\" appended (empty: "
        "\"<face> Wrinkle Mask\")",
        default="",
    )

    poll = face_poll(local=False, object_mode=True)

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    @guarded
    def execute(self, context):
        face = _face(context)
        with Progress(context, "Generate Masks") as progress:
            softness = self.softness / muscle_objects.face_scale(face)  # world -> face-local
            a, b, notes = map_bake.generate_masks(face, int(self.resolution), self.source, softness,
                                                 self.uv_map, self.group_names, progress=progress)
            base = self.image_name or f"{face.name} Wrinkle Mask"
            image_a = images.store(f"{base} A", a, float_buffer=False, non_color=True)
            image_b = images.store(f"{base} B", b, float_buffer=False, non_color=True)
        _assign_if_empty(face, "mask_a", image_a)
        _assign_if_empty(face, "mask_b", image_b)
        for note in notes:
            self.report({"WARNING"}, note)
        self.report({"INFO"}, f'Generated "{image_a.name}" and "{image_b.name}"')
        return {"FINISHED"}


classes = (WRINKLE_OT_bake_wrinkle_map, WRINKLE_OT_generate_masks)
_register, _unregister = bpy.utils.register_classes_factory(classes)


def register():
    _register()


def unregister():
    _unregister()
