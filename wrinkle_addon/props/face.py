# SPDX-License-Identifier: GPL-3.0-or-later
"""The face's settings, ``Object.ewrinkles_face``: what every wrinkle source shares.

Each method keeps its own settings in its own file (``props/muscles.py``,
``props/maps.py``) and hangs them here as a pointer or collection.
"""

import bpy
from bpy.props import (
    BoolProperty,
    CollectionProperty,
    FloatProperty,
    IntProperty,
    PointerProperty,
)

from .common import refresh
from .maps import WrinkleMapSettings
from .muscles import WrinkleMuscleRef


def _enabled_update(self, context):
    from ..glue import frame

    frame.on_enabled_changed(self.id_data, context)


class WrinkleFaceSettings(bpy.types.PropertyGroup):
    enabled: BoolProperty(
        name="Wrinkles",
        description="Compute animated wrinkles on this face every frame. Switching off restores "
        "the mesh exactly",
        default=False,
        update=_enabled_update,
    )
    strength: FloatProperty(
        name="Strength",
        description="Overall gain on the wrinkle heights of every muscle on this face",
        default=1.0, min=0.0, soft_max=3.0,
        update=refresh,
    )
    muscles: CollectionProperty(
        type=WrinkleMuscleRef,
        name="Muscles",
        description="Muscles acting on this face",
    )
    bake_object: PointerProperty(
        name="Baked Stand-in",
        description="The object that renders the baked wrinkles from an Alembic cache, if baked",
        type=bpy.types.Object,
    )
    maps: PointerProperty(
        type=WrinkleMapSettings,
        name="Wrinkle Maps",
        description="Animated wrinkle maps: the material binding and the expression table",
    )
    active_muscle: IntProperty(
        name="Active Muscle",
        description="Index of the selected muscle in the list",
        default=0, min=0,
    )
