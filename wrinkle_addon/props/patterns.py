# SPDX-License-Identifier: GPL-3.0-or-later
"""Properties of the pattern-function layers ("Pattern functions and tears", §3): the face's
stack of layers (``Object.ewrinkles_face.patterns``), each a pattern in the frame of an
Empty, damped toward its region's border."""

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

from ..core.patterns.functions import KINDS, SHAPES
from .common import is_muscle, refresh


def is_empty(_self, ob):
    return ob.type == "EMPTY"


class PatternLayer(bpy.types.PropertyGroup):
    name: StringProperty(name="Name", description="Name of the layer", default="Pattern")
    kind: EnumProperty(name="Type", description="Which pattern function the layer adds", items=KINDS,
                       default="FOREHEAD", update=refresh)
    shape: EnumProperty(
        name="Shape", items=SHAPES, default="PAPER", update=refresh,
        description="For crow's feet, frown and cheek: the paper's pattern function as its text reads, "
        "or a variant shaped as the wrinkle is on a face (new layers get it; a layer saved before "
        "the choice existed keeps the paper's)")
    frame: PointerProperty(
        name="Frame", type=bpy.types.Object, poll=is_empty, update=refresh,
        description="The Empty whose x and y span the pattern on the skin and whose z is the skin's "
        "normal: move, turn or scale it to move, turn or scale the pattern")
    region: EnumProperty(
        name="Region", description="Where on the face the pattern applies", update=refresh,
        items=(("RADIUS", "Radius", "The vertices within a radius of the frame's centre"),
               ("GROUP", "Vertex Group", "The vertices of a vertex group, weighted by it")),
        default="RADIUS")
    radius: FloatProperty(
        name="Radius", description="Size of the region around the frame's centre, in units of the "
        "frame's size (its scale)", default=1.5, min=0.0, soft_max=10.0, update=refresh)
    vertex_group: StringProperty(name="Vertex Group", description="The vertex group of the region",
                                 default="", update=refresh)
    border: FloatProperty(
        name="Border", description="Width of the smooth fall-off to zero at the region's border, in "
        "units of the frame's size", default=0.5, min=0.0, soft_max=5.0, update=refresh)
    # the parameters alpha, beta, gamma under the names of each pattern (core.patterns.functions.PATTERNS)
    depth: FloatProperty(
        name="Depth", description="How deep the pattern is, in units of the frame's size (negative: "
        "furrows, positive: ridges; for a dimple, positive is a dip)", default=-0.12, soft_min=-1.0,
        soft_max=1.0, update=refresh)
    waviness: FloatProperty(name="Waviness", description="0 gives straight furrows, larger values wavier "
                            "ones (the forehead pattern's style)", default=0.3, soft_min=0.0, soft_max=3.0,
                            update=refresh)
    sharpness: FloatProperty(name="Sharpness", description="How narrow each furrow is (crow's feet, "
                             "the cheek fold): its width is 2 / Sharpness of the frame's size",
                             default=6.0, min=0.0, soft_max=30.0, update=refresh)
    count: FloatProperty(name="Count", description="How many furrows: crow's feet in the fan (per half "
                         "turn in the paper's shape), cheek ripples per 2 pi of radius", default=3.0,
                         soft_min=0.0, soft_max=20.0, update=refresh)
    spacing: FloatProperty(name="Spacing", description="Distance between the frown furrows", default=0.3,
                           min=0.001, soft_max=3.0, update=refresh)
    speed_x: FloatProperty(name="Speed X", description="How fast the skin trembles along the frame's x",
                           default=6.0, soft_min=0.0, soft_max=30.0, update=refresh)
    speed_y: FloatProperty(name="Speed Y", description="How fast the skin trembles along the frame's y",
                           default=6.0, soft_min=0.0, soft_max=30.0, update=refresh)
    flatness: FloatProperty(name="Flatness", description="The trembling bumps stand out by at most "
                            "2 / Flatness of the frame's size", default=40.0, min=0.001, soft_max=200.0,
                            update=refresh)
    time: FloatProperty(
        name="Time", description="The pattern's time t: animate it, or let it run with the scene. For "
        "crow's feet it is the furrows' length, for a dimple its sharpness, for anatomical frown "
        "lines it adds to their spacing", default=0.0,
        update=refresh)
    follow_scene: BoolProperty(
        name="Run with the Scene", description="Add the scene's time (seconds times Speed) to Time, so "
        "running cycles play on their own", default=True, update=refresh)
    speed: FloatProperty(name="Speed", description="How fast Time runs with the scene, per second",
                         default=1.0, soft_min=0.0, soft_max=20.0, update=refresh)
    strength: FloatProperty(name="Strength", description="How strongly the pattern shows (animatable)",
                            default=1.0, min=0.0, soft_max=2.0, update=refresh)
    drive: EnumProperty(
        name="Driven By", description="What else scales the strength", update=refresh,
        items=(("NONE", "Nothing", "The strength alone"),
               ("SHAPE_KEY", "Shape Key", "The value of one of the face's shape keys (an ARKit "
                "eyeSquint or mouthSmile)"),
               ("MUSCLE", "Muscle", "The contraction of one of the face's muscles"),
               ("COMPRESSION", "Compression", "How much the skin in the region is compressed, "
                "whatever compresses it")),
        default="NONE")
    drive_shape_key: StringProperty(name="Shape Key", description="The shape key whose value scales "
                                    "the strength", default="", update=refresh)
    drive_muscle: PointerProperty(name="Muscle", type=bpy.types.Object, poll=is_muscle, update=refresh,
                                  description="The muscle whose contraction scales the strength")
    full_compression: FloatProperty(
        name="Full at", description="The region's mean edge compression at which the pattern shows "
        "at full strength", default=0.1, min=0.001, max=1.0, subtype="FACTOR", update=refresh)
    fraction: FloatProperty(
        name="Valid Vertices", description="The fraction of the region's vertices the pattern moves "
        "(the paper's dynamic animation): below 1 the pattern shows as scattered, trembling spikes",
        default=1.0, min=0.0, max=1.0, subtype="FACTOR", update=refresh)
    seed: IntProperty(name="Seed", description="Which vertices are valid: the same seed, the same ones",
                      default=0, min=0, update=refresh)
    show_viewport: BoolProperty(name="Show in Viewport", description="Show the layer in the viewport",
                                default=True, update=refresh)
    show_render: BoolProperty(name="Show in Renders", description="Show the layer in renders",
                              default=True, update=refresh)


class PatternStack(bpy.types.PropertyGroup):
    layers: CollectionProperty(type=PatternLayer, name="Pattern Layers",
                               description="The face's pattern-function layers, summed")
    active: IntProperty(name="Active Layer", description="Index of the selected layer", default=0, min=0)
