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

from ..core import skin_age
from ..core.muscles import irregularity
from .common import refresh
from .maps import WrinkleMapSettings
from .muscles import WrinkleMuscleRef


def _enabled_update(self, context):
    from ..glue import pipeline

    pipeline.on_enabled_changed(self.id_data, context)


def _skin_age_update(self, context):
    from ..glue.bando import fine

    fine.sync(self.id_data)  # the fine wrinkles' rest height and depth in the material
    refresh(self, context)  # the muscles' depth and irregularity


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
    irregularity: FloatProperty(
        name="Irregularity",
        description="How much the muscles' wrinkles vary, as real ones do: the spacing from furrow to "
        "furrow, the depth along each furrow, a gentle wave in their course, furrows that fade out "
        "partway. 0 gives Zhang's perfectly regular furrows; the furrows stay where they are as they "
        "deepen. Each muscle scales it by its own Irregularity",
        default=irregularity.DEFAULT, min=0.0, max=irregularity.MAX_AMOUNT, soft_max=2.0,
        update=refresh,
    )
    skin_age: FloatProperty(
        name="Skin Age",
        description="How old the skin is, from young (0) to old (1). Older skin shows its fine "
        "wrinkles at rest (Bando's rest height, scaled by twice the age), folds deeper (every "
        "furrow's depth times 0.6 + 0.8 age) and more irregularly (Irregularity times 0.5 + age). "
        "0.5 leaves every method as published; young skin shows no fine crackle at rest, only "
        "where it compresses",
        default=skin_age.NEUTRAL, min=0.0, max=1.0, subtype="FACTOR",
        update=_skin_age_update,
    )
    seed: IntProperty(
        name="Seed",
        description="The pattern of the irregular wrinkles. Change it for another pattern; the same "
        "seed gives the same wrinkles on every frame and every computer. A new face gets one of its "
        "own, from its name",
        default=0, min=0,
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
