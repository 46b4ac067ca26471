# SPDX-License-Identifier: GPL-3.0-or-later
"""Operators on the face as a whole: switch wrinkles on and off, bake for a farm, place the
landmarks every method builds on, refine the wrinkling regions of every source."""

import functools

import bpy
import numpy as np
from bpy.props import BoolProperty, FloatProperty, IntProperty, StringProperty

from ..core import landmark_finder
from ..glue import faces, farm_bake, landmarks, pipeline, refine, registry
from ..glue.errors import WrinkleError
from ..glue.muscles import muscle_objects
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


class WRINKLE_OT_add_landmarks(bpy.types.Operator):
    """Find the landmarks the facial muscle set is built from (from the eye and mouth
    openings, the ARKit shape keys or the face's shape) and place them. Check them, move any
    that is off onto its feature, then run Add Facial Muscle Set"""

    bl_idname = "wrinkle.add_landmarks"
    bl_label = "Place Landmarks"
    bl_options = {"REGISTER", "UNDO"}

    poll = face_poll()

    @guarded
    def execute(self, context):
        method, message = landmarks.place_landmarks(context, _face(context))
        if message:
            self.report({"WARNING"}, message)
            return {"FINISHED"}
        self.report({"INFO"}, f"Landmarks found from {landmark_finder.LABELS[method]}: check them "
                              "(WL ...), then Add Facial Muscle Set")
        return {"FINISHED"}


def _union(needs):
    """One refinement rule from several (the sources' ``refine_need``)."""
    return lambda rest, edges: functools.reduce(np.union1d, [need(rest, edges) for need in needs],
                                                np.zeros(0, np.int64))


class WRINKLE_OT_refine(bpy.types.Operator):
    """Split the edges where the wrinkles need it until every half wrinkle cycle of the
    muscles and of the pattern layers spans at least the given number of edges, and the edges
    around the wrinkle curves are short enough for their sharp furrows; new points follow the
    smooth surface (keeps UVs, shape keys, vertex groups and materials)"""

    bl_idname = "wrinkle.refine"
    bl_label = "Refine Wrinkling Regions"
    bl_options = {"REGISTER", "UNDO"}

    edges_per_half_cycle: FloatProperty(
        name="Edges per Half Cycle",
        description="Minimum number of edge lengths across half a wrinkle (Zhang's u)",
        default=4.0, min=1.0, soft_max=8.0,
    )
    max_vertices: IntProperty(
        name="Vertex Limit",
        description="Stop before the mesh would grow beyond this many vertices",
        default=1_000_000, min=1000,
    )

    poll = face_poll(object_mode=True)

    @guarded
    def execute(self, context):
        face = _face(context)
        factor = self.edges_per_half_cycle
        needs = [need for need in (s.refine_need(face, factor, context.scene) for s in registry.sources())
                 if need is not None]
        if not needs:
            raise WrinkleError("This face has no muscles, wrinkle curves or pattern layers, so there is no "
                               "wrinkling region to refine")
        before = len(face.data.vertices)
        with Progress(context, "Refine Wrinkling Regions", total=refine.MAX_PASSES) as progress:
            result = refine.refine(face, _union(needs), self.max_vertices,
                                   progress=lambda i: progress(i, f"pass {i + 1}"))
        after = len(face.data.vertices)
        if result.message:  # set only when the rule is still broken
            self.report({"WARNING"}, result.message)
        elif result.passes == 0:
            self.report({"INFO"}, f"Nothing to refine: every half cycle already spans "
                                  f"{self.edges_per_half_cycle:g} edges")
        else:
            self.report({"INFO"}, f"Refined {before} -> {after} vertices in {result.passes} passes")
        pipeline.refresh_all(context)
        return {"FINISHED"}


classes = (WRINKLE_OT_enable, WRINKLE_OT_disable, WRINKLE_OT_bake, WRINKLE_OT_free_bake,
           WRINKLE_OT_add_landmarks, WRINKLE_OT_refine)
register, unregister = bpy.utils.register_classes_factory(classes)
