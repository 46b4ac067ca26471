"""Sample scene: forehead lines as wrinkle curves (Bando, Kuratate & Nishita 2002, §6-7) on
the scanned ICT head (the add-on's sample head, wrinkle_addon/data/ict_head.npz), next to the muscle wrinkles
of the same pose.

    python sample_scenes/forehead_curves.py [--out out/forehead_curves] [--size 512] [--samples 32]

``build()``: the head with its UVs, Enable Wrinkles, and three horizontal forehead lines
drawn as wrinkle curves.  The lines are placed from the head's landmarks: each follows the
arch of the brows (the parabola through the six brow landmarks, ``brow_arch``), flatter the
higher it lies, the lowest ``FIRST_LINE`` above the arch and the next ones ``LINE_SPACING``
apart, spanning the forehead between the outer brows but not the temples or the hairline,
and snapped to the skin.  Each has rest height r = 0: nothing at neutral, and the furrow
and its bulges rise with the skin's shrinkage across the line, ``M(s)`` (eq. 5), when the
brow shape keys (browInnerUp_L/R and browOuterUp_L/R) push the forehead skin up against
the hairline.  (The scan's brow raise shrinks the skin across the lines by s = 0.13-0.30,
most between 65 and 95 mm above the head's origin: three lines 10 mm apart fit there; a
fourth above them barely rises.)  The forehead is then refined around the lines by the
add-on's Refine Wrinkling Regions, so the millimetre-wide profile of eq. 2 has vertices to
live on, and the lines are snapped again.

``build_muscles()``: the same head, camera and keys with the facial muscle set, wrinkles
only (as ``scanned_head.build``), and no curves: Zhang's wrinkles of the same compression,
for comparison.

Both frame the upper face (eyes to hairline) and key Neutral on frame 1 and the brow raise on
frame 10 (``SHOTS``).  ``toggle`` is the demo's without / with switch for the curves (the
face's Strength scales the muscles only).  Run on its own, the script renders both with
the demo's machinery into one sheet, ``forehead_curves.png``: curves on top, muscles below.
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

from sample_scenes import scanned_head  # noqa: E402
from sample_scenes.lib import rigging, scene_setup  # noqa: E402

DATA = scanned_head.DATA
BROW_RAISE = dict(scanned_head.SURPRISE)  # browInnerUp_L/R + browOuterUp_L/R = 1
SHOTS = {"Neutral": 1, "Brow raise": 10}

# the forehead lines (metres), tuned by looking at the renders
LINES = 3
FIRST_LINE = 0.012  # the lowest line above the brows' arch at the midline
LINE_SPACING = 0.010  # between lines (real ones are 8-12 mm apart)
REACH = (0.82, 0.86, 0.76)  # each line's half length / the outer brow's distance from the midline
ARCH = (0.85, 0.65, 0.45)  # how much of the brows' arch each line keeps (upper lines flatter)
DEPTH = 0.003  # d of eq. 2 at full shrinkage; M(s) takes a fraction of it
WIDTH = 0.0025  # w of eq. 2: the bulges peak 2w from the furrow
TAPER = 0.012  # the fade at each end
POINTS = 9  # Bézier points per line



def available():
    return scanned_head.available()


def _landmarks(data):
    return {k: np.asarray(v, np.float64) for k, v in data["landmarks"].items()}


def _rest(face):
    me = face.data
    co = np.empty(len(me.vertices) * 3, np.float32)
    me.attributes["position"].data.foreach_get("vector", co)
    return co.reshape(-1, 3).astype(np.float64)


def brow_arch(lm):
    """z(x - midline) of the brows' arch: the even parabola through the brow landmarks (outer,
    middle and inner, both sides) by least squares, highest at the midline.  (An exact fit
    through them would dip between the inner brows; forehead lines arch over the whole
    forehead.)"""
    mid = lm["glabella"][0]
    pts = [lm[f"brow_{k}_{side}"] for k in ("outer", "mid", "inner") for side in ("L", "R")]
    x = np.array([p[0] - mid for p in pts])
    z = np.array([p[2] for p in pts])
    coef, *_ = np.linalg.lstsq(np.stack([np.ones_like(x), x ** 2], 1), z, rcond=None)
    coef[1] = min(coef[1], 0.0)  # never a bowl
    return lambda dx: coef[0] + coef[1] * np.asarray(dx) ** 2


def line_points(lm):
    """The forehead lines seen from the front: per line, (POINTS, 2) of (x, z), lowest first."""
    mid = lm["glabella"][0]
    arch = brow_arch(lm)
    outer = 0.5 * (abs(lm["brow_outer_L"][0] - mid) + abs(lm["brow_outer_R"][0] - mid))
    top = arch(0.0)
    out = []
    for k in range(LINES):
        half = REACH[k] * outer
        dx = np.linspace(-half, half, POINTS)
        z = top + FIRST_LINE + k * LINE_SPACING + ARCH[k] * (arch(dx) - top)
        out.append(np.stack([mid + dx, z], 1))
    return out


def project_front(face, xz):
    """Points (k, 2) of (x, z) onto the face's front surface, along +Y (local space)."""
    from mathutils import Vector
    from mathutils.bvhtree import BVHTree

    me = face.data
    rest = _rest(face)
    polys = [tuple(p.vertices) for p in me.polygons]
    bvh = BVHTree.FromPolygons(rest.tolist(), polys)
    y0 = rest[:, 1].min() - 0.05
    out = []
    for x, z in xz:
        hit = bvh.ray_cast(Vector((x, y0, z)), Vector((0.0, 1.0, 0.0)))
        if hit[0] is None:
            raise RuntimeError(f"no skin in front at x={x:.3f}, z={z:.3f}")
        out.append(tuple(hit[0]))
    return np.array(out)


def frame_upper_face(scene, face, lm, height=None):
    """The portrait rig, the camera moved up to frame brows to hairline."""
    scene_setup.add_portrait_rig(scene, face, view="front", frame_scale=1.35)
    cam = scene.camera
    top = lm["hairline_center"][2] + 0.012
    low = min(lm["eye_L"][2], lm["eye_R"][2]) - 0.012
    if height is None:
        height = top - low
    # the camera looks along +Y: its height is the frame's centre; its distance sets the size
    half_fov = math.atan(0.5 * cam.data.sensor_width / cam.data.lens)
    dist = 0.5 * height / math.tan(half_fov)
    cam.location = (lm["glabella"][0], lm["glabella"][1] - dist, 0.5 * (top + low))
    return cam


def add_curves(face, rows, name, depth, width, rest_height, taper=None):
    """Wrinkle curves of ``face`` through the (x, z) ``rows`` projected onto its front,
    snapped to its skin (``name`` 1, 2, ...).  Returns the curve objects."""
    from wrinkle_addon.glue.bando import curves

    made = []
    for k, xz in enumerate(rows):
        ob = curves.create(bpy.context, face, project_front(face, xz), name=f"{name} {k + 1:02d}")
        s = ob.ewrinkles_curve
        s.depth, s.width, s.rest_height = depth, width, rest_height
        if taper is not None:
            s.taper = taper
        made.append(ob)
    _snap_all(face)
    return made


def _snap_all(face):
    rigging.activate(face)
    lst = face.ewrinkles_face.wrinkle_curves
    for i in range(len(lst.items)):
        lst.active = i
        assert bpy.ops.wrinkle.snap_curve() == {"FINISHED"}


def add_lines(face, lm):
    """The forehead lines as wrinkle curves of ``face``, snapped to its skin."""
    return add_curves(face, line_points(lm), "Forehead Line", DEPTH, WIDTH, 0.0, TAPER)


def toggle(face, on):
    """The demo's without / with switch: the curves (and the muscles' Strength) on or off."""
    face.ewrinkles_face.strength = 1.0 if on else 0.0
    for ref in face.ewrinkles_face.wrinkle_curves.items:
        if ref.object is not None and ref.object.ewrinkles_curve.enabled != on:
            ref.object.ewrinkles_curve.enabled = on


def _head():
    from sample_scenes.lib import ict

    data = ict.load_ict(DATA)
    return ict.ict_object(data, name="ICTHead"), _landmarks(data)


def _animate(scene, face):
    rigging.key_shape_keys(face, {SHOTS["Neutral"]: {}, SHOTS["Brow raise"]: BROW_RAISE})
    scene.frame_start, scene.frame_end = 1, max(SHOTS.values())


def build():
    scene = bpy.context.scene
    face, lm = _head()
    frame_upper_face(scene, face, lm)
    add_lines(face, lm)  # before Enable Wrinkles: setting their parameters rebuilds nothing yet
    rigging.activate(face)
    assert bpy.ops.wrinkle.refine() == {"FINISHED"}  # around the curves (Bando 2002 §6)
    _snap_all(face)  # the refined skin moved onto the smooth surface: back onto it
    bpy.ops.wrinkle.enable()
    _animate(scene, face)
    return face, dict(SHOTS)


def build_muscles():
    scene = bpy.context.scene
    face, lm = _head()
    frame_upper_face(scene, face, lm)
    rigging.wrinkle_face(face, lm, wrinkles_only=True)
    _animate(scene, face)
    return face, dict(SHOTS)


def main(argv=None):
    from sample_scenes.lib import rendering

    rendering.enable_addon()

    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=str(ROOT / "out" / "forehead_curves"), help="output folder")
    parser.add_argument("--size", type=int, default=512, help="render size in pixels")
    parser.add_argument("--samples", type=int, default=32, help="Cycles samples")
    args = parser.parse_args(argv)
    if not available():
        raise SystemExit(f"forehead_curves: {DATA} not found")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    jobs = [("forehead_curves", build, toggle),
            ("forehead_muscles", build_muscles, rendering.geometric_toggle)]
    rows, captions = [], []
    for name, builder, switch in jobs:
        row, row_captions = rendering.render_scene(name, builder, out, args.size, args.samples, switch)
        rows.append(row)
        captions.append(row_captions)
    sheet = out / "forehead_curves.png"
    rendering.contact_sheet(rows, sheet, row_names=[j[0] for j in jobs], captions=captions)
    rendering.log(f"contact sheet -> {sheet}")
    bpy.ops.wm.read_factory_settings(use_empty=True)  # avoids the bpy 4.5 exit hang


if __name__ == "__main__":
    main(sys.argv[1:] if "--" not in sys.argv else sys.argv[sys.argv.index("--") + 1:])
