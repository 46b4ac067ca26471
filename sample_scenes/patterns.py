"""Sample scene: pattern-function layers on a head: crow's feet at both eye corners and a
dimple on each cheek that come with the smile, and frown furrows that come with the lowered
brows.  On the scanned ICT head (the add-on's sample head) the layers are
driven by its ARKit shape keys (eyeSquint, mouthSmile, browDown); on the procedural head
(``--head procedural``) by its muscles' contractions.  Only the pattern layers wrinkle the
face here, so the renders show them alone.  A dripping tear forms under the chin, where a
tear that ran down the face leaves it, on frame 30 and is falling on frame 40; a shedding
tear starts under the left eye on frame 1 and is halfway down the cheek on frame 20.

Run alone to save a .blend: ``python sample_scenes/patterns.py out/patterns.blend``.
"""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402
import numpy as np  # noqa: E402

from sample_scenes.lib import rigging, scene_setup  # noqa: E402

DATA = ROOT / "wrinkle_addon" / "data" / "ict_head.npz"
SMILE = {"mouthSmile_L": 1.0, "mouthSmile_R": 1.0, "eyeSquint_L": 1.0, "eyeSquint_R": 1.0}
FROWN = {"browDown_L": 1.0, "browDown_R": 1.0}
SHOTS = {"Neutral": 1, "Smile": 20, "Frowning": 40}
LANDMARKS = {}  # the last built head's landmarks (face space), for the close-ups


def available():
    return DATA.exists()


def places(lm):
    """Where the layers go, in the face's space, from its landmarks (the character's left;
    the right side is mirrored): ``core.patterns.functions.places``, the add-on's own: the
    outer eye corner (the crow's feet's apex), the middle of the smile's cheek fold, the
    cheek beside the mouth corner for the dimple, and between the brows for the frown."""
    from wrinkle_addon.core.patterns import functions

    at = functions.places(lm)
    return {kind: at[kind][0] for kind in ("EYE_CORNER", "CHEEK", "DIMPLE", "FROWN")}


def _front_hit(face, point):
    """The skin straight in front of ``point`` (face space): where a ray along +Y from in
    front of the face at its x and z meets the skin, or ``point`` when it misses."""
    from mathutils import Vector
    from mathutils.bvhtree import BVHTree

    me = face.data
    bvh = BVHTree.FromPolygons([v.co[:] for v in me.vertices], [p.vertices[:] for p in me.polygons])
    hit = bvh.ray_cast(Vector((point[0], -10.0, point[2])), Vector((0.0, 1.0, 0.0)))[0]
    return np.array(hit) if hit is not None else point


def add_layers(face, lm, drivers):
    """The seven layers (crow's feet, cheek fold and dimple on both sides, the frown between
    the brows); ``drivers``: type -> (drive, shape key or muscle) for the left side and the
    middle (the cheek fold, which has none of its own, comes with the dimple's smile)."""
    from mathutils import Vector

    rigging.activate(face)
    for kind, point in places(lm).items():
        point = _front_hit(face, point)
        bpy.context.scene.cursor.location = face.matrix_world @ Vector(point.tolist())
        assert bpy.ops.wrinkle.add_pattern(kind=kind, where="CURSOR") == {"FINISHED"}
        lay = face.ewrinkles_face.patterns.layers[-1]
        drive, what = drivers.get(kind, drivers["DIMPLE"])
        lay.drive = drive
        if drive == "SHAPE_KEY":
            lay.drive_shape_key = what
        else:
            lay.drive_muscle = what
        if kind != "FROWN":
            assert bpy.ops.wrinkle.mirror_pattern() == {"FINISHED"}
            if drive == "MUSCLE":
                mirrored = face.ewrinkles_face.patterns.layers[-1]
                other = bpy.data.objects.get(what.name[:-2] + ".R") if what.name.endswith(".L") else None
                mirrored.drive_muscle = other or what


def drip_point(face, lm):
    """Where a drop leaves the face (face space): a tear runs down the skin to the chin and
    hangs where the skin turns under, the front-most point of the chin's midline, below the
    chin's landmark, whose skin faces down (its world normal at least 60 degrees below the
    horizon), so it falls free along the world's gravity and not into the skin (one formed
    under the eye would fall into the cheek)."""
    chin = np.asarray(lm["chin"], float)
    d = float(np.asarray(lm["eye_L"], float)[2] - np.asarray(lm["mouth_corner_L"], float)[2])
    me = face.data
    co = np.empty(len(me.vertices) * 3, np.float32)
    me.vertices.foreach_get("co", co)
    normals = np.empty(len(me.vertices) * 3, np.float32)
    me.vertices.foreach_get("normal", normals)
    co, normals = co.reshape(-1, 3).astype(float), normals.reshape(-1, 3).astype(float)
    world = np.array(face.matrix_world.to_3x3(), float)
    down = -(normals @ world.T)[:, 2] / np.maximum(np.linalg.norm(normals @ world.T, axis=1), 1e-12)
    height = co @ world.T[:, 2]  # up in the world
    near = ((np.abs(co[:, 0] - chin[0]) < 0.1 * d) & (np.linalg.norm(co - chin, axis=1) < 0.8 * d)
            & (height <= height_of(face, chin)))  # on the chin, below its front, not the lips or the nose
    under = near & (down > np.sin(np.radians(60.0)))
    if not under.any():
        return chin
    forward = -(co @ world.T)[:, 1]  # the face looks toward the world's -Y
    return co[np.flatnonzero(under)[np.argmax(forward[under])]]


def height_of(face, point):
    """How high ``point`` (face space) is in the world."""
    return float((np.array(face.matrix_world.to_3x3(), float) @ np.asarray(point, float))[2])


def add_tear(face, lm, frame):
    """A dripping tear that forms on ``frame`` where a tear that ran down to the chin leaves
    the face (:func:`drip_point`) and falls once, along the world's gravity."""
    from mathutils import Vector

    scene = bpy.context.scene
    scene.frame_set(frame)
    scene.cursor.location = face.matrix_world @ Vector(drip_point(face, lm).tolist())
    rigging.activate(face)
    assert bpy.ops.wrinkle.add_teardrop(every=60.0, lasts=3.0) == {"FINISHED"}


def tear_path(face, lm, n=16):
    """A shedding tear's path on the left cheek, as an artist draws it on the skin (Curve >
    Draw, Depth: Surface): from under the lower lid down beside the nose to the mouth's
    height, each point dropped onto the skin straight from the front (face space)."""
    from mathutils import Vector
    from mathutils.bvhtree import BVHTree

    eye, mouth = np.asarray(lm["eye_L"], float), np.asarray(lm["mouth_corner_L"], float)
    d = eye[2] - mouth[2]
    start = eye + np.array([0.05 * d, 0.0, -0.22 * d])
    end = np.array([0.5 * (eye[0] + mouth[0]) + 0.2 * d, 0.0, mouth[2] + 0.1 * d])
    me = face.data
    bvh = BVHTree.FromPolygons([v.co[:] for v in me.vertices], [p.vertices[:] for p in me.polygons])
    out = []
    for t in np.linspace(0.0, 1.0, n):
        x, _y, z = (1 - t) * start + t * end
        hit = bvh.ray_cast(Vector((x, -10.0, z)), Vector((0.0, 1.0, 0.0)))[0]
        if hit is not None:
            out.append(tuple(hit))
    return out


def add_shedding_tear(face, lm, frame, seconds):
    """A shedding tear that starts under the left eye on ``frame`` and runs down the cheek in
    ``seconds``; its path is a curve on the skin, as an artist draws one.  Returns the tear."""
    scene = bpy.context.scene
    scene.frame_set(frame)
    curve = bpy.data.curves.new("Tear Path", "CURVE")
    curve.dimensions = "3D"
    pts = tear_path(face, lm)
    spline = curve.splines.new("POLY")
    spline.points.add(len(pts) - 1)
    spline.points.foreach_set("co", np.array([(*p, 1.0) for p in pts], np.float32).ravel())
    path = bpy.data.objects.new("Tear Path", curve)
    scene.collection.objects.link(path)
    path.matrix_world = face.matrix_world
    rigging.activate(face)
    path.select_set(True)
    before = set(bpy.data.objects)
    assert bpy.ops.wrinkle.add_shedding_tear(path="CURVE", duration=seconds) == {"FINISHED"}
    path.hide_render = True
    return next(o for o in bpy.data.objects if o not in before)


def build_ict(view="front"):
    from sample_scenes.lib import ict

    scene = bpy.context.scene
    data = ict.load_ict(DATA)
    LANDMARKS.clear()
    LANDMARKS.update(data["landmarks"])
    face = ict.ict_object(data, name="ICTHead")
    scene_setup.add_portrait_rig(scene, face, view=view, frame_scale=1.35)
    # the landmarks keep every layer off the eyelids and the lips; the muscles make none
    rigging.wrinkle_face(face, data["landmarks"], wrinkles_only=True, refine=False)
    face.ewrinkles_face.strength = 0.0
    add_layers(face, data["landmarks"], {"EYE_CORNER": ("SHAPE_KEY", "eyeSquint_L"),
                                         "DIMPLE": ("SHAPE_KEY", "mouthSmile_L"),
                                         "FROWN": ("SHAPE_KEY", "browDown_L")})
    rigging.activate(face)
    assert bpy.ops.wrinkle.refine() == {"FINISHED"}  # the scan is too coarse for the furrows
    rigging.key_shape_keys(face, {1: {}, 20: SMILE, 40: FROWN})
    add_tear(face, data["landmarks"], 30)
    add_shedding_tear(face, data["landmarks"], 1, 1.6)
    scene.frame_start, scene.frame_end = 1, 40
    return face, SHOTS


def build_procedural(view="front"):
    from sample_scenes.lib import headgen

    scene = bpy.context.scene
    head = headgen.make_head(40000)
    LANDMARKS.clear()
    LANDMARKS.update(head["landmarks"])
    face = scene_setup.mesh_object_from_arrays("Head", head["positions"], head["quads"], head["corner_uvs"])
    scene_setup.add_portrait_rig(scene, face, view=view, frame_scale=1.35)
    rigging.wrinkle_face(face, head["landmarks"])
    face.ewrinkles_face.strength = 0.0  # the muscles pull, their own wrinkles stay off
    muscles = {m.ewrinkles_muscle.role + "." + m.name[-1]: m for m in
               (r.object for r in face.ewrinkles_face.muscles) if m is not None}
    add_layers(face, head["landmarks"], {"EYE_CORNER": ("MUSCLE", muscles["ZYGOMATICUS_MAJOR.L"]),
                                         "DIMPLE": ("MUSCLE", muscles["ZYGOMATICUS_MAJOR.L"]),
                                         "FROWN": ("MUSCLE", muscles["CORRUGATOR.L"])})
    rigging.key_expressions(face, {1: "NEUTRAL", 40: "FROWN"})
    scene.frame_set(20)
    for m in muscles.values():  # the smile: both Zygomaticus Major, keyed as a preset is
        m.ewrinkles_muscle.contraction = 1.0 if m.ewrinkles_muscle.role == "ZYGOMATICUS_MAJOR" else 0.0
        m.keyframe_insert("ewrinkles_muscle.contraction", frame=20)
    add_tear(face, head["landmarks"], 30)
    add_shedding_tear(face, head["landmarks"], 1, 1.6)
    scene.frame_start, scene.frame_end = 1, 40
    return face, SHOTS


def build(view="front", head="ict"):
    return build_ict(view) if head == "ict" and available() else build_procedural(view)


def toggle(face, on):
    """The demo's without / with switch: every pattern layer shown in renders, or none."""
    for lay in face.ewrinkles_face.patterns.layers:
        if lay.show_render != on:
            lay.show_render = on


if __name__ == "__main__":
    rigging.save_standalone(build, "patterns.blend")
