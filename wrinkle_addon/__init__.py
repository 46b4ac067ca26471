# SPDX-License-Identifier: GPL-3.0-or-later
"""Expression Wrinkles: animated, expressive wrinkles for face meshes.

Registration is explicit (a ``classes`` tuple per module); unregister removes
every handler and property that register added.  The Blender modules are
imported inside register() so that ``wrinkle_addon.core`` (pure NumPy) can be
imported and tested without Blender.
"""

_MODULES = ()


def _modules():
    from . import convert_ops, draw, map_ops, mapbake, operators, pipeline, props, ui

    return (props, pipeline, operators, map_ops, convert_ops, mapbake, ui, draw)


def register():
    global _MODULES
    _MODULES = _modules()
    for mod in _MODULES:
        mod.register()


def unregister():
    global _MODULES
    for mod in reversed(_MODULES or _modules()):
        mod.unregister()
    _MODULES = ()
