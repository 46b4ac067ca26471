# SPDX-License-Identifier: GPL-3.0-or-later
"""The registry: one line per wrinkle source (method).

The frame stage, the farm bake and the panel loop over these; a new method is its own
files plus one line here (docs/architecture.md, "Adding a method").
"""

import bpy
from bpy.props import PointerProperty

from ..glue import registry
from . import curves, fine, maps, muscles, patterns

SOURCES = (
    muscles.MuscleSource(),  # Zhang, Sim & Tan 2005 on Waters' muscles
    maps.MapSource(),  # Jimenez et al. 2011: tension-driven zone weights, weights bake, panel
    curves.CurveSource(),  # Bando et al. 2002, §6-7: large-scale wrinkles along curves
    fine.FineSource(),  # Bando et al. 2002, §5, §7: carved fine wrinkles, shrinkage per frame
    patterns.PatternSource(),  # pattern functions: forehead, eye corner, cheek, frown, dimple, eye pouch
)


def add(source):
    """Register a source: its face properties (``Object.ewrinkles_face.<attribute>``), then
    the source itself.  Tests use it for sources of their own."""
    from ..props.face import WrinkleFaceSettings

    for attr, group in source.properties:
        bpy.utils.register_class(group)
        setattr(WrinkleFaceSettings, attr, PointerProperty(type=group, name=source.label,
                                                           description=f"Settings of {source.label}"))
    registry.add(source)


def remove(source):
    from ..props.face import WrinkleFaceSettings

    registry.remove(source)
    for attr, group in reversed(source.properties):
        delattr(WrinkleFaceSettings, attr)
        bpy.utils.unregister_class(group)


def register():
    for source in SOURCES:
        add(source)
    try:  # enabled with a file open: what an older version saved in it, brought up to date
        registry.upgrade_all(bpy.data)
    except AttributeError:  # bpy.data is restricted while Blender starts up
        pass


def unregister():
    for source in reversed(registry.sources()):
        remove(source)
