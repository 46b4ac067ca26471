"""Close-ups of the pattern layers and the tears over time, four Cycles frames each: crow's
feet and dimples as the smile comes, on the procedural head and on the scanned ICT head
(with ``mouthSmile`` and ``eyeSquint``); frown furrows as the brows lower (``browDown``);
and a shedding tear running down the cheek (halfway down on frame 20).  The scenes are
``sample_scenes/patterns.py``'s; each close-up looks at the face straight from the front.

The demo calls :func:`render`, which writes one strip per case and
``out/pattern_frames.png`` (a row per case).
"""

import math

import bpy
import numpy as np
from mathutils import Vector

from sample_scenes import patterns
from sample_scenes.lib import scene_setup

SMILE_FRAMES = (1, 8, 14, 20)
FROWN_FRAMES = (22, 28, 34, 40)
TEAR_FRAMES = (6, 12, 20, 28)


def _spots(lm):
    """Where each close-up looks (face space) and how wide it sees (face units)."""
    eye, mouth, g = (np.asarray(lm[k], float) for k in ("eye_L", "mouth_corner_L", "glabella"))
    d = eye[2] - mouth[2]
    at = patterns.places(lm)
    return {
        "smile": (0.5 * (at["EYE_CORNER"] + at["DIMPLE"]), 1.25 * d),
        "frown": (np.array([g[0], g[1], 0.5 * (g[2] + eye[2])]), 0.9 * d),
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
    """(name, builder, close-up, frames) for each case; the ICT ones when the file exists."""
    out = [("smile_procedural", patterns.build_procedural, "smile", SMILE_FRAMES)]
    if patterns.available():
        out += [("smile_ict", patterns.build_ict, "smile", SMILE_FRAMES),
                ("frown_ict", patterns.build_ict, "frown", FROWN_FRAMES),
                ("tear_ict", patterns.build_ict, "tear", TEAR_FRAMES)]
    else:
        out += [("frown_procedural", patterns.build_procedural, "frown", FROWN_FRAMES),
                ("tear_procedural", patterns.build_procedural, "tear", TEAR_FRAMES)]
    return out


def render(out, size, samples, log=print, quiet=None):
    """Render every case's four frames into ``out``; returns the rows of image paths and
    their captions, for a contact sheet."""
    rows, captions = [], []
    for name, builder, spot, frames in cases():
        bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
        face, _shots = builder()
        scene = bpy.context.scene
        scene_setup.setup_cycles(scene, resolution=(size, size), samples=samples)
        centre, width = _spots(patterns.LANDMARKS)[spot]
        _close_up(scene, face, centre, width)
        row = []
        for frame in frames:
            scene.frame_set(frame)
            path = out / f"{name}_{frame:03d}.png"
            scene.render.filepath = str(path)
            if quiet is None:
                bpy.ops.render.render(write_still=True)
            else:
                with quiet(out / "render.log"):
                    bpy.ops.render.render(write_still=True)
            row.append(path)
        log(f"pattern frames: {name} frames {', '.join(map(str, frames))}")
        rows.append(row)
        captions.append([(f"frame {f}", "") for f in frames])
    return rows, captions
