# SPDX-License-Identifier: GPL-3.0-or-later
"""The one face check, the face an operator or panel acts on, and the collections the
add-on's helper objects go into.

Every caller says what it needs (:func:`problem`'s keywords); the messages are the same
everywhere, so the panel, the operators and the frame handler agree about a face.
"""

import bpy

RIG_COLLECTION = "Wrinkle Muscles"  # the face rig's helpers: the muscles and the landmark empties


def active(context):
    """The face an operator acts on: the active object, or the face a selected muscle or
    wrinkle curve belongs to (its parent)."""
    ob = context.active_object
    if ob is not None and ob.parent is not None and (
            (ob.type == "MESH" and ob.ewrinkles_muscle.is_muscle)
            or (ob.type == "CURVE" and ob.ewrinkles_curve.is_curve)):
        return ob.parent
    return ob


def _article(word):
    return "an" if word[:1] in "aeiou" else "a"


def problem(ob, *, local=True, lists=False, object_mode=False, polygons=True, uv=False):
    """Why ``ob`` cannot be used as a face, or None.

    ``local``: its object and mesh must be editable (not linked from a library);
    ``lists``: the add-on's lists on it (pattern layers, wrinkle curves) must be able to
    change, which a library override's cannot (adding to one raises "not supported");
    ``object_mode``: not in Edit Mode (the mesh's arrays are stale there);
    ``polygons``: it must have faces; ``uv``: it must have a UV map.  A face scaled to
    zero along an axis (or to NaN) is refused always: every method works in the face's own
    space, and its transform then has no inverse."""
    if ob is None:
        return "No active object: select the face mesh"
    if ob.type != "MESH":
        kind = ob.type.lower()
        return f'"{ob.name}" is {_article(kind)} {kind}, not a mesh: select the face mesh'
    if ob.ewrinkles_muscle.is_muscle:
        return f'"{ob.name}" is a muscle, not a face: select the face mesh'
    if local:
        if ob.library is not None or ob.data.library is not None:
            lib = (ob.library or ob.data.library).filepath
            return (f'"{ob.name}" is linked from {lib} and is read-only: make it local or use a '
                    "library override")
        if ob.override_library is not None and ob.data.library is not None:
            return f'The mesh of "{ob.name}" is linked and read-only: override or make it local'
    if not abs(ob.matrix_world.to_3x3().determinant()) > 1e-18:  # NaN is refused too
        return (f'"{ob.name}" is scaled to zero (or to an invalid value) along an axis: give it a '
                "scale other than 0 (Object Properties > Transform > Scale)")
    if lists and ob.override_library is not None:
        return (f'"{ob.name}" is a library override, and its lists of pattern layers and wrinkle curves '
                "cannot change: add them in the file it is linked from, or make it local "
                "(Object > Relations > Make Local)")
    if object_mode and ob.mode == "EDIT":
        return f'"{ob.name}" is in Edit Mode: switch to Object Mode'
    if polygons and len(ob.data.polygons) == 0:
        return f'"{ob.name}" has no faces: wrinkles need a surface'
    if uv and len(ob.data.uv_layers) == 0:
        return f'"{ob.name}" has no UV map: unwrap it first (UV > Unwrap)'
    return None


def collections_for(ob, scene):
    """The collections a new object that goes with ``ob`` (a tear on the face) is linked
    into: those of ``ob``'s that can take it, else the scene's own.  Objects cannot be linked
    into a collection that is linked from a library or is a library override."""
    own = [c for c in ob.users_collection if c.library is None and c.override_library is None]
    return own or [scene.collection]


def helper_collection(scene, name):
    """The file's own collection ``name`` (made if there is none), linked into ``scene`` if
    the scene does not use it yet: the collection that helper objects (muscles, landmarks,
    wrinkle curves, pattern frames) are linked into.  A collection of that name linked from a
    library is left alone, since objects cannot be linked into it."""
    coll = bpy.data.collections.get((name, None))
    if coll is None:
        coll = bpy.data.collections.new(name)
    if scene.user_of_id(coll) == 0:
        scene.collection.children.link(coll)
    return coll
