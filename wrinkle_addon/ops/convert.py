# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators that prepare wrinkle maps (Jimenez et al. 2011, §1.2 and §1.2.1).

* ``wrinkle.convert_to_derivative``: standard tangent-space normal map -> partial
  derivative (PD) map, the pre-process of §1.2 (RG = 0.5 + 0.5 (n_x/n_z, n_y/n_z), B = 0).
* ``wrinkle.convert_to_normal``: PD map -> standard normal map (§1.2 reconstruction).
* ``wrinkle.make_difference_map``: base + wrinkle normal maps -> difference map
  d = 0.5 + 0.5 (w - b) (§1.2.1).

The maths is ``core.maps.jimenez``; pixels go through ``images``.  Results are Non-Color
images packed into the .blend, or written to a file the image then points at.  A source
pixel that is not finite (NaN or an infinity, e.g. in an EXR) becomes the neutral value of
its encoding (``replace_non_finite``: a flat normal, zero slopes), so the result is
finite everywhere, and the operator warns with the number of such pixels.
"""

import bpy
import numpy as np
from bpy.props import EnumProperty, StringProperty

from ..core.maps import jimenez
from ..glue import images
from ..glue.progress import Progress
from .common import guarded

N_CHUNKS = 8

FILE_FORMATS = [
    ("PNG_8", "PNG 8-bit", "PNG with 8 bits per channel: small files, the usual precision of normal maps"),
    ("PNG_16", "PNG 16-bit", "PNG with 16 bits per channel: finer slopes, lossless"),
    ("EXR_16", "OpenEXR Half", "OpenEXR with 16-bit half floats, lossless ZIP compression"),
    ("EXR_32", "OpenEXR Float", "OpenEXR with 32-bit floats, lossless ZIP compression"),
]
_FORMAT = {
    "PNG_8": ("PNG", "8"),
    "PNG_16": ("PNG", "16"),
    "EXR_16": ("OPEN_EXR", "16"),
    "EXR_32": ("OPEN_EXR", "32"),
}


def _by_rows(context, label, fn, arrays):
    """``fn`` applied to the arrays (H, W, C) in row chunks, with progress.

    The formulas are per pixel, so the chunks give exactly the whole-image result.
    """
    h = arrays[0].shape[0]
    bounds = np.linspace(0, h, min(N_CHUNKS, h) + 1).astype(int)
    n = len(bounds) - 1
    out = None
    with Progress(context, label, total=n) as progress:
        for i in range(n):
            a, b = bounds[i], bounds[i + 1]
            part = fn(*(x[a:b] for x in arrays))
            if out is None:
                out = np.empty((h,) + part.shape[1:], dtype=np.float32)
            out[a:b] = part
            progress(i + 1, f"rows {a}-{b}")
    return out


def _has_images(cls, context):
    if not context.blend_data.images:
        cls.poll_message_set("Open or create an image first")
        return False
    return True


class _MapOperator:
    """Shared properties and steps: look up the sources, check them, run, store, save."""

    bl_options = {"REGISTER", "UNDO"}

    output: StringProperty(
        name="Output Image",
        description="Name of the image that receives the result; empty: named after the source",
    )
    filepath: StringProperty(
        name="Output File",
        description="Also write the result to this file and make the image use it; "
                    "empty: keep the result packed in the .blend file only",
        subtype="FILE_PATH",
        options={"PATH_SUPPORTS_BLEND_RELATIVE"},
    )
    file_format: EnumProperty(
        name="File Format",
        description="Format of the output file (used only when an output file is given)",
        items=FILE_FORMATS,
        default="PNG_8",
    )

    poll = classmethod(_has_images)

    # Set by subclasses.
    suffix = ""
    verb = ""
    flat = jimenez.FLAT_NORMAL  # what a source pixel that is not finite becomes
    flat_label = ""

    source_props = ("source",)

    def sources(self):
        """[(label, image name)] in the order ``compute`` takes them."""
        raise NotImplementedError

    def compute(self, *pixels):
        raise NotImplementedError

    def _image(self, label, name):
        if not name:
            raise images.ImageError(f"Choose the {label.lower()} image")
        image = bpy.data.images.get(name)
        if image is None:
            raise images.ImageError(f"There is no image called '{name}'")
        images.check_loaded(image)
        n = images.channel_count(image)
        if n < 3:
            raise images.ImageError(f"{label} '{name}' has {n} channel{'s' * (n > 1)}; it needs RGB")
        return image

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def draw(self, context):
        layout = self.layout
        layout.use_property_split = True
        for prop in self.source_props:
            layout.prop_search(self, prop, bpy.data, "images")
        for prop in ("output", "filepath", "file_format"):
            layout.prop(self, prop)

    def _check_path(self):
        if self.filepath.startswith("//") and not bpy.data.filepath:
            raise images.ImageError("The output file path is relative to the .blend file, which is "
                                    "not saved yet: save it first or give an absolute path")

    @guarded
    def execute(self, context):
        try:
            srcs = [self._image(label, name) for label, name in self.sources()]
            images.check_same_size(srcs)
            out_name = self.output.strip() or f"{srcs[-1].name} {self.suffix}"
            if out_name in {im.name for im in srcs}:
                raise images.ImageError(f"The output image '{out_name}' is one of the sources: "
                                        "choose another output name")
            self._check_path()
            pixels = [images.read(im) for im in srcs]
        except images.ImageError as exc:
            self.report({"ERROR"}, str(exc))
            return {"CANCELLED"}
        pixels, n_bad = jimenez.replace_non_finite(pixels, self.flat)
        result = _by_rows(context, f"{self.verb} {srcs[-1].name}", self.compute, pixels)
        if n_bad:
            self.report({"WARNING"}, f"{n_bad} pixel{'s were' if n_bad > 1 else ' was'} not finite "
                                     f"(NaN or infinity) and {'were' if n_bad > 1 else 'was'} "
                                     f"replaced by {self.flat_label}")
        float_buffer = any(im.is_float for im in srcs) or bool(self.filepath and self.file_format != "PNG_8")
        image = images.store(out_name, result, float_buffer=float_buffer)
        for im in srcs:
            warning = images.colour_warning(im)
            if warning:
                self.report({"WARNING"}, warning)
        if self.filepath:
            try:
                path = images.save(image, self.filepath, *_FORMAT[self.file_format])
                images.link_to_file(image, bpy.path.relpath(path) if self.filepath.startswith("//") else path)
            except images.ImageError as exc:
                self.report({"WARNING"}, f"{exc}; the result is kept packed in '{image.name}'")
                return {"FINISHED"}
            self.report({"INFO"}, f"Made '{image.name}', saved to {path}")
        else:
            self.report({"INFO"}, f"Made '{image.name}' (packed in the .blend file)")
        return {"FINISHED"}


class WRINKLE_OT_convert_to_derivative(_MapOperator, bpy.types.Operator):
    """Convert a tangent-space normal map to a partial-derivative map (Jimenez et al. 2011, §1.2):
    wrinkle maps in this form add up; slopes steeper than 45 degrees are clipped"""

    bl_idname = "wrinkle.convert_to_derivative"
    bl_label = "Normal Map to Derivative Map"

    source: StringProperty(
        name="Normal Map",
        description="Standard tangent-space normal map to convert (OpenGL convention, +Y up)",
    )

    suffix = "PD"
    verb = "converting"
    flat_label = "a flat normal (0.5, 0.5, 1): zero slopes (0.5, 0.5, 0) in the result"

    def sources(self):
        return [("Normal map", self.source)]

    def compute(self, rgba):
        return jimenez.normal_to_derivative(rgba)


class WRINKLE_OT_convert_to_normal(_MapOperator, bpy.types.Operator):
    """Convert a partial-derivative map back to a standard tangent-space normal map
    (Jimenez et al. 2011, §1.2)"""

    bl_idname = "wrinkle.convert_to_normal"
    bl_label = "Derivative Map to Normal Map"

    source: StringProperty(
        name="Derivative Map",
        description="Partial-derivative map to convert (slopes in R and G)",
    )

    suffix = "Normal"
    verb = "converting"
    flat = jimenez.FLAT_DERIVATIVE
    flat_label = "zero slopes (0.5, 0.5): a flat normal (0.5, 0.5, 1) in the result"

    def sources(self):
        return [("Derivative map", self.source)]

    def compute(self, rgba):
        return jimenez.derivative_to_normal(rgba)


class WRINKLE_OT_make_difference_map(_MapOperator, bpy.types.Operator):
    """Make a difference map, 0.5 + 0.5 (wrinkle - base), from a base and a wrinkle normal map
    of the same size (Jimenez et al. 2011, §1.2.1)"""

    bl_idname = "wrinkle.make_difference_map"
    bl_label = "Make Difference Map"

    source_props = ("base", "wrinkle")
    base: StringProperty(
        name="Base Normal Map",
        description="The face's normal map without expression wrinkles",
    )
    wrinkle: StringProperty(
        name="Wrinkle Normal Map",
        description="The same normal map with the expression's wrinkles added",
    )

    suffix = "Diff"
    verb = "differencing"
    flat_label = ("a flat normal (0.5, 0.5, 1) in both maps: no difference (0.5, 0.5, 0.5) "
                  "in the result")

    def sources(self):
        return [("Base normal map", self.base), ("Wrinkle normal map", self.wrinkle)]

    def compute(self, base, wrinkle):
        return jimenez.difference_map(base, wrinkle)


classes = (
    WRINKLE_OT_convert_to_derivative,
    WRINKLE_OT_convert_to_normal,
    WRINKLE_OT_make_difference_map,
)
_register, _unregister = bpy.utils.register_classes_factory(classes)


def register():
    _register()


def unregister():
    _unregister()
