"""Shedding tears in Blender: a tear built along a path on the skin (a curve drawn on it, or
selected faces), bound to the skin so it follows the face, revealed by the scene time with
no Python per frame, and never inside the skin."""

import textwrap
from pathlib import Path

import bpy
import numpy as np
import pytest
from mathutils.bvhtree import BVHTree

from tests.blender import scenes
from wrinkle_addon.glue.patterns import shedding, tears

R = 0.1  # the sphere "face"
DATA = Path(__file__).resolve().parents[2] / "wrinkle_addon" / "data" / "ict_head.npz"


def _sphere_face():
    """A head-sized sphere facing every way, with a 'Puff' shape key that swells it unevenly
    (forward and narrower): the skin a tear must follow."""
    bpy.ops.mesh.primitive_uv_sphere_add(radius=R, segments=48, ring_count=24)
    face = bpy.context.active_object
    face.name = "Face"
    face.shape_key_add(name="Basis")
    key = face.shape_key_add(name="Puff")
    key.value = 0.0  # bpy 5.2 creates new shape keys at 1.0
    co = np.empty(len(face.data.vertices) * 3, np.float32)
    key.data.foreach_get("co", co)
    co = co.reshape(-1, 3)
    co[:, 1] *= 1.15
    co[:, 0] *= 0.9
    key.data.foreach_set("co", co.ravel())
    return face, key


def _curve(points, name="Tear Path"):
    cu = bpy.data.curves.new(name, "CURVE")
    cu.dimensions = "3D"
    sp = cu.splines.new("POLY")
    sp.points.add(len(points) - 1)
    sp.points.foreach_set("co", np.array([(*p, 1.0) for p in points], np.float32).ravel())
    ob = bpy.data.objects.new(name, cu)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def _meridian(n=20, lo=0.4, hi=1.2, radius=R):
    th = np.linspace(lo, hi, n)
    return np.stack([np.full(n, 0.01), -radius * np.sin(th), radius * np.cos(th)], 1)


def _add(face, curve, **kw):
    for o in bpy.context.selected_objects:
        o.select_set(False)
    curve.select_set(True)
    face.select_set(True)
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.add_shedding_tear(path="CURVE", **kw) == {"FINISHED"}
    return next(o for o in bpy.data.objects if o.name.endswith(" Tear"))


def _evaluated(ob):
    dg = bpy.context.evaluated_depsgraph_get()
    me = ob.evaluated_get(dg).data
    co = np.empty(len(me.vertices) * 3, np.float32)
    me.vertices.foreach_get("co", co)
    arc = np.empty(len(me.vertices), np.float32)
    if len(me.vertices):
        me.attributes[shedding.ARC_ATTR].data.foreach_get("value", arc)
    loops = np.empty(len(me.loops), np.int32)
    me.loops.foreach_get("vertex_index", loops)
    return co.reshape(-1, 3), arc, loops.reshape(-1, 4), len(me.polygons)


def signed_distances(face, ob):
    """The signed distance to the face's evaluated skin (positive outside) of every vertex,
    edge midpoint and face centre of the evaluated tear."""
    dg = bpy.context.evaluated_depsgraph_get()
    fe = face.evaluated_get(dg).data
    pos = np.empty(len(fe.vertices) * 3, np.float32)
    fe.vertices.foreach_get("co", pos)
    bvh = BVHTree.FromPolygons(pos.reshape(-1, 3).tolist(), [p.vertices[:] for p in fe.polygons])
    co, _arc, quads, _n = _evaluated(ob)
    edges = np.stack([quads, np.roll(quads, -1, axis=1)], 2).reshape(-1, 2)
    pts = np.concatenate([co, co[edges].mean(axis=1), co[quads].mean(axis=1)])
    out = np.empty(len(pts))
    for i, p in enumerate(pts):
        loc, normal, _index, _d = bvh.find_nearest(p)
        out[i] = (p - np.array(loc)) @ np.array(normal)
    return out


def test_the_tear_runs_down_its_path_follows_the_skin_and_never_enters_it():
    face, key = _sphere_face()
    curve = _curve(_meridian())
    ob = _add(face, curve, duration=2.0, width=0.015)
    assert ob.parent == face
    (reveal,) = ob.modifiers
    assert reveal.node_group.name == shedding.GROUP_NAME
    assert tears.get_input(reveal, "Skin") == face
    assert ob.data.materials[0].name == tears.FILM_NAME
    length = ob["ewrinkles_tear_length"]
    assert length == pytest.approx(0.08, rel=0.02)  # the meridian from 0.4 to 1.2 rad
    speed = tears.get_input(reveal, "Speed")
    assert speed == pytest.approx(length / 2.0, rel=1e-4)
    scene = bpy.context.scene
    fps = scene.render.fps / scene.render.fps_base
    row = 2.0 * 0.5 * 0.015 * 0.2 / shedding.ROWS_PER_WIDTH  # rows along the path, face units
    shown, faces_shown = [], []
    for frame in (1, 6, 12, 24, 36, 48, 60):
        scene.frame_set(frame)
        co, arc, _q, n_faces = _evaluated(ob)
        h = speed * (frame - 1) / fps  # started on frame 1
        front = float(arc.max()) if len(arc) else 0.0
        assert front <= min(h, length) + row + 1e-6  # nothing ahead of the head
        assert front >= min(h, length) - 1e-6
        shown.append(front)
        faces_shown.append(n_faces)
        if n_faces:
            d = signed_distances(face, ob)
            assert d.min() > 0.0, f"frame {frame}: {d.min()}"
    assert faces_shown[0] == 0  # on its first frame it has not run yet
    assert shown == sorted(shown) and faces_shown == sorted(faces_shown)  # it only runs on
    assert faces_shown[-1] == len(ob.data.polygons)  # all of it at the end
    # the head is a bead: it swells over the trail behind it, then comes down steeply to a
    # round front (core.patterns.tears.bead_profile)
    scene.frame_set(24)
    co, arc, _q, _n = _evaluated(ob)
    rest = np.linalg.norm(co, axis=1) - R  # height over the sphere
    front = arc.max()
    head = tears.get_input(reveal, "Head")
    behind = (arc > front - 3 * head) & (arc < front - 2 * head)
    bead = (arc > front - 0.7 * head) & (arc < front - 0.3 * head)
    assert rest[bead].max() > 1.5 * rest[behind].max()
    assert rest[arc > front - 0.05 * head].max() < 0.8 * rest[bead].max()
    # it follows the face: swollen, the tear moves out with the skin and stays on it
    scene.frame_set(60)
    before, _a, _q, _n = _evaluated(ob)
    for value in (0.5, 1.0):
        key.value = value
        bpy.context.view_layer.update()
        d = signed_distances(face, ob)
        assert 0.0 < d.min() and d.max() < 0.015 * 0.2 * 2 * 0.5 * 2.0 + 0.005  # on the skin, not floating
    after, _a, _q, _n = _evaluated(ob)
    assert np.linalg.norm(after - before, axis=1).mean() > 0.005


def test_the_film_is_clear_glossy_water_that_lets_the_light_through():
    """The shedding tear's material is a thin film: transparent (so shadow rays pass and the
    skin under it stays lit) plus a sharp gloss weighted by water's Fresnel factor (the skin
    is not dimmed by ``1 - F``, which drew a dark outline), its inner surfaces clear; in EEVEE
    its shadows are transparent and it is blended."""
    face, _key = _sphere_face()
    ob = _add(face, _curve(_meridian()), duration=1.0)
    mat = ob.data.materials[0]
    nodes = mat.node_tree.nodes
    out = next(n for n in nodes if n.type == "OUTPUT_MATERIAL" and n.is_active_output)
    mix = out.inputs["Surface"].links[0].from_node
    assert mix.type == "MIX_SHADER"
    assert mix.inputs[1].links[0].from_node.type == "BSDF_TRANSPARENT"  # from inside: clear
    wet = mix.inputs[2].links[0].from_node  # from outside: clear + gloss, mixed in by F
    assert wet.type == "ADD_SHADER"
    assert {wet.inputs[0].links[0].from_node.type, wet.inputs[1].links[0].from_node.type} == {
        "BSDF_TRANSPARENT", "BSDF_GLOSSY"}
    assert not any(n.type in ("BSDF_PRINCIPLED", "BSDF_GLASS", "BSDF_REFRACTION") for n in nodes)
    fresnel = next(n for n in nodes if n.type == "FRESNEL")
    assert fresnel.inputs["IOR"].default_value == pytest.approx(1.33)
    gloss = next(n for n in nodes if n.type == "BSDF_GLOSSY")
    assert gloss.inputs["Roughness"].default_value <= 0.2
    assert gloss.inputs["Normal"].is_linked  # the ripples
    backfacing = next(n for n in nodes if n.type == "NEW_GEOMETRY")
    assert backfacing.outputs["Backfacing"].is_linked  # seen from inside: clear
    assert mat.use_transparent_shadow and mat.surface_render_method == "BLENDED"
    assert shedding.SURFACE_ATTR in ob.data.attributes


def _lit_scene(face):
    """The sphere face in skin, a sun from high on the right as the sample scenes' key, a grey
    world, and an orthographic camera on the tear's path."""
    from sample_scenes.lib import scene_setup

    face.data.materials.append(scene_setup.skin_material())
    scene = bpy.context.scene
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    sun.data.energy, sun.data.angle = 3.5, np.radians(12.0)
    sun.rotation_euler = (np.radians(40.0), 0.0, np.radians(-35.0))
    scene.collection.objects.link(sun)
    scene.world = bpy.data.worlds.new("World")
    scene_setup._enable_nodes(scene.world)
    bg = next(n for n in scene.world.node_tree.nodes if n.type == "BACKGROUND")
    bg.inputs["Color"].default_value, bg.inputs["Strength"].default_value = (0.18, 0.18, 0.18, 1.0), 0.3
    cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
    cam.data.type, cam.data.ortho_scale = "ORTHO", 0.06
    cam.location, cam.rotation_euler = (0.01, -0.5, 0.06), (np.pi / 2, 0.0, 0.0)
    scene.collection.objects.link(cam)
    scene.camera = cam
    return scene


@pytest.mark.render
@pytest.mark.parametrize("material", ["film", "refracting shell"])
def test_the_skin_under_the_tear_stays_lit_in_a_render(material, render_small, tmp_path):
    """A small Cycles render: the tear's pixels are at least 0.9 as bright as the same pixels
    with the tear hidden (``benchmarks/tear_look.py``'s luminance ratio).  A refracting
    (transmission) shell, as the tear's material was, blocks the light's shadow rays and
    leaves the skin under it dark: the measure tells the two apart."""
    from benchmarks import tear_look

    face, _key = _sphere_face()
    ob = _add(face, _curve(_meridian()), duration=0.5)
    if material != "film":
        ob.data.materials[0] = tears.water_material()
    scene = _lit_scene(face)
    scene.frame_set(30)  # all of it shows
    shown = render_small(scene, tmp_path / "with.exr", size=96, samples=16)[::-1]
    ob.hide_render = True
    hidden = render_small(scene, tmp_path / "without.exr", size=96, samples=16)[::-1]
    ob.hide_render = False
    cover, face_cover = tear_look.coverage(scene, face, ob, tmp_path / "mask.exr")
    got = tear_look.figures(shown, hidden, cover, face_cover)
    assert got["tear_pixels"] > 50
    if material == "film":
        assert got["tear_luminance_ratio"] >= 0.9, got
    else:
        assert got["tear_luminance_ratio"] < 0.8, got


FARM_SCRIPT = textwrap.dedent("""
    import sys
    import bpy
    import numpy as np
    blend, out = sys.argv[-2], sys.argv[-1]
    bpy.ops.wm.open_mainfile(filepath=blend)
    assert "wrinkle_addon" not in sys.modules, "the add-on must not be loaded on the farm"
    ob = next(o for o in bpy.data.objects if o.name.endswith(" Tear"))
    for frame in (20, 40):
        bpy.context.scene.frame_set(frame)
        me = ob.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
        co = np.empty(len(me.vertices) * 3, np.float32)
        me.vertices.foreach_get("co", co)
        np.save(out + f"/farm_{frame}.npy", co.reshape(-1, 3))
    bpy.ops.wm.read_factory_settings(use_empty=True)
""")


def test_a_saved_tear_runs_and_follows_the_face_with_no_add_on(tmp_path):
    """Saved and opened where the add-on is not installed (a render farm), the tear still
    runs and follows the animated face, frame for frame as here."""
    face, key = _sphere_face()
    ob = _add(face, _curve(_meridian()), duration=1.5)
    key.value = 0.0
    key.keyframe_insert("value", frame=1)
    key.value = 1.0
    key.keyframe_insert("value", frame=40)
    here = {}
    for frame in (20, 40):
        bpy.context.scene.frame_set(frame)
        here[frame] = _evaluated(ob)[0]
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "shot.blend"))
    scenes.run_on_farm(FARM_SCRIPT, tmp_path / "shot.blend", tmp_path)
    for frame in (20, 40):
        farm = np.load(tmp_path / f"farm_{frame}.npy")
        assert farm.shape == here[frame].shape
        np.testing.assert_allclose(farm, here[frame], atol=1e-6)
    assert len(here[20]) < len(here[40])  # half way on frame 20, all of it on 40


def test_selected_faces_give_the_path_from_their_higher_end():
    face = scenes.make_face(shape_key=False)  # the XZ plane facing -Y
    me = face.data
    centres = np.empty(len(me.polygons) * 3, np.float32)
    me.polygons.foreach_get("center", centres)
    centres = centres.reshape(-1, 3)
    band = (np.abs(centres[:, 0] - 0.01) < 0.003) & (centres[:, 2] > 0.015) & (centres[:, 2] < 0.065)
    me.polygons.foreach_set("select", band)
    bpy.context.view_layer.objects.active = face
    assert bpy.ops.wrinkle.add_shedding_tear(path="FACES", duration=1.0) == {"FINISHED"}
    ob = next(o for o in bpy.data.objects if o.name.endswith(" Tear"))
    co = np.empty(len(ob.data.vertices) * 3, np.float32)
    ob.data.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    arc = np.empty(len(co), np.float32)
    ob.data.attributes[shedding.ARC_ATTR].data.foreach_get("value", arc)
    assert co[arc.argmin(), 2] > co[arc.argmax(), 2] + 0.03  # runs down
    assert np.ptp(co[:, 0]) == pytest.approx(0.006, rel=0.25)  # as wide as the band
    assert (co[:, 1] < 0).all()  # on the skin's side (-Y), not behind it


def test_a_face_whose_mesh_changed_leaves_the_tear_where_it_was_made():
    face, _key = _sphere_face()
    ob = _add(face, _curve(_meridian()), duration=0.5)
    bpy.context.scene.frame_set(30)
    made = _evaluated(ob)[0]
    face.modifiers.new("Subdivision", "SUBSURF")  # the face's vertices are not the ones bound
    bpy.context.view_layer.update()
    co = _evaluated(ob)[0]
    assert np.isfinite(co).all()
    np.testing.assert_allclose(co, made, atol=1e-6)


@pytest.mark.parametrize("case, message", [
    ("one point", "at least two"),
    ("off the skin", "off the skin"),
    ("two curves", "Select one curve"),
    ("no faces", "No face"),
])
def test_bad_paths_get_a_message_and_no_tear(case, message):
    face, _key = _sphere_face()
    if case == "one point":
        _curve(_meridian(n=1)).select_set(True)
    elif case == "off the skin":
        _curve(_meridian(radius=1.5 * R)).select_set(True)
    elif case == "two curves":
        _curve(_meridian()).select_set(True)
        _curve(_meridian(lo=1.3, hi=1.8)).select_set(True)
    face.select_set(True)
    bpy.context.view_layer.objects.active = face
    path = "FACES" if case == "no faces" else "CURVE"
    if case == "no faces":
        face.data.polygons.foreach_set("select", np.zeros(len(face.data.polygons), bool))
    with pytest.raises(RuntimeError, match=message):
        bpy.ops.wrinkle.add_shedding_tear(path=path)
    assert not any(o.name.endswith(" Tear") for o in bpy.data.objects)


def test_on_the_scanned_head_the_tear_stays_out_of_the_smiling_cheek():
    """The sample's tear under the left eye of the ICT head, while the cheek rises in a smile
    and a squint (shape keys): never inside the skin."""
    from sample_scenes import patterns
    from sample_scenes.lib import ict

    data = ict.load_ict(DATA)
    face = ict.ict_object(data, name="ICTHead")
    patterns.add_shedding_tear(face, data["landmarks"], 1, 1.0)
    ob = next(o for o in bpy.data.objects if o.name.endswith(" Tear"))
    bpy.context.scene.frame_set(30)  # all of it shows
    assert len(_evaluated(ob)[0]) == len(ob.data.vertices)
    keys = face.data.shape_keys.key_blocks
    for name in ("mouthSmile_L", "eyeSquint_L", "cheekSquint_L", "cheekPuff_L"):
        assert name in keys
    for k in keys[1:]:
        k.value = 0.0
    bpy.context.view_layer.update()
    rest = _evaluated(ob)[0]
    for values in ({"mouthSmile_L": 1.0}, {"mouthSmile_L": 1.0, "eyeSquint_L": 1.0, "cheekSquint_L": 1.0},
                   {"cheekPuff_L": 1.0, "jawOpen": 1.0}):
        for k in keys[1:]:
            k.value = values.get(k.name, 0.0)
        bpy.context.view_layer.update()
        d = signed_distances(face, ob)
        assert d.min() > 0.0, f"{values}: {d.min()}"
        moved = np.linalg.norm(_evaluated(ob)[0] - rest, axis=1).max()
        assert moved > 0.001, f"{values}: the cheek under the tear moved only {moved} m"
