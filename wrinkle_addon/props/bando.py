# SPDX-License-Identifier: GPL-3.0-or-later
"""Properties of Bando, Kuratate & Nishita 2002's wrinkles: ``Object.ewrinkles_curve`` on
wrinkle-curve objects (§6-7), the face's list of its curves and its fine-wrinkle settings
(§5), each hung on the face by its wrinkle source."""

import math

import bpy
from bpy.props import (
    BoolProperty,
    CollectionProperty,
    EnumProperty,
    FloatProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)

from .common import refresh


def is_wrinkle_curve(_self, ob):
    return ob.type == "CURVE" and ob.ewrinkles_curve.is_curve


class WrinkleCurveSettings(bpy.types.PropertyGroup):
    is_curve: BoolProperty(
        name="Is Wrinkle Curve",
        description="This curve object marks the furrow of a large-scale wrinkle on a face",
        default=False,
    )
    depth: FloatProperty(
        name="Depth d",
        description="Depth of the furrow at full strength (Bando 2002 eq. 2's d); the bulges on "
        "both sides rise to d/e² about 2 widths away. Faces take 2-12 mm",
        default=0.0015, min=0.0, soft_max=0.012, subtype="DISTANCE", unit="LENGTH",
        update=refresh,
    )
    width: FloatProperty(
        name="Width w",
        description="Width of the wrinkle (Bando 2002 eq. 2's w): the bulges peak at 2w from the "
        "furrow and the skin is touched up to about 9w away",
        default=0.003, min=0.0, soft_min=0.0002, soft_max=0.012, subtype="DISTANCE", unit="LENGTH",
        update=refresh,
    )
    rest_height: FloatProperty(
        name="Rest Height r",
        description="Height of the wrinkle on the undeformed face, relative to its full height "
        "(Bando 2002 eq. 5's r). 0: it shows only where the skin shrinks across it, as "
        "expression wrinkles do; 1: always at full height. Stretching the skin flattens it",
        default=0.3, min=0.0, max=1.0, subtype="FACTOR",
        update=refresh,
    )
    taper: FloatProperty(
        name="End Taper",
        description="Length over which the wrinkle fades in at each end of the curve, so it never "
        "stops abruptly (at most half the curve's length)",
        default=0.008, min=0.0, soft_max=0.05, subtype="DISTANCE", unit="LENGTH",
        update=refresh,
    )
    enabled: BoolProperty(
        name="Enabled",
        description="Raise this wrinkle on its face",
        default=True,
        update=refresh,
    )


class WrinkleCurveRef(bpy.types.PropertyGroup):
    object: PointerProperty(
        name="Curve",
        description="A wrinkle curve of this face",
        type=bpy.types.Object,
        poll=is_wrinkle_curve,
        update=refresh,
    )


class WrinkleCurveList(bpy.types.PropertyGroup):
    items: CollectionProperty(
        type=WrinkleCurveRef,
        name="Wrinkle Curves",
        description="The large-scale wrinkle curves drawn on this face",
    )
    active: IntProperty(
        name="Active Curve",
        description="Index of the selected wrinkle curve in the list",
        default=0, min=0,
    )


def _sync_fine(self, context):
    from ..glue.bando import fine

    fine.sync(self.id_data)


class WrinkleFineSettings(bpy.types.PropertyGroup):
    """Fine-scale wrinkles (Bando 2002, §5): carved once into two height images, modulated
    every frame by the skin's shrinkage across each direction field (§7)."""

    field_source: EnumProperty(
        name="Directions",
        description="Where the wrinkle directions come from",
        items=[
            ("FACE", "From the Face", "Wrinkles run across the direction in which the skin is most "
             "compressed by the face's shape keys, its muscles (each contracted alone) and its "
             "current pose (bones)"),
            ("GUIDES", "From Guides", "Directions you give: annotation strokes on the face, selected "
             "curve objects, and directions set on selected vertices (Set Direction); interpolated "
             "over the face (Bando 2002 §5.1)"),
        ],
        default="FACE",
    )
    base_magnitude: FloatProperty(
        name="Base Strength",
        description="Magnitude m of the directions from the face where no pose compresses the "
        "skin (0-1): fine furrows cover all the skin, deeper, longer and straighter where it "
        "folds (Bando 2002 eq. 1)",
        default=0.5, min=0.0, max=1.0, subtype="FACTOR",
    )
    angle: FloatProperty(
        name="Second Direction",
        description="Angle of the second family of furrows to the first: fine furrows run in two "
        "directions and cross in diamonds (Bando 2002 §3)",
        default=math.radians(65.0), min=0.0, max=math.pi, subtype="ANGLE",
    )
    resolution: EnumProperty(
        name="Resolution",
        description="Size of the two height images",
        items=[(str(r), f"{r} x {r}", f"Carve {r} x {r} pixel height images")
               for r in (512, 1024, 2048, 4096)],
        default="1024",
    )
    seed: IntProperty(
        name="Seed",
        description="Random seed of the furrows' starting points and perturbation: the same seed "
        "carves the same images",
        default=1, min=0,
    )
    reference_length: FloatProperty(
        name="Stroke Length for Full Strength",
        description="A guide stroke this long (on the skin) gives the strongest, longest, deepest "
        "furrows (magnitude m = 1); shorter strokes give finer, more irregular ones",
        default=0.05, min=0.001, soft_max=0.3, subtype="DISTANCE", unit="LENGTH",
    )
    strength: FloatProperty(
        name="Strength",
        description="Strength of the fine wrinkles' bump in the material",
        default=1.0, min=0.0, soft_max=5.0,
        update=_sync_fine,
    )
    distance: FloatProperty(
        name="Depth",
        description="Depth of a full fine furrow in the bump, in scene units",
        default=0.0003, min=0.0, soft_max=0.003, subtype="DISTANCE", unit="LENGTH",
        update=_sync_fine,
    )
    rest_height: FloatProperty(
        name="Rest Height r",
        description="Height of the fine wrinkles on the undeformed skin relative to their full "
        "height (Bando 2002 eq. 5's r; 0.5 in the paper: fine wrinkles show at rest, deepen where "
        "the skin shrinks across them and fade where it stretches)",
        default=0.5, min=0.0, max=1.0, subtype="FACTOR",
        update=_sync_fine,
    )
    continue_from: PointerProperty(
        name="Continue From",
        description="Another body part, carved before, that shares a band of faces with this one "
        "(the same faces at the same place): its directions and furrows on the shared faces are "
        "copied before this part is carved, so the furrows run on across the border without a "
        "seam (Bando 2002 §5.4)",
        type=bpy.types.Object,
        poll=lambda self, ob: ob.type == "MESH" and ob != self.id_data,
    )
    image_1: PointerProperty(
        name="Height Image 1", description="The carved furrows of the first direction field",
        type=bpy.types.Image,
    )
    image_2: PointerProperty(
        name="Height Image 2", description="The carved furrows of the second direction field",
        type=bpy.types.Image,
    )
    material: PointerProperty(
        name="Material", description="The material the fine wrinkles are wired into",
        type=bpy.types.Material,
    )
    uv_map: StringProperty(
        name="UV Map", description="The UV map the furrows were carved in",
        default="",
    )
    furrows: IntProperty(
        name="Furrows", description="How many furrows the last carving made (both images)",
        default=0, min=0,
    )
    coverage: FloatProperty(
        name="Coverage", description="Fraction of the UV islands the furrows of the first image cover",
        default=0.0, min=0.0, max=1.0, subtype="FACTOR",
    )

