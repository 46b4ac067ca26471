# SPDX-License-Identifier: GPL-3.0-or-later
"""How real the muscle wrinkles look: furrow counts, continuity, angles, spacing, depths.

Run:  .venv45/bin/python benchmarks/realism.py   (or .venv52)
      options: --faces ict,procedural (both by default)  --npz PATH  --step 0.5  --dump DIR

Prints one JSON line per (face, expression) on stdout, e.g.::

    {"face": "ict", "expression": "brow_raise", "furrows": 4, "continuity": 0.7, "angle_deg": 6.0,
     "spacing_cv": 0.2, "furrow_bulge_ratio": 1.8, "eyelid_lip_max_mm": 0.0}

with the keys that apply to the expression (progress and details go to stderr), and for a
head with ICT's topology whose reference lies beside it, a line with ``"expression":
"landmarks"`` (``benchmarks/landmarks.py``: the found landmarks against ICT's own 68).  How each
number is measured, and its goal, is in ``benchmarks/realism_measures.py``.  For the ICT head
(or ``--npz``) it then renders (``--no-renders`` leaves this out): ``"expression": "map_anger"``
and ``"map_surprise"`` with ``map_geometry_ratio`` (``benchmarks/map_look.py``: the wrinkle
maps against the geometric wrinkles of the same pose), and for the sample head ``"expression":
"tear"`` with ``tear_luminance_ratio`` and ``tear_highlight_ratio`` per engine
(``benchmarks/tear_look.py``).

The faces, rigged as the sample scenes rig them (``sample_scenes/lib/rigging.py``):

* ``ict``: the scanned ICT head (the add-on's sample head,
  ``wrinkle_addon/data/ict_head.npz``), as ``sample_scenes/scanned_head.py`` builds it: its landmarks
  from ``sample_scenes/lib/ict.py``, the facial muscle set wrinkles-only, the regions
  refined, posed by its ARKit shape keys: brow_raise = browInnerUp_L/R + browOuterUp_L/R,
  brow_down = browDown_L/R, smile = mouthSmile_L/R, squint = eyeSquint_L/R +
  cheekSquint_L/R, all at 1; anger = browDown_L/R + noseSneer_L/R at 1 (the brows drawn
  down and together, the nose wrinkled: FACS AU 4 + 9) + eyeSquint_L/R at 0.5 (the lids
  tightened, AU 7).  ``--npz PATH`` runs the same on any head file with the ICT layout (its
  face is named after the file; ``tools/variant_head.py`` writes one the benchmark has
  never seen).
* ``procedural``: ``sample_scenes/lib/headgen.py``'s head (40k vertices) as
  ``sample_scenes/head.py`` builds it: pulling muscles posed by the add-on's expression
  presets (``wrinkle.expression``): brow_raise = Surprise, brow_down = Frowning.  There is
  no smile, squint or anger preset; those contract muscles by role (keyed like the
  operator keys a preset): smile both Zygomaticus Major fully, squint both Orbicularis
  Oculi fully (the line is left out when the face has no such muscle), anger the
  Corrugators, the Procerus and the Nasalis fully and the Orbicularis Oculi at 0.5 (the
  roles the face has).

Each pose is a frame; on it the add-on's own frame stage runs (the handler), and the
heights are computed with the functions it calls: the muscle source's ``build`` (the plan,
``core.muscles.system.build_plan``) on the face's mesh read by ``glue.meshio``, the skin the
*Wrinkles* modifier stored (``wrinkle_skin``), the source's contractions, and
``core.muscles.system.heights`` and ``evaluate``.  The wrinkled skin is checked against
what the frame stage left in the evaluated mesh (``offset_check_mm`` on stderr).  Heights and positions are in
millimetres; the positions are the wrinkled skin (skin + pull + heights), in the face's
local space.  The regions are set from the landmarks, each moved with the skin (the
nearest vertex's posed position):

* forehead: x between the outer brows, z from the highest brow landmark to the hairline;
  the brow line runs through the two outer brows;
* glabella: x within 0.4 half brow widths of the glabella, z from halfway between the
  eyes and the glabella up to 0.4 of the way to the hairline;
* below the eyes: z from the chin to the lower eye, x within the cheekbones; each
  nasolabial band is 0.3 mouth half-widths (corner to midline) either side of the segment
  from 0.1 of that beside and above the nose's wing to 0.4 of it beside and 0.2 below the
  mouth corner;
* eyelids and lips: the add-on's zones (``core.zones.face_zones``), on the rest mesh;
* crow's feet (squint): per side the outer eye corner, estimated on the rest mesh as the
  lateral end of the zones' eyelid ellipse (the eye's centre moved outward by
  ``zones.EYELID["half_width"]`` times the eyes' distance E, at the eye's height and depth), is the
  nearest vertex's posed position; E is twice the rest eye-to-glabella distance.  The
  grid is seen along the mean normal of the posed skin lateral of the corner (turned
  about the vertical through the corner) and covers 0 to 0.6 E outward and +-0.45 E in
  height; the measure keeps 0.1 E to 0.6 E;
* nose root (anger): x within 0.25 E of the glabella, z from the eyes' mean height up to
  the glabella.

The smile's knots are logged with the muscles whose regions hold the vertex nearest each
(their fully formed heights there, ``system.formed_heights``).
"""

import argparse
import json
import sys
import time
import traceback
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402, I001
import addon_utils  # noqa: E402
import numpy as np  # noqa: E402

from benchmarks import realism_measures as rm  # noqa: E402

ICT_POSES = {
    "brow_raise": {"browInnerUp_L": 1.0, "browInnerUp_R": 1.0, "browOuterUp_L": 1.0, "browOuterUp_R": 1.0},
    "brow_down": {"browDown_L": 1.0, "browDown_R": 1.0},
    "smile": {"mouthSmile_L": 1.0, "mouthSmile_R": 1.0},
    "squint": {"eyeSquint_L": 1.0, "eyeSquint_R": 1.0, "cheekSquint_L": 1.0, "cheekSquint_R": 1.0},
    "anger": {"browDown_L": 1.0, "browDown_R": 1.0, "noseSneer_L": 1.0, "noseSneer_R": 1.0,
              "eyeSquint_L": 0.5, "eyeSquint_R": 0.5},
}
PROCEDURAL_POSES = {"brow_raise": "SURPRISE", "brow_down": "FROWN", "smile": {"ZYGOMATICUS_MAJOR": 1.0},
                    "squint": {"ORBICULARIS_OCULI": 1.0},
                    "anger": {"CORRUGATOR": 1.0, "PROCERUS": 1.0, "NASALIS": 1.0, "ORBICULARIS_OCULI": 0.5}}
# a pose by role is left out when the face has none of its roles in this set
REQUIRED_ROLES = {"squint": {"ORBICULARIS_OCULI"}}
BROWS = ("brow_inner_L", "brow_inner_R", "brow_mid_L", "brow_mid_R", "brow_outer_L", "brow_outer_R")


def log(msg):
    print(f"[realism] {msg}", file=sys.stderr, flush=True)


def clean(value):
    if isinstance(value, dict):
        return {k: clean(v) for k, v in value.items()}
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return round(float(value), 3)
    return value


# --------------------------------------------------------------------------- faces
def reference_json(path):
    """The iBUG-68 reference of the head file ``path`` (``benchmarks/landmarks.py``): the
    json beside it, or for the add-on's sample head ``tests/data``'s; None without one."""
    from benchmarks import landmarks

    ref = Path(path).with_name(landmarks.REFERENCE_NAME)
    if ref.exists():
        return ref
    if Path(path).resolve() == Path(landmarks.DEFAULT_NPZ).resolve() and landmarks.DEFAULT_REFERENCE.exists():
        return landmarks.DEFAULT_REFERENCE
    return None


def build_ict(path):
    """(face, landmarks, {expression: frame}, inner brows): the inner brow ends are the
    reference's iBUG 22 (``_L``, +X) and 21 (``_R``) on the rest mesh (the landmarks'
    units) when the head has a reference (:func:`reference_json`), else None."""
    from benchmarks import landmarks as ibug
    from sample_scenes.lib import ict, rigging

    data = ict.load_ict(path)
    face = ict.ict_object(data, name="ICTHead")
    rigging.wrinkle_face(face, data["landmarks"], wrinkles_only=True)
    frames = {i + 1: values for i, values in enumerate(ICT_POSES.values())}
    rigging.key_shape_keys(face, frames)
    ref = reference_json(path)
    inner = None
    if ref is not None:
        idx = ibug.load_reference(ref)
        pos = np.asarray(data["positions"], np.float64)
        inner = {"brow_inner_L": pos[idx[22]], "brow_inner_R": pos[idx[21]]}
        log(f"inner brows: iBUG 22 (L) and 21 (R) of {ref}")
    else:
        log("no iBUG reference beside the head: the inner brows are its brow_inner_L/R landmarks")
    return face, data["landmarks"], dict(zip(ICT_POSES, frames)), inner


def build_procedural(target_verts=40000):
    from sample_scenes.lib import headgen, rigging, scene_setup

    head = headgen.make_head(target_verts)
    face = scene_setup.mesh_object_from_arrays("Head", head["positions"], head["quads"], head["corner_uvs"])
    rigging.wrinkle_face(face, head["landmarks"])
    from wrinkle_addon.glue.muscles import muscle_objects

    scene = bpy.context.scene
    roles = {m.ewrinkles_muscle.role for m in muscle_objects.live_muscles(face)}
    frames = {}
    for i, (name, pose) in enumerate(PROCEDURAL_POSES.items()):
        if name in REQUIRED_ROLES and not REQUIRED_ROLES[name] & roles:
            log(f"procedural: no {', '.join(sorted(REQUIRED_ROLES[name]))} muscle: {name} left out")
            continue
        frames[name] = frame = i + 1
        if isinstance(pose, str):
            rigging.key_expressions(face, {frame: pose})
            continue
        scene.frame_set(frame)
        for m in muscle_objects.live_muscles(face):  # keyed as the expression operator keys a preset
            m.ewrinkles_muscle.contraction = pose.get(m.ewrinkles_muscle.role, 0.0)
            m.keyframe_insert("ewrinkles_muscle.contraction", frame=frame)
    return face, head["landmarks"], frames, None


# --------------------------------------------------------------------------- heights
class FaceHeights:
    """The add-on's wrinkle heights on one face, computed as its frame stage computes them."""

    def __init__(self, face):
        from wrinkle_addon.core import mesh as core_mesh
        from wrinkle_addon.glue import meshio, registry
        from wrinkle_addon.glue.muscles import muscle_objects

        self.face = face
        me = face.data
        rest = meshio.read_vectors(me, "position")
        corner, starts, sizes = meshio.read_polygons(me)
        tris = core_mesh.fan_triangles(corner, starts, sizes)
        self.mesh = registry.MeshArrays(rest, meshio.read_edges(me), tris)
        self.source = next(s for s in registry.sources() if s.name == "muscles")
        in_scene = {o.session_uid for o in bpy.context.scene.objects}
        self.static = self.source.build(face, self.mesh, in_scene)
        self.mm = 1000.0 * muscle_objects.face_scale(face)  # local units -> mm
        # each muscle's role, in the order of the plan's muscles (the source's static.names)
        roles = {ob.name: ob.ewrinkles_muscle.role for ob in muscle_objects.live_muscles(face)}
        self.roles = [roles.get(n) for n in self.static.names]

    def role_verts(self, role):
        """The vertices (global indices) in the wrinkling regions of the muscles of ``role``."""
        plan = self.static.plan
        rows = np.isin(plan.row_muscle, [m for m, r in enumerate(self.roles) if r == role])
        return np.unique(plan.verts[plan.row_vert[rows]])

    def at(self, frame):
        """(heights (N,) mm, wrinkled positions (N, 3) mm, largest difference in mm from the
        positions the frame stage left in the evaluated mesh, the posed skin before the
        wrinkles (N, 3) mm: the skin the modifier stored plus the muscles' Waters pull, none
        on a wrinkles-only face) on ``frame``."""
        from wrinkle_addon.core.muscles import system
        from wrinkle_addon.glue import meshio, stage

        scene = bpy.context.scene
        scene.frame_set(frame)
        n = len(self.mesh.rest)
        ev = self.face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
        skin = meshio.read_vector_prefix(ev, stage.SKIN_ATTR, n, np.empty((n, 3), np.float32))
        contraction = self.source.inputs(self.face, self.static).values
        strength = self.face.ewrinkles_face.strength
        plan = self.static.plan
        heights = system.heights(plan, skin, contraction, strength)
        offset = system.evaluate(plan, skin, contraction, strength)
        # what the user sees: the evaluated mesh after the frame stage ran (it writes into
        # the evaluated mesh, or back into the original and Blender evaluates it again)
        ev = self.face.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
        shown = meshio.read_vector_prefix(ev, "position", n, np.empty((n, 3), np.float32))
        check = float(np.abs(shown - (skin + offset)).max()) * self.mm
        pulled = skin.astype(np.float64)
        pull = system.waters_pull(plan, np.ascontiguousarray(skin[plan.verts].T), contraction)
        if pull is not None:
            pulled[plan.verts] += pull.T
        return (heights.astype(np.float64) * self.mm, (skin + offset).astype(np.float64) * self.mm, check,
                pulled * self.mm)

    def formed_at(self, vertex):
        """[(muscle name, its fully formed height at ``vertex`` in mm)] for the muscles
        whose wrinkling region holds it, largest |height| first."""
        from wrinkle_addon.core.muscles import system

        plan = self.static.plan
        strength = self.face.ewrinkles_face.strength
        out = []
        for m, name in enumerate(self.static.names):
            v = float(system.formed_heights(plan, m, strength)[vertex]) * self.mm
            if v != 0.0:
                out.append((name, v))
        return sorted(out, key=lambda t: -abs(t[1]))


# --------------------------------------------------------------------------- regions
def posed_landmarks(rest, posed_mm, landmarks):
    """Each landmark at the posed position (mm) of its nearest rest vertex; right-side
    ones missing from ``landmarks`` mirrored about the glabella."""
    rest = np.asarray(rest, np.float64)
    out = {}
    for name, p in landmarks.items():
        out[name] = posed_mm[int(np.argmin(np.sum((rest - np.asarray(p, float)) ** 2, axis=1)))]
    g = out["glabella"]
    for name in list(out):
        if name.endswith("_L") and name[:-2] + "_R" not in out:
            q = out[name].copy()
            q[0] = 2.0 * g[0] - q[0]
            out[name[:-2] + "_R"] = q
    return out


def forehead_box(lm):
    x = sorted((lm["brow_outer_R"][0], lm["brow_outer_L"][0]))
    z_brow = max(lm[k][2] for k in BROWS if k in lm)
    bo_l, bo_r = lm["brow_outer_L"], lm["brow_outer_R"]
    angle = float(np.degrees(np.arctan2(bo_l[2] - bo_r[2], bo_l[0] - bo_r[0])))
    return x, (z_brow, lm["hairline_center"][2]), angle


def glabella_box(lm):
    g = lm["glabella"]
    bw = 0.5 * abs(lm["brow_outer_L"][0] - lm["brow_outer_R"][0])
    eye_z = 0.5 * (lm["eye_L"][2] + lm["eye_R"][2])
    top = g[2] + 0.4 * (lm["hairline_center"][2] - g[2])
    return (g[0] - 0.4 * bw, g[0] + 0.4 * bw), (0.5 * (eye_z + g[2]), top)


def below_eyes(lm):
    x = sorted((lm["cheekbone_R"][0], lm["cheekbone_L"][0]))
    return x, (lm["chin"][2], min(lm["eye_L"][2], lm["eye_R"][2]))


def interocular(landmarks, mm):
    """E: twice the rest eye-to-glabella distance across, in mm."""
    return 2.0 * abs(float(landmarks["eye_L"][0]) - float(landmarks["glabella"][0])) * mm


def eye_corners(landmarks):
    """The outer eye corners on the rest mesh ({'eye_corner_L': p, 'eye_corner_R': p}, the
    landmarks' units): the lateral ends of ``core.zones``' eyelid ellipses (the right one
    mirrored about the glabella, as there)."""
    from wrinkle_addon.core import zones

    g, bo, eye = (np.asarray(landmarks[k], float) for k in ("glabella", "brow_outer_L", "eye_L"))
    reach = abs(eye[0] - g[0]) + zones.EYELID["half_width"] * 2.0 * abs(eye[0] - g[0])
    out = {}
    for side, s in (("L", 1.0), ("R", -1.0)):
        c = eye.copy()
        c[0] = g[0] + s * reach
        out[f"eye_corner_{side}"] = c
    return out


def temple_grid(posed, tris, heights, corner, s, e, step):
    """The crow's feet grid of one side (``s`` +1 left, -1 right): the posed skin turned
    about the vertical through ``corner`` so that its mean normal lateral of the corner
    faces the viewer, resampled 0 to 0.6 E outward and +-0.45 E in height.  Returns
    (grid, the turn in degrees)."""
    c = np.asarray(corner, float)
    p = posed[tris]
    centre = p.mean(axis=1)
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])  # area-weighted
    lateral = s * (centre[:, 0] - c[0])
    near = ((lateral >= 0.05 * e) & (lateral <= 0.6 * e) & (np.abs(centre[:, 2] - c[2]) <= 0.45 * e)
            & (centre[:, 1] - c[1] <= 0.5 * e) & ((n[:, 1] < 0) | (s * n[:, 0] > 0)))
    m = n[near].sum(axis=0) if near.any() else np.array([0.0, -1.0, 0.0])
    yaw = float(np.arctan2(m[0], -m[1])) if np.hypot(m[0], m[1]) > 0 else 0.0
    yaw = float(np.clip(yaw, -np.radians(80.0), np.radians(80.0)))
    ca, sa = np.cos(-yaw), np.sin(-yaw)  # turn the normal's horizontal part onto -y
    d = posed - c
    turned = np.stack([c[0] + d[:, 0] * ca - d[:, 1] * sa, c[1] + d[:, 0] * sa + d[:, 1] * ca, posed[:, 2]],
                      1)
    x = sorted((c[0], c[0] + s * 0.6 * e))
    z = (c[2] - 0.45 * e, c[2] + 0.45 * e)
    return rm.front_grid(turned, tris, heights, x, z, step), float(np.degrees(yaw))


def nose_root_box(lm, e):
    g = lm["glabella"]
    eye_z = 0.5 * (lm["eye_L"][2] + lm["eye_R"][2])
    return (g[0] - 0.25 * e, g[0] + 0.25 * e), (min(eye_z, g[2]), max(eye_z, g[2]))


def nearest_front_vertex(posed, x, z, radius=1.5):
    """The front-most posed vertex within ``radius`` mm of (x, z) in the front plane (or
    the nearest there)."""
    d = np.hypot(posed[:, 0] - x, posed[:, 2] - z)
    close = np.flatnonzero(d <= radius)
    return int(close[np.argmin(posed[close, 1])]) if len(close) else int(np.argmin(d))


def nasolabial_band(grid, lm, side):
    """The nasolabial band of one side ('L' or 'R') on ``grid`` (see the module doc)."""
    g = lm["glabella"]
    s = 1.0 if side == "L" else -1.0
    corner = lm[f"mouth_corner_{side}"]
    mw = abs(corner[0] - g[0])
    ala = lm.get(f"nose_ala_{side}")
    if ala is None:  # the wing of the nose, roughly, from the nose tip
        ala = lm["nose_tip"] + np.array([s * 0.65 * mw, 0.0, -0.3 * mw])
    a = (ala[0] + s * 0.1 * mw, ala[2] + 0.1 * mw)
    b = (corner[0] + s * 0.4 * mw, corner[2] - 0.2 * mw)
    return rm.segment_band(grid, a, b, 0.3 * mw)



# --------------------------------------------------------------------------- measures
def balance(row, name, expression, feature, deepest, counts):
    """One feature's left/right balance (``rm.lr_balance``) into ``row``, logged."""
    got = rm.lr_balance(deepest, counts)
    row[f"lr_ratio_{feature}"], row[f"lr_counts_{feature}"] = got["ratio"], got["counts"]

    def depth(v):
        return "nothing" if v is None or not v > 0 else f"{v:.3f} mm"

    why = ""
    if got["ratio"] is None:
        why = " (None: " + " and ".join(f"side {k} has nothing" for k in "LR"
                                       if deepest[k] is None or not deepest[k] > 0) + ")"
    ratio = "None" if got["ratio"] is None else f"{got['ratio']:.3f}"
    log(f"{name} {expression}: balance {feature}: deepest L {depth(deepest['L'])}, R {depth(deepest['R'])}, "
        f"counts [L, R] {got['counts']}, ratio {ratio}{why}")


def curvature(row, name, expression, region, grid):
    """``ridge_curvature_max`` of ``grid`` into ``row``, logged with where it sits."""
    got = rm.ridge_curvature_max(grid)
    row["ridge_curvature_max"] = got["ridge_curvature_max"]
    where = ("no cell 0.1 mm deep or high" if got["where"] is None else
             "at x {:.1f} z {:.1f} mm (h {:+.2f} mm)".format(*got["where"]))
    log(f"{name} {expression}: {region}: ridge_curvature_max {got['ridge_curvature_max']:.3f} /mm {where}")


def slit_line(row, name, expression, region, grid, across):
    """``slit_count`` of ``grid`` (furrows across ``across``) into ``row``, logged."""
    got = rm.slits(grid, across)
    row["slit_count"] = got["slit_count"]
    lines = sorted(got["lines"], key=lambda t: -(t[3] or 0.0))[:8]
    log(f"{name} {expression}: {region}: {got['slit_count']} slits; ridge-lines >= 0.1 mm deep at their "
        "deepest 10 % (x, z, width, depth mm, width/depth) "
        + ", ".join(f"({x:.1f}, {z:.1f}, unknown)" if w is None else
                    f"({x:.1f}, {z:.1f}, {w:.2f}, {d:.2f}, {q:.1f}{' SLIT' if q < 3.0 else ''})"
                    for x, z, w, d, q in lines))


def strain(row, name, expression, heights, posed, skin, fh, lm):
    """``strain_r``, ``strain_r_corrugator``, ``strain_r_procerus``: the correlation of the
    skin's compression (rest -> posed skin, before the wrinkles) with |h|."""
    eps = rm.vertex_compression(fh.mesh.rest * fh.mm, skin, fh.mesh.tris)
    depth = np.abs(heights)
    (x0, x1), (z0, z1) = glabella_box(lm)
    front = rm.vertex_normals(posed, fh.mesh.tris)[:, 1] < 0.0
    box = np.flatnonzero(front & (posed[:, 0] >= x0) & (posed[:, 0] <= x1)
                         & (posed[:, 2] >= z0) & (posed[:, 2] <= z1))
    for key, verts, what in (("strain_r", box, "glabella box, front"),
                             ("strain_r_corrugator", fh.role_verts("CORRUGATOR"), "corrugator regions"),
                             ("strain_r_procerus", fh.role_verts("PROCERUS"), "procerus region")):
        row[key] = r = rm.pearson(eps[verts], depth[verts])
        got = "None" if r is None else f"{r:.3f}"
        detail = "no vertices"
        if len(verts):
            detail = (f"compression mean {eps[verts].mean():.3f} max {eps[verts].max():.3f}, |h| mean "
                      f"{depth[verts].mean():.3f} max {depth[verts].max():.3f} mm")
        log(f"{name} {expression}: {key} {got} over {len(verts)} vertices ({what}); {detail}")


def measure(name, expression, heights, posed, fh, landmarks, zones, step, dump, skin=None, inner_brows=None):
    tris = fh.mesh.tris
    extra = {f"ref_{k}": v for k, v in (inner_brows or {}).items()}
    lm = posed_landmarks(fh.mesh.rest, posed, {**landmarks, **eye_corners(landmarks), **extra})
    e = interocular(landmarks, fh.mm)
    row = {"face": name, "expression": expression}
    grids = {}
    if expression == "brow_raise":
        x, z, angle = forehead_box(lm)
        grids["forehead"] = grid = rm.front_grid(posed, tris, heights, x, z, step)
        got = rm.forehead(grid, brow_angle_deg=angle)
        row.update(got)
        log(f"{name} {expression}: forehead x {x[0]:.1f}..{x[1]:.1f} z {z[0]:.1f}..{z[1]:.1f} mm, "
            f"brow line {angle:.1f} deg, min height {np.nanmin(grid.h):.3f} mm, max {np.nanmax(grid.h):.3f}")
        halves = rm.forehead_sides(grid, float(lm["glabella"][0]))
        balance(row, name, expression, "forehead", {k: v[0] for k, v in halves.items()},
                {k: v[1] for k, v in halves.items()})
        curvature(row, name, expression, "forehead", grid)
        slit_line(row, name, expression, "forehead", grid, "z")
    elif expression == "brow_down":
        x, z = glabella_box(lm)
        grids["glabella"] = grid = rm.front_grid(posed, tris, heights, x, z, step)
        got = rm.glabella(grid, lm["glabella"][0])
        sides, lines = got.pop("sides"), got.pop("lines")
        row.update(got)
        for side, found in sides.items():
            found = sorted(found, key=lambda f: -f[1])[:6]
            log(f"{name} {expression}: side {side}: (angle deg, length >= 0.3 mm deep, depth mm) "
                + ", ".join(f"({a:.0f}, {length:.1f}, {d:.2f})" for a, length, d in found))
        # the frown lines against the inner brow ends
        source = "iBUG 22 / 21" if inner_brows else "brow_inner_L/R landmarks"
        inner = {k: float(lm[f"ref_brow_inner_{k}" if inner_brows else f"brow_inner_{k}"][0]) for k in "LR"}
        off = rm.glabella_offset(lines, inner)
        row["glabella_offset_mm"] = off["glabella_offset_mm"]
        for side, v in off["sides"].items():
            log(f"{name} {expression}: glabella offset side {side}: " + (
                f"no frown line (inner brow x {inner[side]:.1f} mm, {source})" if v is None else
                f"frown line centre x {v[0]:.1f} mm, inner brow x {v[1]:.1f} mm ({source}), "
                f"offset {v[2]:.2f} mm"))
        if skin is not None:
            strain(row, name, expression, heights, posed, skin, fh, lm)
        # no crow's feet when only the brows come down
        worst = 0.0
        for side, s in (("L", 1.0), ("R", -1.0)):
            corner = lm[f"eye_corner_{side}"]
            v, n = rm.corner_max_abs(posed, heights, corner, s, 0.3 * e, zones.eyelid)
            worst = max(worst, v)
            log(f"{name} {expression}: eye corner {side} (x {corner[0]:.1f} z {corner[2]:.1f} mm): "
                f"largest |h| {v:.3f} mm over {n} vertices within 0.3 E = {0.3 * e:.1f} mm, lateral, "
                "off the lids")
        row["eye_corner_brow_down_mm"] = worst
        deepest = {k: (max(float(np.max(r.depth)) for r in lines[k]) if lines[k] else None) for k in "LR"}
        balance(row, name, expression, "frown", deepest, {k: len(lines[k]) for k in "LR"})
        curvature(row, name, expression, "glabella", grid)
        slit_line(row, name, expression, "glabella", grid, "x")
    elif expression == "smile":
        x, z = below_eyes(lm)
        grids["below_eyes"] = grid = rm.front_grid(posed, tris, heights, x, z, step)
        per_side = {k: nasolabial_band(grid, lm, k) for k in "LR"}
        grid.band = band = per_side["L"] | per_side["R"]  # dumped with the grid
        hit, low, other = rm.deepest_in_band(grid, band)
        in_band = float(np.nanmin(np.where(band, grid.h, np.nan))) if (band & grid.valid).any() else 0.0
        row["nasolabial_deepest"] = hit
        log(f"{name} {expression}: deepest below the eyes {low:.3f} mm, in the nasolabial bands "
            f"{in_band:.3f} mm, elsewhere {other:.3f} mm")
        got = rm.knots(grid)
        row["knots"] = got["knots"]
        log(f"{name} {expression}: knots: typical furrow {got['furrow_depth']:.3f} mm, "
            f"bulge {got['bulge']:.3f} mm")
        for x, z, h, dist in got["where"]:
            mc = {side: lm[f"mouth_corner_{side}"] for side in "LR"}
            side = min(mc, key=lambda k: np.hypot(mc[k][0] - x, mc[k][2] - z))
            log(f"{name} {expression}: knot at x {x:.1f} z {z:.1f} mm (nub {h:.2f} mm high, a slit "
                f"{dist:.1f} mm away; {x - mc[side][0]:+.1f}, {z - mc[side][2]:+.1f} mm from "
                f"mouth_corner_{side})")
            try:
                v = nearest_front_vertex(posed, x, z)
                log(f"{name} {expression}:   vertex {v} (height {heights[v]:.2f} mm) lies in the regions of: "
                    + ", ".join(f"{n} ({f:+.2f} mm formed)" for n, f in fh.formed_at(v)))
            except Exception as err:  # noqa: BLE001 - a diagnostic only
                log(f"{name} {expression}:   no per-muscle breakdown: {err!r}")
        deepest = {k: rm.band_deepest(grid, b) for k, b in per_side.items()}
        balance(row, name, expression, "nasolabial", deepest,
                {k: int(v is not None and v >= 0.1) for k, v in deepest.items()})
    elif expression == "squint":
        sides = []
        for side, s in (("L", 1.0), ("R", -1.0)):
            corner = lm[f"eye_corner_{side}"]
            grids[f"crow_{side}"] = grid = temple_grid(posed, tris, heights, corner, s, e, step)[0]
            got = rm.crows_feet_side(grid, (corner[0], corner[2]), s, e)
            sides.append(got)
            found = sorted((f for f in got["furrows"] if f[1] > 0), key=lambda f: -f[1])[:8]
            log(f"{name} {expression}: side {side}: corner x {corner[0]:.1f} z {corner[2]:.1f} mm, "
                f"E {e:.1f} mm, {got['count']} crow's feet; "
                "(direction deg, length >= 0.2 mm deep, depth mm, radii mm) "
                + ", ".join(f"({d:.0f}, {length:.1f}, {dp:.2f}, {r0:.0f}-{r1:.0f})"
                            for d, length, dp, r0, r1 in found))
        row.update(rm.crows_feet(sides))
        by_side = dict(zip("LR", sides))
        balance(row, name, expression, "crows_feet", {k: v["depth"] for k, v in by_side.items()},
                {k: v["count"] for k, v in by_side.items()})
    elif expression == "anger":
        x, z = nose_root_box(lm, e)
        grids["nose_root"] = grid = rm.front_grid(posed, tris, heights, x, z, step)
        got = rm.procerus(grid)
        row["procerus_line"] = got["procerus_line"]
        found = sorted(got["lines"], key=lambda f: -f[1])[:6]
        log(f"{name} {expression}: nose root x {x[0]:.1f}..{x[1]:.1f} z {z[0]:.1f}..{z[1]:.1f} mm: "
            "(angle from horizontal deg, length >= 0.2 mm deep, depth mm) "
            + ", ".join(f"({a:.0f}, {length:.1f}, {d:.2f})" for a, length, d in found))
        got = rm.knots(grid)
        row["nose_root_knots"] = got["knots"]
        log(f"{name} {expression}: nose root knots {got['knots']}: typical furrow "
            f"{got['furrow_depth']:.3f} mm, bulge {got['bulge']:.3f} mm; "
            + ", ".join("at x {:.1f} z {:.1f} mm (nub {:.2f} mm high, a slit {:.1f} mm away)".format(*w)
                        for w in got["where"]))
        curvature(row, name, expression, "nose root", grid)
    row["eyelid_lip_max_mm"] = rm.max_abs(heights, zones.eyelid | zones.lip)
    if dump:
        Path(dump).mkdir(parents=True, exist_ok=True)
        arrays = {f"{k}_{a}": getattr(g, a) for k, g in grids.items()
                  for a in ("h", "y", "xs", "zs", "band") if hasattr(g, a)}
        arrays.update({f"lm_{k}": np.asarray(v, float) for k, v in lm.items()})
        np.savez_compressed(Path(dump) / f"{name}_{expression}.npz", **arrays)
    return row


def run_face(name, build, step, dump):
    from wrinkle_addon.core import zones as core_zones

    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    t = time.perf_counter()
    face, landmarks, frames, inner_brows = build()
    fh = FaceHeights(face)
    log(f"{name}: built in {time.perf_counter() - t:.1f} s, {len(fh.mesh.rest)} vertices, "
        f"{len(fh.static.plan.region_sizes)} muscles")
    zones = core_zones.face_zones(fh.mesh.rest, landmarks)
    for expression, frame in frames.items():
        heights, posed, check, skin = fh.at(frame)
        log(f"{name} {expression}: offset_check_mm {check:.2e} (the frame stage's offsets against ours)")
        row = measure(name, expression, heights, posed, fh, landmarks, zones, step, dump, skin, inner_brows)
        print(json.dumps(clean(row)), flush=True)


def landmark_line(path):
    """The ``"expression": "landmarks"`` line (``benchmarks/landmarks.py``): the found
    landmarks against ICT's own 68, when the reference lies beside the head file."""
    from benchmarks import landmarks

    ref = reference_json(path)
    if ref is None:
        log(f"{Path(path).with_name(landmarks.REFERENCE_NAME)} not found: no landmarks line")
        return
    row = landmarks.measure(path, ref)
    row["face"] = "ict" if Path(path) == landmarks.DEFAULT_NPZ else Path(path).stem
    print(json.dumps(clean(row)), flush=True)


def look_lines(path):
    """The rendered lines: how the wrinkle maps look against the geometry
    (``benchmarks/map_look.py``: ``map_anger``, ``map_surprise``) and how the shedding tear
    reads as water in Cycles and EEVEE (``benchmarks/tear_look.py``: ``tear``), each on a
    fresh empty scene."""
    from benchmarks import map_look, tear_look

    bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
    for row in map_look.lines(path):
        print(json.dumps(clean(row)), flush=True)
    if Path(path) != Path(map_look.DEFAULT_NPZ):
        return  # the tear's scene is the sample head's (sample_scenes/patterns.py)
    for engine in ("CYCLES", "EEVEE"):
        bpy.ops.wm.read_homefile(use_empty=True, use_factory_startup=True)
        print(json.dumps(clean(tear_look.measure(engine))), flush=True)


def main(argv):
    from sample_scenes.lib import ict

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--faces", default="ict,procedural", help="comma-separated: ict, procedural")
    ap.add_argument("--npz", default=None, help="a head file with the ICT layout (default: the ICT head)")
    ap.add_argument("--step", type=float, default=0.5, help="grid step in mm")
    ap.add_argument("--dump", default=None, help="a folder to save the resampled grids in (.npz)")
    ap.add_argument("--no-renders", action="store_true",
                    help="leave out the rendered lines (the maps against the geometry, the tear)")
    args = ap.parse_args(argv)
    faces = [f.strip() for f in args.faces.split(",") if f.strip()]
    path = Path(args.npz) if args.npz else ict.DEFAULT_PATH
    ict_name = "ict" if args.npz is None else path.stem
    log(f"bpy {bpy.app.version_string}, numpy {np.__version__}")
    addon_utils.enable("wrinkle_addon", default_set=True)
    failed = False
    try:
        for name in faces:
            if name == "ict":
                if not path.exists():
                    log(f"{path} not found: the ICT face is skipped")
                    continue
                run_face(ict_name, lambda: build_ict(path), args.step, args.dump)
                landmark_line(path)
                if not args.no_renders:
                    look_lines(path)
            elif name == "procedural":
                run_face("procedural", build_procedural, args.step, args.dump)
            else:
                log(f"unknown face {name!r}")
                failed = True
    except Exception:  # noqa: BLE001 - report, then exit cleanly
        failed = True
        log(traceback.format_exc())
    finally:
        bpy.ops.wm.read_factory_settings(use_empty=True)  # bpy 4.5 hangs at exit otherwise
    if failed:
        sys.exit(1)


if __name__ == "__main__":
    main(sys.argv[1:])
