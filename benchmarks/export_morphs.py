# SPDX-License-Identifier: GPL-3.0-or-later
"""How many wrinkle morph targets does a real shot need, and how close are they?

Run:  .venv45/bin/python benchmarks/export_morphs.py   [--npz PATH] [--out DIR]

Builds the ICT head (or ``--npz``, any head with its layout) with the facial muscle set
placed from its landmarks and refined (``sample_scenes/lib/rigging.wrinkle_face``), and
keys its ARKit shape keys through Surprise (frame 1: the brows raised) -> Anger (frame 25:
browDown + noseSneer + eyeSquint 0.5) -> Smile (frame 49: mouthSmile), linear in between.
The muscles' wrinkles come from the compression the shape keys cause.

Then it exports the range with the add-on's glTF export (``glue.export.gltf``: Blender's glTF
exporter, K by the default tolerance of 0.05 mm capped at 16), imports the file back with
Blender's glTF importer, and compares the imported face with the live wrinkled face at
frames 1, 25 and 49 (the distance of every vertex, in mm).

Prints one JSON line: ``targets`` (K), ``max_error_mm`` and ``mean_error_mm`` (over the
frames and the vertices the wrinkles move), ``round_trip_max_mm`` per compared frame,
``wrinkle_max_mm`` (the largest wrinkle offset of the range, for scale), ``moved_vertices``,
``engine_normal_deg`` (the angle between the live face's vertex normals and the normals an
engine shades with, NORMAL plus the weighted morph-target normals read from the file: max,
99th percentile and the number of vertices more than 5 degrees off), ``normal_error_deg_range``
(the same over the whole range, [max, 99th percentile], with the exporter's own target normals
and with the refit ones),
``k_for_tolerance`` (K for 0.01, 0.02, 0.05, 0.1 and 0.2 mm, uncapped up to 48),
``error_by_k`` (the largest error with 1 to 16 targets), the file's size and the seconds
taken by sampling the range and by the export.  Progress goes to stderr.
"""

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402, I001
import addon_utils  # noqa: E402
import numpy as np  # noqa: E402

SURPRISE = {"browInnerUp_L": 1.0, "browInnerUp_R": 1.0, "browOuterUp_L": 1.0, "browOuterUp_R": 1.0}
ANGER = {"browDown_L": 1.0, "browDown_R": 1.0, "noseSneer_L": 1.0, "noseSneer_R": 1.0,
         "eyeSquint_L": 0.5, "eyeSquint_R": 0.5}
SMILE = {"mouthSmile_L": 1.0, "mouthSmile_R": 1.0}
KEYS = {1: SURPRISE, 25: ANGER, 49: SMILE}
COMPARED = (1, 25, 49)


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def _positions(ob):
    dg = bpy.context.evaluated_depsgraph_get()
    me = ob.evaluated_get(dg).data
    out = np.empty((len(me.vertices), 3), np.float32)
    me.attributes["position"].data.foreach_get("vector", out.ravel())
    return out


def engine_normals(path, mesh_name, frame_index):
    """What an engine shades with on a frame: per glTF vertex, POSITION and the normal
    NORMAL + sum_t w_t dNORMAL_t with the animation's weights on ``frame_index``, normalised
    (read with the add-on's own .glb reader, ``glue/export/glb.py``)."""
    from wrinkle_addon.glue.export import glb

    doc = glb.Glb(path)
    prim, _names = doc.mesh(mesh_name)
    weights = doc.weights(len(prim["targets"]))[frame_index]
    normal = doc.accessor(prim["attributes"]["NORMAL"]).astype(np.float64)
    for w, target in zip(weights, prim["targets"]):
        normal += w * doc.accessor(target["NORMAL"])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    return doc.accessor(prim["attributes"]["POSITION"]), normal


def _engine_mesh(path, imported, mesh_name, frame):
    """A still mesh of the imported glTF on ``frame`` shaded as an engine shades it: the
    morphed positions (Blender's importer's shape keys) and, as custom normals, NORMAL plus
    the weighted morph-target normals of the file (which Blender's importer does not use)."""
    scene = bpy.context.scene
    scene.frame_set(frame)
    dg = bpy.context.evaluated_depsgraph_get()
    me = bpy.data.meshes.new_from_object(imported.evaluated_get(dg))
    pos, normal = engine_normals(path, mesh_name, frame - 1)
    to_blender = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])
    pos, normal = pos @ to_blender.T, normal @ to_blender.T
    rest = np.empty((len(imported.data.vertices), 3), np.float32)
    imported.data.vertices.foreach_get("co", rest.ravel())
    if rest.shape != pos.shape or np.abs(rest - pos).max() > 1e-6:  # the importer keeps the file's order
        raise RuntimeError("the imported mesh's vertices are not the file's, in its order")
    me.normals_split_custom_set_from_vertices(normal.tolist())
    ob = bpy.data.objects.new("Engine view", me)
    scene.collection.objects.link(ob)
    ob.matrix_world = imported.matrix_world
    return ob


def _render_pair(face, imported, path, folder):
    """The live face and the glTF as an engine shades it (``_engine_mesh``) at frame 25
    (Anger), the same skin material and portrait lights on both, side by side:
    out/glb_round_trip.png."""
    from sample_scenes.lib import rendering, scene_setup

    scene = bpy.context.scene
    scene_setup.setup_cycles(scene, (512, 512), samples=16, denoise=False)
    scene_setup.add_portrait_rig(scene, face, view="three_quarter", frame_scale=1.0)
    engine = _engine_mesh(path, imported, face.data.name, 25)
    engine.data.materials.clear()
    for mat in face.data.materials:
        engine.data.materials.append(mat)
    imported.hide_render = True
    scene.frame_set(25)
    paths = []
    for name, shown in (("live", face), ("engine", engine)):
        for ob in (face, engine):
            ob.hide_render = ob is not shown
        log(f"rendering the {name} face")
        paths.append(os.path.join(folder, f"anger_{name}.png"))
        scene.render.filepath = paths[-1]
        bpy.ops.render.render(write_still=True)
    rendering.contact_sheet([paths], os.path.join(folder, "glb_round_trip.png"), row_names=["anger"],
                            captions=[[("live", "add-on"), ("glTF", "engine normals")]])


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--npz", default=str(ROOT / "wrinkle_addon" / "data" / "ict_head.npz"))
    parser.add_argument("--out", help="keep the .glb in this folder")
    parser.add_argument("--render", action="store_true",
                        help="also render the live face and the glTF as an engine shades it at Anger "
                        "(frame 25), side by side, with the same material and lights, into --out "
                        "(glb_round_trip.png)")
    ns = parser.parse_args(argv)
    addon_utils.enable("wrinkle_addon", default_set=True)
    from sample_scenes.lib import ict, rigging
    from wrinkle_addon.core import morphs
    from wrinkle_addon.glue.export import gltf, sample

    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    scene = bpy.context.scene
    data = ict.load_ict(Path(ns.npz))
    face = ict.ict_object(data, name="ICTHead")
    log("placing and refining the muscles ...")
    rigging.wrinkle_face(face, data["landmarks"])
    rigging.key_shape_keys(face, KEYS)
    scene.frame_start, scene.frame_end = 1, 49
    t = time.perf_counter()
    frames = sample.read(bpy.context, face, 1, 49)
    sample_s = time.perf_counter() - t
    mm = 1000.0 * sample.metres_per_unit(face, scene)
    d = frames.offsets
    moved = int(np.any(d != 0, axis=(0, 2)).sum())
    k_for = {str(tol): morphs.fit(d, tol / mm, max_targets=48).count for tol in (0.01, 0.02, 0.05, 0.1, 0.2)}
    error_by_k = [round(morphs.fit(d, 0.0, count=k).max_error * mm, 5) for k in range(1, 17)]
    live = {}
    for f in COMPARED:
        scene.frame_set(f)
        live[f] = _positions(face)
    rest = np.empty((len(face.data.vertices), 3), np.float32)
    face.data.vertices.foreach_get("co", rest.ravel())
    folder = ns.out or tempfile.mkdtemp(prefix="ewrinkles-bench-")
    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, "ict_surprise_anger_smile.glb")
    log("exporting ...")
    t = time.perf_counter()
    report = gltf.export(bpy.context, face, path, 1, 49)
    export_s = time.perf_counter() - t
    log("importing it back ...")
    before = set(bpy.data.objects)
    bpy.ops.import_scene.gltf(filepath=path)
    (ob,) = [o for o in bpy.data.objects if o not in before and o.type == "MESH" and o.data.shape_keys]
    from mathutils.kdtree import KDTree

    imported_rest = np.empty((len(ob.data.vertices), 3), np.float32)
    ob.data.vertices.foreach_get("co", imported_rest.ravel())
    tree = KDTree(len(rest))
    for i, p in enumerate(rest):
        tree.insert(p, i)
    tree.balance()
    idx = np.array([tree.find(p)[1] for p in imported_rest])
    round_trip = {}
    for f in COMPARED:
        scene.frame_set(f)
        round_trip[str(f)] = round(float(np.linalg.norm(_positions(ob) - live[f][idx], axis=1).max() * mm), 5)
    # the engine's normals from the file (glTF is Y up: Blender's (x, y, z) is (x, z, -y))
    to_blender = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])
    normal_deg = {}
    for f in COMPARED:
        pos, normal = engine_normals(path, face.data.name, f - 1)
        pos, normal = pos @ to_blender.T, normal @ to_blender.T
        scene.frame_set(f)
        ev = face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
        live_n = np.empty((len(ev.vertices), 3), np.float32)
        ev.vertex_normals.foreach_get("vector", live_n.ravel())
        near = np.array([tree.find(p)[1] for p in pos])
        cos = np.clip(np.sum(normal * live_n[near], axis=1), -1.0, 1.0)
        angle = np.degrees(np.arccos(cos))
        normal_deg[str(f)] = {"max": round(float(angle.max()), 3),
                              "p99": round(float(np.percentile(angle, 99)), 3),
                              "over_5": int((angle > 5.0).sum())}
    if ns.render:
        _render_pair(face, ob, path, folder)
    print(json.dumps({
        "face": "ict", "range": "Surprise 1 -> Anger 25 -> Smile 49", "frames": len(frames.frames),
        "vertices": len(rest), "moved_vertices": moved,
        "targets": report["targets"], "max_error_mm": round(report["max_error_mm"], 5),
        "mean_error_mm": round(report["mean_error_mm"], 6), "within_tolerance": report["within_tolerance"],
        "wrinkle_max_mm": round(float(np.linalg.norm(d, axis=2).max() * mm), 4),
        "round_trip_max_mm": round_trip, "engine_normal_deg": normal_deg, "k_for_tolerance": k_for,
        "error_by_k": error_by_k,
        "normal_error_deg_range": {"blender_deltas": report.get("normal_error_deg_before"),
                                   "fitted": report.get("normal_error_deg")},
        "glb_bytes": os.path.getsize(path), "sample_s": round(sample_s, 2), "export_s": round(export_s, 2),
        "blender": bpy.app.version_string,
    }))


if __name__ == "__main__":
    code = 0
    try:
        main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else None)
    except BaseException:  # noqa: BLE001 - printed, then the exit code says it
        import traceback

        traceback.print_exc()
        code = 1
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)  # bpy can hang at interpreter exit (docs/architecture.md, "Exit")
