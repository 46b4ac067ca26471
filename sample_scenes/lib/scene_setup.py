"""Thin bpy helpers that turn the sample arrays into a renderable scene.

Works on bpy 4.5 and 5.x. Meshes are built with bulk ``foreach_set`` on
contiguous float32/int32 buffers; nothing loops over vertices in Python.
"""

import math

import bpy
import numpy as np
from mathutils import Vector

__all__ = [
    "mesh_object_from_arrays",
    "setup_cycles",
    "add_portrait_rig",
    "skin_material",
]


def mesh_object_from_arrays(name, positions, quads, corner_uvs=None, collection=None):
    """Build a smooth-shaded all-quad mesh object from NumPy arrays.

    ``positions`` (N, 3), ``quads`` (F, 4) vertex indices, ``corner_uvs``
    (F, 4, 2) or None. The UV map is named "UVMap". The object is linked to
    ``collection`` (default: the active scene's master collection).
    """
    pos = np.ascontiguousarray(positions, dtype=np.float32).reshape(-1, 3)
    quads = np.ascontiguousarray(quads, dtype=np.int32).reshape(-1, 4)
    n_faces = len(quads)

    mesh = bpy.data.meshes.new(name)
    mesh.vertices.add(len(pos))
    mesh.attributes["position"].data.foreach_set("vector", pos.ravel())
    mesh.loops.add(4 * n_faces)
    mesh.loops.foreach_set("vertex_index", quads.ravel())
    mesh.polygons.add(n_faces)
    mesh.polygons.foreach_set("loop_start", np.arange(0, 4 * n_faces, 4, dtype=np.int32))
    mesh.polygons.foreach_set("loop_total", np.full(n_faces, 4, dtype=np.int32))
    mesh.update(calc_edges=True)

    if corner_uvs is not None:
        uvs = np.ascontiguousarray(corner_uvs, dtype=np.float32).reshape(-1)
        uv_layer = mesh.uv_layers.new(name="UVMap")
        uv_layer.uv.foreach_set("vector", uvs)
    mesh.shade_smooth()

    obj = bpy.data.objects.new(name, mesh)
    if collection is None:
        collection = bpy.context.scene.collection
    collection.objects.link(obj)
    return obj


def _has_oidn():
    try:
        import _cycles
    except ImportError:
        return False
    return bool(getattr(_cycles, "with_openimagedenoise", False))


def setup_cycles(scene, resolution=(512, 512), samples=32, denoise=None):
    """Cycles on the CPU at a fixed seed.

    ``denoise=None`` turns OpenImageDenoise on when the build has it.
    """
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = int(samples)
    scene.cycles.seed = 0
    if denoise is None:
        denoise = _has_oidn()
    scene.cycles.use_denoising = bool(denoise)
    if denoise:
        scene.cycles.denoiser = "OPENIMAGEDENOISE"
    scene.render.resolution_x = int(resolution[0])
    scene.render.resolution_y = int(resolution[1])
    scene.render.resolution_percentage = 100
    scene.render.film_transparent = False
    return scene


def _enable_nodes(id_block):
    # Nodes are always on in 5.x, where use_nodes is deprecated (reading it warns too).
    if bpy.app.version < (5, 0, 0) and not id_block.use_nodes:
        id_block.use_nodes = True


def skin_material(name="Skin"):
    """A Principled BSDF skin: skin colour, moderate roughness, no subsurface."""
    mat = bpy.data.materials.get(name) or bpy.data.materials.new(name)
    _enable_nodes(mat)
    bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    bsdf.inputs["Base Color"].default_value = (0.50, 0.30, 0.22, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.48
    bsdf.inputs["Subsurface Weight"].default_value = 0.0
    bsdf.inputs["Specular IOR Level"].default_value = 0.4
    mat.diffuse_color = (0.50, 0.30, 0.22, 1.0)
    return mat


def _world_points(obj):
    mesh = obj.data
    pos = np.empty(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.attributes["position"].data.foreach_get("vector", pos)
    pos = pos.reshape(-1, 3).astype(np.float64)
    mat = np.array(obj.matrix_world, dtype=np.float64)
    return pos @ mat[:3, :3].T + mat[:3, 3]


def _aim(obj, direction):
    """Point the object's local -Z along ``direction`` with +Y up."""
    obj.rotation_mode = "QUATERNION"
    obj.rotation_quaternion = (-Vector(direction)).to_track_quat("Z", "Y")


def _from_angles(azimuth, elevation):
    """Unit vector toward a light: azimuth 0 is in front of the face (-Y),
    positive toward the character's left (+X); elevation above the horizon."""
    a, e = math.radians(azimuth), math.radians(elevation)
    return np.array([math.sin(a) * math.cos(e), -math.cos(a) * math.cos(e), math.sin(e)])


def _light(scene, collection, name, kind, energy, direction, location, **props):
    data = bpy.data.lights.new(name, kind)
    data.energy = energy
    for key, value in props.items():
        setattr(data, key, value)
    obj = bpy.data.objects.new(name, data)
    collection.objects.link(obj)
    obj.location = location
    _aim(obj, direction)
    return obj


def add_portrait_rig(scene, target_object, view="front", frame_height=None, material=True,
                     collection=None, frame_scale=1.9):
    """Camera, lights and world for a head facing -Y, Z up.

    The frame is centred a little below the eyes: the nose tip is taken as the
    most forward vertex near the midline, the crown as the highest vertex. The
    frame is ``frame_height`` metres tall, by default ``frame_scale`` times the
    crown-to-nose height (1.9: the whole head; 1.3: forehead to mouth).
    ``view`` is ``'front'`` or ``'three_quarter'`` (35 degrees toward the
    character's left, +X). The key light is a sun from high above and to the
    character's right, grazing the forehead so horizontal furrows and the
    vertical furrows between the brows shade; a large soft fill, a weak rim
    and a neutral grey world complete it. With ``material`` an object with no
    material yet gets the "Skin" material. Returns a dict of the created datablocks.
    """
    if view not in {"front", "three_quarter"}:
        raise ValueError(f"view must be 'front' or 'three_quarter', not {view!r}")
    if collection is None:
        collection = scene.collection

    pts = _world_points(target_object)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    centre = 0.5 * (lo + hi)
    width = hi[0] - lo[0]
    midline = np.abs(pts[:, 0] - centre[0]) < 0.1 * width
    upper = pts[:, 2] > lo[2] + 0.25 * (hi[2] - lo[2])
    cand = pts[midline & upper] if np.any(midline & upper) else pts
    nose = cand[np.argmin(cand[:, 1])]
    span = max(hi[2] - nose[2], 1e-3)  # crown to nose tip, ~0.15 m on an adult
    if frame_height is None:  # frame_scale 1.9: the whole head; 1.3: forehead to mouth
        frame_height = frame_scale * span
    look_at = np.array([centre[0], nose[1], hi[2] - 0.80 * span])

    cam_data = bpy.data.cameras.new("PortraitCamera")
    cam_data.lens = 85.0
    cam_data.sensor_fit = "AUTO"
    cam_data.clip_start = 0.01
    cam_data.clip_end = 100.0
    half_fov = math.atan(0.5 * cam_data.sensor_width / cam_data.lens)
    res = (scene.render.resolution_x, scene.render.resolution_y)
    aspect = min(res) / max(res)
    dist = 0.5 * frame_height / (math.tan(half_fov) * aspect)

    yaw = math.radians(35.0) if view == "three_quarter" else 0.0
    # Orbit about the middle of the head at face height, so both views centre it.
    level = np.abs(pts[:, 2] - look_at[2]) < 0.1 * span
    back = pts[level, 1].max() if np.any(level) else centre[1]
    pivot = np.array([centre[0], 0.5 * (nose[1] + back), look_at[2]])
    offset = dist * np.array([math.sin(yaw), -math.cos(yaw), 0.0])
    cam = bpy.data.objects.new("PortraitCamera", cam_data)
    collection.objects.link(cam)
    cam.location = pivot + offset
    _aim(cam, -offset)
    scene.camera = cam

    head = max(width, hi[1] - lo[1], span)
    # Key: a sun high above and to the character's right, grazing the forehead.
    key_to_light = _from_angles(azimuth=-35.0, elevation=52.0)
    key = _light(scene, collection, "KeyLight", "SUN", 3.5, -key_to_light,
                 tuple(look_at + 3 * head * key_to_light), angle=math.radians(12.0))
    # Fill: a large soft area light low on the other side, about 1/4 of the key.
    fill_to_light = _from_angles(azimuth=50.0, elevation=10.0)
    fill_dist = 4.0 * head
    fill = _light(scene, collection, "FillLight", "AREA", math.pi * fill_dist ** 2 * 1.1,
                  -fill_to_light, tuple(look_at + fill_dist * fill_to_light), size=2.5 * head)
    # Rim from behind to separate the silhouette from the background.
    rim_to_light = _from_angles(azimuth=150.0, elevation=30.0)
    rim = _light(scene, collection, "RimLight", "SUN", 1.2, -rim_to_light,
                 tuple(look_at + 3 * head * rim_to_light), angle=math.radians(8.0))

    world = scene.world or bpy.data.worlds.new("World")
    scene.world = world
    _enable_nodes(world)
    background = next(n for n in world.node_tree.nodes if n.type == "BACKGROUND")
    background.inputs["Color"].default_value = (0.18, 0.18, 0.18, 1.0)
    background.inputs["Strength"].default_value = 0.3

    mat = None
    if material and not any(target_object.data.materials):
        mat = skin_material()
        mats = target_object.data.materials
        if len(mats) == 0:
            mats.append(mat)
        else:
            for i in range(len(mats)):
                mats[i] = mat
    return {"camera": cam, "key": key, "fill": fill, "rim": rim, "world": world, "material": mat}
