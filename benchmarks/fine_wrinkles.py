# SPDX-License-Identifier: GPL-3.0-or-later
"""Fine-scale wrinkles (Bando, Kuratate & Nishita 2002, §5): how long carving the furrows takes.

Run:  .venv45/bin/python benchmarks/fine_wrinkles.py --carve-only   (no bpy needed)
      options: --mesh face|square  --sizes 512,1024,2048  --repeats 3  --seed 1

``carve_s``
    Wall time (``time.perf_counter``) of ``core.bando.carve.carve`` at each image size,
    everything included: rasterising the mapped mesh, seeding (random and fill phases),
    growing the furrows in lockstep, and drawing the occupancy and height images.  The
    median of ``--repeats`` runs for sizes up to 1024, one run above (2048 takes longest
    and varies least).  The default ``scale = R / 512`` carves the same furrows in texture
    space at every size (the paper's 512 x 512 layout, finer pixels), so the figures
    compare like for like.  The paper reports about 10 s at 512 x 512 (XEON 2 GHz).
``coverage`` / ``furrows``
    Of the last run at each size: the fraction of the mesh's pixels the furrows lower,
    and the number of furrows.

The mapped mesh (``--mesh``):

``face`` (default)
    A face-like UV layout: a 41 x 41 vertex grid cut to an oval with holes for the eyes
    and the mouth, plus a separate small island (an ear); the field runs across the
    forehead and bends around the cheeks, its magnitude 0.25 at the chin to 0.75 on top.
``square``
    Two triangles over the whole unit square, m = 0.5 everywhere, the direction turning
    slowly across it (by 1.5 rad corner to corner).

Output: progress on stderr, one JSON object on the last line of stdout::

    {"carve_s": {"512": ..., "1024": ..., "2048": ...}, "coverage": {...}, "furrows": {...},
     "mesh": "face", "repeats": 3}

``--carve-only`` is the only mode for now.  A second figure that needs Blender (the
per-frame cost of the furrows as curves, ``curves_frame_ms``) is to come in its own
function, run when ``--carve-only`` is not given; without it the script measures the
carving alone, like with it.
"""

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from wrinkle_addon.core.bando import carve as bando_carve  # noqa: E402


def log(msg):
    print(f"[fine_wrinkles] {msg}", file=sys.stderr, flush=True)


def square_mesh():
    """Two triangles over [0, 1]^2; m = 0.5, the direction turning slowly."""
    uv = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    tris = np.array([[0, 1, 2], [0, 2, 3]])
    ang = uv[:, 0] + 0.5 * uv[:, 1]
    return uv, tris, 0.5 * np.stack([np.cos(ang), np.sin(ang)], 1)


def face_mesh(n=41):
    """A face-like UV layout with holes and a second island (see the module docstring)."""
    u, v = np.meshgrid(np.linspace(0.02, 0.98, n), np.linspace(0.02, 0.98, n))
    uv = np.stack([u.ravel(), v.ravel()], 1)
    idx = np.arange(n * n).reshape(n, n)
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    tris = np.concatenate([np.stack([a, b, c], 1), np.stack([a, c, d], 1)])
    cen = uv[tris].mean(axis=1)

    def inside(x, y, ax, ay):
        return ((cen[:, 0] - x) / ax) ** 2 + ((cen[:, 1] - y) / ay) ** 2 < 1.0

    keep = inside(0.45, 0.5, 0.36, 0.46)
    for x, y, ax, ay in ((0.32, 0.58, 0.08, 0.04), (0.58, 0.58, 0.08, 0.04), (0.45, 0.25, 0.12, 0.04)):
        keep &= ~inside(x, y, ax, ay)
    keep |= inside(0.9, 0.5, 0.06, 0.14)  # the ear
    ang = 0.7 * np.sin(2.5 * (uv[:, 0] - 0.45)) * (1.0 - uv[:, 1])
    m = 0.25 + 0.5 * uv[:, 1]
    return uv, tris[keep], m[:, None] * np.stack([np.cos(ang), np.sin(ang)], 1)


MESHES = {"face": face_mesh, "square": square_mesh}


def carve_s(mesh, sizes, repeats, seed):
    """The ``carve_s`` figures (see the module docstring) and, per size, the coverage and
    the furrow count of the last run."""
    uv, tris, field = MESHES[mesh]()
    times, coverage, furrows = {}, {}, {}
    bando_carve.carve(uv, tris, field, 64, seed=seed)  # warm-up: imports, first allocations
    for R in sizes:
        runs = []
        for _ in range(repeats if R <= 1024 else 1):
            t = time.perf_counter()
            res = bando_carve.carve(uv, tris, field, R, seed=seed)
            runs.append(time.perf_counter() - t)
        times[str(R)] = round(statistics.median(runs), 3)
        coverage[str(R)] = round(res.coverage, 4)
        furrows[str(R)] = res.furrows
        batches = int(res.batches.max(initial=-1)) + 1
        log(f"{mesh} {R}^2: " + ", ".join(f"{x:.3f}" for x in runs) + f" s; coverage {res.coverage:.3f}, "
            f"{res.furrows} furrows, {len(res.segments)} segments, {batches} batches")
    return times, coverage, furrows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--carve-only", action="store_true",
                    help="measure the carving alone, no bpy (the only mode for now)")
    ap.add_argument("--mesh", choices=sorted(MESHES), default="face")
    ap.add_argument("--sizes", default="512,1024,2048")
    ap.add_argument("--repeats", type=int, default=3, help="runs per size up to 1024 (the median is kept)")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args(argv)
    if args.repeats < 1:
        ap.error("--repeats must be at least 1")
    sizes = [int(s) for s in args.sizes.split(",") if s.strip()]
    log(f"numpy {np.__version__}, {os.cpu_count()} cpus, load {os.getloadavg()[0]:.2f}, mesh {args.mesh}")
    times, coverage, furrows = carve_s(args.mesh, sizes, args.repeats, args.seed)
    result = {"carve_s": times, "coverage": coverage, "furrows": furrows, "mesh": args.mesh,
              "repeats": args.repeats}
    print(json.dumps(result), flush=True)


if __name__ == "__main__":
    main()
