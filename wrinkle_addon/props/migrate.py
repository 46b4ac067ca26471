# SPDX-License-Identifier: GPL-3.0-or-later
"""Files saved by version 0.2 open with everything kept.

Version 0.2 stored its settings under unprefixed names (``Object.wrinkles``,
``Object.wrinkle_muscle``).  On load (and when the add-on is enabled with such a file
open) each object's stored group is copied, key by key, into the property group of its
prefixed name; assigning an ID property deep-copies it, keeping every value, collection
item and pointer.  (Blender 5 keeps registered properties apart from the custom
properties a 4.x file holds them in, so the copy goes through the new property group,
never through ``ob[new]``.)  Keyframes and
drivers whose data paths start with an old name are rewritten, including the driver
variables that read a muscle's contraction.
"""

import bpy
from bpy.app.handlers import persistent

RENAMES = (("wrinkles", "ewrinkles_face"), ("wrinkle_muscle", "ewrinkles_muscle"))


def _new_path(path):
    for old, new in RENAMES:
        if path.startswith(old + "."):
            return new + path[len(old):]
    return None


def _action_fcurves(action):
    """Every F-curve of an action: layered (Blender 4.4+) and legacy."""
    for layer in getattr(action, "layers", ()):
        for strip in layer.strips:
            for bag in getattr(strip, "channelbags", ()):
                yield from bag.fcurves
    legacy = getattr(action, "fcurves", None)
    if legacy is not None:
        yield from legacy


def _ids_with_animation(data):
    for name in dir(data):
        coll = getattr(data, name, None)
        if not isinstance(coll, bpy.types.bpy_prop_collection):
            continue
        for idb in coll:
            if isinstance(idb, bpy.types.ID) and getattr(idb, "animation_data", None) is not None:
                yield idb


def _rewrite_paths(data):
    count = 0
    for action in data.actions:
        if action.library is not None:
            continue
        for fc in _action_fcurves(action):
            new = _new_path(fc.data_path)
            if new:
                fc.data_path = new
                count += 1
    for idb in _ids_with_animation(data):
        if idb.library is not None:
            continue
        for fc in idb.animation_data.drivers:
            before = count
            new = _new_path(fc.data_path)
            if new:
                fc.data_path = new
                count += 1
            for var in fc.driver.variables:
                for target in var.targets:
                    new = _new_path(target.data_path)
                    if new:
                        target.data_path = new
                        count += 1
            if count != before:  # the load marked it invalid under its old path: check it again
                fc.is_valid = True
                fc.driver.is_valid = True
    return count


def migrate(data=None):
    """Move 0.2 data to the prefixed names.  Returns how many groups and paths moved."""
    data = data or bpy.data
    moved = 0
    for ob in data.objects:
        if ob.library is not None:
            continue
        for old, new in RENAMES:
            if old in ob.keys():
                group = getattr(ob, new)
                stored = ob[old]
                if not group.keys() and hasattr(stored, "keys"):  # a group, and nothing new yet
                    for key in stored.keys():
                        try:
                            group[key] = stored[key]  # a deep copy of each value
                        except (TypeError, ValueError):  # a value of no known type: dropped
                            print(f"Expression Wrinkles: {ob.name}: could not keep {old}.{key}")
                del ob[old]
                moved += 1
    if moved:
        moved += _rewrite_paths(data)
    return moved


@persistent
def on_load_post(*_args):
    n = migrate()
    if n:
        print(f"Expression Wrinkles: moved {n} settings and animation paths of version 0.2 to "
              "their new names")


def register():
    bpy.app.handlers.load_post.insert(0, on_load_post)  # before the frame stage's own
    try:
        migrate()
    except AttributeError:  # bpy.data is restricted while Blender starts up
        pass


def unregister():
    while on_load_post in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(on_load_post)
