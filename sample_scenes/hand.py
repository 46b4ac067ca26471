"""Sample scene: fine-scale wrinkles on the back of the wrist and hand (Bando, Kuratate &
Nishita 2002, §5 and §7; their Fig. 15), bending and stretching.

    python sample_scenes/hand.py [--out out/hand] [--size 512] [--samples 32]

``build()``: a procedural forearm, wrist and back of the hand (``lib/handgen.py``, 45 600
vertices, a cylindrical UV unwrap with its seam on the palm side) with two shape keys that
bend the wrist: ``Extend`` lifts the hand (the skin on the back of the wrist shrinks along the
arm by up to a third, the palm side stretches) and ``Flex`` drops it (the back of the wrist
stretches).  Keyed: Rest on frame 1, Bent (extended) on 10, Stretched (flexed) on 20
(``SHOTS``).

The furrows' directions are guides, set on rings of vertices round the arm with Set Direction
(Directions: From Guides), as the paper's artist does (§5.1, Fig. 4): the first family runs
round the arm, across the bend's compression, with magnitude m = 1 at the wrist (long, deep,
wide creases) and about 0.5 on the hand and forearm (a finer, shallower pattern); the second
crosses it at ``ANGLE``, in diamonds as on the back of a hand (Fig. 1).  ``build(field_source=
"FACE")`` takes the directions from the two bend poses instead: the same directions at the
wrist, but away from the joint the skin never shrinks and the field's magnitude stays at the
add-on's floor (0.25), so the hand and forearm get only faint furrows.

The camera looks at the back of the wrist from above and from the elbow's side, lit by a low
sun along the arm so that furrows running round it shade.  Every frame the add-on writes the
shrinkage across each field; the material's ``Fine Wrinkles`` group scales each height image by
M(s) (eq. 5, rest height ``REST_HEIGHT``): the creases across the wrist deepen where it bends
back and fade where the flexed wrist stretches the skin, while the furrows running along the
stretch change little (Fig. 15c, d).

``toggle`` is the demo's without / with switch: the fine wrinkles' bump Strength.  Run on its own,
the script renders the three shots without and with wrinkles into one sheet, ``hand.png``.
"""

import argparse
import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402
import numpy as np  # noqa: E402
from mathutils import Vector  # noqa: E402

from sample_scenes.lib import handgen, rigging, scene_setup  # noqa: E402

SHOTS = {"Rest": 1, "Bent": 10, "Stretched": 20}
POSES = {"Rest": {}, "Bent": {"Extend": 1.0}, "Stretched": {"Flex": 1.0}}

# the fine wrinkles, tuned by looking at the renders
ANGLE = math.radians(65.0)  # the second family of furrows to the first
RESOLUTION = "1024"
SEED = 3
STRENGTH = 1.0
DEPTH = 0.0011  # bump depth of a full furrow (metres)
REST_HEIGHT = 0.3  # eq. 5's r: visible at rest, ~2x at full shrinkage, fading when stretched
# guides round the arm (y in metres, magnitude m): the deep, long creases at the wrist and a
# finer, shallower diamond pattern on the back of the hand and the forearm (§5.3, Fig. 1)
GUIDES = ((-0.095, 0.45), (-0.035, 0.5), (0.0, 1.0), (0.012, 1.0), (0.045, 0.5), (0.075, 0.5))

FRAME_WIDTH = 0.12  # metres of skin across the picture
LOOK_AT = (0.0, 0.004, 0.012)  # the back of the wrist
VIEW = (0.25, -0.52, 0.82)  # from there toward the camera: above, from the elbow and thumb side


def _aim(ob, direction):
    ob.rotation_mode = "QUATERNION"
    ob.rotation_quaternion = (-Vector(direction)).to_track_quat("Z", "Y")


def _light(scene, name, kind, energy, to_light, distance, **props):
    data = bpy.data.lights.new(name, kind)
    data.energy = energy
    for key, value in props.items():
        setattr(data, key, value)
    ob = bpy.data.objects.new(name, data)
    scene.collection.objects.link(ob)
    to_light = np.asarray(to_light, np.float64) / np.linalg.norm(to_light)
    ob.location = tuple(np.asarray(LOOK_AT) + distance * to_light)
    _aim(ob, -to_light)
    return ob


def add_camera_and_lights(scene):
    """The camera on the back of the wrist, a low key sun along the arm (from the elbow and
    a little from the thumb side, so the furrows round the wrist shade), a soft fill from
    the little-finger side, a rim light and a grey world."""
    cam_data = bpy.data.cameras.new("HandCamera")
    cam_data.lens = 85.0
    cam_data.clip_start = 0.01
    half_fov = math.atan(0.5 * cam_data.sensor_width / cam_data.lens)
    dist = 0.5 * FRAME_WIDTH / math.tan(half_fov)
    view = np.asarray(VIEW, np.float64) / np.linalg.norm(VIEW)
    cam = bpy.data.objects.new("HandCamera", cam_data)
    scene.collection.objects.link(cam)
    cam.location = tuple(np.asarray(LOOK_AT) + dist * view)
    _aim(cam, -view)  # up in the picture is up in the world: the hand at the top
    scene.camera = cam
    _light(scene, "KeyLight", "SUN", 2.6, (0.35, -0.85, 0.45), 0.5, angle=math.radians(4.0))
    _light(scene, "FillLight", "AREA", 3.0, (-0.7, 0.2, 0.7), 0.4, size=0.3)
    _light(scene, "RimLight", "SUN", 1.0, (-0.3, 0.8, 0.5), 0.5, angle=math.radians(8.0))
    world = scene.world or bpy.data.worlds.new("World")
    scene.world = world
    if bpy.app.version < (5, 0, 0) and not world.use_nodes:  # always on (and deprecated) in 5.x
        world.use_nodes = True
    background = next(n for n in world.node_tree.nodes if n.type == "BACKGROUND")
    background.inputs["Color"].default_value = (0.16, 0.16, 0.17, 1.0)
    background.inputs["Strength"].default_value = 0.35
    return cam


def skin_material():
    """The sample scenes' Principled skin with a little subsurface scattering."""
    mat = scene_setup.skin_material("Hand Skin")
    bsdf = next(n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    bsdf.inputs["Base Color"].default_value = (0.50, 0.29, 0.20, 1.0)
    bsdf.inputs["Roughness"].default_value = 0.5
    bsdf.inputs["Subsurface Weight"].default_value = 0.15
    bsdf.inputs["Subsurface Radius"].default_value = (1.0, 0.35, 0.2)
    bsdf.inputs["Subsurface Scale"].default_value = 0.002
    return mat


def add_shape_keys(ob, keys):
    ob.shape_key_add(name="Basis")
    for name, positions in keys.items():
        key = ob.shape_key_add(name=name)
        key.points.foreach_set("co", np.ascontiguousarray(positions, np.float32).ravel())
        key.value = 0.0  # bpy 5.2 creates new shape keys at 1.0, 4.5 at 0.0


def _select(face, mask):
    face.data.vertices.foreach_set("select", np.ascontiguousarray(mask, bool))


def set_guides(face, arm):
    """Directions on vertices (Set Direction on selected vertices, as an artist would): rings
    of guides round the arm at ``GUIDES``, each in four quarters (the back, the thumb side,
    the palm, the little-finger side), pointing round the arm the same way in UV so that
    neighbouring guides agree; the rest is interpolated (§5.1)."""
    y, around = arm["axial"], arm["around"]
    # quarter -> the direction round the arm (+u in the UV map) at its middle
    quarters = (((np.abs(around) < 0.06), (1.0, 0.0, 0.0)),  # the back: toward the thumb
                ((np.abs(around + 0.25) < 0.06), (0.0, 0.0, -1.0)),  # the thumb side: down
                ((np.abs(around) > 0.44), (-1.0, 0.0, 0.0)),  # the palm
                ((np.abs(around - 0.25) < 0.06), (0.0, 0.0, 1.0)))  # the little-finger side: up
    rings = np.unique(y)
    rigging.activate(face)
    for level, magnitude in GUIDES:
        ring = y == rings[np.argmin(np.abs(rings - level))]  # the ring nearest the level
        for where, direction in quarters:
            _select(face, ring & where)
            bpy.ops.wrinkle.fine_direction(direction=tuple(magnitude * np.asarray(direction)))
    _select(face, np.zeros(len(y), bool))


def carve(face, arm, resolution=RESOLUTION, field_source="GUIDES"):
    """Carve the fine wrinkles with the scene's settings: directions from guides round the
    arm (``GUIDES``), or from the bend poses (``field_source="FACE"``)."""
    fs = face.ewrinkles_face.fine_wrinkles
    if field_source == "GUIDES":
        set_guides(face, arm)
    fs.field_source = field_source
    fs.angle = ANGLE
    fs.resolution = resolution
    fs.seed = SEED
    fs.distance = DEPTH
    fs.rest_height = REST_HEIGHT
    fs.strength = STRENGTH
    rigging.activate(face)
    if bpy.ops.wrinkle.carve_fine() != {"FINISHED"}:
        raise RuntimeError("hand: Carve Fine Wrinkles failed")


def build(resolution=RESOLUTION, rings=190, around=240, field_source="GUIDES"):
    """The scene; ``resolution`` of the height images, ``rings`` x ``around`` vertices
    (smaller for quick tests).  Returns ``(face, SHOTS)``."""
    scene = bpy.context.scene
    arm = handgen.make_arm(rings=rings, around=around)
    face = scene_setup.mesh_object_from_arrays("Hand", arm["positions"], arm["quads"], arm["corner_uvs"])
    add_shape_keys(face, arm["shape_keys"])
    face.data.materials.append(skin_material())
    add_camera_and_lights(scene)
    carve(face, arm, resolution, field_source)
    rigging.key_shape_keys(face, {SHOTS[name]: POSES[name] for name in SHOTS})
    scene.frame_start, scene.frame_end = 1, max(SHOTS.values())
    scene.frame_set(1)
    return face, dict(SHOTS)


def toggle(face, on):
    """The demo's without / with switch: the fine wrinkles' bump Strength."""
    face.ewrinkles_face.fine_wrinkles.strength = STRENGTH if on else 0.0


def main(argv=None):
    from sample_scenes.lib import rendering

    rendering.enable_addon()

    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=str(ROOT / "out" / "hand"), help="output folder")
    parser.add_argument("--size", type=int, default=512, help="render size in pixels")
    parser.add_argument("--samples", type=int, default=32, help="Cycles samples")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    row, captions = rendering.render_scene("hand", build, out, args.size, args.samples, toggle)
    sheet = out / "hand.png"
    rendering.contact_sheet([row], sheet, row_names=["hand"], captions=[captions])
    rendering.log(f"contact sheet -> {sheet}")
    bpy.ops.wm.read_factory_settings(use_empty=True)  # avoids the bpy 4.5 exit hang


if __name__ == "__main__":
    main(sys.argv[1:] if "--" not in sys.argv else sys.argv[sys.argv.index("--") + 1:])
