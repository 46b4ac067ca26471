# SPDX-License-Identifier: GPL-3.0-or-later
"""The frame stage: one per face object, run from a ``frame_change_post`` handler.

Per frame, for every face on which a wrinkle source is active (docs/architecture.md):

1. read the deformed skin once: ``wrinkle_skin`` from the evaluated mesh (shape keys,
   armature and other deformers, before our own offset - no feedback);
2. rebuild a source's cached static data only when its ``static_key`` changes (the
   topology, the rest positions, a muscle's geometry or parameters: compared by value, so
   undo, drivers and animated parameters are all handled), and the combined plan of the
   geometric sources only when one of theirs changes;
3. ask every active source for its contribution (``glue.registry``) and sum them
   (``core.combine``): the tangential offsets, plus every height along one skin normal;
4. write the result once, in one of two ways, then the sources' shading values:

   * **write-back** (renders, exports, interactive edits): ``foreach_set`` the
     offsets into the original mesh's ``wrinkle_offset`` and tag it.  Blender
     then evaluates the face's whole modifier stack a second time in the same
     frame change (shape keys, armature, the stage), and any depsgraph built
     later - a render's, an exporter's - sees the same offsets.
   * **in place** (viewport frame changes: playback, scrubbing, ``frame_set``):
     write ``skin + offset`` straight into the evaluated mesh of the depsgraph
     that is being updated, and tell that mesh its positions changed so its
     normals are recomputed.  No second evaluation: a frame costs Blender's own
     evaluation plus this handler.  Used only when no modifier shown in the
     viewport follows the Wrinkles modifier but a final Subdivision Surface (a
     deformer after it - Displace, Smooth, Armature - moves the points again,
     and writing over its result would drop its effect; ``stage.output_is_final``),
     when the evaluated mesh was re-evaluated for this frame (so its draw cache
     is rebuilt from our data) and has exactly the base vertices (no CPU
     subdivision); otherwise the frame falls back to write-back, which is always
     right since Blender then evaluates the whole stack again.

   Render and export depsgraphs are always written back (measured: every
   render and Alembic frame calls ``frame_change_post`` with a RENDER-mode
   depsgraph), so final frames never depend on the in-place path.

No ``bpy`` object is held between calls: the cache holds NumPy arrays keyed by
``Object.session_uid``, and every call looks the objects up again, so undo,
file reload, deleted muscles and Edit Mode topology changes cannot leave a
dangling reference.  Handlers never raise: problems become a status message
shown in the panel, and a source that raises loses only its own wrinkles for that frame
(:func:`_run`).
"""

import contextlib
import itertools
import time

import bpy
import numpy as np
from bpy.app.handlers import persistent

from ..core import combine, mesh
from . import faces, meshio, registry, stage, status
from .errors import WrinkleError

CHANNEL = "stage"  # the status channel of the stage itself
_cache = {}  # session_uid -> _FaceState
_builds = itertools.count()  # serial numbers of static builds


class _FaceState:
    __slots__ = ("key", "mesh", "scratch", "statics", "plan", "plan_key", "out", "skin", "positions",
                 "orig_inputs", "shown", "pull_written")

    def __init__(self):
        self.key = None
        self.mesh = None
        self.scratch = None
        self.statics = {}  # source name -> (static key, static data, build serial number)
        self.plan = None  # core.combine.Plan of the geometric sources
        self.plan_key = None
        self.orig_inputs = None  # the inputs whose offsets the original mesh holds
        self.shown = None  # the positions the evaluated mesh shows after our last write
        self.pull_written = True  # the original mesh may hold a pull (unknown: assume it does)


def status_of(ob):
    """Every message the panel shows for ``ob`` (the stage's and the sources')."""
    return status.get(ob)


def forget(ob, source_name=None):
    """Drop ``ob``'s cached static data (of one source, or all): the next frame rebuilds it.
    For changes no static key can see, such as new pixels in a mask image."""
    state = _cache.get(ob.session_uid)
    if state is not None:
        if source_name is None:
            _cache.pop(ob.session_uid, None)
        else:
            state.statics.pop(source_name, None)
            state.plan_key = None


def face_state(ob):
    """The stage's cached state of the face ``ob`` (None before its first frame), for
    benchmarks and tests; read it, never change it: ``statics`` (source name -> (static key,
    static data, build serial number)), ``out`` (the offsets of the last frame, (N, 3)),
    ``mesh`` (the rest mesh, ``registry.MeshArrays``), ``skin`` and ``positions`` (buffers of
    the last frame)."""
    return _cache.get(ob.session_uid)


def forget_all():
    """Drop every face's cached state: the next frame builds everything again."""
    _cache.clear()


def write_in_place(ob, ev, skin, offset):
    """The viewport frame's in-place write of ``skin + offset`` into the evaluated mesh
    ``ev`` of the face ``ob`` (see :func:`_write_in_place`), on its own: for benchmarks that
    time it.  False when it is not safe or ``ob`` has no state yet."""
    state = _cache.get(ob.session_uid)
    return state is not None and _write_in_place(state, ev, skin, offset)


def _topology(state, me, changes=None):
    """Re-read the rest mesh when its topology or rest positions changed.  ``changes`` (see
    :func:`_static`): an edit of the mesh tags it with every flag, transform included;
    animation (shape keys) tags only its geometry, and then the rest cannot have changed."""
    key = meshio.topology_key(me)
    if state.key == key and changes is not None and not changes.get(me.session_uid, (False,))[0]:
        return False
    if state.key == key:  # same counts: compare the rest shape in a reused buffer
        state.scratch = meshio.read_vectors(me, "position", state.scratch)
        if np.array_equal(state.scratch, state.mesh.rest):
            return False
    rest = meshio.read_vectors(me, "position")
    corner, starts, sizes = meshio.read_polygons(me)
    state.key = key
    tris = mesh.fan_triangles(corner, starts, sizes)
    state.mesh = registry.MeshArrays(rest, meshio.read_edges(me), tris)
    n = len(rest)
    state.out = np.zeros((n, 3), dtype=np.float32)
    state.skin = np.empty((n, 3), dtype=np.float32)
    state.positions = np.empty((n, 3), dtype=np.float32)
    state.statics = {}
    state.plan = state.plan_key = None
    state.shown = None
    return True


def _static(state, source, ob, in_scene, changes):
    """The source's static data, rebuilt when its key changed; each build gets a new serial
    number, which the combined plan's key is made of.  ``changes`` (viewport frames): the
    IDs Blender updated; when they cannot have changed the data, the key is not computed."""
    cached = state.statics.get(source.name)
    if cached is not None and changes is not None and source.unchanged(ob, cached[1], changes, in_scene):
        return cached[1]
    key = source.static_key(ob, in_scene)
    if cached is not None and cached[0] == key:
        return cached[1]
    data = source.build(ob, state.mesh, in_scene)
    state.statics[source.name] = (key, data, next(_builds))
    return data


def _nothing_to_do(ob, active, changes, in_scene):
    """Whether a viewport frame has no work on a face whose active sources all compute nothing
    per frame (``per_frame`` False) and keep their static data (``unchanged``)."""
    if any(s.per_frame for s in active):
        return False
    state = _cache.get(ob.session_uid)
    if state is None or in_scene is None:
        return False
    for s in active:
        cached = state.statics.get(s.name)
        if cached is None or not s.unchanged(ob, cached[1], changes, in_scene):
            return False
    return True


def _plan(state, geometric, statics):
    key = tuple((s.name, state.statics[s.name][2]) for s in geometric)
    if state.plan is None or state.plan_key != key:
        footprints = [statics[s.name].footprint for s in geometric]
        state.plan = combine.build(len(state.mesh.rest), state.mesh.tris, footprints)
        state.plan_key = key
        state.out[:] = 0.0
        state.orig_inputs = None
    return state.plan


def _write_in_place(state, ev, skin, offset):
    """Write ``skin + offset`` into the evaluated mesh ``ev``.  False when that is not safe.

    Safe only when ``ev`` has exactly the base vertices and was re-evaluated
    since our last write, which we know when it no longer shows the positions
    that write left (``state.shown``): then Blender rebuilds its draw data from
    what we leave in it (after ``ev.update()``, which the caller calls once every
    value is in).  If it was not re-evaluated and already shows these positions,
    there is nothing to do.  Without a previous write we cannot tell.
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
    att = meshio.attribute(ev, stage.OFFSET_ATTR, "FLOAT_VECTOR")
    if att is not None:  # keep it consistent
        att.data.foreach_set("vector", offset.reshape(-1))
    state.shown = new
    return True


def _write_pulled(ob, readers, statics, ev, pulled, failed):
    """Whether every source whose tree measures the skin plus the pull (``readers``) wrote
    this in-place frame's values from the pulled skin into ``ev`` (``write_pulled``)."""
    return all(_run(ob, s, failed, s.write_pulled, ob, statics[s.name], ev, pulled) is True
               for s in readers)


def _stage_problem(ob, ev, mod):
    """Why the geometric stage cannot run on ``ob`` this frame, or None."""
    if mod is None:
        return "The Wrinkles modifier is missing: switch wrinkles off and on again"
    if meshio.attribute(ev, stage.SKIN_ATTR, "FLOAT_VECTOR") is None:
        return "The Wrinkles modifier is disabled or not evaluated"
    return stage.order_problem(ob, mod, len(ev.vertices))


def _write_shading(ob, active, statics, contributions, failed, ev=None, update=False):
    """The sources' shading values; their point attributes into the evaluated mesh ``ev``
    when given (viewport frames whose geometry was written in place: no re-evaluation, which
    a write into the original mesh's attribute triggers, measured 3 ms at 50k vertices), else
    into the original mesh (renders, exports, edits).  ``ev.update()`` follows when anything
    went into ``ev`` or ``update`` says other values did.  Returns whether any went in."""
    in_place = False

    def write(source, part):
        nonlocal in_place
        for name, values in part.attributes.items():
            att = meshio.attribute(ev, name, "FLOAT") if ev is not None else None
            if (att is not None and len(att.data) == len(values)
                    and meshio.attribute(ob.data, name, "FLOAT") is not None):
                att.data.foreach_set("value", np.ascontiguousarray(values, dtype=np.float32))
                in_place = True
            else:
                meshio.write_floats(ob.data, name, values)
        for name, values in part.shading.items():
            source.write_shading(ob, statics[source.name], name, values)

    for source, part in zip(active, contributions):
        _run(ob, source, failed, write, source, part)
    if in_place or update:
        ev.update()  # drops the cached normals and draw data; measured not to re-evaluate
    return in_place


_FAILED = object()


def _run(ob, source, failed, call, *args):
    """``call(*args)`` for ``source``, or ``_FAILED`` if it raised.  One source's problem stays
    its own: its message goes to ``failed[source.name]`` (a ``WrinkleError``'s as is, anything
    else as an internal error, also printed on the console), the caller leaves that source
    out of the frame, and the other sources' wrinkles are still written."""
    try:
        return call(*args)
    except WrinkleError as exc:
        failed[source.name] = str(exc)
    except Exception as exc:
        failed[source.name] = f"Internal error, {source.label or source.name} skipped: {exc!r}"
        print(f"Expression Wrinkles: {ob.name}: {source.name}: {exc!r}")
    return _FAILED


def _contributions(ob, active, statics, skin, inputs, failed):
    """Every active source's contribution, in the registry's order (an empty one for a source
    whose ``contribute`` raised, see :func:`_run`).  A source that moves the skin
    tangentially (Waters' pull) deforms it for the sources after it: their compression and
    shrinkage see the pulled skin.  Heights never feed back: every source reads the skin
    before any wrinkle.  Returns the contributions and the pulled skin (``skin`` itself where
    no source moved it)."""
    out, deformed = [], skin
    for i, (s, frame_in) in enumerate(zip(active, inputs)):
        c = _run(ob, s, failed, s.contribute, ob, statics[s.name], deformed, frame_in)
        if c is _FAILED:
            c = combine.Contribution()
        out.append(c)
        if i + 1 < len(active) and s.geometric and c.offset is not None and len(c.offset):
            if deformed is skin:
                deformed = skin.copy()
            deformed[statics[s.name].footprint.offset_verts] += c.offset.T
    return out, deformed


def update_face(ob, depsgraph, only_if_changed=False, in_place=False, in_scene=None, changes=None):
    """Evaluate every active wrinkle source on one face and write the result once.

    Returns True when it wrote new offsets.  ``in_place``: write into ``depsgraph``'s
    evaluated mesh if that is safe (see the module doc), else write back into the original
    mesh.  ``only_if_changed``: skip when the original mesh already holds the offsets of
    these inputs.  ``in_scene``: the ``session_uid`` of every object of the scene.
    ``changes``: the IDs Blender updated for this frame (see :func:`_static`), or None."""
    enabled = ob.ewrinkles_face.enabled
    active = [s for s in registry.sources() if (enabled or not s.geometric) and s.active(ob)]
    if not active and not enabled:
        return False
    if not enabled and changes is not None and _nothing_to_do(ob, active, changes, in_scene):
        return False  # what there is Blender computes itself, and nothing it reads changed
    why = faces.problem(ob)
    if why is None and (ob.mode == "EDIT" or ob.data.is_editmode):  # also through another object
        why = "Paused in Edit Mode"
    me = ob.data
    ev = ob.evaluated_get(depsgraph).data if why is None else None
    mod = stage.find_modifier(ob) if enabled else None
    if why is None and enabled:
        if mod is not None and meshio.attribute(me, stage.OFFSET_ATTR, "FLOAT_VECTOR") is None:
            stage.ensure_offset_attribute(me)  # missing, or another type under our name: replaced
        why = _stage_problem(ob, ev, mod)
    status.set(ob, CHANNEL, why or "")
    if why:
        return False
    if in_scene is None:
        in_scene = {o.session_uid for o in bpy.context.scene.objects}

    state = _cache.get(ob.session_uid)
    if state is None:
        state = _cache[ob.session_uid] = _FaceState()
    _topology(state, me, changes)
    n = len(state.mesh.rest)
    if len(ev.vertices) < n:
        status.set(ob, CHANNEL, f'The modifiers of "{ob.name}" remove vertices: wrinkles need them all')
        return False
    skin = meshio.read_vector_prefix(ev, stage.SKIN_ATTR if enabled else "position", n, state.skin)
    failed = {}  # source name -> its message, for a source that raised (see _run)
    statics, ok, frame_inputs = {}, [], ()
    for s in active:  # a source whose static data or inputs raise leaves this frame
        data = _run(ob, s, failed, _static, state, s, ob, in_scene, changes)
        if data is not _FAILED:
            statics[s.name] = data
            frame_in = _run(ob, s, failed, s.inputs, ob, data)
            if frame_in is not _FAILED:
                ok.append(s)
                frame_inputs += (frame_in,)
    active = ok
    # the build serials: static data rebuilt by an interactive edit (a curve or muscle moved)
    # must be written even when the skin and the frame's inputs are as before
    serials = tuple(state.statics[s.name][2] for s in active)
    inputs = (float(ob.ewrinkles_face.strength), serials) + frame_inputs
    if only_if_changed and state.orig_inputs is not None:
        old_skin, old_inputs = state.orig_inputs
        # the original mesh must also hold this frame's offsets: after in-place frames it
        # holds an older frame's, which the tree does not show on this one (a saved file)
        if (old_inputs == inputs and np.array_equal(old_skin, skin)
                and (not enabled or stage.holds_frame(me, depsgraph))):
            return False
    contributions, pulled = _contributions(ob, active, statics, skin, inputs[2:], failed)
    problems = {s.name: _run(ob, s, failed, s.problems, ob, statics[s.name]) for s in active}
    if not enabled:
        if not _write_shading(ob, active, statics, contributions, failed, ev if in_place else None):
            state.orig_inputs = (skin.copy(), inputs)  # only what went into the original mesh
        wrote = False
    else:
        geometric = [(s, c) for s, c in zip(active, contributions) if s.geometric]
        plan = _plan(state, [s for s, _c in geometric], statics)
        parts = [c for _s, c in geometric]
        out = combine.combine(plan, skin, parts, out=state.out)
        # a tree above the stage measures the skin plus the pull, which it finds only in the
        # original mesh: on a frame with one (or the first after one) written in place, the
        # sources write the tree's values from the pulled skin into the evaluated mesh
        readers = [s for s in active if s.reads_pull]
        pull_frame = bool(readers) and (pulled is not skin or state.pull_written)
        if (in_place and stage.output_is_final(ob, mod) and _write_in_place(state, ev, skin, out)
                and (not pull_frame or _write_pulled(ob, readers, statics, ev, pulled, failed))):
            _write_shading(ob, active, statics, contributions, failed, ev, update=True)
        else:
            _write_shading(ob, active, statics, contributions, failed)
            meshio.write_vectors(me, stage.OFFSET_ATTR, out)
            if pull_frame:
                meshio.point_attribute(me, stage.PULL_ATTR, "FLOAT_VECTOR")
                meshio.write_vectors(me, stage.PULL_ATTR, pulled - skin)
                state.pull_written = pulled is not skin
            stage.stamp(ob, depsgraph)
            me.update_tag()
            state.orig_inputs = (skin.copy(), inputs)
            state.shown = skin + out  # what the re-evaluation that the tag triggers will show
        wrote = True
    for s in registry.sources():
        message = failed.get(s.name) or problems.get(s.name)
        status.set(ob, s.name, message if isinstance(message, str) else "")
    return wrote


_is_face = {}  # session_uid -> whether a wrinkle source works on that object


def _scan(scene, changes=None):
    """The faces any wrinkle source works on, and the session_uid of every object, in one
    pass.  With ``changes`` (viewport frames), only objects Blender updated are looked at
    again: a property set on an object tags it."""
    found, in_scene = [], set()
    shading = [s for s in registry.sources() if not s.geometric]
    for ob in scene.objects:
        uid = ob.session_uid
        in_scene.add(uid)
        face = _is_face.get(uid) if changes is not None and uid not in changes else None
        if face is None:
            # a muscle is never a face (faces.problem): its animated contraction tags it on
            # every frame, and the shading sources' checks are skipped for it
            face = _is_face[uid] = ob.type == "MESH" and (ob.ewrinkles_face.enabled or (
                not ob.ewrinkles_muscle.is_muscle and any(s.active(ob) for s in shading)))
        if face:
            found.append(ob)
    return found, in_scene


def updated_ids(depsgraph):
    """``session_uid`` -> (transform, geometry) of every ID ``depsgraph`` updated, as
    the viewport frame reads them (``update_scene``'s ``changes``; benchmarks use it too)."""
    return {u.id.original.session_uid: (u.is_updated_transform, u.is_updated_geometry)
            for u in depsgraph.updates}


# The updates of viewport evaluations between frame changes that no full check has seen
# (session_uid -> (transform, geometry)).  An evaluation consumes the depsgraph's updates:
# a muscle moved, then view_layer.update() or an evaluated mesh read in a script, leaves
# nothing of the move in the next frame change's updates.  on_depsgraph_update_post
# collects them where it does not check everything itself (background mode, renders,
# playback); the next viewport frame adds them to its own.
_pending = {}


def _merge(into, changes):
    """Add ``changes`` to ``into`` (both ``session_uid`` -> (transform, geometry)), or-ing
    the flags of an ID in both."""
    for uid, (moved, edited) in changes.items():
        was = into.get(uid, (False, False))
        into[uid] = (moved or was[0], edited or was[1])
    return into


def _frame_changes(depsgraph):
    """The IDs updated for this viewport frame, with those of the evaluations since the last
    frame change (:data:`_pending`)."""
    changes = _merge(updated_ids(depsgraph), _pending)
    _pending.clear()
    return changes


def update_scene(scene, depsgraph, only_if_changed=False, in_place=False, changes=None):
    if changes is None:
        _pending.clear()  # everything is checked
    found, in_scene = _scan(scene, changes)
    meshes = [ob.data for ob in found if ob.ewrinkles_face.enabled]
    for ob in found:
        if ob.ewrinkles_face.enabled and meshes.count(ob.data) > 1:  # they would overwrite each other
            status.set(ob, CHANNEL, f'"{ob.name}" shares its mesh with another face with wrinkles: '
                                    "make the mesh single-user (Object > Relations > Make Single User)")
            continue
        try:
            update_face(ob, depsgraph, only_if_changed, in_place, in_scene, changes)
        except Exception as exc:  # a handler must never raise into Blender
            status.set(ob, CHANNEL, f"Internal error, wrinkles skipped: {exc!r}")
            print(f"Expression Wrinkles: {ob.name}: {exc!r}")


def _rendering():
    running = getattr(bpy.app, "is_job_running", None)
    return bool(running and running("RENDER"))


_render_frame = [False]  # the frame being computed is for a render or an export


def render_frame():
    """Whether the frame being computed is a render's or an export's (a source shows its
    render visibility then, its viewport visibility otherwise)."""
    return _render_frame[0] or _rendering()


_in_frame_sync = False


def _current_depsgraph(scene, animate=False):
    """The context's evaluated depsgraph, brought to the scene's current frame; with
    ``animate`` (render and export frames), its animation evaluated again even when it is
    at that frame.

    Measured on bpy 4.5 and 5.2: on the FIRST frame of ``render(animation=True)``
    started from another frame, the context's depsgraph is still at the old
    frame (its ``scene_eval.frame_current`` lags), so the skin read from it and
    the original shape-key values the render re-evaluates with are both stale.
    Started on the current frame, it is at that frame, but a keyed value typed over
    since the last frame change (a muscle's contraction) is still the typed one in
    the original and in the context's evaluated copy, where the render and Bake for
    Farm's export evaluate the F-curve; the render's own depsgraph does not evaluate
    the animation of objects hidden from renders, such as the muscles.  Setting the
    frame again evaluates it, and writes the animated values back into the original
    data, as every frame change and a still render (measured) do; our handler skips
    the nested call.
    """
    global _in_frame_sync
    dg = bpy.context.evaluated_depsgraph_get()
    if (animate or dg.scene_eval.frame_current != scene.frame_current) and not _in_frame_sync:
        _in_frame_sync = True
        try:
            scene.frame_set(scene.frame_current, subframe=scene.frame_subframe)
        finally:
            _in_frame_sync = False
        dg = bpy.context.evaluated_depsgraph_get()
    return dg


# Seconds the frame handler has spent since the batch command last reset it: the wrinkle
# stage's share of a batch frame, which `ewrinkles render --json` reports.
stage_seconds = [0.0]


_suspended = [0]  # > 0 while an export samples a copy that holds the wrinkles itself


@contextlib.contextmanager
def suspended():
    """The frame handler does nothing inside this block: an exporter that samples the
    timeline of a copy holding the wrinkles as shape keys need not compute them again."""
    _suspended[0] += 1
    try:
        yield
    finally:
        _suspended[0] -= 1


def export_frame(scene, ob):
    """Set ``scene`` to its current frame as an export does and write ``ob``'s offsets
    of that frame back into its mesh (every source, as a render shows them); returns the
    evaluated depsgraph."""
    _render_frame[0] = True
    try:
        depsgraph = _current_depsgraph(scene, animate=True)
        update_face(ob, depsgraph)
    finally:
        _render_frame[0] = False
    return depsgraph


@persistent
def on_frame_change_post(scene, depsgraph=None):
    if _in_frame_sync or _suspended[0]:
        return
    start = time.perf_counter()
    try:
        _frame_change(scene, depsgraph)
    finally:
        stage_seconds[0] += time.perf_counter() - start


def _frame_change(scene, depsgraph):
    if depsgraph is not None and depsgraph.mode == "VIEWPORT":
        # the depsgraph just evaluated for this frame: write into it, no second evaluation
        update_scene(scene, depsgraph, in_place=True, changes=_frame_changes(depsgraph))
        return
    # Renders and exports: write back, reading through the context's depsgraph, since the
    # handler's argument drops other animated shape keys during render(animation=True)
    # (docs/architecture.md, "The frame handler").
    _render_frame[0] = depsgraph is not None and depsgraph.mode == "RENDER"
    try:
        update_scene(scene, _current_depsgraph(scene, animate=_render_frame[0]))
    finally:
        _render_frame[0] = False


@persistent
def on_depsgraph_update_post(scene, depsgraph=None):
    # Interactive edits only (a shape key slider, a muscle moved): renders and background
    # jobs are driven by frame changes, which also see what this evaluation updated
    # (_pending).  Unchanged inputs write nothing, so our own write does not loop.
    screen = getattr(bpy.context, "screen", None)
    if bpy.app.background or _rendering() or (screen is not None and screen.is_animation_playing):
        if depsgraph is not None and depsgraph.mode == "VIEWPORT":
            _merge(_pending, updated_ids(depsgraph))
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
    _is_face.clear()
    _pending.clear()
    status.clear()
    registry.upgrade_all(bpy.data)


@persistent
def on_undo_post(*_args):
    # Undo reloads the data: the next frame rebuilds every face's cache from scratch
    # rather than trust the IDs Blender reports as updated.
    _cache.clear()
    _is_face.clear()


def refresh_all(context):
    """Re-evaluate after a property change (not while rendering)."""
    if context is None or context.scene is None or _rendering():
        return
    update_scene(context.scene, context.evaluated_depsgraph_get())


def enable(ob, scene):
    """Add the output stage and switch wrinkles on.  Raises ``WrinkleError``."""
    why = faces.problem(ob)
    if why:
        raise WrinkleError(why)
    stage.ensure_modifier(ob)
    scene.render.use_lock_interface = True


def disable(ob):
    """Remove the output stage: the mesh and its shape keys are exactly as before."""
    stage.remove(ob)
    _cache.pop(ob.session_uid, None)
    status.clear(ob)


def on_enabled_changed(ob, context):
    try:
        if ob.ewrinkles_face.enabled:
            enable(ob, context.scene)
            refresh_all(context)
        else:
            disable(ob)
    except WrinkleError as exc:
        status.set(ob, CHANNEL, str(exc))


_HANDLERS = (
    (bpy.app.handlers.frame_change_post, on_frame_change_post),
    (bpy.app.handlers.depsgraph_update_post, on_depsgraph_update_post),
    (bpy.app.handlers.load_post, on_load_post),
    (bpy.app.handlers.save_pre, on_save_pre),
    (bpy.app.handlers.undo_post, on_undo_post),
    (bpy.app.handlers.redo_post, on_undo_post),
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
    _is_face.clear()
    status.clear()
