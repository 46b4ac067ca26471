"""Close-ups of the pattern layers and the tears over time, four Cycles frames each: one per
pattern type (crow's feet, the smile's cheek fold and dimple as the smile comes, frown lines
as the brows lower) on the scanned ICT head (``mouthSmile``, ``eyeSquint``, ``browDown``) and
on the procedural head (its muscles), and a shedding tear running down the cheek (halfway
down on frame 20).  The scenes are ``sample_scenes/patterns.py``'s; each close-up looks at
the face straight from the front, sized from the face's landmarks.

The demo calls :func:`render`, which writes one strip per case and
``out/pattern_frames.png`` (a row per case).
"""

import math

import bpy
import numpy as np
from mathutils import Vector

from sample_scenes import patterns
from sample_scenes.lib import rendering, scene_setup
from wrinkle_addon.core.patterns import functions

SMILE_FRAMES = (1, 8, 14, 20)
FROWN_FRAMES = (22, 28, 34, 40)
TEAR_FRAMES = (6, 12, 20, 28)
# per pattern close-up: the frames it is seen on
PATTERN_SPOTS = (("crows_feet", SMILE_FRAMES), ("cheek", SMILE_FRAMES), ("dimple", SMILE_FRAMES),
                 ("frown", FROWN_FRAMES))


def _spots(lm):
    """Where each close-up looks (face space) and how wide it sees (face units)."""
    eye, mouth = (np.asarray(lm[k], float) for k in ("eye_L", "mouth_corner_L"))
    d = eye[2] - mouth[2]
    e = functions.eye_distance(lm)
    at = patterns.places(lm)
    return {
        "crows_feet": (at["EYE_CORNER"] + np.array([0.05 * e, 0.0, 0.0]), 0.6 * e),
        "cheek": (at["CHEEK"] + np.array([-0.05 * e, 0.0, 0.0]), 0.9 * e),
        "dimple": (at["DIMPLE"] + np.array([-0.1 * e, 0.0, 0.04 * e]), 0.6 * e),
        "frown": (at["FROWN"], 0.6 * e),
        "smile": (0.5 * (at["EYE_CORNER"] + at["DIMPLE"]), 1.25 * d),
        "tear": (0.5 * (eye + mouth) + np.array([0.15 * d, 0.0, 0.0]), 1.2 * d),
    }


def _close_up(scene, face, centre, width):
    """An orthographic camera straight in front of ``centre`` (face space) seeing ``width``."""
    cam = scene.camera
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = width * float(face.matrix_world.to_scale()[0])
    at = face.matrix_world @ Vector(centre.tolist())
    cam.location = at + Vector((0.0, -1.0, 0.0))
    cam.rotation_euler = (math.pi / 2, 0.0, 0.0)
    cam.data.clip_start, cam.data.clip_end = 0.01, 10.0


def cases():
    """(name, builder, close-up, frames) for each case: every pattern type on the ICT head
    when the file exists and on the procedural head, then the tear (on the ICT head when the
    file exists)."""
    heads = [("procedural", patterns.build_procedural)]
    if patterns.available():
        heads.insert(0, ("ict", patterns.build_ict))
    out = [(f"{spot}_{head}", builder, spot, frames) for head, builder in heads
           for spot, frames in PATTERN_SPOTS]
    head, builder = heads[0]
    return out + [(f"tear_{head}", builder, "tear", TEAR_FRAMES)]


def render(out, size, samples, progress=None, only=None):
    """Render every case's four frames into ``out`` (or only the cases named in ``only``);
    returns the rows of image paths and their captions, for a contact sheet.  The pattern
    close-ups of one head share its scene; the tear's case gets a scene of its own."""
    rows, captions = [], []
    built = None
    for name, builder, spot, frames in cases():
        if only is not None and name not in only:
            continue
        if spot == "tear" or built is None or built[0] is not builder:
            bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
            face, _shots = builder()
            built = (None if spot == "tear" else builder, face)
        face = built[1]
        scene = bpy.context.scene
        scene_setup.setup_cycles(scene, resolution=(size, size), samples=samples)
        centre, width = _spots(patterns.LANDMARKS)[spot]
        _close_up(scene, face, centre, width)
        row = []
        for frame in frames:
            scene.frame_set(frame)
            path = out / f"{name}_{frame:03d}.png"
            rendering.render_still(path, progress, f"pattern close-up: {name}, frame {frame}")
            row.append(path)
        rows.append(row)
        captions.append([(f"frame {f}", "") for f in frames])
    return rows, captions
