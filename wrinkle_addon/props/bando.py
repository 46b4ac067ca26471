# SPDX-License-Identifier: GPL-3.0-or-later
"""Properties of the large-scale wrinkle curves (Bando, Kuratate & Nishita 2002, §6-7):
``Object.ewrinkles_curve`` on wrinkle-curve objects, and the face's list of its curves
(hung on the face by the curve source)."""

import bpy
from bpy.props import BoolProperty, CollectionProperty, FloatProperty, IntProperty, PointerProperty

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
