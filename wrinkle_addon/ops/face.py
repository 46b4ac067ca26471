# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators on the face as a whole: switch wrinkles on and off, bake for a farm."""

import bpy
from bpy.props import BoolProperty, IntProperty, StringProperty

from ..glue import faces, farm_bake, pipeline, registry
from ..glue.errors import WrinkleError
from ..glue.muscles import objects as muscle_objects
from ..glue.progress import Progress
from .common import face_poll, guarded

_face = faces.active


class WRINKLE_OT_enable(bpy.types.Operator):
    """Switch animated wrinkles on for the active face: adds the Wrinkles output modifier"""

    bl_idname = "wrinkle.enable"
    bl_label = "Enable Wrinkles"
    bl_options = {"REGISTER", "UNDO"}

    poll = face_poll()

    @guarded
    def execute(self, context):
        ob = _face(context)
        pipeline.enable(ob, context.scene)
        muscle_objects.set_up_face(ob)  # its own seed for the irregular wrinkles
        ob.ewrinkles_face.enabled = True
        self.report({"INFO"}, "Wrinkles on. Render > Lock Interface was switched on so that "
                              "renders started from the interface show the right wrinkles")
        return {"FINISHED"}


class WRINKLE_OT_disable(bpy.types.Operator):
    """Switch wrinkles off for the active face and remove the output stage; the mesh is
    restored exactly, muscles and settings are kept"""

    bl_idname = "wrinkle.disable"
    bl_label = "Disable Wrinkles"
    bl_options = {"REGISTER", "UNDO"}

    remove_muscles: BoolProperty(
        name="Delete Muscles",
        description="Also delete this face's muscle objects and empty its muscle list (muscles "
        "linked from a library are kept)",
        default=False,
    )

    poll = face_poll(local=False, polygons=False)

    @guarded
    def execute(self, context):
        ob = _face(context)
        why = faces.problem(ob, polygons=False)
        if why:
            raise WrinkleError(why)
        ob.ewrinkles_face.enabled = False
        pipeline.disable(ob)
        if self.remove_muscles:
            refs = ob.ewrinkles_face.muscles
            linked = [r.object for r in refs if r.object is not None and r.object.library is not None]
            for m in [r.object for r in refs if r.object is not None and r.object.library is None]:
                bpy.data.objects.remove(m)
            refs.clear()
            for m in linked:  # linked muscles are not ours to delete: they stay on the face
                refs.add().object = m
            if linked:
                self.report({"WARNING"}, f"{len(linked)} muscle(s) linked from a library were kept")
        return {"FINISHED"}


class WRINKLE_OT_bake(bpy.types.Operator):
    """Bake the animated, wrinkled face to an Alembic cache next to the .blend file and render
    a stand-in from it, so the file renders on a farm with no add-on installed"""

    bl_idname = "wrinkle.bake"
    bl_label = "Bake for Farm"
    bl_options = {"REGISTER", "UNDO"}

    filepath: StringProperty(name="File", description="Alembic file to write (// is the .blend's folder)",
                             subtype="FILE_PATH", default="")
    frame_start: IntProperty(name="Start", description="First frame to bake (default: the scene's)",
                             default=-1)
    frame_end: IntProperty(name="End", description="Last frame to bake (default: the scene's)",
                           default=-1)

    poll = face_poll()

    @guarded
    def execute(self, context):
        face = _face(context)
        scene = context.scene
        start = scene.frame_start if self.frame_start < 0 else self.frame_start
        end = scene.frame_end if self.frame_end < 0 else self.frame_end
        geometry = farm_bake.has_stage(face)
        baking = [s for s in registry.sources() if s.bakes(face)]
        if not geometry and not baking:
            raise WrinkleError(f'"{face.name}" has nothing to bake: it has no geometric wrinkles or wrinkle '
                               "maps, and what else it has Blender computes on a farm by itself")
        path = self.filepath or farm_bake.default_path(face)
        # every precondition, the geometry's and each source's, before anything changes
        if end < start:
            raise farm_bake.BakeError(f"The frame range {start}-{end} is empty: set End at or after Start")
        problems = [farm_bake.problem(face, path, start, end)] if geometry else []
        problems += [source.check(face, scene, start, end) for source in baking]
        problems = list(dict.fromkeys(p for p in problems if p))
        if problems:
            raise farm_bake.BakeError("Nothing was baked: " + "; ".join(problems))
        n = end - start + 1
        done = []
        job = None
        try:
            with Progress(context, f"Bake for Farm {face.name}", total=(1 + len(baking)) * n,
                          every=25) as progress:
                if geometry:
                    progress(0, f"frames {start}-{end} to {path}")
                    try:
                        job = farm_bake.Bake(context, face, path, start, end)
                        baked = job.run()
                    except (RuntimeError, OSError) as exc:
                        raise farm_bake.BakeError(str(exc)) from exc
                    done.append(f'frames {start}-{end} to {path}; "{baked.name}" renders them')
                for k, source in enumerate(baking):
                    offset = (k + 1) * n
                    line = source.bake(face, scene, start, end,
                                       lambda i, _total, o=offset, s=source: progress(o + i, s.label))
                    if line:
                        done.append(line)
        except WrinkleError as exc:
            # the bake has begun: the geometry's cache is taken back (no file is left behind),
            # and what else changed is one undo step that brings the file back as it was
            if job is not None:
                job.undo()
                done = [line for line in done if not line.startswith(f"frames {start}-{end} to ")]
            made = f"Baked only {'; '.join(done)}" if done else "Nothing was baked"
            self.report({"ERROR"}, f"{exc}. {made}: {farm_bake.FAILED_ENDING}")
            return {"FINISHED"}
        if job is not None:
            job.keep()
        self.report({"INFO"}, "Baked " + "; ".join(done) if done else
                    "Nothing needed baking: the wrinkle maps' drivers need no add-on")
        return {"FINISHED"}


class WRINKLE_OT_free_bake(bpy.types.Operator):
    """Remove the baked stand-in and render the live wrinkles again (the cache file is kept)"""

    bl_idname = "wrinkle.free_bake"
    bl_label = "Free Bake"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        face = _face(context)
        if face is None or face.type != "MESH" or not farm_bake.has_any_bake(face):
            cls.poll_message_set("This face has no bake")
            return False
        return True

    @guarded
    def execute(self, context):
        face = _face(context)
        farm_bake.free(face)
        for source in registry.sources():
            if source.has_bake(face):
                source.free_bake(face)
        return {"FINISHED"}


classes = (WRINKLE_OT_enable, WRINKLE_OT_disable, WRINKLE_OT_bake, WRINKLE_OT_free_bake)
register, unregister = bpy.utils.register_classes_factory(classes)
