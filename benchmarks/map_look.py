# SPDX-License-Identifier: GPL-3.0-or-later
"""Do the wrinkle maps look like the geometric wrinkles they come from?

Run:  .venv45/bin/python benchmarks/map_look.py   [--npz PATH] [--size 512] [--samples 32]
      [--poses anger,surprise] [--out DIR]

Builds the ICT head (or ``--npz``, any head with its layout) with the demo's wrinkle maps
exactly as ``sample_scenes/scanned_head_maps.py`` sets them up (``set_up_maps``: the map baked
from the muscles, the masks from their regions, Table 1.1 bound to the ARKit shape keys),
poses it with the shape keys of ``benchmarks/realism.py`` (anger: browDown + noseSneer +
eyeSquint 0.5; surprise: its brow raise) and renders each pose three times in Cycles with
the demo's camera and portrait lights, at the demo's 512 px:

* ``none``: no wrinkles (Enable Wrinkles off, the maps' Strength 0);
* ``geometry``: the muscles' geometric wrinkles of the pose (Enable Wrinkles on, maps off);
* ``map``: the wrinkle maps alone (Enable Wrinkles off, the maps' Strength 1).

The pixels measured are the face's pixels inside the zones the pose lights: the zone masks
are rendered as emission (the maps' UVs, one sample at each pixel's centre), and a pixel
belongs to zone z when its membership is above 0.5; the zones lit are those whose weight
on any map (``glue.maps.map_material.zone_weights``: Table 1.1 over the expressions' driven
values, clamped, as the weights group computes it) is above 0.05.  On the display
luminance L (Rec. 709 weights on the rendered PNG)::

    map_geometry_ratio = sum |L_map - L_geometry| / sum |L_none - L_geometry|

over those pixels: 0 when the map shades exactly like the geometry, 1 when it is no better
than no wrinkles at all, above 1 when it draws what the geometry does not.  The goal is at
most 0.5.  Per zone the same ratio is printed under ``zones`` (with the zone's pixel count).

Prints one JSON line per pose, ``{"face": "ict", "expression": "map_anger",
"map_geometry_ratio": ..., "zones": {...}, "pixels": ...}``; progress goes to stderr.  With
``--out`` it writes the three renders of each pose and a sheet ``map_look.png`` (a row per
pose: none, geometry, map).  ``benchmarks/realism.py`` prints the same lines (``lines``).
"""

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402, I001
import addon_utils  # noqa: E402
import numpy as np  # noqa: E402

POSES = {
    "anger": {"browDown_L": 1.0, "browDown_R": 1.0, "noseSneer_L": 1.0, "noseSneer_R": 1.0,
              "eyeSquint_L": 0.5, "eyeSquint_R": 0.5},
    "surprise": {"browInnerUp_L": 1.0, "browInnerUp_R": 1.0, "browOuterUp_L": 1.0, "browOuterUp_R": 1.0},
}
LIT = 0.05  # a zone whose weight is above this is measured
INSIDE = 0.5  # a pixel whose membership of a lit zone is above this is measured
LUMA = np.array([0.2126, 0.7152, 0.0722], np.float32)
DEFAULT_NPZ = ROOT / "wrinkle_addon" / "data" / "ict_head.npz"  # sample_scenes/lib/ict.py's DEFAULT_PATH


def log(msg):
    print(f"[map_look] {msg}", file=sys.stderr, flush=True)


def build(path, size, samples, map_resolution=None):
    """The demo's map scene on the head at ``path`` (maps of ``map_resolution`` pixels, by
    default the demo's); returns (face, {pose: frame})."""
    from sample_scenes import scanned_head_maps
    from sample_scenes.lib import ict, rigging, scene_setup

    scene = bpy.context.scene
    scene_setup.setup_cycles(scene, (size, size), samples=samples)
    data = ict.load_ict(path)
    face = ict.ict_object(data, name="ICTHead")
    scene_setup.add_portrait_rig(scene, face, view="front", frame_scale=1.35)
    rigging.wrinkle_face(face, data["landmarks"], wrinkles_only=True)
    scanned_head_maps.set_up_maps(face, map_resolution or scanned_head_maps.MAP_RESOLUTION)
    frames = {pose: i + 2 for i, pose in enumerate(POSES)}
    rigging.key_shape_keys(face, {1: {}, **{frames[p]: POSES[p] for p in POSES}})
    return face, frames


def _pixels(path):
    img = bpy.data.images.load(str(path), check_existing=False)
    px = np.empty(img.size[0] * img.size[1] * 4, np.float32)
    img.pixels.foreach_get(px)
    w, h = img.size
    bpy.data.images.remove(img)
    return px.reshape(h, w, 4)


def render(scene, path):
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)
    return _pixels(path)


def zone_memberships(scene, face, folder):
    """(H, W, 8) zone memberships per pixel and (H, W) face coverage: the masks rendered as
    emission through the maps' UVs, one sample at each pixel's centre."""
    from wrinkle_addon.glue.maps import map_bake

    maps = face.ewrinkles_face.maps
    mat = bpy.data.materials.new("ZoneProbe")
    if bpy.app.version < (5, 0, 0):
        mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    uv = nt.nodes.new("ShaderNodeUVMap")
    uv.uv_map = maps.uv_map or map_bake.uv_layer(face).name
    emit = nt.nodes.new("ShaderNodeEmission")
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    nt.links.new(emit.outputs[0], out.inputs["Surface"])
    comb = nt.nodes.new("ShaderNodeCombineColor")
    nt.links.new(comb.outputs[0], emit.inputs["Color"])
    texs = []
    for img in (maps.mask_a, maps.mask_b):
        t = nt.nodes.new("ShaderNodeTexImage")
        t.image = img
        t.interpolation = "Closest"
        nt.links.new(uv.outputs["UV"], t.inputs["Vector"])
        sep = nt.nodes.new("ShaderNodeSeparateColor")
        nt.links.new(t.outputs["Color"], sep.inputs[0])
        texs.append((t, sep))
    channels = [(texs[0][1], 0), (texs[0][1], 1), (texs[0][1], 2), (texs[0][0], "Alpha"),
                (texs[1][1], 0), (texs[1][1], 1), (texs[1][1], 2), (texs[1][0], "Alpha")]
    saved = {k: getattr(scene.render, k) for k in ("film_transparent",)}
    cyc = {k: getattr(scene.cycles, k) for k in ("samples", "pixel_filter_type", "use_denoising",
                                                  "max_bounces")}
    view = scene.view_settings.view_transform
    scene.render.film_transparent = True
    scene.cycles.samples, scene.cycles.pixel_filter_type = 1, "BOX"
    scene.cycles.use_denoising, scene.cycles.max_bounces = False, 0
    scene.view_settings.view_transform = "Standard"
    slots = [s.material for s in face.material_slots]
    for s in face.material_slots:
        s.material = mat
    zones, cover = [], None
    try:
        for k in range(0, 8, 3):
            for i, sock in enumerate(("Red", "Green", "Blue")):
                for link in list(comb.inputs[sock].links):
                    nt.links.remove(link)
                if k + i < 8:
                    node, ch = channels[k + i]
                    nt.links.new(node.outputs[ch], comb.inputs[sock])
                else:
                    comb.inputs[sock].default_value = 0.0
            px = render(scene, Path(folder) / f"zones_{k}.png")
            zones += [px[..., i] for i in range(3) if k + i < 8]
            cover = px[..., 3]
    finally:
        for s, m in zip(face.material_slots, slots):
            s.material = m
        bpy.data.materials.remove(mat)
        for k, v in saved.items():
            setattr(scene.render, k, v)
        for k, v in cyc.items():
            setattr(scene.cycles, k, v)
        scene.view_settings.view_transform = view
    return np.stack(zones, axis=-1), cover


def ratio(none, geometry, mapped, where):
    """sum |L_map - L_geometry| / sum |L_none - L_geometry| over ``where``."""
    lum = [(im[..., :3] @ LUMA)[where] for im in (none, geometry, mapped)]
    den = float(np.abs(lum[0] - lum[1]).sum())
    return float(np.abs(lum[2] - lum[1]).sum()) / den if den > 0 else float("nan")


def measure_pose(scene, face, pose, frame, folder):
    fs = face.ewrinkles_face
    shots = {}
    for state, enabled, strength in (("none", False, 0.0), ("geometry", True, 0.0), ("map", False, 1.0)):
        fs.enabled = enabled
        fs.maps.strength = strength
        scene.frame_set(frame)
        shots[state] = render(scene, Path(folder) / f"{pose}_{state}.png")
    from wrinkle_addon.glue.maps import map_material

    weights = map_material.zone_weights(face).max(axis=0)
    members, cover = zone_memberships(scene, face, folder)
    from wrinkle_addon.core.maps import jimenez

    lit = np.flatnonzero(weights > LIT)
    face_px = cover > 0.99
    zone_of = members.argmax(axis=-1)
    inside = members.max(axis=-1) > INSIDE
    region = face_px & inside & np.isin(zone_of, lit)
    zones = {}
    for z in lit:
        where = region & (zone_of == z)
        if where.sum() >= 20:
            zones[jimenez.ZONES[z][1]] = {"ratio": round(ratio(shots["none"], shots["geometry"], shots["map"],
                                                                 where), 3),
                                          "weight": round(float(weights[z]), 3), "pixels": int(where.sum())}
    return {"map_geometry_ratio": round(ratio(shots["none"], shots["geometry"], shots["map"], region), 3),
            "zones": zones, "pixels": int(region.sum())}, [Path(folder) / f"{pose}_{s}.png" for s in shots]


def lines(path, size=512, samples=32, poses=None, out=None):
    """The JSON lines (dicts) for the head at ``path``, one per pose; renders into ``out``
    (a temporary folder when None)."""
    import tempfile

    poses = list(poses or POSES)
    name = "ict" if Path(path) == Path(DEFAULT_NPZ) else Path(path).stem
    keep = out is not None
    folder = Path(out) if keep else Path(tempfile.mkdtemp(prefix="map_look_"))
    folder.mkdir(parents=True, exist_ok=True)
    face, frames = build(path, size, samples)
    scene = bpy.context.scene
    result, rows = [], []
    for i, pose in enumerate(poses):
        t = time.perf_counter()
        line, files = measure_pose(scene, face, pose, frames[pose], folder)
        rows.append(files)
        log(f"{i + 1}/{len(poses)} map_{pose}: ratio {line['map_geometry_ratio']} "
            f"({time.perf_counter() - t:.1f} s)")
        result.append({"face": name, "expression": f"map_{pose}", **line})
    if keep:
        from sample_scenes.lib.rendering import contact_sheet

        contact_sheet(rows, folder / "map_look.png", gap=4)
        log(f"sheet {folder / 'map_look.png'}")
    return result


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--npz", default=None, help="a head file with the ICT layout (default: the ICT head)")
    ap.add_argument("--size", type=int, default=512, help="pixels (the demo's 512)")
    ap.add_argument("--samples", type=int, default=32, help="Cycles samples")
    ap.add_argument("--poses", default=",".join(POSES), help="comma-separated: " + ", ".join(POSES))
    ap.add_argument("--out", default=None, help="keep the renders and a sheet in this folder")
    args = ap.parse_args(argv)
    poses = [p.strip() for p in args.poses.split(",") if p.strip()]
    if any(p not in POSES for p in poses):
        log(f"unknown poses {poses}: choose from {list(POSES)}")
        sys.exit(2)
    path = Path(args.npz) if args.npz else DEFAULT_NPZ
    if not path.exists():
        log(f"{path} not found")
        sys.exit(2)
    addon_utils.enable("wrinkle_addon", default_set=True)
    try:
        bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
        for line in lines(path, args.size, args.samples, poses, args.out):
            print(json.dumps(line), flush=True)
    finally:
        bpy.ops.wm.read_factory_settings(use_empty=True)  # bpy 4.5 hangs at exit otherwise


if __name__ == "__main__":
    main(sys.argv[1:])
