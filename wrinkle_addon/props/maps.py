# SPDX-License-Identifier: GPL-3.0-or-later
"""Properties of the animated wrinkle maps (Jimenez et al. 2011): the material binding,
the expression table and the zones, at ``Object.ewrinkles_face.maps``."""

import math

import bpy
from bpy.props import (
    BoolProperty,
    CollectionProperty,
    EnumProperty,
    FloatProperty,
    FloatVectorProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)

from .common import is_muscle


def _maps_update(self, context):
    from ..glue.maps import map_material  # lazily: props import the glue only in callbacks

    map_material.sync_quietly(self.id_data)


def _bindings_update(self, context):
    from ..glue.maps import map_material

    map_material.sync_quietly(self.id_data, rebind=True)


def _restore_finite(owner, name, default):
    """Put ``default`` back where the float (or float vector) property ``name`` holds NaN.

    A FloatProperty's min and max clamp infinities to the float range but let NaN
    through, and a NaN here would reach every zone weight in the shader.  Returns True if
    something was restored (the assignment runs the property's update again)."""
    value = getattr(owner, name)
    if isinstance(value, float):
        if math.isfinite(value):
            return False
        setattr(owner, name, default)
        return True
    values = list(value)
    if all(math.isfinite(v) for v in values):
        return False
    setattr(owner, name, [v if math.isfinite(v) else d for v, d in zip(values, default)])
    return True


def _finite(name, default, then=None):
    """An update callback that keeps the property ``name`` finite, then runs ``then``."""

    def update(self, context):
        if not _restore_finite(self, name, default) and then is not None:
            then(self, context)

    return update


class WrinkleMapExpression(bpy.types.PropertyGroup):
    name: StringProperty(
        name="Expression",
        description="Name of the expression, e.g. Surprise",
        default="Expression",
    )
    source: EnumProperty(
        name="Source",
        description="What drives this expression's value",
        items=[
            ("SHAPE_KEY", "Shape Key", "The value of one of the face's shape keys"),
            ("MUSCLE", "Muscle", "The contraction of a muscle object"),
            ("PROPERTY", "Property", "Any animatable property of an object, by data path"),
            ("MANUAL", "Manual", "The Value field below, which you can animate"),
        ],
        default="MANUAL",
        update=_bindings_update,
    )
    shape_key: StringProperty(
        name="Shape Key",
        description="Shape key of the face whose value drives this expression",
        update=_bindings_update,
    )
    muscle: PointerProperty(
        name="Muscle",
        description="Muscle whose contraction drives this expression",
        type=bpy.types.Object,
        poll=is_muscle,
        update=_bindings_update,
    )
    target: PointerProperty(
        name="Object",
        description="Object that owns the driving property",
        type=bpy.types.Object,
        update=_bindings_update,
    )
    data_path: StringProperty(
        name="Data Path",
        description='Path of the driving property on the object, e.g. ["Smile"] or '
        'pose.bones["jaw"].rotation_euler[0]',
        update=_bindings_update,
    )
    value: FloatProperty(
        name="Value",
        description="The expression's value when its source is Manual (animatable)",
        default=0.0, soft_min=0.0, soft_max=1.0,
        update=_finite("value", 0.0, _maps_update),
    )
    map_index: IntProperty(
        name="Map",
        description="Which wrinkle map this expression's weights apply to (1 = the first map)",
        default=1, min=1, max=8,
        update=_bindings_update,
    )
    weights: FloatVectorProperty(
        name="Zone Weights",
        description="Weight of this expression in each of the 8 mask zones; negative weights "
        "cancel other expressions (Jimenez et al. 2011, Table 1.1)",
        size=8, default=(0.0,) * 8, min=-4.0, max=4.0, soft_min=-1.0, soft_max=1.0,
        update=_finite("weights", (0.0,) * 8, _maps_update),
    )


# The tooltips of the eight wrinkle-map slots, map_a ... map_h ("Wrinkle Map 1" ... "8"),
# which glue.maps.map_material.MAP_PROPS names
_MAP_HINTS = (
    "First wrinkle map (partial-derivative or difference map), e.g. the compressed pose",
    "Second wrinkle map, e.g. the stretched pose (Oat 2007); may stay empty",
) + tuple(f"Wrinkle map {k}, for the expressions whose Map is {k} (shown when one is)" for k in range(3, 9))


class WrinkleMapSettings(bpy.types.PropertyGroup):
    material: PointerProperty(
        name="Material",
        description="The face material the wrinkle maps are wired into",
        type=bpy.types.Material,
    )
    base_image: PointerProperty(
        name="Base Normal Map",
        description="The face's base tangent-space normal map (empty: flat, or the image "
        "already wired into the material's normal input)",
        type=bpy.types.Image,
    )
    mask_a: PointerProperty(
        name="Mask A",
        description="RGBA mask of zones 1-4",
        type=bpy.types.Image,
    )
    mask_b: PointerProperty(
        name="Mask B",
        description="RGBA mask of zones 5-8",
        type=bpy.types.Image,
    )
    uv_map: StringProperty(
        name="UV Map",
        description="UV map of the wrinkle maps and masks (empty: the active render UV map)",
    )
    strength: FloatProperty(
        name="Strength",
        description="Overall strength of the wrinkle maps",
        default=1.0, min=0.0, soft_max=2.0,
        update=_finite("strength", 1.0, _maps_update),
    )
    difference: BoolProperty(
        name="Difference Maps",
        description="The wrinkle maps are difference maps d = 0.5 + 0.5 (w - b) instead of "
        "partial-derivative maps (Jimenez et al. 2011, §1.2.1)",
        default=False,
        update=_maps_update,
    )
    expressions: CollectionProperty(
        type=WrinkleMapExpression,
        name="Expressions",
        description="Expressions and their zone weights",
    )
    active_expression: IntProperty(
        name="Active Expression",
        description="Index of the selected expression in the table",
        default=0, min=0,
    )
    zone_strength: FloatVectorProperty(
        name="Zone Strength",
        description="Gain on each zone's weight after the clamp",
        size=8, default=(1.0,) * 8, min=0.0, max=2.0,
        update=_finite("zone_strength", (1.0,) * 8, _maps_update),
    )
    zone_power: FloatVectorProperty(
        name="Zone Response",
        description="Response curve of each zone: the clamped weight is raised to this power "
        "(below 1 wrinkles come early, above 1 late)",
        size=8, default=(1.0,) * 8, min=0.25, max=2.0,
        update=_finite("zone_power", (1.0,) * 8, _maps_update),
    )
    weight_mode: EnumProperty(
        name="Weights",
        description="Where the zone weights come from",
        items=[
            ("TABLE", "Expressions", "The expression table: each zone weight is "
             "clamp(sum of value x weight, 0, 1)"),
            ("TENSION", "Tension", "The measured compression of the skin in each zone, frame "
             "by frame (plus the table)"),
        ],
        default="TABLE",
        update=_maps_update,
    )
    tension_gain: FloatProperty(
        name="Tension Gain",
        description="Zone weight per unit of mean edge shrinkage in the zone: 5 makes 20 % "
        "compression a full-strength wrinkle",
        default=5.0, min=0.0, soft_max=20.0,
        update=_finite("tension_gain", 5.0),
    )
    weights_group: PointerProperty(
        name="Weights Group",
        description="The node group that turns expression values into zone weights",
        type=bpy.types.NodeTree,
    )


WrinkleMapSettings.__annotations__.update({  # the eight slots, map_a ... map_h
    f"map_{key}": PointerProperty(name=f"Wrinkle Map {k + 1}", description=hint, type=bpy.types.Image)
    for k, (key, hint) in enumerate(zip("abcdefgh", _MAP_HINTS))})
