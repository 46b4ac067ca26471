# SPDX-License-Identifier: GPL-3.0-or-later
"""The per-frame evaluator: one per face object, run from a ``frame_change_post`` handler.

Per frame, for every face with wrinkles enabled:

1. read the deformed skin ``wrinkle_skin`` from the evaluated mesh (shape keys,
   armature and other deformers, before our own offset - no feedback);
2. rebuild the cached static plan only if the topology, the rest positions or
   a muscle's geometry or parameters changed (compared by signature, so undo,
   drivers and animated parameters are all handled);
3. evaluate the muscles in NumPy (``core.system.evaluate``);
4. write the result, in one of two ways:

   * **write-back** (renders, exports, interactive edits): ``foreach_set`` the
     offsets into the original mesh's ``wrinkle_offset`` and tag it.  Blender
     then evaluates the face's whole modifier stack a second time in the same
     frame change (shape keys, armature, the stage), and any depsgraph built
     later - a render's, an exporter's - sees the same offsets.
   * **in place** (viewport frame changes: playback, scrubbing, ``frame_set``):
     write ``skin + offset`` straight into the evaluated mesh of the depsgraph
     that is being updated, and tell that mesh its positions changed so its
     normals are recomputed.  No second evaluation: a frame costs Blender's own
     evaluation plus this handler.  Used only when the evaluated mesh was
     re-evaluated for this frame (so its draw cache is rebuilt from our data)
     and has exactly the base vertices (no CPU subdivision after the stage);
     otherwise the frame falls back to write-back.

   Render and export depsgraphs are always written back (measured: every
   render and Alembic frame calls ``frame_change_post`` with a RENDER-mode
   depsgraph), so final frames never depend on the in-place path.

No ``bpy`` object is held between calls: the cache holds NumPy arrays keyed by
``Object.session_uid``, and every call looks the objects up again, so undo,
file reload, deleted muscles and Edit Mode topology changes cannot leave a
dangling reference.  Handlers never raise: problems become a status message
shown in the panel.
"""

import bpy
import numpy as np
from bpy.app.handlers import persistent

from . import meshio, muscle_objects, stage, wrinklemaps
from .core import mesh as core_mesh
from .core import system

_cache = {}  # session_uid -> _FaceState
_status = {}  # session_uid -> message for the panel


class _FaceState:
    __slots__ = ("key", "edges", "tris", "rest", "scratch", "sigs", "plan", "out", "skin", "positions",
                 "orig_inputs", "shown")

    def __init__(self):
        self.key = None
        self.scratch = None
        self.sigs = None
        self.plan = None
        self.orig_inputs = None  # the inputs whose offsets the original mesh holds
        self.shown = None  # the positions the evaluated mesh shows after our last write


def status(ob):
    return _status.get(ob.session_uid, "")


def _set_status(ob, message):
    if message:
        _status[ob.session_uid] = message
    else:
        _status.pop(ob.session_uid, None)


def check_face(ob):
    """Why wrinkles cannot run on ``ob``, or ``None``.  Used by operators and the handler."""
    if ob is None:
        return "No active object"
    if ob.type != "MESH":
        return f'"{ob.name}" is a {ob.type.lower()}, not a mesh: wrinkles need a face mesh'
    if ob.wrinkle_muscle.is_muscle:
        return f'"{ob.name}" is a muscle, not a face'
    if ob.library is not None or ob.data.library is not None:
        lib = (ob.library or ob.data.library).filepath
        return f'"{ob.name}" is linked from {lib} and is read-only: make it local or use a library override'
    if ob.override_library is not None and ob.data.library is not None:
        return f'The mesh of "{ob.name}" is linked and read-only: override or make it local'
    if len(ob.data.polygons) == 0:
        return f'"{ob.name}" has no faces: wrinkles need a surface'
    return None


def _topology(state, me):
    key = meshio.topology_key(me)
    if state.key == key:  # same counts: compare the rest shape in a reused buffer
        state.scratch = meshio.read_vectors(me, "position", state.scratch)
        if np.array_equal(state.scratch, state.rest):
            return False
    rest = meshio.read_vectors(me, "position")
    edges = meshio.read_edges(me)
    corner, starts, sizes = meshio.read_polygons(me)
    state.key = key
    state.rest = rest
    state.edges = edges
    state.tris = core_mesh.fan_triangles(corner, starts, sizes)
    state.out = np.zeros((len(rest), 3), dtype=np.float32)
    state.skin = np.empty((len(rest), 3), dtype=np.float32)
    state.positions = np.empty((len(rest), 3), dtype=np.float32)
    state.shown = None
    state.plan = None
    return True


def _plan(state, face, muscles):
    sigs = (np.array(face.matrix_world).tobytes(),) + tuple(
        muscle_objects.signature(m) for m in muscles)
    if state.plan is not None and sigs == state.sigs:
        return state.plan
    core_muscles = [muscle_objects.to_core(m, face) for m in muscles]
    state.plan = system.build_plan(state.rest, state.edges, state.tris, core_muscles)
    state.sigs = sigs
    state.out[:] = 0.0
    state.orig_inputs = None
    return state.plan


def _write_in_place(state, ev, skin, offset):
    """Write ``skin + offset`` into the evaluated mesh ``ev``.  False when that is not safe.

    Safe only when ``ev`` has exactly the base vertices and was re-evaluated
    since our last write, which we know when it no longer shows the positions
    that write left (``state.shown``): then Blender rebuilds its draw data from
    what we leave in it.  If it was not re-evaluated and already shows these
    positions, there is nothing to do.  Without a previous write we cannot tell.
    """
    if len(ev.vertices) != len(skin) or state.shown is None:
        return False
    pos = ev.attributes["position"]
    current = state.positions
    pos.data.foreach_get("vector", current.reshape(-1))
    new = skin + offset
    if np.array_equal(current, state.shown):
        return np.array_equal(new, current)  # not re-evaluated: only identical is fine
    pos.data.foreach_set("vector", new.reshape(-1))
    if ev.attributes.get(stage.OFFSET_ATTR) is not None:  # keep the evaluated mesh consistent
        meshio.write_vectors(ev, stage.OFFSET_ATTR, offset)
    ev.update()  # drops the cached normals; measured not to trigger a re-evaluation
    state.shown = new
    return True


def update_face(ob, depsgraph, only_if_changed=False, in_place=False, in_scene=None):
    """Evaluate and write one face's wrinkles.  Returns True when it wrote new offsets.

    ``in_place``: write into ``depsgraph``'s evaluated mesh if that is safe
    (see the module doc), else write back into the original mesh.
    ``only_if_changed``: skip when the original mesh already holds the offsets
    of these inputs.  ``in_scene``: see ``muscle_objects.live_muscles``."""
    uid = ob.session_uid
    why = check_face(ob)
    if why:
        _set_status(ob, why)
        return False
    if ob.mode == "EDIT":
        _set_status(ob, "Paused in Edit Mode")
        return False
    mod = stage.find_modifier(ob)
    if mod is None:
        _set_status(ob, "The Wrinkles modifier is missing: switch wrinkles off and on again")
        return False
    me = ob.data
    if me.attributes.get(stage.OFFSET_ATTR) is None:
        stage.ensure_offset_attribute(me)
    ev = ob.evaluated_get(depsgraph).data
    skin_att = ev.attributes.get(stage.SKIN_ATTR)
    if skin_att is None:
        _set_status(ob, "The Wrinkles modifier is disabled or not evaluated")
        return False
    why = stage.order_problem(ob, mod, len(ev.vertices))
    if why:
        _set_status(ob, why)
        return False

    state = _cache.get(uid)
    if state is None:
        state = _cache[uid] = _FaceState()
    _topology(state, me)
    muscles = muscle_objects.live_muscles(ob, in_scene)
    plan = _plan(state, ob, muscles)
    skin = meshio.read_vector_prefix(ev, stage.SKIN_ATTR, len(me.vertices), state.skin)
    contraction = np.array([m.wrinkle_muscle.contraction for m in muscles], dtype=np.float64)
    strength = ob.wrinkles.strength
    if only_if_changed and state.orig_inputs is not None:
        old_skin, old_c, old_s = state.orig_inputs
        if old_s == strength and np.array_equal(old_c, contraction) and np.array_equal(old_skin, skin):
            return False
    out = system.evaluate(plan, skin, contraction, strength, out=state.out)
    if not (in_place and _write_in_place(state, ev, skin, out)):
        meshio.write_vectors(me, stage.OFFSET_ATTR, out)
        me.update_tag()
        state.orig_inputs = (skin.copy(), contraction, strength)
        state.shown = skin + out  # what the re-evaluation that the tag triggers will show
    problems = [f'"{muscles[i].name}": {msg}' for i, msg in plan.problems]
    _set_status(ob, "Muscle without effect: " + "; ".join(problems) if problems else "")
    return True


def _scan(scene):
    """The faces with wrinkles on, the faces with tension-driven wrinkle maps, and the
    session_uid of every object, in one pass."""
    faces, tension, in_scene = [], [], set()
    for ob in scene.objects:
        in_scene.add(ob.session_uid)
        if ob.type == "MESH":
            if ob.wrinkles.enabled:
                faces.append(ob)
            if wrinklemaps.wants_tension(ob):
                tension.append(ob)
    return faces, tension, in_scene


def update_scene(scene, depsgraph, only_if_changed=False, in_place=False):
    faces, tension, in_scene = _scan(scene)
    for ob in tension:
        try:
            wrinklemaps.update_tension(ob, depsgraph)
        except Exception as exc:  # a handler must never raise into Blender
            wrinklemaps.set_status(ob, f"Tension weights skipped: {exc}")
    meshes = [ob.data for ob in faces]
    for ob in faces:
        if meshes.count(ob.data) > 1:  # linked duplicates would overwrite each other
            _set_status(ob, f'"{ob.name}" shares its mesh with another face with wrinkles: '
                            "make the mesh single-user (Object > Relations > Make Single User)")
            continue
        try:
            update_face(ob, depsgraph, only_if_changed, in_place, in_scene)
        except Exception as exc:  # a handler must never raise into Blender
            _set_status(ob, f"Internal error, wrinkles skipped: {exc!r}")
            print(f"Expression Wrinkles: {ob.name}: {exc!r}")


def _rendering():
    running = getattr(bpy.app, "is_job_running", None)
    return bool(running and running("RENDER"))


_in_frame_sync = False


def _current_depsgraph(scene):
    """The context's evaluated depsgraph, brought to the scene's current frame.

    Measured on bpy 4.5 and 5.2: on the FIRST frame of ``render(animation=True)``
    started from another frame, the context's depsgraph is still at the old
    frame (its ``scene_eval.frame_current`` lags), so the skin read from it and
    the original shape-key values the render re-evaluates with are both stale.
    Setting the frame again evaluates it; our handler skips the nested call.
    """
    global _in_frame_sync
    dg = bpy.context.evaluated_depsgraph_get()
    if dg.scene_eval.frame_current != scene.frame_current and not _in_frame_sync:
        _in_frame_sync = True
        try:
            scene.frame_set(scene.frame_current, subframe=scene.frame_subframe)
        finally:
            _in_frame_sync = False
        dg = bpy.context.evaluated_depsgraph_get()
    return dg


@persistent
def on_frame_change_post(scene, depsgraph=None):
    if _in_frame_sync:
        return
    if depsgraph is not None and depsgraph.mode == "VIEWPORT":
        # the depsgraph just evaluated for this frame: write into it, no second evaluation
        update_scene(scene, depsgraph, in_place=True)
        return
    # Renders and exports: write back, reading through the context's depsgraph, since the
    # handler's argument drops other animated shape keys during render(animation=True)
    # (BLENDER_NOTES.md, "Handlers").
    update_scene(scene, _current_depsgraph(scene))


@persistent
def on_depsgraph_update_post(scene, depsgraph=None):
    # Interactive edits only (a shape key slider, a muscle moved): renders and background
    # jobs are driven by frame changes.  Unchanged inputs write nothing, so our own
    # write does not loop.
    if bpy.app.background or _rendering():
        return
    screen = getattr(bpy.context, "screen", None)
    if screen is not None and screen.is_animation_playing:
        return  # playback is handled frame by frame
    update_scene(scene, bpy.context.evaluated_depsgraph_get(), only_if_changed=True)


@persistent
def on_save_pre(*_args):
    # In-place frames leave older offsets in the original mesh: store this frame's, so the
    # file opens showing what was on screen (even where the add-on is not installed).
    ctx = bpy.context
    if ctx.scene is not None and not _rendering():
        update_scene(ctx.scene, ctx.evaluated_depsgraph_get(), only_if_changed=True)


@persistent
def on_load_post(*_args):
    _cache.clear()
    _status.clear()


def refresh_all(context):
    """Re-evaluate after a property change (not while rendering)."""
    if context is None or context.scene is None or _rendering():
        return
    update_scene(context.scene, context.evaluated_depsgraph_get())


def enable(ob, scene):
    """Add the output stage and switch wrinkles on.  Raises ``stage.StageError``."""
    why = check_face(ob)
    if why:
        raise stage.StageError(why)
    stage.ensure_modifier(ob)
    scene.render.use_lock_interface = True


def disable(ob):
    """Remove the output stage: the mesh and its shape keys are exactly as before."""
    stage.remove(ob)
    _cache.pop(ob.session_uid, None)
    _status.pop(ob.session_uid, None)


def on_enabled_changed(ob, context):
    try:
        if ob.wrinkles.enabled:
            enable(ob, context.scene)
            refresh_all(context)
        else:
            disable(ob)
    except stage.StageError as exc:
        _set_status(ob, str(exc))


_HANDLERS = (
    (bpy.app.handlers.frame_change_post, on_frame_change_post),
    (bpy.app.handlers.depsgraph_update_post, on_depsgraph_update_post),
    (bpy.app.handlers.load_post, on_load_post),
    (bpy.app.handlers.save_pre, on_save_pre),
)


def register():
    for handlers, fn in _HANDLERS:
        if fn not in handlers:
            handlers.append(fn)


def unregister():
    for handlers, fn in _HANDLERS:
        while fn in handlers:
            handlers.remove(fn)
    _cache.clear()
    _status.clear()
