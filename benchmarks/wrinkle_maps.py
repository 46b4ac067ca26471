# SPDX-License-Identifier: GPL-3.0-or-later
"""Animated wrinkle maps: render cost, bake time and texture memory.

Run:  .venv45/bin/python benchmarks/wrinkle_maps.py   (or .venv52)
      options: --size 512 --samples 32 --rounds 5 --bake 2048 [--float-map]

Uses the scanned ICT head, the add-on's sample head (wrinkle_addon/data/ict_head.npz).
The head is built like ``sample_scenes/scanned_head_maps.py``: the facial muscle set,
a wrinkle map baked from the muscles (1024^2, 8-bit, the scene's and the operator's
defaults; ``--float-map``: float precision), generated masks, Table 1.1 bound to the ARKit
shape keys, posed in Surprise (frame 20).

``--pose`` picks the expression rendered (Surprise by default); the group costs least where
an expression leaves zones at 0 (Cycles folds them away, with the lookups only they read)
and most where it lights them all (Fear: every zone but the nose).

Every ratio is the median of per-round ratios: each round renders every variant once, in
reversed order every other round (so drift cancels), Cycles on the CPU at ``--size`` px
and ``--samples``.  Only the links and values of one material change between variants.

``render_ratio_plain``
    The demo's plain face: a 2048^2 fine-noise base normal map (standing in for pores)
    through a Normal Map node, against the same face with the "Wrinkle Map Blend" group
    (base, wrinkle map, two masks, weights from the drivers).  Bar: at most 1.10.
    ``render_ratio_lookups_only``: the plain face plus the three texture lookups the method
    needs (wrinkle map, two masks) added into the normal's colour at 1e-4, without the
    blend: the floor any implementation of the group pays in this scene.
``render_ratio_skin``
    A production skin: Principled BSDF with subsurface scattering (weight 1, scale 3 mm)
    and 1024^2 base colour, roughness and normal map images (made here in NumPy), plain
    against with the group, whose base normal input is fed from the skin's normal map
    node.  ``render_ratio_skin_lookups_only``: the skin plus the three extra lookups with
    no blend arithmetic.  Bar: at most 1.05, or, where the lookups alone cost more, at most
    the lookups' ratio + 0.01 (the group's own arithmetic within 1 %).
    ``render_ratio_skin_faint``: the group at Strength 1e-4, all of its arithmetic but
    next to no wrinkles, so the light paths stay the plain skin's: against
    ``render_ratio_skin`` it tells the cost of the nodes from that of the wrinkled shading.
``arithmetic_per_zone``
    The blend group's own arithmetic, per zone the pose lights (``active_zones``: zone
    weights above 0), as a fraction of the skin render: per round (t(skin with the group) -
    t(skin with the three lookups alone)) / t(skin) / active zones, the median over the
    rounds.  The lookups are the method's cost; this is what the group adds over them.
    Goal: at most 0.004 (0.4 % per active zone).
``bake_s``
    ``wrinkle.bake_wrinkle_map`` at ``--bake`` px (2048 by default) in "each muscle
    contracted" mode: the heights of every muscle, the UV rasterisation, the slopes and
    storing the image.  ``masks_s``: ``wrinkle.generate_masks`` at its default 256 px.
``texture_mb``
    What the wrinkle map and the two masks take as Blender holds them (4 bytes a pixel
    for 8-bit images, 16 for float ones; Blender has no half-float buffer), in MiB.
    ``texture_mb_float_map``: the same with a float map.  ``texture_kb_paper_layout``:
    8-bit maps at the paper's resolutions (a 256^2 wrinkle map, 64^2 masks), next to
    ``paper_kb`` = 96, which the paper reaches with 3Dc/DXT block compression (not
    available in Blender).
"""

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402, I001
import addon_utils  # noqa: E402
import numpy as np  # noqa: E402

MIB = 2 ** 20
# --pose: (frame of the scene's keyed shots, or None for frame 1; shape keys set on top)
POSES = {"Surprise": ("Surprise", {}), "Anger": ("Anger", {}), "Surprise + Anger": ("Surprise + Anger", {}),
         "Neutral": (None, {}), "Fear": (None, {"eyeWide_L": 1.0, "eyeWide_R": 1.0})}


def log(msg):
    print(f"[wrinkle_maps] {msg}", flush=True)


def image(name, rgb, colour=False):
    """A packed byte image of ``rgb`` (H, W, 3) in [0, 1]; sRGB if ``colour``, else Non-Color."""
    h, w = rgb.shape[:2]
    px = np.concatenate([np.clip(rgb, 0.0, 1.0), np.ones((h, w, 1), np.float32)], axis=2)
    img = bpy.data.images.new(name, w, h, alpha=True)
    img.colorspace_settings.name = "sRGB" if colour else "Non-Color"
    img.pixels.foreach_set(px.astype(np.float32).ravel())
    img.pack()
    return img


def normal_map(name, size, seed=0, sigma=0.08):
    """A fine-noise tangent-space normal map (standard encoding), Non-Color."""
    rng = np.random.default_rng(seed)
    d = rng.normal(0.0, sigma, (size, size, 2)).astype(np.float32)
    n = np.concatenate([d, np.ones((size, size, 1), np.float32)], axis=2)
    n /= np.linalg.norm(n, axis=2, keepdims=True)
    return image(name, 0.5 + 0.5 * n)


def smooth_noise(rng, size, cells):
    """Value noise in [-1, 1]: random values on a (cells + 1)^2 grid, bilinear in between."""
    grid = rng.uniform(-1.0, 1.0, (cells + 1, cells + 1))
    t = np.linspace(0.0, cells, size, endpoint=False)
    i = t.astype(int)
    f = (t - i)[:, None]
    rows = grid[i] * (1 - f) + grid[i + 1] * f  # (size, cells + 1)
    g = f.T
    return (rows[:, i] * (1 - g) + rows[:, i + 1] * g).astype(np.float32)


def skin_images(size=1024, seed=1):
    """Plausible skin textures: a base colour with blotches and freckles (sRGB), a
    roughness map with oily and dry areas, and a pore normal map."""
    rng = np.random.default_rng(seed)
    tone = np.array([0.62, 0.42, 0.34], np.float32)
    blotch = 0.06 * smooth_noise(rng, size, 8) + 0.03 * smooth_noise(rng, size, 40)
    redness = 0.05 * np.maximum(smooth_noise(rng, size, 12), 0.0)
    freckles = (rng.random((size, size)) > 0.997) * rng.uniform(0.05, 0.15, (size, size))
    colour = tone * (1.0 + blotch[..., None]) - freckles[..., None] * np.array([0.1, 0.12, 0.1])
    colour[..., 0] += redness
    colour += rng.normal(0.0, 0.01, colour.shape)
    rough = 0.45 + 0.08 * smooth_noise(rng, size, 10) + rng.normal(0.0, 0.03, (size, size))
    return (image("Skin Colour", colour.astype(np.float32), colour=True),
            image("Skin Roughness", np.repeat(rough[..., None], 3, axis=2).astype(np.float32)),
            normal_map("Skin Normal", size, seed=seed + 1, sigma=0.06))


def tex(nt, img, uv):
    node = nt.nodes.new("ShaderNodeTexImage")
    node.image = img
    nt.links.new(uv, node.inputs["Vector"])
    return node


def lookups_only(nt, uv, color, imgs):
    """A Normal Map node fed ``color`` plus 1e-4 x each of ``imgs``: the texture lookups of
    the method without its blend."""
    for img in imgs:
        add = nt.nodes.new("ShaderNodeVectorMath")
        add.operation = "MULTIPLY_ADD"
        nt.links.new(tex(nt, img, uv).outputs["Color"], add.inputs[0])
        add.inputs[1].default_value = (1e-4, 1e-4, 1e-4)
        nt.links.new(color, add.inputs[2])
        color = add.outputs[0]
    nmap = nt.nodes.new("ShaderNodeNormalMap")
    nt.links.new(color, nmap.inputs["Color"])
    return nmap.outputs["Normal"]


def held_mb(imgs):
    """MiB of the images as Blender holds them: ``depth`` bits a pixel (32 for 8-bit RGBA,
    128 for float)."""
    return sum(im.size[0] * im.size[1] * im.depth // 8 for im in imgs) / MIB


def _zone_weights(face):
    """The 8 zone weights of map 1 as the blend node gets them this frame."""
    from wrinkle_addon.core.maps import jimenez
    from wrinkle_addon.glue.maps import map_material

    maps = face.ewrinkles_face.maps
    keys = face.data.shape_keys.key_blocks
    values = [keys[ex.shape_key].value if ex.source == "SHAPE_KEY" and ex.shape_key in keys else 0.0
              for ex in maps.expressions]
    sums = jimenez.expression_sums(values, map_material.table(maps))
    return jimenez.zone_response(sums, list(maps.zone_strength), list(maps.zone_power))


def render_time(scene, path):
    scene.render.filepath = str(path)
    t = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    return time.perf_counter() - t


class Variants:
    """The face material's variants: each sets the BSDF's normal link, the group's base
    normal link and the skin inputs (textures and subsurface, or the demo's constants)."""

    def __init__(self, nt, maps, skin):
        self.nt = nt
        self.bsdf = next(n for n in nt.nodes if n.type == "BSDF_PRINCIPLED")
        self.blend = nt.nodes["Wrinkle Map Blend"]
        uv = nt.nodes["Wrinkle UV"].outputs["UV"]
        self.defaults = {k: self.bsdf.inputs[k].default_value
                         for k in ("Subsurface Weight", "Subsurface Scale")}
        self.demo_colour = tuple(self.bsdf.inputs["Base Color"].default_value)
        self.demo_rough = self.bsdf.inputs["Roughness"].default_value
        # the demo's plain face: its base map through a Normal Map node
        self.pores = nt.nodes["Wrinkle Base"]
        plain_map = nt.nodes.new("ShaderNodeNormalMap")
        nt.links.new(self.pores.outputs["Color"], plain_map.inputs["Color"])
        extra = (maps.map_a, maps.mask_a, maps.mask_b)
        # the skin: its own texture nodes, the normal through a Normal Map node
        colour, rough, normal = skin
        self.skin_colour = tex(nt, colour, uv)
        self.skin_rough = tex(nt, rough, uv)
        self.skin_normal = tex(nt, normal, uv)
        skin_map = nt.nodes.new("ShaderNodeNormalMap")
        nt.links.new(self.skin_normal.outputs["Color"], skin_map.inputs["Color"])
        group = self.blend.outputs["Normal"]
        self.table = {
            "plain": (False, plain_map.outputs["Normal"]),
            "maps": (False, group),
            "lookups": (False, lookups_only(nt, uv, self.pores.outputs["Color"], extra)),
            "skin": (True, skin_map.outputs["Normal"]),
            "skin_maps": (True, group),
            "skin_lookups": (True, lookups_only(nt, uv, self.skin_normal.outputs["Color"], extra)),
            "skin_maps_faint": (True, group),
        }
        self.strength = self.blend.inputs["Strength"].default_value

    def set(self, name):
        skin, normal = self.table[name]
        nt, bsdf = self.nt, self.bsdf
        nt.links.new(normal, bsdf.inputs["Normal"])
        base = self.skin_normal if skin else self.pores
        nt.links.new(base.outputs["Color"], self.blend.inputs["Base Normal"])
        for socket, node, value in (("Base Color", self.skin_colour, self.demo_colour),
                                    ("Roughness", self.skin_rough, self.demo_rough)):
            for link in list(bsdf.inputs[socket].links):
                nt.links.remove(link)
            if skin:
                nt.links.new(node.outputs["Color"], bsdf.inputs[socket])
            else:
                bsdf.inputs[socket].default_value = value
        # faint: the group's whole arithmetic (the strength folds into the zone weights)
        # with the wrinkles at 1e-4, so the shading, and the light paths, stay the skin's
        self.blend.inputs["Strength"].default_value = 1e-4 if name.endswith("faint") else self.strength
        bsdf.inputs["Subsurface Weight"].default_value = 1.0 if skin else self.defaults["Subsurface Weight"]
        bsdf.inputs["Subsurface Scale"].default_value = 0.003 if skin else self.defaults["Subsurface Scale"]


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--samples", type=int, default=32)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--bake", default="2048")
    ap.add_argument("--out", default="/tmp/wrinkle_maps_bench")
    ap.add_argument("--float-map", action="store_true",
                    help="render with a float-precision wrinkle map instead of the 8-bit one")
    ap.add_argument("--pose", default="Surprise", choices=sorted(POSES),
                    help="the expression rendered: Surprise lights zones 1-4 (mask A) only; Fear "
                    "lights all but the nose (both masks, both alphas), the group's dearest case")
    args = ap.parse_args(argv)
    from sample_scenes import scanned_head_maps
    from sample_scenes.lib import scene_setup

    if not scanned_head_maps.available():
        print(json.dumps({"error": f"{scanned_head_maps.DATA} not found"}))
        return
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    addon_utils.enable("wrinkle_addon", default_set=True)
    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    t = time.perf_counter()
    face, shots = scanned_head_maps.build()
    log(f"scene built in {time.perf_counter() - t:.1f} s ({len(face.data.vertices)} vertices)")
    scene = bpy.context.scene
    maps = face.ewrinkles_face.maps

    # bake and masks, timed through the operators an artist uses
    t = time.perf_counter()
    bpy.ops.wrinkle.bake_wrinkle_map(resolution=args.bake, mode="MUSCLES", image_name="Bench Bake")
    bake_s = time.perf_counter() - t
    log(f"bake {args.bake}^2: {bake_s:.2f} s")
    t = time.perf_counter()
    bpy.ops.wrinkle.generate_masks(source="MUSCLES", image_name="Bench Mask")
    masks_s = time.perf_counter() - t
    log(f"masks: {masks_s:.2f} s")

    if args.float_map:
        bpy.ops.wrinkle.bake_wrinkle_map(resolution=scanned_head_maps.MAP_RESOLUTION, mode="MUSCLES",
                                         float_precision=True, image_name="Wrinkle PD float")
        maps.map_a = bpy.data.images["Wrinkle PD float"]
    # the same base normal map in both variants of the plain face
    maps.base_image = normal_map("Pores", 2048)
    bpy.ops.wrinkle.setup_wrinkle_maps()
    variants = Variants(maps.material.node_tree, maps, skin_images(1024))

    scene_setup.setup_cycles(scene, resolution=(args.size, args.size), samples=args.samples, denoise=False)
    scene.render.image_settings.file_format = "PNG"
    shot, keys = POSES[args.pose]
    scene.frame_set(shots[shot] if shot else 1)
    for key, value in keys.items():  # not keyed: they stay
        face.data.shape_keys.key_blocks[key].value = value
    scene.frame_set(scene.frame_current)
    weights = [round(float(v), 3) for v in _zone_weights(face)]
    log(f"pose {args.pose}: zone weights {weights}")
    names = list(variants.table)
    times = {k: [] for k in names}
    for name in names:  # warm-up: kernels, image loading
        variants.set(name)
        render_time(scene, out / f"warm_{name}.png")
    for r in range(args.rounds):
        for name in names if r % 2 == 0 else names[::-1]:
            variants.set(name)
            times[name].append(render_time(scene, out / f"{name}_{r}.png"))
        log(f"round {r + 1}/{args.rounds}: " + ", ".join(f"{k} {v[-1]:.2f} s" for k, v in times.items()))

    def ratio(name, over):
        return round(statistics.median(a / b for a, b in zip(times[name], times[over])), 4)

    def median(name):
        return round(statistics.median(times[name]), 3)

    active = sum(1 for w in weights if w > 0.0)
    # per round: the group's own arithmetic over the three lookups, in skin renders, per zone lit
    per_zone = [(m - lk) / sk / max(active, 1) for m, lk, sk in
                zip(times["skin_maps"], times["skin_lookups"], times["skin"])]
    used = [maps.map_a, maps.mask_a, maps.mask_b]
    wmap = maps.map_a
    result = {
        "bpy": bpy.app.version_string,
        "verts": len(face.data.vertices),
        "render_size": args.size, "samples": args.samples, "rounds": args.rounds,
        "pose": args.pose, "zone_weights": weights,
        "render_ratio_skin": ratio("skin_maps", "skin"),
        "render_ratio_skin_lookups_only": ratio("skin_lookups", "skin"),
        "render_ratio_plain": ratio("maps", "plain"),
        "render_ratio_lookups_only": ratio("lookups", "plain"),
        "render_ratio_skin_faint": ratio("skin_maps_faint", "skin"),
        "active_zones": active,
        "arithmetic_per_zone": round(statistics.median(per_zone), 5),
        "texture_mb": round(held_mb(used), 3),
        "render_s": {k: median(k) for k in names},
        "render_all_s": {k: [round(x, 3) for x in v] for k, v in times.items()},
        "bake_resolution": int(args.bake), "bake_s": round(bake_s, 3), "masks_s": round(masks_s, 3),
        "wrinkle_map": f"{wmap.size[0]}x{wmap.size[1]} {'float' if wmap.is_float else '8-bit'}",
        "masks": f"{maps.mask_a.size[0]}x{maps.mask_a.size[1]} "
                 f"{'float' if maps.mask_a.is_float else '8-bit'}",
        "texture_mb_float_map": round((wmap.size[0] * wmap.size[1] * 16) / MIB + held_mb(used[1:]), 3),
        "texture_kb_paper_layout": round((256 * 256 * 4 + 2 * 64 * 64 * 4) / 1024, 1),
        "paper_kb": 96,
    }
    bpy.ops.wm.read_factory_settings(use_empty=True)  # avoids the bpy 4.5 exit hang
    print(json.dumps(result))


if __name__ == "__main__":
    main(sys.argv[1:])
