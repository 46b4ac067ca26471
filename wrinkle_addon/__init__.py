# SPDX-License-Identifier: GPL-3.0-or-later
"""Expression Wrinkles: animated, expressive wrinkles for face meshes.

The layers and their rules are in ``docs/architecture.md``.  Registration is explicit (a
``classes`` tuple per module) and in layer order; unregister reverses it and removes every
handler and property that register added.  The Blender modules are imported inside
register() so that ``wrinkle_addon.core`` (pure NumPy) can be imported and tested without
Blender.
"""

_MODULES = ()


def _modules():
    from . import cli, props, sources
    from .glue import frame
    from .ops import bando, convert, export, face, mapbake, maps, muscles, patterns, sample_head
    from .ui import bando as bando_ui
    from .ui import draw, panels
    from .ui import maps as maps_ui
    from .ui import muscles as muscles_ui
    from .ui import patterns as patterns_ui

    return (props, frame, face, muscles, maps, convert, mapbake, bando, patterns, sample_head, export,
            muscles_ui, maps_ui, bando_ui, patterns_ui, panels, draw, sources, cli)


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
