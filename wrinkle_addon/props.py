# SPDX-License-Identifier: GPL-3.0-or-later
"""Data model: ``Object.wrinkles`` on faces and ``Object.wrinkle_muscle`` on muscles.

Every property has a description (the tooltip), units where they apply and
soft limits that keep an artist in the useful range.  Property updates only
redraw or re-evaluate; the evaluator notices parameter changes itself by
comparing a signature, so undo, drivers and animated parameters are all safe.
"""

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

from .core.presets import MUSCLES


def _refresh(self, context):
    # Imported lazily: pipeline imports this module.
    from . import pipeline

    pipeline.refresh_all(context)


def _is_muscle(self, ob):
    return ob.type == "MESH" and ob.wrinkle_muscle.is_muscle


class WrinkleMuscleSettings(bpy.types.PropertyGroup):
    is_muscle: BoolProperty(
        name="Is Muscle",
        description="This object is an Expression Wrinkles muscle",
        default=False,
    )
    kind: EnumProperty(
        name="Type",
        description="Waters muscle type",
        items=[
            ("LINEAR", "Linear", "A linear muscle: an attachment point on the bone and an insertion "
             "point in the skin, pulling inside a cone (Waters 1987, Zhang 2005 §2.2)"),
            ("SHEET", "Sheet", "A sheet muscle: parallel fibres from an attachment line to an "
             "insertion line, like the Frontalis (Zhang 2005 §2.3)"),
        ],
        default="LINEAR",
        update=_refresh,
    )
    role: EnumProperty(
        name="Role",
        description="Which facial muscle this is; expression presets key muscles by role",
        items=[("CUSTOM", "Custom", "A muscle of your own")]
        + [(r, n, f"{n} ({k.lower()} muscle, Zhang 2005 Fig. 1)") for r, n, k in MUSCLES],
        default="CUSTOM",
    )
    side: EnumProperty(
        name="Side",
        description="Side of the face, for mirrored pairs",
        items=[("L", "Left", "Character's left (+X)"), ("R", "Right", "Character's right (-X)"),
               ("C", "Centre", "On the midline or unpaired")],
        default="C",
    )
    contraction: FloatProperty(
        name="Contraction",
        description="How much the muscle contracts, from relaxed (0) to fully contracted (1). "
        "Animate or drive it",
        default=0.0, min=0.0, max=1.0, subtype="FACTOR",
        update=_refresh,
    )
    wrinkles_only: BoolProperty(
        name="Wrinkles Only",
        description="Do not pull the skin: only raise wrinkles where shape keys, bones or other "
        "muscles compress it. Use it on faces that are already animated",
        default=False,
        update=_refresh,
    )
    pull: FloatProperty(
        name="Pull",
        description="Strength of the skin pull at full contraction, as a fraction of the "
        "attachment-to-insertion distance (Waters' k). Kept below 2/pi so no skin overshoots "
        "the attachment",
        default=0.2, min=0.0, max=0.6, soft_max=0.5, subtype="FACTOR",
        update=_refresh,
    )
    radius: FloatProperty(
        name="Radius R",
        description="Linear muscle: radius of the area of influence, from the attachment "
        "(Zhang's R, Waters' fall-off finish Rf)",
        default=0.05, min=0.0, soft_min=0.001, soft_max=0.3, subtype="DISTANCE", unit="LENGTH",
        update=_refresh,
    )
    angle: FloatProperty(
        name="Angle",
        description="Linear muscle: maximal angle of influence around the central fibre (Zhang's "
        "Phi, Waters' Omega)",
        default=math.radians(35.0), min=0.0, max=math.pi, soft_min=math.radians(5.0),
        soft_max=math.radians(80.0), subtype="ANGLE",
        update=_refresh,
    )
    angle_c: FloatProperty(
        name="Attenuation Start",
        description="Linear muscle: angle from the central fibre where the wrinkle amplitude "
        "starts to decrease (Zhang's phi_c, eq. 12)",
        default=math.radians(15.0), min=0.0, max=math.pi, soft_max=math.radians(80.0),
        subtype="ANGLE",
        update=_refresh,
    )
    length: FloatProperty(
        name="Length Ls",
        description="Sheet muscle: length of the area of influence, from the attachment line "
        "along the fibres (Zhang's Ls)",
        default=0.07, min=0.0, soft_min=0.001, soft_max=0.3, subtype="DISTANCE", unit="LENGTH",
        update=_refresh,
    )
    width: FloatProperty(
        name="Width Ws",
        description="Sheet muscle: width of the area of influence across the fibres (Zhang's Ws)",
        default=0.05, min=0.0, soft_min=0.001, soft_max=0.3, subtype="DISTANCE", unit="LENGTH",
        update=_refresh,
    )
    width_c: FloatProperty(
        name="Attenuation Start",
        description="Sheet muscle: distance from the central fibre where the wrinkle amplitude "
        "starts to decrease (Zhang's h_c, eq. 15)",
        default=0.015, min=0.0, soft_max=0.15, subtype="DISTANCE", unit="LENGTH",
        update=_refresh,
    )
    depth: FloatProperty(
        name="Depth",
        description="Sheet muscle: only skin within this distance of the sheet's plane is "
        "affected, so the sheet cannot reach through the head",
        default=0.03, min=0.0, soft_max=0.2, subtype="DISTANCE", unit="LENGTH",
        update=_refresh,
    )
    lambda_w: FloatProperty(
        name="Wrinkling Region",
        description="Where the wrinkling region starts along the muscle, as a fraction of its "
        "length (Zhang's lambda_w). Smaller values give a larger region",
        default=0.4, min=0.0, max=0.99, subtype="FACTOR",
        update=_refresh,
    )
    n_wrinkles: IntProperty(
        name="Wrinkles",
        description="Number of wrinkles across the wrinkling region (Zhang's n_w, eq. 6). "
        "0 switches this muscle's wrinkles off but keeps its pull",
        default=4, min=0, max=1000, soft_min=1, soft_max=12,
        update=_refresh,
    )
    k0: FloatProperty(
        name="Furrow Depth",
        description="Furrow depth factor k0 of the wrinkle shape (Zhang eq. 5). The bulge "
        "height d follows from it so that the skin volume is preserved (eq. 8)",
        default=0.0008, soft_min=0.0, soft_max=0.005, subtype="DISTANCE", unit="LENGTH",
        precision=5,
        update=_refresh,
    )
    alpha: FloatProperty(
        name="Shape",
        description="Shape modulation factor alpha (Zhang eq. 5): larger values make the furrows "
        "sharper relative to the bulges",
        default=1.0, min=-5.0, max=5.0, soft_min=0.0, soft_max=3.0,
        update=_refresh,
    )
    fade_ends: BoolProperty(
        name="Fade Ends",
        description="Fade the wrinkles over half a cycle at both ends of the wrinkling region, so "
        "the last furrow does not end in a step (not in the paper; off gives Zhang's exact model)",
        default=True,
        update=_refresh,
    )
    show_region: BoolProperty(
        name="Show Region",
        description="Draw the area of influence and the wrinkling region in the viewport",
        default=True,
    )


class WrinkleMuscleRef(bpy.types.PropertyGroup):
    object: PointerProperty(
        name="Muscle",
        description="A muscle object acting on this face",
        type=bpy.types.Object,
        poll=_is_muscle,
        update=_refresh,
    )


def _enabled_update(self, context):
    from . import pipeline

    pipeline.on_enabled_changed(self.id_data, context)


def _maps_update(self, context):
    from . import wrinklemaps  # lazily, like pipeline above

    wrinklemaps.sync_quietly(self.id_data)


def _bindings_update(self, context):
    from . import wrinklemaps

    wrinklemaps.sync_quietly(self.id_data, rebind=True)


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
        poll=_is_muscle,
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
        update=_maps_update,
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
        update=_maps_update,
    )


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
    map_a: PointerProperty(
        name="Wrinkle Map 1",
        description="First wrinkle map (partial-derivative or difference map), e.g. the "
        "compressed pose",
        type=bpy.types.Image,
    )
    map_b: PointerProperty(
        name="Wrinkle Map 2",
        description="Second wrinkle map, e.g. the stretched pose (Oat 2007); may stay empty",
        type=bpy.types.Image,
    )
    map_c: PointerProperty(
        name="Wrinkle Map 3",
        description="Wrinkle map 3, for the expressions whose Map is 3 (shown when one is)",
        type=bpy.types.Image,
    )
    map_d: PointerProperty(
        name="Wrinkle Map 4",
        description="Wrinkle map 4, for the expressions whose Map is 4 (shown when one is)",
        type=bpy.types.Image,
    )
    map_e: PointerProperty(
        name="Wrinkle Map 5",
        description="Wrinkle map 5, for the expressions whose Map is 5 (shown when one is)",
        type=bpy.types.Image,
    )
    map_f: PointerProperty(
        name="Wrinkle Map 6",
        description="Wrinkle map 6, for the expressions whose Map is 6 (shown when one is)",
        type=bpy.types.Image,
    )
    map_g: PointerProperty(
        name="Wrinkle Map 7",
        description="Wrinkle map 7, for the expressions whose Map is 7 (shown when one is)",
        type=bpy.types.Image,
    )
    map_h: PointerProperty(
        name="Wrinkle Map 8",
        description="Wrinkle map 8, for the expressions whose Map is 8 (shown when one is)",
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
        update=_maps_update,
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
        update=_maps_update,
    )
    zone_power: FloatVectorProperty(
        name="Zone Response",
        description="Response curve of each zone: the clamped weight is raised to this power "
        "(below 1 wrinkles come early, above 1 late)",
        size=8, default=(1.0,) * 8, min=0.25, max=2.0,
        update=_maps_update,
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
    )
    weights_group: PointerProperty(
        name="Weights Group",
        description="The node group that turns expression values into zone weights",
        type=bpy.types.NodeTree,
    )


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
        update=_refresh,
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


classes = (WrinkleMuscleSettings, WrinkleMuscleRef, WrinkleMapExpression, WrinkleMapSettings,
           WrinkleFaceSettings)
_register, _unregister = bpy.utils.register_classes_factory(classes)


def register():
    _register()
    bpy.types.Object.wrinkle_muscle = PointerProperty(type=WrinkleMuscleSettings)
    bpy.types.Object.wrinkles = PointerProperty(type=WrinkleFaceSettings)


def unregister():
    del bpy.types.Object.wrinkles
    del bpy.types.Object.wrinkle_muscle
    _unregister()
