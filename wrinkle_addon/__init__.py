# SPDX-License-Identifier: GPL-3.0-or-later
"""Expression Wrinkles: animated, expressive wrinkles for face meshes.

The layers and their rules are in ``docs/architecture.md``.  Registration is explicit (a
``classes`` tuple per module) and in layer order; unregister reverses it and removes every
handler and property that register added.  The Blender modules are imported inside
register() so that ``wrinkle_addon.core`` (pure NumPy) can be imported and tested without
Blender.
"""

_MODULES = ()


def _registered(package):
    """Every module of ``package`` that registers something (has ``register``), in name
    order: a method's operators and panels are its own files, listed nowhere else."""
    import importlib
    import pkgutil

    names = sorted(info.name for info in pkgutil.iter_modules(package.__path__))
    modules = [importlib.import_module(f"{package.__name__}.{name}") for name in names]
    return [m for m in modules if hasattr(m, "register")]


def _modules():
    """The layers in order: properties, the frame handlers, operators, panels, the sources
    (which hang their settings on the face and may draw in the panels), the batch command."""
    from . import cli, ops, props, sources, ui
    from .glue import pipeline

    return (props, pipeline, *_registered(ops), *_registered(ui), sources, cli)


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
