# SPDX-License-Identifier: GPL-3.0-or-later
"""Muscle-driven wrinkles (Zhang, Sim & Tan 2005, on Waters' linear and sheet muscles) as a
wrinkle source: the muscles' pull and eq. 4's wrinkle height, from ``core.muscles``."""

import numpy as np

from ..core.muscles import system
from ..glue import landmarks
from ..glue.muscles import muscle_objects, resolution
from ..glue.registry import WrinkleSource
from ..ui import muscles as muscles_ui


class _Static:
    __slots__ = ("plan", "footprint", "refs", "n_refs", "names", "uids", "params", "not_finite",
                 "face_params", "left_out", "objects")

    def __init__(self, plan, refs, n_refs, muscles, marks, face_params, left_out=frozenset()):
        self.plan, self.footprint, self.refs, self.n_refs = plan, plan.footprint, refs, n_refs
        self.names = [m.name for m in muscles]
        self.not_finite = [muscle_objects.not_finite(m) for m in muscles]
        self.uids = frozenset(m.session_uid for m in muscles + marks)
        self.params = {m.session_uid: muscle_objects.parameters(m) for m in muscles}
        self.objects = {m.session_uid: m for m in muscles}
        self.face_params = face_params  # the face's Irregularity and Seed
        self.left_out = left_out  # the face's muscle objects that were in no scene at the build


class _Contraction:
    """The muscles' contractions this frame, comparable with ``==``."""

    __slots__ = ("values",)

    def __init__(self, values):
        self.values = values

    def __eq__(self, other):
        return isinstance(other, _Contraction) and np.array_equal(self.values, other.values)

    __hash__ = None


def _live_refs(face, in_scene):
    """Indices into the face's muscle list of the muscles that still exist in the scene."""
    live = {m.session_uid for m in muscle_objects.live_muscles(face, in_scene)}
    return [i for i, r in enumerate(face.ewrinkles_face.muscles) if r.object is not None
            and r.object.session_uid in live]


class MuscleSource(WrinkleSource):
    name = "muscles"
    label = "Muscles"
    geometric = True

    def active(self, face):
        return len(face.ewrinkles_face.muscles) > 0

    def static_key(self, face, in_scene):
        muscles = muscle_objects.live_muscles(face, in_scene)
        marks = landmarks.landmark_positions(face)
        marks = None if marks is None else tuple(tuple(v) for v in marks.values())
        return ((muscle_objects.matrix_key(face), marks, muscle_objects.face_parameters(face))
                + tuple(muscle_objects.signature(m) for m in muscles))

    def build(self, face, mesh, in_scene):
        refs = _live_refs(face, in_scene)
        muscles = [face.ewrinkles_face.muscles[i].object for i in refs]
        core = [muscle_objects.to_core(m, face) for m in muscles]
        # the landmarks, when placed, keep every muscle off the eyelids and the lips
        keep = landmarks.keep_out(face, mesh.rest)
        plan = system.build_plan(mesh.rest, mesh.edges, mesh.tris, core, keep_out=keep)
        marks = landmarks.landmark_objects(face)
        listed = {ref.object.session_uid for ref in face.ewrinkles_face.muscles if ref.object is not None}
        return _Static(plan, refs, len(face.ewrinkles_face.muscles), muscles, marks,
                       muscle_objects.face_parameters(face),
                       frozenset(listed - {m.session_uid for m in muscles}))

    def unchanged(self, face, static, changes, in_scene):
        # Muscles are placed in the face's space: a moved face, or a muscle or landmark
        # moved or edited (Blender flags its transform or geometry), needs the signatures
        # checked, and so does a muscle deleted, unlinked (or linked again), added or removed
        # from the list.
        # The face's own geometry updates every frame.  A muscle updated otherwise had a
        # property set (an animated contraction does that on every frame): then only its
        # parameters are compared, about 1 us each against 9 us for a whole signature.
        moved = changes.get(face.session_uid, (False, False))[0]
        if moved or not static.uids <= in_scene or len(face.ewrinkles_face.muscles) != static.n_refs:
            return False
        if static.left_out and (static.left_out & in_scene):  # a muscle linked into the scene again
            return False
        if muscle_objects.face_parameters(face) != static.face_params:  # Irregularity, Seed, Skin Age
            return False
        touched = static.uids & changes.keys()
        if not touched:
            return True
        if any(changes[uid][0] or changes[uid][1] for uid in touched):
            return False
        # the face's list of muscles is as it was (an edit of it tags the face's transform,
        # which returned above): only the touched muscles' parameters need a look
        for uid in touched:
            ob = static.objects.get(uid)
            if ob is not None and muscle_objects.parameters(ob) != static.params[uid]:  # None: a landmark
                return False
        return True

    def _contraction(self, face, static):
        refs = face.ewrinkles_face.muscles
        return np.array([refs[i].object.ewrinkles_muscle.contraction for i in static.refs], np.float64)

    def inputs(self, face, static):
        return _Contraction(self._contraction(face, static))

    def contribute(self, face, static, skin, inputs):
        return system.part(static.plan, skin, inputs.values, face.ewrinkles_face.strength)

    def refine_need(self, face, factor, scene):
        return resolution.refine_need(face, factor)

    def problems(self, face, static):
        found = [f'"{static.names[i]}": {msg}' for i, msg in static.plan.problems]
        out = ["Muscle without effect: " + "; ".join(found) + "."] if found else []
        for i, asked, built in static.plan.limits:
            out.append(f'"{static.names[i]}" asks for {asked:.0f} wrinkles, more than the mesh can show '
                       f"in its wrinkling region (a wrinkle needs about two edges along the muscle): "
                       f"it shows {built}. Lower Wrinkles, or add vertices with Refine Wrinkling Regions.")
        for name, labels in zip(static.names, static.not_finite):
            if labels:
                verb = "is not a number" if len(labels) == 1 else "are not numbers"
                out.append(f'"{name}": {", ".join(labels)} {verb} (NaN) and cannot be used. '
                           "Type a value.")
        return " ".join(out)

    def draw(self, layout, context, face):
        muscles_ui.draw_face_muscles(layout, context, face)
