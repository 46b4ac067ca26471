# SPDX-License-Identifier: GPL-3.0-or-later
"""Animated wrinkle maps (Jimenez, Echevarria, Oat & Gutierrez 2011) as a wrinkle source.

The maps themselves are shaded by the *Wrinkle Map Blend* group; what runs per frame is
the tension-driven mode, whose 8 zone weights are the skin's measured compression in each
zone (``core.maps.jimenez.zone_tension``, folded onto the edges once per face:
``core.maps.jimenez.tension_plan``).  Its farm bake keys the weights that a farm
without the add-on cannot compute: the tension-driven zones and the expressions driven by a
muscle's contraction.  Maps driven by shape keys, ordinary properties or Manual values alone
have nothing to bake (``bakes`` is False): their one-variable drivers evaluate on a farm
with no add-on."""

from ..core.combine import Contribution
from ..core.maps import jimenez
from ..glue.maps import map_material
from ..glue.registry import WrinkleSource
from ..glue.surface import SurfaceError
from ..ui import maps as maps_ui


class _Static:
    """The tension's plan (``core.maps.jimenez.tension_plan`` of ``map_material.tension_statics``),
    or why there is none."""

    __slots__ = ("tension", "problem")

    def __init__(self, tension=None, problem=""):
        self.tension, self.problem = tension, problem


class MapSource(WrinkleSource):
    name = map_material.CHANNEL
    label = "Wrinkle Maps"
    geometric = False

    def active(self, face):
        return map_material.wants_tension(face)

    def static_key(self, face, in_scene):
        return map_material.tension_key(face)

    def build(self, face, mesh, in_scene):
        try:
            rest_length, edges, vertex_masks = map_material.tension_statics(face)
            return _Static(jimenez.tension_plan(edges, rest_length, vertex_masks))
        except SurfaceError as exc:  # the UV map is gone, say: the maps' own problem
            return _Static(problem=f"Tension-driven wrinkle maps paused: {exc}")

    def inputs(self, face, static):
        return (float(face.ewrinkles_face.maps.tension_gain),)

    def contribute(self, face, static, skin, inputs):
        if static.tension is None:
            return Contribution()
        (gain,) = inputs
        return Contribution(shading={"zone_weights": jimenez.plan_tension(static.tension, skin, gain)})

    def problems(self, face, static):
        return static.problem

    def write_shading(self, face, static, name, values):
        map_material.write_tension(face, values)

    def bake(self, face, scene, frame_start, frame_end, progress):
        k = map_material.bake_weights(face, scene, frame_start, frame_end, progress)
        return f"{k} wrinkle-map weight channel(s) keyed" if k else ""

    def bakes(self, face):
        # a bake of values that no longer need one (the muscle's row was rebound to a shape
        # key, say) is something to do too: baking again frees it
        return map_material.needs_bake(face) or self.has_bake(face)

    def has_bake(self, face):
        return bool(map_material.baked_paths(face.ewrinkles_face.maps.weights_group))

    def free_bake(self, face):
        map_material.free_weights(face)

    def upgrade(self, face):
        return map_material.upgrade(face)

    def draw(self, layout, context, face):
        maps_ui.draw(layout, context, face)
