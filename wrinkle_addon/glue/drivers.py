# SPDX-License-Identifier: GPL-3.0-or-later
"""The one driver builder.

Every driver the add-on makes has one variable and either no expression (type AVERAGE)
or a simple expression such as ``key*0.8``: both evaluate with Python auto-run off and
need no add-on.  Names inside data paths are escaped, so a shape key called ``Brow "up"``
still gives a valid path.
"""

import bpy


def shape_key_path(name):
    """The data path of a shape key's value on its Key, with the name escaped."""
    return f'key_blocks["{bpy.utils.escape_identifier(name)}"].value'


def drive(owner, path, id_type, target, data_path, gain=None):
    """Drive ``owner.<path>`` from ``target.<data_path>``.  Returns the F-curve.

    ``gain`` None: type AVERAGE, the variable's value as is; else a simple scripted
    expression ``value*<gain>``.  Raises ValueError if the target path does not resolve,
    so no broken driver is left behind."""
    try:
        target.path_resolve(data_path)
    except (ValueError, TypeError):
        raise ValueError(f'"{target.name}" has no property {data_path}') from None
    owner.driver_remove(path)
    fc = owner.driver_add(path)
    drv = fc.driver
    for var in list(drv.variables):
        drv.variables.remove(var)
    var = drv.variables.new()
    var.name = "value"
    var.type = "SINGLE_PROP"
    var.targets[0].id_type = id_type
    var.targets[0].id = target
    var.targets[0].data_path = data_path
    if gain is None:
        drv.type = "AVERAGE"
    else:
        drv.type = "SCRIPTED"
        drv.expression = f"value*{gain:.6g}"
    return fc


def action_fcurves(id_data):
    """The F-curves of ``id_data``'s action (keyframes, not drivers), on Blender 4.x and
    5.x alike (5.x keeps them in the slot's channel bag); an empty list when it has none."""
    ad = id_data.animation_data
    if ad is None or ad.action is None:
        return []
    from bpy_extras import anim_utils

    slot = getattr(ad, "action_slot", None)
    bag = anim_utils.action_get_channelbag_for_slot(ad.action, slot) if slot else ad.action
    return bag.fcurves if bag is not None else []
