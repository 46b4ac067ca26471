# SPDX-License-Identifier: GPL-3.0-or-later
"""Whether the pattern layer's frown lines read as cuts: ``slit_count`` on the sample scenes'
pattern frown.

Run:  .venv45/bin/python benchmarks/pattern_slits.py   (or .venv52)
      options: --step 0.25 (grid step in mm)

Builds ``sample_scenes/patterns.py``'s scene on the sample head (the showcase's pattern layers:
the anatomical frown between the brows with the lowered brows, its muscles' own wrinkles off),
goes to its frown frame and takes the wrinkle heights the frame stage left in the evaluated
mesh: the evaluated positions less the skin before any wrinkle (``wrinkle_skin``), along the
rest normals, in mm.  On the glabella (``benchmarks/realism.py``'s box) it counts the furrows
whose width between the zero crossings is under 3 times their depth at their deepest 10 %
(``benchmarks/realism_measures.py``, ``slits``).  Prints one JSON line::

    {"face": "ict", "expression": "pattern_frown", "slit_count": 0, "deepest_mm": 0.8,
     "furrows": [[x, z, width, depth], ...]}

(``furrows``: the slits, if any; progress and details go to stderr).
"""

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402, I001
import addon_utils  # noqa: E402
import numpy as np  # noqa: E402

from benchmarks import realism  # noqa: E402
from benchmarks import realism_measures as rm  # noqa: E402

FROWN_FRAME = 40  # sample_scenes/patterns.py keys the lowered brows here


def log(msg):
    print(f"[pattern_slits] {msg}", file=sys.stderr, flush=True)


def heights(face):
    """(heights (N,) mm along the rest normals, shown positions (N, 3) mm, rest (N, 3) local)."""
    from wrinkle_addon.core import mesh as core_mesh
    from wrinkle_addon.glue import meshio, stage
    from wrinkle_addon.glue.muscles import muscle_objects

    me = face.data
    rest = meshio.read_vectors(me, "position").astype(np.float64)
    corner, starts, sizes = meshio.read_polygons(me)
    tris = core_mesh.fan_triangles(corner, starts, sizes)
    n = len(rest)
    ev = face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    skin = meshio.read_vector_prefix(ev, stage.SKIN_ATTR, n, np.empty((n, 3), np.float32))
    shown = meshio.read_vector_prefix(ev, "position", n, np.empty((n, 3), np.float32))
    normals = rm.vertex_normals(rest, tris)
    mm = 1000.0 * muscle_objects.face_scale(face)
    h = np.einsum("ij,ij->i", (shown - skin).astype(np.float64), normals) * mm
    return h, shown.astype(np.float64) * mm, rest, tris


def main(argv):
    from sample_scenes import patterns

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--step", type=float, default=0.25, help="grid step in mm")
    args = ap.parse_args(argv)
    if not patterns.available():
        log("the sample head is not there: nothing to measure")
        sys.exit(2)
    addon_utils.enable("wrinkle_addon", default_set=True)
    try:
        bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
        face, _shots = patterns.build_ict()
        bpy.context.scene.frame_set(FROWN_FRAME)
        h, shown, rest, tris = heights(face)
        lm = realism.posed_landmarks(rest, shown, dict(patterns.LANDMARKS))
        x, z = realism.glabella_box(lm)
        grid = rm.front_grid(shown, tris, h, x, z, args.step)
        got = rm.slits(grid, "x")
        log(f"glabella x {x[0]:.1f}..{x[1]:.1f} z {z[0]:.1f}..{z[1]:.1f} mm, "
            f"deepest {-np.nanmin(grid.h):.3f} mm, {got['slit_count']} slits")
        row = {"face": "ict", "expression": "pattern_frown", "slit_count": got["slit_count"],
               "deepest_mm": round(float(-np.nanmin(grid.h)), 3),
               "furrows": [[round(float(v), 2) for v in s] for s in got.get("slits", [])]}
        print(json.dumps(row), flush=True)
    finally:
        bpy.ops.wm.read_factory_settings(use_empty=True)  # bpy 4.5 hangs at exit otherwise


if __name__ == "__main__":
    main(sys.argv[1:])
