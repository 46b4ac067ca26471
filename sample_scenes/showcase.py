"""The showcase: every method on one face, the sample head, through a sequence of beats.

    python sample_scenes/showcase.py [out.blend]        (builds and saves the scene)

The sample head dressed as *Add Sample Head* dresses it (skin, eyes, lashes, teeth), with:

* the facial muscle set from its landmarks, wrinkles-only: the wrinkles come from the
  compression its ARKit shape keys make (Zhang et al. 2005);
* wrinkle maps baked from its Anger and Surprise poses, blended by zone with Table 1.1's
  expression weights bound to the shape keys (Jimenez et al. 2011);
* three forehead lines as Bando's wrinkle curves, and fine wrinkles carved along the face's
  own direction field, both modulated by the skin's shrinkage (Bando et al. 2002);
* pattern layers: crow's feet with the squint, the cheek fold and the dimple with the smile,
  the frown lines with the lowered brows;
* a shedding tear that runs down the left cheek in the sad beat, and a drop that falls from
  the chin after it.

The beats (:data:`BEATS`), each held for :data:`HOLD` frames and blended into the next over
:data:`BLEND`: neutral, surprise, anger, surprise with anger, smile, sadness with tears.
``sample_scenes/demo.py`` renders the stills of each beat (front, three-quarter, the eye
corner and the glabella: :func:`render_stills`) and the clip (:func:`render_clip`).
"""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402
import numpy as np  # noqa: E402

from sample_scenes.lib import rendering, rigging, scene_setup  # noqa: E402

SURPRISE = {"browInnerUp_L": 1.0, "browInnerUp_R": 1.0, "browOuterUp_L": 1.0, "browOuterUp_R": 1.0,
            "eyeWide_L": 0.5, "eyeWide_R": 0.5, "jawOpen": 0.2}
ANGER = {"browDown_L": 1.0, "browDown_R": 1.0, "noseSneer_L": 1.0, "noseSneer_R": 1.0,
         "eyeSquint_L": 0.5, "eyeSquint_R": 0.5}
SMILE = {"mouthSmile_L": 1.0, "mouthSmile_R": 1.0, "eyeSquint_L": 1.0, "eyeSquint_R": 1.0,
         "cheekSquint_L": 1.0, "cheekSquint_R": 1.0}
SADNESS = {"browInnerUp_L": 1.0, "browInnerUp_R": 1.0, "browDown_L": 0.3, "browDown_R": 0.3,
           "mouthFrown_L": 0.9, "mouthFrown_R": 0.9, "mouthShrugLower": 0.5, "eyeSquint_L": 0.3,
           "eyeSquint_R": 0.3}
BEATS = (("Neutral", {}), ("Surprise", SURPRISE), ("Anger", ANGER),
         ("Surprise + Anger", {**SURPRISE, **ANGER}), ("Smile", SMILE), ("Sadness", SADNESS))
HOLD = 10  # frames each beat is held
BLEND = 14  # frames from one beat to the next
FPS = 24
TAIL = 8  # frames after the last beat: the drop falls
VIEWS = ("front", "three_quarter", "eye_corner", "glabella")


def beat_frames():
    """``[(name, first, last)]``: the frames over which each beat is held."""
    out, frame = [], 1
    for name, _pose in BEATS:
        out.append((name, frame, frame + HOLD))
        frame += HOLD + BLEND
    return out


def still_frame(name):
    """The frame a beat's stills are taken at: the middle of its hold."""
    _n, first, last = next(b for b in beat_frames() if b[0] == name)
    return (first + last) // 2


def _key_beats(face):
    frames = {}
    for (_name, pose), (_n, first, last) in zip(BEATS, beat_frames()):
        frames[first] = pose
        frames[last] = pose
    rigging.key_shape_keys(face, frames)


def build(maps=True, fine=True, map_resolution="1024", fine_resolution="1024"):
    """The showcase scene in the current (empty) file; returns ``(face, landmarks)``.
    ``maps`` / ``fine`` off leave out the two slowest set-ups (for quick runs)."""
    from sample_scenes import forehead_curves, patterns, scanned_head_maps
    from sample_scenes.lib import ict

    scene = bpy.context.scene
    scene.render.fps = FPS
    dressed = ict.DRESS["on"]
    ict.DRESS["on"] = True
    try:
        data = ict.load_ict()
        face = ict.ict_object(data, name="Sample Head")
    finally:
        ict.DRESS["on"] = dressed
    lm = data["landmarks"]
    rendering.log("showcase: the sample head dressed")
    scene_setup.add_portrait_rig(scene, face, frame_scale=1.35)
    forehead_curves.add_lines(face, lm)  # Bando's large-scale wrinkles: before Enable
    rigging.wrinkle_face(face, lm, wrinkles_only=True, refine=False)
    patterns.add_layers(face, lm, {"EYE_CORNER": ("SHAPE_KEY", "eyeSquint_L"),
                                   "DIMPLE": ("SHAPE_KEY", "mouthSmile_L"),
                                   "FROWN": ("SHAPE_KEY", "browDown_L")})
    rendering.log("showcase: muscles, wrinkle curves and pattern layers added; refining")
    rigging.activate(face)
    assert bpy.ops.wrinkle.refine() == {"FINISHED"}
    forehead_curves._snap_all(face)
    rendering.log(f"showcase: refined to {len(face.data.vertices)} vertices")
    if maps:
        scanned_head_maps.set_up_maps(face, resolution=map_resolution)  # leaves wrinkles off
        rigging.activate(face)
        assert bpy.ops.wrinkle.enable() == {"FINISHED"}
        rendering.log("showcase: wrinkle maps baked and wired")
    if fine:
        fs = face.ewrinkles_face.fine_wrinkles
        fs.field_source = "FACE"
        fs.resolution = fine_resolution
        rigging.activate(face)
        assert bpy.ops.wrinkle.carve_fine() == {"FINISHED"}
        rendering.log("showcase: fine wrinkles carved")
    _key_beats(face)
    _n, sad_first, sad_last = beat_frames()[-1]
    patterns.add_shedding_tear(face, lm, sad_first - BLEND // 2, (HOLD + BLEND) / FPS)
    patterns.add_tear(face, lm, sad_last)
    scene.frame_start, scene.frame_end = 1, sad_last + TAIL
    scene.frame_set(1)
    return face, lm


def _close_camera(scene, face, point, height, direction=(0.0, -1.0, 0.0)):
    """A camera framing ``height`` metres around ``point`` (face space) from ``direction``."""
    from mathutils import Vector

    cam = scene.camera
    target = face.matrix_world @ Vector(np.asarray(point, float).tolist())
    d = Vector(direction).normalized()
    dist = 0.5 * height / np.tan(0.5 * cam.data.angle)
    cam.location = target - d * dist
    cam.rotation_mode = "XYZ"
    cam.rotation_euler = d.to_track_quat("-Z", "Y").to_euler()


def views(lm):
    """``{view: spec}`` of :data:`VIEWS`: None for the front camera, "three_quarter" for the
    rig's three-quarter one, else ``(point, frame height, direction)`` of a close-up."""
    eye, glabella = np.asarray(lm["eye_L"], float), np.asarray(lm["glabella"], float)
    e = 2.0 * abs(eye[0] - glabella[0])
    corner = eye + np.array([0.42 * e, 0.0, -0.02 * e])  # the outer eye corner, where crow's feet fan
    return {"front": None, "three_quarter": "three_quarter",
            "eye_corner": (corner, 0.75 * e, (-0.55, 0.8, 0.0)),
            "glabella": (glabella + np.array([0.0, 0.0, 0.05 * e]), 0.9 * e, (0.0, 1.0, -0.1))}


def render_stills(face, lm, out, progress=None, beats=None, which=None):
    """Render each beat's stills to ``out``; returns ``{beat: [paths in views() order]}``
    (``which``: the views to render, all by default)."""
    scene = bpy.context.scene
    cam = scene.camera
    home = (cam.location.copy(), cam.rotation_mode, cam.rotation_euler.copy(), cam.rotation_quaternion.copy())
    rig3q = scene_setup.add_portrait_rig(scene, face, view="three_quarter", frame_scale=1.35, material=False)
    three = rig3q["camera"]
    for light in ("key", "fill", "rim"):  # keep one set of lights
        bpy.data.objects.remove(rig3q[light])
    front = cam
    scene.camera = front
    beats = beats or [b[0] for b in BEATS]
    chosen = {k: v for k, v in views(lm).items() if which is None or k in which}
    out_paths = {}
    for beat in beats:
        scene.frame_set(still_frame(beat))
        out_paths[beat] = []
        for view, spec in chosen.items():
            scene.camera = three if spec == "three_quarter" else front
            if isinstance(spec, tuple):
                _close_camera(scene, face, *spec)
            elif spec is None:
                front.location, front.rotation_mode = home[0], home[1]
                front.rotation_euler, front.rotation_quaternion = home[2], home[3]
            path = out / f"showcase_{beat.lower().replace(' + ', '_')}_{view}.png"
            rendering.render_still(path, progress, f"showcase: {beat}, {view} -> {path.name}")
            out_paths[beat].append(path)
    front.location, front.rotation_mode = home[0], home[1]
    front.rotation_euler, front.rotation_quaternion = home[2], home[3]
    scene.camera = front
    return out_paths


def _strips(scene):
    """The sequencer's strip collection (``strips`` since Blender 5, ``sequences`` before)."""
    editor = scene.sequence_editor or scene.sequence_editor_create()
    return editor.strips if hasattr(editor, "strips") else editor.sequences


def encode_mp4(frames, path, fps=FPS):
    """Encode the PNG ``frames`` into an H.264 MP4 with Blender's own video output: an image
    strip in a scene of its own, rendered through the sequencer to FFmpeg."""
    scene = bpy.data.scenes.new("Showcase Clip")
    try:
        strips = _strips(scene)
        strip = strips.new_image("frames", str(frames[0]), channel=1, frame_start=1)
        for f in frames[1:]:
            strip.elements.append(Path(f).name)
        img = bpy.data.images.load(str(frames[0]))
        w, h = img.size
        bpy.data.images.remove(img)
        r = scene.render
        r.resolution_x, r.resolution_y, r.resolution_percentage = w, h, 100
        r.fps = fps
        scene.frame_start, scene.frame_end = 1, len(frames)
        if hasattr(r.image_settings, "media_type"):  # Blender 5: video is a media type
            r.image_settings.media_type = "VIDEO"
        r.image_settings.file_format = "FFMPEG"
        r.ffmpeg.format = "MPEG4"
        r.ffmpeg.codec = "H264"
        r.ffmpeg.constant_rate_factor = "MEDIUM"
        r.ffmpeg.gopsize = fps
        r.use_sequencer = True
        r.filepath = str(path)
        window_scene = bpy.context.window.scene if bpy.context.window else None
        with bpy.context.temp_override(scene=scene):
            bpy.ops.render.render(animation=True, scene=scene.name)
        if window_scene is not None:
            bpy.context.window.scene = window_scene
    finally:
        bpy.data.scenes.remove(scene)
    written = sorted(Path(path).parent.glob(Path(path).stem + "*.mp4"))
    if Path(path).exists():
        return Path(path)
    if written:  # Blender appends the frame range when the name has no extension it knows
        written[-1].rename(path)
    return Path(path)


def clip_frames(step=1):
    scene = bpy.context.scene
    return list(range(scene.frame_start, scene.frame_end + 1, step))


def render_clip(out, progress=None, step=1, gif_size=240):
    """Render the scene's frames (every ``step``-th) to ``out/clip/``, then the MP4
    (:func:`encode_mp4`) and a small looping GIF (``lib/gif.py``: Blender writes no animated
    GIF or WebP).  Returns ``(mp4, gif, seconds per frame)``."""
    from sample_scenes.lib import gif

    scene = bpy.context.scene
    folder = out / "clip"
    folder.mkdir(parents=True, exist_ok=True)
    frames = clip_frames(step)
    paths, spent = [], 0.0
    for f in frames:
        scene.frame_set(f)
        path = folder / f"frame_{f:04d}.png"
        spent += rendering.render_still(path, progress, f"showcase clip: frame {f}")
        paths.append(path)
    seconds = spent / len(frames)
    mp4 = encode_mp4(paths, out / "showcase.mp4", fps=max(1, round(FPS / step)))
    pixels = []
    for p in paths:
        img = bpy.data.images.load(str(p), check_existing=False)
        w, h = img.size
        px = np.empty(w * h * 4, np.float32)
        img.pixels.foreach_get(px)
        bpy.data.images.remove(img)
        px = px.reshape(h, w, 4)[::-1, :, :3]
        k = max(1, w // gif_size)
        pixels.append(np.clip(px[::k, ::k] * 255.0 + 0.5, 0, 255).astype(np.uint8))
    gif_path = out / "showcase.gif"
    gif.write_gif(gif_path, np.stack(pixels), fps=max(1, round(FPS / step)))
    return mp4, gif_path, seconds


if __name__ == "__main__":
    rigging.save_standalone(lambda: (build()[0], {}), "showcase.blend")
