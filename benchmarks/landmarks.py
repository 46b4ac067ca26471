# SPDX-License-Identifier: GPL-3.0-or-later
"""How far the add-on's landmark finder lands from an independent reference on the ICT head.

Run:  .venv45/bin/python benchmarks/landmarks.py   (or any Python with NumPy: no bpy needed)
      options: --npz PATH (another head with the ICT topology; default the add-on's sample head)
               --json PATH (the reference; default tests/data/ict_head_landmarks.json)

Prints one JSON line::

    {"face": "ict", "expression": "landmarks", "landmark_max_mm": 3.1,
     "landmark_mm": {"glabella": 1.6, ...}, "method": "openings", "rule_max_mm": {...}}

``landmark_mm``: per comparable landmark, the distance (mm, in 3D) from what
``core.landmark_finder.find_landmarks`` finds on the head (with its shape keys, as
*Place Landmarks* runs it; ``method`` is the rule that fitted) to the reference point below;
``landmark_max_mm`` their largest (the goal: 5 mm or less).  ``rule_max_mm``: the same
largest distance with each rule run on its own.  ``--npz`` runs it on any head with ICT's
vertex order (an ICT identity, a variant head): the reference is vertex indices, so it
applies to such a head too (the face is then named after the file).

The reference is ICT-FaceKit's own 68 landmarks (``ict_head_landmarks.json``, the iBUG
68-point layout as vertex indices, placed by the model's authors; only tests and this
benchmark read it, never the add-on).  iBUG's 22-26 are the subject's left brow, 42-47 the
left eye, 54 the left mouth corner: the add-on's ``_L`` (+X).  Compared like with like:

==================  ==========================================================================
landmark            reference point
==================  ==========================================================================
``glabella``        the glabella as anatomy defines it (the most prominent midline point
                    between the brows), within the reference's bounds: the most forward point
                    of the midline profile from the top of the nose bridge (iBUG 27) up to
                    the inner brow ends' height (mean z of iBUG 21 and 22).  Not the profile
                    at that height itself: iBUG's brow points trace the brows' upper edge, and
                    on a head with a heavy brow ridge the glabella lies well below it
``brow_outer_L``    iBUG 26, the left brow's outer end
``eye_L``           the centroid of the left eye's contour, iBUG 42-47
``nose_tip``        iBUG 30, the nose tip
``mouth_corner_L``  iBUG 54, the left mouth corner (the outer lip contour's corner)
``chin``            the pogonion, the front of the chin: the most forward point of the midline
                    profile's forward bump below the mentolabial sulcus and above the menton
                    (iBUG 8), the sulcus being the profile's deepest point, from the chord
                    between the lower lip's lowest point (iBUG 57) and the menton.  iBUG 8
                    itself is the menton, the chin's lowest point, not its front; the
                    add-on's chin is the front
``hairline_center`` none: the 68 points end at the brows (and a bald scan shows no hairline)
``cheekbone_L``     none: the 68 points have no point on the cheek (the jaw contour 0-16 runs
                    round the face's outline, not over the malar eminence)
==================  ==========================================================================

"The midline" is the mean x of the reference's midline points (27-30, 33, 51, 57, 8); the
front surface is met by a ray along +Y (the face looks toward -Y) through the mesh's
triangles.  Pure NumPy, independent of the finder's own surface code.
"""

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from wrinkle_addon.core import landmark_finder  # noqa: E402

DEFAULT_NPZ = ROOT / "wrinkle_addon" / "data" / "ict_head.npz"
REFERENCE_NAME = "ict_head_landmarks.json"
#: ICT's own landmarks, a reference for the tests and this benchmark only (the add-on never reads it)
DEFAULT_REFERENCE = ROOT / "tests" / "data" / REFERENCE_NAME
GOAL_MM = 5.0
MIDLINE = (27, 28, 29, 30, 33, 51, 57, 8)  # iBUG points on the midline
NO_COUNTERPART = {
    "hairline_center": "the 68 iBUG points end at the brows; a bald scan shows no hairline",
    "cheekbone_L": "the 68 iBUG points have none on the cheek (the jaw contour 0-16 runs round "
                   "the face's outline, not over the malar eminence)",
}


def to_blender(a):
    """ICT (cm, Y up, face toward +Z) -> Blender (m, Z up, face toward -Y), as
    ``sample_scenes/lib/ict.py`` converts it: (x, y, z) -> (x, -z, y) * 0.01."""
    a = np.asarray(a, np.float64)
    return np.stack([a[..., 0], -a[..., 2], a[..., 1]], axis=-1) * 0.01


def load_head(npz=DEFAULT_NPZ):
    """``(positions (N, 3) m, quads (F, 4), shape_keys {name: (N, 3)})`` in Blender's frame."""
    with np.load(Path(npz)) as data:
        pos = to_blender(data["positions"])
        quads = np.asarray(data["quads"], np.int64)
        keys = {}
        if "expression_names" in data and "expression_deltas" in data:
            keys = {str(n): pos + to_blender(d)
                    for n, d in zip(data["expression_names"], data["expression_deltas"])}
    return pos, quads, keys


def load_reference(path):
    """The 68 iBUG points' vertex indices (index i is iBUG point i)."""
    with open(path, encoding="utf-8") as f:
        return np.asarray(json.load(f)["vertex_indices"], np.int64)


def front_surface(pos, quads, xz):
    """y of the front-most surface point on the ray along +Y through each (x, z) of ``xz``
    (K, 2) (NaN where it meets nothing): exact, over the quads split into triangles."""
    q = np.asarray(quads, np.int64)
    tris = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
    a, b, c = (pos[tris[:, i]] for i in range(3))
    xz = np.asarray(xz, np.float64).reshape(-1, 2)
    out = np.full(len(xz), np.nan)
    # 2-D barycentric coordinates of every ray in every triangle, the rays in chunks
    e1, e2 = (b - a)[:, [0, 2]], (c - a)[:, [0, 2]]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    ok = np.abs(det) > 1e-16
    for s in range(0, len(xz), 64):
        r = xz[s:s + 64, None, :] - a[None, ok][:, :, [0, 2]]
        u = (r[..., 0] * e2[ok, 1] - r[..., 1] * e2[ok, 0]) / det[ok]
        v = (e1[ok, 0] * r[..., 1] - e1[ok, 1] * r[..., 0]) / det[ok]
        hit = (u >= 0) & (v >= 0) & (u + v <= 1)
        y = a[ok, 1] + u * (b - a)[ok, 1] + v * (c - a)[ok, 1]
        y = np.where(hit, y, np.inf).min(axis=1)
        out[s:s + 64] = np.where(np.isfinite(y), y, np.nan)
    return out


def _midline_profile(pos, quads, x, z_lo, z_hi, step=0.00025):
    zs = np.arange(z_lo, z_hi + 0.5 * step, step)
    return zs, front_surface(pos, quads, np.column_stack([np.full(len(zs), x), zs]))


def reference_points(pos, quads, ibug):
    """name -> (3,) reference point of every add-on landmark with a counterpart (the
    module doc's table), from the iBUG vertex indices ``ibug`` on the head ``pos``."""
    pos = np.asarray(pos, np.float64)
    r = pos[ibug]
    mid_x = float(r[list(MIDLINE), 0].mean())
    zs, ys = _midline_profile(pos, quads, mid_x, r[27, 2], 0.5 * (r[21, 2] + r[22, 2]))
    g = int(np.nanargmin(ys))
    glabella = np.array([mid_x, ys[g], zs[g]])
    # the chin: the sulcus is the deepest point of the midline profile between the lower lip
    # (57) and the menton (8), measured from the chord between them (the profile turns back
    # under the chin toward the menton); the pogonion the most forward point between the
    # sulcus and the menton: the chin's forward bump (a local minimum of y 2 mm either side:
    # the lower lip's underside by a shallow sulcus reaches as far forward, but not as a bump)
    zs, ys = _midline_profile(pos, quads, mid_x, r[8, 2], r[57, 2])
    chord = ys[0] + (ys[-1] - ys[0]) * (zs - zs[0]) / (zs[-1] - zs[0])
    sulcus = int(np.nanargmax(ys - chord))
    w = 8  # samples: 2 mm
    padded = np.pad(np.where(np.isfinite(ys), ys, np.inf), w, constant_values=np.inf)
    window = np.lib.stride_tricks.sliding_window_view(padded, 2 * w + 1).min(axis=1)
    bump = np.flatnonzero((ys <= window) & (np.arange(len(ys)) >= w) & (np.arange(len(ys)) <= sulcus - w))
    pog = int(bump[np.argmin(ys[bump])]) if len(bump) else int(np.nanargmin(ys[:sulcus + 1]))
    return {
        "glabella": glabella,
        "brow_outer_L": r[26].copy(),
        "eye_L": r[42:48].mean(axis=0),
        "nose_tip": r[30].copy(),
        "mouth_corner_L": r[54].copy(),
        "chin": np.array([mid_x, ys[pog], zs[pog]]),
    }


def distances_mm(found, reference):
    """name -> distance (mm) of each reference point from the found landmark."""
    return {k: round(float(np.linalg.norm(np.asarray(found[k], np.float64) - v)) * 1000.0, 2)
            for k, v in reference.items()}


def measure(npz=DEFAULT_NPZ, reference_json=None):
    """The benchmark's result dict for the head ``npz`` (see the module doc)."""
    npz = Path(npz)
    reference_json = Path(reference_json) if reference_json else DEFAULT_REFERENCE
    pos, quads, keys = load_head(npz)
    ref = reference_points(pos, quads, load_reference(reference_json))
    found, method, _message = landmark_finder.find_landmarks(pos, quads, keys or None)
    mm = distances_mm(found, ref)
    rule_max = {}
    for rule in landmark_finder.RULES:
        f, m, _msg = landmark_finder.find_landmarks(pos, quads, keys or None, rules=(rule,))
        rule_max[rule] = max(distances_mm(f, ref).values()) if m == rule else None
    return {"face": "ict" if npz.name == "ict_head.npz" else npz.stem, "expression": "landmarks",
            "landmark_max_mm": max(mm.values()), "landmark_mm": mm, "method": method,
            "rule_max_mm": rule_max}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--npz", default=str(DEFAULT_NPZ), help="a head with ICT's topology")
    ap.add_argument("--json", default=None, help="the reference (default: tests/data/" + REFERENCE_NAME + ")")
    args = ap.parse_args(argv)
    npz = Path(args.npz)
    ref = Path(args.json) if args.json else DEFAULT_REFERENCE
    if not npz.exists() or not ref.exists():
        print(f"[landmarks] {npz if not npz.exists() else ref} is not available: nothing measured",
              file=sys.stderr)
        return 0
    print(json.dumps(measure(npz, ref)), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
