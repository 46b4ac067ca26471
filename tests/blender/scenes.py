"""Small scenes for the Blender tests, built with the add-on's own operators."""

from pathlib import Path

import bpy
import numpy as np

from tests.core.meshes import grid, squash_vertical  # noqa: F401 (re-exported)

WIDTH, HEIGHT = 0.14, 0.08


def make_face(name="Face", nx=70, nz=40, shape_key=True):
    """A forehead-like patch in the XZ plane facing -Y, with a 'BrowsUp' shape key that
    compresses it vertically toward the top edge."""
    rest, _edges, _tris, quads = grid(nx, nz, WIDTH, HEIGHT)
    me = bpy.data.meshes.new(name)
    me.vertices.add(len(rest))
    me.vertices.foreach_set("co", rest.astype(np.float32).ravel())
    me.loops.add(quads.size)
    me.loops.foreach_set("vertex_index", quads.astype(np.int32).ravel())
    me.polygons.add(len(quads))
    me.polygons.foreach_set("loop_start", (np.arange(len(quads)) * 4).astype(np.int32))
    me.polygons.foreach_set("loop_total", np.full(len(quads), 4, np.int32))
    me.update(calc_edges=True)
    me.validate()
    me.shade_smooth()
    ob = bpy.data.objects.new(name, me)
    bpy.context.scene.collection.objects.link(ob)
    if shape_key:
        ob.shape_key_add(name="Basis")
        key = ob.shape_key_add(name="BrowsUp")
        key.points.foreach_set("co", squash_vertical(rest, 0.7, HEIGHT).astype(np.float32).ravel())
        key.value = 0.0  # bpy 5.2 creates new shape keys at 1.0, 4.5 at 0.0
    bpy.context.view_layer.objects.active = ob
    ob.select_set(True)
    return ob


def sheet_points():
    half = 0.05
    return (-half, 0, HEIGHT, half, 0, HEIGHT, half, 0, 0.008, -half, 0, 0.008)


def add_sheet(face, **params):
    bpy.context.view_layer.objects.active = face
    bpy.ops.wrinkle.add_muscle(kind="SHEET", use_points=True, points=sheet_points(), name="Frontalis")
    ob = bpy.context.view_layer.objects.active
    for k, v in params.items():
        setattr(ob.ewrinkles_muscle, k, v)
    bpy.context.view_layer.objects.active = face
    return ob


def wrinkled_face(**params):
    face = make_face()
    bpy.ops.wrinkle.enable()
    muscle = add_sheet(face, **params)
    return face, muscle


def animate_shape_key(face, frames_values):
    key = face.data.shape_keys.key_blocks["BrowsUp"]
    for frame, value in frames_values:
        key.value = value
        key.keyframe_insert("value", frame=frame)


def select_only(ob):
    """``ob`` the only selected object and the active one, as an operator on it expects."""
    for other in bpy.context.view_layer.objects:
        other.select_set(False)
    ob.select_set(True)
    bpy.context.view_layer.objects.active = ob


def evaluated_positions(ob):
    dg = bpy.context.evaluated_depsgraph_get()
    ev = ob.evaluated_get(dg).data
    out = np.empty((len(ev.vertices), 3), np.float32)
    ev.attributes["position"].data.foreach_get("vector", out.ravel())
    return out


def offsets(ob):
    """The offsets the face shows now: ``wrinkle_offset`` of its evaluated mesh.

    In the viewport the pipeline may write them into the evaluated mesh only
    (in place), so the original mesh can hold an older frame's offsets."""
    ev = ob.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    out = np.empty((len(ob.data.vertices), 3), np.float32)
    att = ev.attributes["wrinkle_offset"]
    if len(ev.vertices) == len(out):
        att.data.foreach_get("vector", out.ravel())
    else:  # a Subdivision Surface after the stage: the base vertices come first
        full = np.empty((len(ev.vertices), 3), np.float32)
        att.data.foreach_get("vector", full.ravel())
        out[:] = full[: len(out)]
    return out


def stored_offsets(ob):
    """The offsets held by the original mesh (what write-back last wrote)."""
    out = np.empty((len(ob.data.vertices), 3), np.float32)
    ob.data.attributes["wrinkle_offset"].data.foreach_get("vector", out.ravel())
    return out


def add_camera_and_light(scene, target=(0.0, 0.0, HEIGHT / 2)):
    cam = bpy.data.objects.new("Cam", bpy.data.cameras.new("Cam"))
    cam.data.type = "ORTHO"
    cam.data.ortho_scale = 0.16
    cam.location = (target[0], -0.5, target[2])
    cam.rotation_euler = (np.pi / 2, 0, 0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.rotation_euler = (np.radians(10), 0, 0)  # grazing from above: furrows cast shading
    sun.data.energy = 4.0
    scene.collection.objects.link(sun)


def setup_cycles(scene, size=48, samples=4):
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False
    scene.cycles.seed = 0
    scene.render.resolution_x = scene.render.resolution_y = size
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.render.image_settings.color_depth = "16"
    scene.render.threads_mode = "FIXED"
    scene.render.threads = 2


def load_png(path):
    img = bpy.data.images.load(str(path), check_existing=False)
    px = np.empty(img.size[0] * img.size[1] * 4, np.float32)
    img.pixels.foreach_get(px)
    bpy.data.images.remove(img)
    return px.reshape(-1, 4)[:, :3]


def animated_render_scene(last_frame):
    """A wrinkled face whose shape key and contraction both ramp 0 -> 1 over frames
    1..last_frame, with a camera, a raking light and small Cycles renders."""
    scene = bpy.context.scene
    face, muscle = wrinkled_face()
    animate_shape_key(face, [(1, 0.0), (last_frame, 1.0)])
    for frame, value in ((1, 0.0), (last_frame, 1.0)):
        muscle.ewrinkles_muscle.contraction = value
        muscle.keyframe_insert("ewrinkles_muscle.contraction", frame=frame)
    add_camera_and_light(scene)
    setup_cycles(scene)
    scene.frame_start, scene.frame_end = 1, last_frame
    return scene, face


def run_on_farm(script_text, blend, out):
    """Run ``script_text`` (it gets ``blend`` and ``out`` as its last two arguments) in a fresh
    interpreter with no add-on installed and no ``PYTHONPATH``: a render farm's Blender.
    Fails the test with the output when it does not succeed."""
    import os
    import subprocess
    import sys

    out = Path(out)
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(out / "farm_user"))
    env.pop("PYTHONPATH", None)
    script = out / "farm.py"
    script.write_text(script_text)
    run = subprocess.run([sys.executable, str(script), str(blend), str(out)], env=env,
                         cwd=str(out), capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
