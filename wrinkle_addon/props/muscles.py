# SPDX-License-Identifier: GPL-3.0-or-later
"""Properties of the muscle-driven wrinkles (Zhang, Sim & Tan 2005, on Waters' muscles):
``Object.ewrinkles_muscle`` on muscle objects, and the face's list of its muscles."""

import math

import bpy
from bpy.props import (
    BoolProperty,
    EnumProperty,
    FloatProperty,
    IntProperty,
    PointerProperty,
)

from ..core.muscles.presets import MUSCLES
from .common import is_muscle, refresh


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
            ("SPHINCTER", "Sphincter", "A sphincter muscle: an ellipse of fibres round an opening "
             "(the eye, the mouth) that draws the skin toward its centre; its wrinkles run across "
             "the fibres, like crow's feet (Waters 1987)"),
        ],
        default="LINEAR",
        update=refresh,
    )
    role: EnumProperty(
        name="Role",
        description="Which facial muscle this is; expression presets key muscles by role",
        items=[("CUSTOM", "Custom", "A muscle of your own")]
        + [(r, n, f"{n} ({k.lower()} muscle of the facial muscle set)") for r, n, k in MUSCLES],
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
        update=refresh,
    )
    wrinkles_only: BoolProperty(
        name="Wrinkles Only",
        description="Do not pull the skin: only raise wrinkles where shape keys, bones or other "
        "muscles compress it. Use it on faces that are already animated",
        default=False,
        update=refresh,
    )
    pull: FloatProperty(
        name="Pull",
        description="Strength of the skin pull at full contraction, as a fraction of the "
        "attachment-to-insertion distance (Waters' k). Kept below 2/pi so no skin overshoots "
        "the attachment",
        default=0.2, min=0.0, max=0.6, soft_max=0.5, subtype="FACTOR",
        update=refresh,
    )
    radius: FloatProperty(
        name="Radius R",
        description="Linear muscle: radius of the area of influence, from the attachment "
        "(Zhang's R, Waters' fall-off finish Rf)",
        default=0.05, min=0.0, soft_min=0.001, soft_max=0.3, subtype="DISTANCE", unit="LENGTH",
        update=refresh,
    )
    angle: FloatProperty(
        name="Angle",
        description="Linear muscle: maximal angle of influence around the central fibre (Zhang's "
        "Phi, Waters' Omega). Sphincter: half the angle of the wrinkling sector round its first "
        "axis",
        default=math.radians(35.0), min=0.0, max=math.pi, soft_min=math.radians(5.0),
        soft_max=math.radians(80.0), subtype="ANGLE",
        update=refresh,
    )
    angle_c: FloatProperty(
        name="Attenuation Start",
        description="Linear muscle: angle from the central fibre where the wrinkle amplitude "
        "starts to decrease (Zhang's phi_c, eq. 12). Sphincter: the same, from the middle of its "
        "wrinkling sector",
        default=math.radians(15.0), min=0.0, max=math.pi, soft_max=math.radians(80.0),
        subtype="ANGLE",
        update=refresh,
    )
    length: FloatProperty(
        name="Length Ls",
        description="Sheet muscle: length of the area of influence, from the attachment line "
        "along the fibres (Zhang's Ls)",
        default=0.07, min=0.0, soft_min=0.001, soft_max=0.3, subtype="DISTANCE", unit="LENGTH",
        update=refresh,
    )
    width: FloatProperty(
        name="Width Ws",
        description="Sheet muscle: width of the area of influence across the fibres (Zhang's Ws)",
        default=0.05, min=0.0, soft_min=0.001, soft_max=0.3, subtype="DISTANCE", unit="LENGTH",
        update=refresh,
    )
    width_c: FloatProperty(
        name="Attenuation Start",
        description="Sheet muscle: distance from the central fibre where the wrinkle amplitude "
        "starts to decrease (Zhang's h_c, eq. 15)",
        default=0.015, min=0.0, soft_max=0.15, subtype="DISTANCE", unit="LENGTH",
        update=refresh,
    )
    depth: FloatProperty(
        name="Depth",
        description="Sheet and sphincter muscle: only skin within this distance of the muscle's "
        "plane is affected, so it cannot reach through the head",
        default=0.03, min=0.0, soft_max=0.2, subtype="DISTANCE", unit="LENGTH",
        update=refresh,
    )
    back_reach: FloatProperty(
        name="Reach Behind",
        description="Sheet muscle: how far the sheet also reaches behind its attachment line, as "
        "a fraction of its length. That skin is pulled toward the line too, so the skin converges "
        "on the line from both sides, as the forehead does when the brows rise (0: Waters' sheet)",
        default=0.0, min=0.0, max=2.0, subtype="FACTOR",
        update=refresh,
    )
    region_end: FloatProperty(
        name="Region End",
        description="Sheet muscle: where the wrinkling region ends along the fibres, as a "
        "fraction of its length Ls (1: at the sheet's end, Zhang's). The pull still reaches the "
        "sheet's end, so the skin beyond is drawn along but does not wrinkle, as the brows' skin "
        "under the forehead's lines",
        default=1.0, min=0.0, max=1.0, subtype="FACTOR",
        update=refresh,
    )
    reach: FloatProperty(
        name="Outer Reach",
        description="Sphincter muscle: how far its area of influence reaches beyond the centre, in "
        "radii of its ring (the ellipse of its object). The pull fades from the ring to there",
        default=1.3, min=1.0, max=5.0, soft_max=3.0,
        update=refresh,
    )
    lambda_w: FloatProperty(
        name="Wrinkling Region",
        description="Where the wrinkling region starts along the muscle, as a fraction of its "
        "length (Zhang's lambda_w); for a sphincter, from its centre as a fraction of its outer "
        "reach. Smaller values give a larger region",
        default=0.4, min=0.0, max=0.99, subtype="FACTOR",
        update=refresh,
    )
    n_wrinkles: IntProperty(
        name="Wrinkles",
        description="Number of wrinkles across the wrinkling region (Zhang's n_w, eq. 6). "
        "0 switches this muscle's wrinkles off but keeps its pull",
        default=4, min=0, max=1000, soft_min=1, soft_max=12,
        update=refresh,
    )
    k0: FloatProperty(
        name="Furrow Depth",
        description="Furrow depth factor k0 of the wrinkle shape (Zhang eq. 5). The bulge "
        "height d follows from it so that the skin volume is preserved (eq. 8)",
        default=0.0008, soft_min=0.0, soft_max=0.005, subtype="DISTANCE", unit="LENGTH",
        precision=5,
        update=refresh,
    )
    alpha: FloatProperty(
        name="Shape",
        description="Shape modulation factor alpha (Zhang eq. 5): larger values make the furrows "
        "sharper relative to the bulges",
        default=1.0, min=-5.0, max=5.0, soft_min=0.0, soft_max=3.0,
        update=refresh,
    )
    fade_ends: BoolProperty(
        name="Fade Ends",
        description="Fade the wrinkles over half a cycle at both ends of the wrinkling region, so "
        "the last furrow does not end in a step (not in the paper; off gives Zhang's exact model)",
        default=True,
        update=refresh,
    )
    irregularity: FloatProperty(
        name="Irregularity Factor",
        description="This muscle's share of the face's Irregularity (its value times this): 0 gives "
        "this muscle Zhang's regular furrows, above 1 it is more irregular than the face. Keep "
        "neighbouring muscles whose furrows join at the same value, or the furrows step where they meet",
        default=1.0, min=0.0, max=4.0, soft_max=2.0,
        update=refresh,
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
        poll=is_muscle,
        update=refresh,
    )
