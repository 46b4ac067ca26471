# SPDX-License-Identifier: GPL-3.0-or-later
"""Pattern-function layers ("Pattern functions and tears", §3) as a wrinkle source: each
layer's pattern in the frame of its Empty, damped toward its region's border, summed along
the skin normal with every other source, from ``core.patterns``."""

import bpy
import numpy as np

from ..core import combine
from ..core.patterns import functions
from ..glue import drivers, landmarks, meshio, pipeline
from ..glue.patterns import pattern_layers, shedding
from ..glue.registry import WrinkleSource
from ..props.patterns import PatternStack
from ..ui import patterns as patterns_ui


class _Static:
    __slots__ = ("plan", "layer_of", "placed", "footprint", "problem", "watched", "present", "known",
                 "n_layers")

    def __init__(self, layers=(), layer_of=(), placed=(), problem="", watched=None, present=None,
                 known=frozenset(), n_layers=-1):
        self.plan = functions.plan(layers)
        self.layer_of = tuple(layer_of)  # the stack index of each built layer
        self.placed = tuple(placed)  # where each layer's frame was when it was built
        self.footprint = combine.Footprint(height_verts=self.plan.footprint)
        self.problem = problem
        # for ``unchanged``: the objects whose moves change the static data (the landmark
        # empties, the frames of regions around them), the objects that must stay in the
        # scene (those and every layer's frame; None: always compute the key), the scene's
        # objects when it was built, the stack's length
        self.watched, self.present, self.known, self.n_layers = watched, present, known, n_layers


_SETTINGS = "ewrinkles_face.patterns"  # the data paths of the layers' settings


def _settings_animated(face):
    """Whether a keyframe or a driver sets any layer setting of ``face``: then Blender does
    not tag the face when it changes one, and the static key must be computed."""
    ad = face.animation_data
    if ad is None:
        return False
    return (any(d.data_path.startswith(_SETTINGS) for d in ad.drivers)
            or any(fc.data_path.startswith(_SETTINGS) for fc in drivers.action_fcurves(face)))


def _watch(face, in_scene):
    """(watched, present) uids for :class:`_Static`: the landmark empties and the frames of
    regions around them, whose moves change the static data, and those with every other
    layer's frame in the scene, which must stay there."""
    watched = {ob.session_uid for ob in landmarks.landmark_objects(face)}
    present = set(watched)
    for lay in face.ewrinkles_face.patterns.layers:
        ob = lay.frame
        if ob is not None and ob.session_uid in in_scene:
            present.add(ob.session_uid)
            if lay.region == "RADIUS":
                watched.add(ob.session_uid)
    return frozenset(watched), frozenset(present)


def _frame_key(face, lay):
    """What of the layer's frame the static data depends on: the Empty, and for a region
    around it, where it is on the face (to a micrometre of the face's units: a frame moving
    with the face must not rebuild from float noise).  Its turn and scale only place the
    pattern, which every frame does again (``inputs``)."""
    ob = lay.frame
    if ob is None:
        return None
    try:
        around = pattern_layers.setting(lay, "region") == "RADIUS"
    except pattern_layers.PatternError:  # a value this version does not know: build_layer says so
        around = False
    if not around:
        return (ob.name,)
    centre = face.matrix_world.inverted_safe() @ ob.matrix_world.translation
    return (ob.name,) + tuple(round(c, 6) for c in centre)


def _placement(face_matrix, face_inverse, lay):
    """Where the layer's frame is this frame: the face-to-frame matrix (16 floats, row by
    row) and the length of the frame's z in the face's units (``pattern_layers.to_frame``), in
    mathutils alone (a few microseconds a layer)."""
    frame = lay.frame.matrix_world
    m = frame.inverted_safe() @ face_matrix
    return tuple(v for row in m for v in row), (face_inverse.to_3x3() @ frame.col[2].xyz).length


class PatternSource(WrinkleSource):
    name = "patterns"
    label = "Pattern Functions"
    geometric = True
    properties = (("patterns", PatternStack),)

    def active(self, face):
        return len(face.ewrinkles_face.patterns.layers) > 0

    def unchanged(self, face, static, changes, in_scene):
        # an edit of a layer's setting, of its frame's pointer or of the face's transform
        # tags the face's transform (measured on bpy 4.5 and 5.2); shape keys and bones tag
        # only its geometry.  A landmark or a region's frame moved is tagged itself.
        # A new object (a landmark placed, a frame linked back into the scene) is updated too.
        return (static.present is not None and not changes.get(face.session_uid, (False, False))[0]
                and static.present <= in_scene and not static.watched & changes.keys()
                and not (changes.keys() & in_scene) - static.known
                and len(face.ewrinkles_face.patterns.layers) == static.n_layers
                and not _settings_animated(face))

    def static_key(self, face, in_scene):
        marks = landmarks.landmark_positions(face)
        marks = None if marks is None else tuple(tuple(v) for v in marks.values())
        # the face's scale (radius and border are scene lengths), not where it is: the
        # layers live in its space
        key = [round(pattern_layers.face_unit(face), 9), meshio.topology_key(face.data), marks]
        for lay in face.ewrinkles_face.patterns.layers:
            in_it = lay.frame is not None and lay.frame.session_uid in in_scene
            numbers = tuple(pattern_layers.setting(lay, p) for p in ("radius", "border", "fraction", "seed"))
            # what build_layer reads (a stored NaN reads as the default)
            key.append((lay.kind, lay.shape, lay.region, lay.drive, _frame_key(face, lay), in_it,
                        lay.vertex_group) + numbers)
        return tuple(key)

    def build(self, face, mesh, in_scene):
        layers, index, placed, problems = [], [], [], []
        fw, inverse = face.matrix_world, face.matrix_world.inverted_safe()
        for i, lay in enumerate(face.ewrinkles_face.patterns.layers):
            try:
                layers.append(pattern_layers.build_layer(face, mesh, lay))
                index.append(i)
                placed.append(_placement(fw, inverse, lay))
            except pattern_layers.PatternError as exc:
                problems.append(str(exc))
        watched, present = _watch(face, in_scene)
        return _Static(layers, index, placed, "; ".join(problems), watched, present, frozenset(in_scene),
                       len(face.ewrinkles_face.patterns.layers))

    def inputs(self, face, static):
        st = face.ewrinkles_face.patterns.layers
        scene = bpy.context.scene
        render = pipeline.render_frame()
        fw, inverse = face.matrix_world, face.matrix_world.inverted_safe()
        out = []
        for i in static.layer_of:
            lay = st[i] if i < len(st) else None
            if lay is None or not (lay.show_render if render else lay.show_viewport):
                out.append(((0.0, 0.0, 0.0, 0.0, 0.0, 0.0), None))
                continue
            full = pattern_layers.setting(lay, "full_compression") if lay.drive == "COMPRESSION" else 0.0
            placed = _placement(fw, inverse, lay) if lay.frame is not None else None
            out.append((pattern_layers.values(face, lay, scene) + (full,), placed))
        return tuple(out)

    def contribute(self, face, static, skin, inputs):
        if len(static.plan.footprint) == 0:
            return combine.Contribution()
        vals, layers = [], []
        for lay, (v, placed), built in zip(static.plan.layers, inputs, static.placed):
            t, strength, a, b, g, full = v
            if placed is not None and placed != built and strength != 0.0:  # its frame moved
                lay = functions.in_frame(lay, placed[0], placed[1])
            if full > 0.0 and strength != 0.0:  # driven by the region's compression
                strength *= min(functions.compression(lay, skin) / full, 1.0)
            vals.append((t, strength, a, b, g))
            layers.append(lay)
        plan = functions.Plan(tuple(layers), static.plan.footprint, static.plan.index)
        return combine.Contribution(height=functions.heights(plan, vals).astype(np.float32))

    def map_heights(self, face, mesh, skin, formed):
        static = self.build(face, mesh, {o.session_uid for o in bpy.context.scene.objects})
        if static.problem:
            raise pattern_layers.PatternError(static.problem)
        if len(static.plan.footprint) == 0:
            return None
        vals = self.inputs(face, static)
        if formed:  # every layer at full strength: the map's zone weights animate it
            vals = tuple((v[:1] + (1.0 if any(v) else 0.0,) + v[2:5] + (0.0,), placed) for v, placed in vals)
        out = np.zeros(len(mesh.rest), np.float32)
        out[static.plan.footprint] = self.contribute(face, static, skin, vals).height
        return out

    def skin_handed_over(self, old, new):
        shedding.follow(old, new)  # the shedding tears follow the stand-in's skin, and back

    def refine_need(self, face, factor, scene):
        return pattern_layers.refine_need(face, factor, scene)

    def problems(self, face, static):
        return static.problem

    def draw(self, layout, context, face):
        patterns_ui.draw_face_patterns(layout, context, face)
