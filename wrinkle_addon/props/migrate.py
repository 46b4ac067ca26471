# SPDX-License-Identifier: GPL-3.0-or-later
"""Files saved by older versions open with everything kept.

Every custom property the add-on stores on a datablock or a node starts with
``ewrinkles_``.  Older versions stored some under other names (:data:`KEYS`: the wrinkle
maps' tags and baked paths, the stage's version, the landmark empties' names and
descriptions).  On load (and when the add-on is enabled with such a file open) each is
moved to its new name on every local node group, material, node of their trees and object
(:func:`rename_keys`), before anything else reads them: the node groups' builders rebuild a
group whose version tag is missing.  Where both names are stored, the new one's value is
kept.  A landmark empty's ``description`` is moved only on an object that is one (it holds
the landmark key): another object's own ``description`` is the artist's.

Version 0.2 stored its settings under unprefixed names (``Object.wrinkles``,
``Object.wrinkle_muscle``).  On load (and when the add-on is enabled with such a file
open) each object's stored group is copied, key by key, into the property group of its
prefixed name; assigning an ID property deep-copies it, keeping every value, collection
item and pointer.  (Blender 5 keeps registered properties apart from the custom
properties a 4.x file holds them in, so the copy goes through the new property group,
never through ``ob[new]``.)  Keyframes and
drivers whose data paths start with an old name are rewritten, including the driver
variables that read a muscle's contraction.

Stored groups are also checked on load (:func:`repair`): a file (or a script) can hold
any value under the name of one of our lists or groups, and Blender does not check it
when it reads the list.  On bpy 4.5 reading an item of a list whose stored value is not a
list of groups (``["a"]``, say) blocks forever inside Blender (measured: a deadlock in
``RNA_property_pointer_get``).  Such a value is removed, with a line on the console: it
holds nothing the add-on could use.

A face saved before the muscles' *Irregularity* existed keeps the regular wrinkles it was
saved with (:func:`keep_regular`): its Irregularity, which the file does not hold, is set
to 0 instead of the natural default a new face gets.  A new face stores its own when it is
set up (``glue.muscles.muscle_objects.set_up_face``), so the two are told apart.
"""

import bpy
from bpy.app.handlers import persistent

RENAMES = (("wrinkles", "ewrinkles_face"), ("wrinkle_muscle", "ewrinkles_muscle"))
# (old custom property, new): see the module doc
KEYS = (
    ("wrinkle_baked", "ewrinkles_baked"),  # a weights group: the data paths its bake keyed
    ("wrinkle_layout", "ewrinkles_layout"),  # a weights group: the layout it was built for
    ("wrinkle_map_version", "ewrinkles_map_version"),  # the Wrinkle Map Blend group
    ("wrinkle_stage_version", "ewrinkles_stage_version"),  # the output stage's group
    ("wrinkle_previous_normal", "ewrinkles_previous_normal"),  # the blend node of a material
    ("wrinkle_landmark", "ewrinkles_landmark"),  # a landmark empty: its landmark
    ("description", "ewrinkles_description"),  # a landmark empty: what it marks
)


def _local(idb):
    return idb.library is None and getattr(idb, "override_library", None) is None


def _holders(data):
    """(name for the console, holder) of every local node group, material, node of their
    trees and object of ``data``."""
    for ng in data.node_groups:
        if _local(ng):
            yield ng.name, ng
            for node in ng.nodes:
                yield f"{ng.name}: {node.name}", node
    for mat in data.materials:
        if _local(mat):
            yield mat.name, mat
            for node in getattr(mat.node_tree, "nodes", ()):
                yield f"{mat.name}: {node.name}", node
    for ob in data.objects:
        if _local(ob):
            yield ob.name, ob


def _rename(holder, where):
    keys = set(holder.keys())
    landmark = bool({"wrinkle_landmark", "ewrinkles_landmark"} & keys)
    moved = []
    for old, new in KEYS:
        if old not in keys or (old == "description" and not landmark):  # another object's is the artist's
            continue
        if new not in keys:
            try:
                holder[new] = holder[old]  # a deep copy of the value
            except (TypeError, ValueError):  # a value of no known type: dropped
                print(f"Expression Wrinkles: {where}: could not keep {old}")
        del holder[old]
        moved.append(f"{where}: {old}")
    return moved


def rename_keys(data=None):
    """Move the custom properties of :data:`KEYS` to their new names (see the module doc).
    Returns ``"<where>: <old name>"`` for each one moved (or dropped for the new one
    already there)."""
    data = data or bpy.data
    moved = []
    for where, holder in _holders(data):
        try:
            moved += _rename(holder, where)
        except Exception as exc:  # a file must open whatever it holds
            print(f"Expression Wrinkles: {where}: could not rename its custom properties: {exc}")
    if moved:
        print(f"Expression Wrinkles: moved {len(moved)} custom properties of older versions to their "
              "new names (ewrinkles_...)")
    return moved


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


GROUPS = ("ewrinkles_face", "ewrinkles_muscle", "ewrinkles_curve")


def _is_group_type(struct):
    while struct is not None:
        if struct.identifier == "PropertyGroup":
            return True
        struct = struct.base
    return False


def _repair_group(raw, struct, where):
    """Remove the stored values of ``raw`` (an ID property group holding the property
    group ``struct``) whose type cannot be what ``struct`` declares for them: a list that
    is not a list of groups, a group that is not one, an object pointer that is no ID.
    Returns the paths removed."""
    removed = []
    for prop in struct.properties:
        if prop.type not in {"POINTER", "COLLECTION"} or prop.identifier == "rna_type":
            continue
        stored = raw.get(prop.identifier)
        if stored is None:
            continue
        path = f"{where}.{prop.identifier}"
        if prop.type == "POINTER" and not _is_group_type(prop.fixed_type):
            # an ID pointer: an ID, or the empty group Blender itself stores when an unset one
            # is read (measured on bpy 4.5)
            ok = isinstance(stored, bpy.types.ID) or (hasattr(stored, "keys") and not stored.keys())
        elif prop.type == "POINTER":
            ok = hasattr(stored, "keys")
            if ok:
                removed += _repair_group(stored, prop.fixed_type, path)
        else:
            ok = isinstance(stored, list) and all(hasattr(item, "keys") for item in stored)
            if ok:
                for i, item in enumerate(stored):
                    removed += _repair_group(item, prop.fixed_type, f"{path}[{i}]")
        if not ok:
            del raw[prop.identifier]
            removed.append(path)
    return removed


def repair(data=None):
    """Remove the stored values of our groups that have the wrong type (see the module
    doc).  Returns the paths removed."""
    data = data or bpy.data
    removed = []
    for ob in data.objects:
        if ob.library is not None:
            continue
        for name in GROUPS:
            raw = ob.get(name)  # bpy 4.x; Blender 5 keeps registered properties apart
            struct = getattr(bpy.types.Object.bl_rna.properties.get(name), "fixed_type", None)
            if raw is None or struct is None:
                continue
            if not hasattr(raw, "keys"):
                del ob[name]
                removed.append(f"{ob.name}.{name}")
            else:
                removed += _repair_group(raw, struct, f"{ob.name}.{name}")
    for path in removed:
        print(f"Expression Wrinkles: {path} held a value of the wrong type and was removed")
    return removed


def keep_regular(data=None):
    """Set the Irregularity of every face with muscles whose file does not hold one (saved
    before the setting existed) to 0, so it keeps the regular wrinkles it was saved with.
    Returns the names of the faces changed."""
    data = data or bpy.data
    changed = []
    for ob in data.objects:
        if ob.library is not None or getattr(ob, "override_library", None) is not None:
            continue
        s = ob.ewrinkles_face
        if len(s.muscles) and not s.is_property_set("irregularity"):
            s.irregularity = 0.0
            changed.append(ob.name)
    for name in changed:
        print(f"Expression Wrinkles: {name}: saved before Irregularity existed, its wrinkles are kept "
              "regular (Irregularity 0)")
    return changed


@persistent
def on_load_post(*_args):
    rename_keys()
    repair()
    n = migrate()
    keep_regular()
    if n:
        print(f"Expression Wrinkles: moved {n} settings and animation paths of version 0.2 to "
              "their new names")


def register():
    bpy.app.handlers.load_post.insert(0, on_load_post)  # before the frame stage's own
    try:
        rename_keys()
        repair()
        migrate()
        keep_regular()
    except AttributeError:  # bpy.data is restricted while Blender starts up
        pass


def unregister():
    while on_load_post in bpy.app.handlers.load_post:
        bpy.app.handlers.load_post.remove(on_load_post)
