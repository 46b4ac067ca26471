# SPDX-License-Identifier: GPL-3.0-or-later
"""Animated wrinkle maps: render cost, bake time and texture memory.

Run:  .venv45/bin/python benchmarks/wrinkle_maps.py   (or .venv52)
      options: --size 256 --samples 16 --rounds 3 --bake 2048

Needs ../shared/data/ict_head.npz (the scanned ICT head); exits with a message without it.
The head is built like ``sample_scenes/scanned_head_maps.py``: the facial muscle set,
a wrinkle map baked from the muscles, generated masks, Table 1.1 bound to the ARKit
shape keys, posed in Surprise (frame 20).  Both variants get the same 2048^2 base normal
map (fine noise, standing in for pores).

``render_plain_s`` / ``render_maps_s`` / ``render_ratio``
    Cycles CPU render of the head (``--size`` px, ``--samples``) with the base map
    through a plain Normal Map node, against the same face with the "Wrinkle Map Blend"
    group (base, wrinkle map, two masks, weights from the drivers).  Only the link into
    the BSDF's normal changes between the variants; each round renders every variant, in
    reversed order every other round (so drift cancels), and each figure is the median.
    ``render_ratio`` is the median of the per-round ratios.  The goal is at most 1.05.
    ``render_ratio_lookups_only``: the plain face plus the three texture lookups the
    method needs (wrinkle map, two masks) added into the base colour at 1e-4, without the
    blend: the floor any implementation of the group pays in this scene.  The demo's skin has no
    subsurface scattering; ``render_*_sss_s`` / ``render_ratio_sss`` repeat the race with
    it on (weight 1, scale 3 mm), as production skin has it.
``bake_s``
    ``wrinkle.bake_wrinkle_map`` at ``--bake`` px (2048 by default) in "each muscle
    contracted" mode: the heights of every muscle, the UV rasterisation, the slopes and
    storing the image.  ``masks_s``: ``wrinkle.generate_masks`` at its default 256 px.
``texture_memory_kb``
    What the wrinkle map and the two masks take as Cycles holds them: 16 bytes a texel
    for float images, 4 for 8-bit ones, at the resolutions used here.
    ``texture_memory_8bit_kb``: the same maps stored as 8-bit textures with the PD map in
    two channels (R, G).  ``texture_memory_paper_layout_kb``: that at the paper's
    resolutions (a 256^2 wrinkle map, 64^2 masks), next to ``paper_kb`` = 96, which the
    paper reaches with 3Dc/DXT block compression (not available in Blender).
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


def log(msg):
    print(f"[wrinkle_maps] {msg}", flush=True)


def base_normal_map(size, seed=0):
    """A fine-noise tangent-space normal map (standard encoding), Non-Color."""
    rng = np.random.default_rng(seed)
    d = rng.normal(0.0, 0.08, (size, size, 2)).astype(np.float32)
    n = np.concatenate([d, np.ones((size, size, 1), np.float32)], axis=2)
    n /= np.linalg.norm(n, axis=2, keepdims=True)
    px = np.concatenate([0.5 + 0.5 * n, np.ones((size, size, 1), np.float32)], axis=2)
    img = bpy.data.images.new("Pores", size, size, alpha=True)
    img.colorspace_settings.name = "Non-Color"
    img.pixels.foreach_set(px.ravel())
    img.pack()
    return img


def lookups_only(nt, uv, base_tex, imgs):
    """A plain normal map whose colour also gets 1e-4 x each of ``imgs``: the texture
    lookups of the method without its blend."""
    color = base_tex.outputs["Color"]
    for img in imgs:
        tex = nt.nodes.new("ShaderNodeTexImage")
        tex.image = img
        nt.links.new(uv, tex.inputs["Vector"])
        add = nt.nodes.new("ShaderNodeVectorMath")
        add.operation = "MULTIPLY_ADD"
        nt.links.new(tex.outputs["Color"], add.inputs[0])
        add.inputs[1].default_value = (1e-4, 1e-4, 1e-4)
        nt.links.new(color, add.inputs[2])
        color = add.outputs[0]
    nmap = nt.nodes.new("ShaderNodeNormalMap")
    nt.links.new(color, nmap.inputs["Color"])
    return nmap.outputs["Normal"]


def texel_bytes(img):
    return 16 if img.is_float else 4


def render_time(scene, path):
    scene.render.filepath = str(path)
    t = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    return time.perf_counter() - t


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--samples", type=int, default=32)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--bake", default="2048")
    ap.add_argument("--out", default="/tmp/wrinkle_maps_bench")
    ap.add_argument("--byte-map", action="store_true",
                    help="render with an 8-bit copy of the wrinkle map instead of the float one")
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

    if args.byte_map:
        from wrinkle_addon.glue import images

        maps.map_a = images.store("Wrinkle PD 8-bit", images.read(maps.map_a), float_buffer=False)
    # the same base normal map in both variants
    maps.base_image = base_normal_map(2048)
    bpy.ops.wrinkle.setup_wrinkle_maps()
    nt = maps.material.node_tree
    bsdf = next(n for n in nt.nodes if n.type == "BSDF_PRINCIPLED")
    blend = nt.nodes["Wrinkle Map Blend"]
    plain_tex = nt.nodes.new("ShaderNodeTexImage")
    plain_tex.image = maps.base_image
    plain_map = nt.nodes.new("ShaderNodeNormalMap")
    nt.links.new(nt.nodes["Wrinkle UV"].outputs["UV"], plain_tex.inputs["Vector"])
    nt.links.new(plain_tex.outputs["Color"], plain_map.inputs["Color"])
    variants = {"plain": plain_map.outputs["Normal"], "maps": blend.outputs["Normal"],
                "lookups": lookups_only(nt, nt.nodes["Wrinkle UV"].outputs["UV"], plain_tex,
                                        (maps.map_a, maps.mask_a, maps.mask_b))}

    scene_setup.setup_cycles(scene, resolution=(args.size, args.size), samples=args.samples, denoise=False)
    scene.render.image_settings.file_format = "PNG"
    scene.frame_set(shots["Surprise"])
    def race(tag, names):
        times = {k: [] for k in names}
        for name in names:  # warm-up: kernels, image loading
            nt.links.new(variants[name], bsdf.inputs["Normal"])
            render_time(scene, out / f"warm_{tag}{name}.png")
        for r in range(args.rounds):
            for name in names if r % 2 == 0 else names[::-1]:
                nt.links.new(variants[name], bsdf.inputs["Normal"])
                times[name].append(render_time(scene, out / f"{tag}{name}_{r}.png"))
            log(f"{tag or 'skin'} round {r + 1}/{args.rounds}: "
                + ", ".join(f"{k} {v[-1]:.2f} s" for k, v in times.items()))
        return times

    def ratio(times, name):
        return statistics.median(a / b for a, b in zip(times[name], times["plain"]))

    times = race("", ["plain", "maps", "lookups"])
    plain, with_maps = statistics.median(times["plain"]), statistics.median(times["maps"])
    # the same with subsurface scattering on, as production skin has it
    bsdf.inputs["Subsurface Weight"].default_value = 1.0
    bsdf.inputs["Subsurface Scale"].default_value = 0.003
    sss = race("sss_", ["plain", "maps"])
    sss_plain, sss_maps = statistics.median(sss["plain"]), statistics.median(sss["maps"])

    used = [maps.map_a, maps.mask_a, maps.mask_b]
    memory = sum(img.size[0] * img.size[1] * texel_bytes(img) for img in used) / 1024
    wmap = maps.map_a
    memory8 = (wmap.size[0] * wmap.size[1] * 2 + sum(m.size[0] * m.size[1] * 4 for m in used[1:])) / 1024
    paper_layout = (256 * 256 * 2 + 2 * 64 * 64 * 4) / 1024
    result = {
        "bpy": bpy.app.version_string,
        "verts": len(face.data.vertices),
        "render_size": args.size, "samples": args.samples, "rounds": args.rounds,
        "render_plain_s": round(plain, 3), "render_maps_s": round(with_maps, 3),
        "render_ratio": round(ratio(times, "maps"), 4),
        "render_ratio_lookups_only": round(ratio(times, "lookups"), 4),
        "render_plain_all_s": [round(x, 3) for x in times["plain"]],
        "render_maps_all_s": [round(x, 3) for x in times["maps"]],
        "render_plain_sss_s": round(sss_plain, 3), "render_maps_sss_s": round(sss_maps, 3),
        "render_ratio_sss": round(ratio(sss, "maps"), 4),
        "bake_resolution": int(args.bake), "bake_s": round(bake_s, 3), "masks_s": round(masks_s, 3),
        "wrinkle_map": f"{wmap.size[0]}x{wmap.size[1]} {'float' if wmap.is_float else '8-bit'}",
        "masks": f"{maps.mask_a.size[0]}x{maps.mask_a.size[1]} "
                 f"{'float' if maps.mask_a.is_float else '8-bit'}",
        "texture_memory_kb": round(memory, 1),
        "texture_memory_8bit_kb": round(memory8, 1),
        "texture_memory_paper_layout_kb": round(paper_layout, 1),
        "paper_kb": 96,
    }
    bpy.ops.wm.read_factory_settings(use_empty=True)  # avoids the bpy 4.5 exit hang
    print(json.dumps(result))


if __name__ == "__main__":
    main(sys.argv[1:])
