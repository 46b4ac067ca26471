# SPDX-License-Identifier: GPL-3.0-or-later
"""Export the wrinkled face for other tools and engines: glTF (wrinkle morph targets),
USD (time-sampled points) and the wrinkle-map package; import a package back."""

import os

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, IntProperty, StringProperty

from ..glue import faces
from ..glue.export import gltf, package, usd
from ..glue.progress import Progress
from .common import face_poll, guarded

_face = faces.active


def _range(op, scene):
    start = scene.frame_start if op.frame_start < 0 else op.frame_start
    end = scene.frame_end if op.frame_end < 0 else op.frame_end
    return start, end


def _default_path(face, ext):
    """``<.blend folder>/<face><ext>``, or beside the working folder for an unsaved file."""
    folder = os.path.dirname(bpy.data.filepath) if bpy.data.filepath else os.getcwd()
    return os.path.join(folder, bpy.path.clean_name(face.name) + ext)


def _start():
    return IntProperty(name="Start", description="First frame to export (-1: the scene's)", default=-1,
                       min=-1)


def _end():
    return IntProperty(name="End", description="Last frame to export (-1: the scene's)", default=-1, min=-1)


class _FileExport:
    """A file browser first, then ``execute``; the path defaults to the face's name."""

    ext = ""

    def invoke(self, context, _event):
        if not self.filepath:
            self.filepath = _default_path(_face(context), self.ext)
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}


class WRINKLE_OT_export_gltf(_FileExport, bpy.types.Operator):
    """Export the face with its wrinkles as glTF for game engines: its shape keys plus a few
    wrinkle morph targets, the animation of all their weights, and the wrinkle maps and masks
    as textures (Blender's glTF exporter)"""

    bl_idname = "wrinkle.export_gltf"
    bl_label = "Export glTF"
    bl_options = {"REGISTER", "UNDO"}
    ext = ".glb"

    filepath: StringProperty(name="File", description="The .glb (one file) or .gltf (with separate files) "
                             "to write", subtype="FILE_PATH", default="")
    filter_glob: StringProperty(default="*.glb;*.gltf", options={"HIDDEN"},
                                description="Files the browser shows")
    frame_start: _start()
    frame_end: _end()
    tolerance: FloatProperty(name="Tolerance", description="Largest distance in millimetres between the "
                             "exported wrinkles and the live ones on any vertex and frame; the fewest "
                             "wrinkle targets that reach it are exported", default=0.05, min=0.0,
                             soft_max=1.0, precision=3)
    max_targets: IntProperty(name="Max Targets", description="At most this many wrinkle morph targets "
                             "(engines limit how many play at once)", default=16, min=1, max=64)
    targets: IntProperty(name="Targets", description="Exactly this many wrinkle morph targets (0: the "
                         "fewest within the tolerance)", default=0, min=0, max=64)

    poll = face_poll()

    @guarded
    def execute(self, context):
        face = _face(context)
        start, end = _range(self, context.scene)
        with Progress(context, f"Export glTF {face.name}") as progress:
            r = gltf.export(context, face, self.filepath, start, end, self.tolerance, self.max_targets,
                            self.targets, progress)
        line = (f"{r['frames']} frames to {r['file']}: {r['targets']} wrinkle targets, largest error "
                f"{r['max_error_mm']:.4f} mm, mean {r['mean_error_mm']:.4f} mm")
        if r["within_tolerance"]:
            self.report({"INFO"}, line)
        else:
            self.report({"WARNING"}, f"{line}: more than the tolerance of {r['tolerance_mm']:g} mm; "
                                     "raise Max Targets or the Tolerance")
        return {"FINISHED"}


class WRINKLE_OT_export_usd(_FileExport, bpy.types.Operator):
    """Export the animated, wrinkled face as USD: its points on every frame, as it renders
    (Blender's USD exporter)"""

    bl_idname = "wrinkle.export_usd"
    bl_label = "Export USD"
    bl_options = {"REGISTER", "UNDO"}
    ext = ".usdc"

    filepath: StringProperty(name="File", description="The .usd, .usda, .usdc or .usdz file to write",
                             subtype="FILE_PATH", default="")
    filter_glob: StringProperty(default="*.usd;*.usda;*.usdc;*.usdz", options={"HIDDEN"},
                                description="Files the browser shows")
    frame_start: _start()
    frame_end: _end()
    keep_attributes: BoolProperty(name="Keep Wrinkle Attributes", description="Also write the add-on's "
                                  "own attributes (the wrinkle stage's skin, offsets and frame stamp, the "
                                  "fine wrinkles' fields), which only Blender reads: about half of the "
                                  "file", default=False)

    poll = face_poll()

    @guarded
    def execute(self, context):
        face = _face(context)
        start, end = _range(self, context.scene)
        with Progress(context, f"Export USD {face.name}") as progress:
            r = usd.export(context, face, self.filepath, start, end, progress,
                           keep_attributes=self.keep_attributes)
        self.report({"INFO"}, f"{r['frames']} frames of {r['points']} points to {r['file']}")
        return {"FINISHED"}


class _FolderPick:
    def invoke(self, context, _event):
        if not self.directory:
            self.directory = os.path.splitext(_default_path(_face(context), ""))[0] + "_wrinkles" + os.sep
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}


class WRINKLE_OT_export_package(_FolderPick, bpy.types.Operator):
    """Write the face's wrinkle maps, masks, expression table and the zone weights of every
    frame into one folder (wrinkles.json and images) for engine shaders"""

    bl_idname = "wrinkle.export_wrinkle_package"
    bl_label = "Export Wrinkle-Map Package"
    bl_options = {"REGISTER", "UNDO"}

    directory: StringProperty(name="Folder", description="The package's folder (made if missing; its "
                              "files of the same names are replaced)", subtype="DIR_PATH", default="")
    image_format: EnumProperty(name="Images", description="The file format of the maps and masks",
                               items=[("PNG", "PNG 16-bit", "16-bit PNG, linear"),
                                      ("OPEN_EXR", "OpenEXR 32-bit", "32-bit float OpenEXR")], default="PNG")
    frame_start: _start()
    frame_end: _end()

    poll = face_poll()

    @guarded
    def execute(self, context):
        face = _face(context)
        start, end = _range(self, context.scene)
        with Progress(context, f"Export Wrinkle Maps {face.name}", total=end - start + 1, every=25) as p:
            r = package.write(context, face, self.directory, start, end, self.image_format, p)
        self.report({"INFO"}, f"{r['maps']} maps, {r['expressions']} expressions and {r['frames']} frames "
                              f"of zone weights to {r['folder']}")
        return {"FINISHED"}


class WRINKLE_OT_import_package(_FolderPick, bpy.types.Operator):
    """Set the face's wrinkle maps up from a wrinkle-map package: its maps, masks and
    expression table, bound to this face's shape keys (or muscles and objects) of the same names"""

    bl_idname = "wrinkle.import_wrinkle_package"
    bl_label = "Import Wrinkle-Map Package"
    bl_options = {"REGISTER", "UNDO"}

    directory: StringProperty(name="Folder", description="The package's folder (it holds wrinkles.json)",
                              subtype="DIR_PATH", default="")

    poll = face_poll(uv=True)

    @guarded
    def execute(self, context):
        face = _face(context)
        unbound = package.read(context, face, self.directory)
        if unbound:
            self.report({"WARNING"}, "Wrinkle maps set up; " + "; ".join(unbound))
        else:
            self.report({"INFO"}, f'Wrinkle maps set up on "{face.name}" from {self.directory}')
        return {"FINISHED"}


classes = (WRINKLE_OT_export_gltf, WRINKLE_OT_export_usd, WRINKLE_OT_export_package,
           WRINKLE_OT_import_package)
register, unregister = bpy.utils.register_classes_factory(classes)
