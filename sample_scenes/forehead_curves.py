"""Sample scene: forehead lines as wrinkle curves (Bando, Kuratate & Nishita 2002, §6-7) on
the scanned ICT head (../shared/data/ict_head.npz, not shipped), next to the muscle wrinkles
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
fourth above them barely rises.)  The forehead is first refined around the lines
(``refine_along``) so the millimetre-wide profile of eq. 2 has vertices to live on:
11k -> 19k vertices.

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

# refinement around the lines (``refine_along``), in wrinkle widths
FINE_REACH, FINE_EDGE = 4.0, 0.45  # near the furrow: edges of at most 0.45 w
COARSE_EDGE = 1.2  # out to the cut-off, 10 w: at most 1.2 w


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


def _distance_to(points, samples):
    """Distance (N,) from 3-D points to the nearest of dense 3-D ``samples`` (a KD tree)."""
    from mathutils.kdtree import KDTree

    tree = KDTree(len(samples))
    for i, co in enumerate(samples):
        tree.insert(co, i)
    tree.balance()
    return np.array([tree.find(co)[2] for co in points])


def refine_along(face, lines, width=WIDTH, max_passes=8):
    """Adaptive refinement around the wrinkle locations (Bando et al. 2002, §6: "if the mesh is
    not fine enough to represent wrinkles, we apply the adaptive refinement around the specified
    wrinkle locations"): edges within ``FINE_REACH`` widths of a line (3-D polylines, face
    space) are bisected until no longer than ``FINE_EDGE`` widths, and up to the profile's
    cut-off (10 w) until no longer than ``COARSE_EDGE`` widths.

    The bisection pass is the add-on's own (``glue.muscles.refine.bisect_pass``, which its
    Refine Wrinkling Regions runs around the muscles' regions only): new points on the
    smooth surface through the old ones, for the mesh and every shape key, UVs interpolated;
    the pentagons it leaves are triangulated after each pass (``_triangulate_ngons``).
    Returns the passes made (6 on the ICT head)."""
    from wrinkle_addon.core.muscles import refinement
    from wrinkle_addon.glue import meshio
    from wrinkle_addon.glue.muscles import refine as addon_refine

    me = face.data
    samples = np.concatenate(lines)  # dense: their spacing is far below a width
    passes = max_passes
    for i in range(max_passes):
        rest = meshio.read_vectors(me, "position").astype(np.float64)
        edges = meshio.read_edges(me).astype(np.int64)
        p0, p1 = rest[edges[:, 0]], rest[edges[:, 1]]
        length = np.linalg.norm(p1 - p0, axis=1)
        near = np.full(len(edges), np.inf)
        box = np.flatnonzero(((np.minimum(p0, p1) < samples.max(axis=0) + 10.0 * width)
                              & (np.maximum(p0, p1) > samples.min(axis=0) - 10.0 * width)).all(axis=1))
        for p in (p0[box], 0.5 * (p0[box] + p1[box]), p1[box]):
            near[box] = np.minimum(near[box], _distance_to(p, samples))
        limit = np.where(near < FINE_REACH * width, FINE_EDGE * width,
                         np.where(near < 10.0 * width, COARSE_EDGE * width, np.inf))
        need = np.flatnonzero(length > limit)
        if len(need) == 0:
            passes = i
            break
        corner, starts, sizes = meshio.read_polygons(me)
        split, _grid = refinement.split_edges(rest, edges, corner, starts, sizes, need)
        addon_refine.bisect_pass(me, edges[split], split)
        _triangulate_ngons(me)
    return passes


def _triangulate_ngons(me):
    """Split the pentagons a bisection pass leaves (a quad with one split edge) into
    triangles, after every pass.  No vertex is added: shape keys and UVs stay.

    Such a pentagon has a corner of 180 degrees at the new point.  Kept to the next pass,
    bmesh cuts that corner off as a zero-area triangle when both halves of the edge are split
    again, and the pass after puts a new point on top of the old one; kept to the end,
    Blender fans it into a sliver.  Either way a normal there is ill-defined, and the render
    shows dark dots or dashes (above the glabella once the brows rise)."""
    import bmesh

    bm = bmesh.new()
    bm.from_mesh(me)
    ngons = [f for f in bm.faces if len(f.verts) > 4]
    bmesh.ops.triangulate(bm, faces=ngons, quad_method="BEAUTY", ngon_method="BEAUTY")
    bm.to_mesh(me)
    bm.free()
    me.update()


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


def dense_lines(face, lm, samples=400):
    """The forehead lines sampled densely along x and projected onto the skin (for the
    refinement); the curves' own Bézier points are ``line_points``'s."""
    out = []
    for xz in line_points(lm):
        x = np.linspace(xz[0, 0], xz[-1, 0], samples)
        out.append(project_front(face, np.stack([x, np.interp(x, xz[:, 0], xz[:, 1])], 1)))
    return out


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
    rigging.activate(face)
    lst = face.ewrinkles_face.wrinkle_curves
    for i in range(len(lst.items)):
        lst.active = i
        assert bpy.ops.wrinkle.snap_curve() == {"FINISHED"}
    return made


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
    refine_along(face, dense_lines(face, lm))
    frame_upper_face(scene, face, lm)
    add_lines(face, lm)  # before Enable Wrinkles: setting their parameters rebuilds nothing yet
    rigging.activate(face)
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
    from sample_scenes import demo  # enables the add-on

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
    jobs = [("forehead_curves", build, toggle), ("forehead_muscles", build_muscles, demo.geometric_toggle)]
    rows, captions = [], []
    for name, builder, switch in jobs:
        row, row_captions = demo.render_scene(name, builder, out, args.size, args.samples, switch)
        rows.append(row)
        captions.append(row_captions)
    sheet = out / "forehead_curves.png"
    demo.contact_sheet(rows, sheet, row_names=[j[0] for j in jobs], captions=captions)
    demo.log(f"contact sheet -> {sheet}")
    bpy.ops.wm.read_factory_settings(use_empty=True)  # avoids the bpy 4.5 exit hang


if __name__ == "__main__":
    main(sys.argv[1:] if "--" not in sys.argv else sys.argv[sys.argv.index("--") + 1:])
