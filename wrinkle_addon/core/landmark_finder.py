# SPDX-License-Identifier: GPL-3.0-or-later
"""The eight facial landmarks (``LANDMARKS``), and finding them on a face mesh.  Every
method places its work from them: the muscle set, the no-wrinkle zones (``core.zones``), the
pattern layers' frames, the skin's regions (``core.skin``).

Face-local coordinates, the face looking toward -Y, Z up, the character's left +X; all
landmarks are of the character's left side except the midline ones, and the right side is
mirrored about the plane through the glabella.  Three rules are tried in order; the first that fits gives
the *anchors*, the centres of both eyes and the two mouth corners:

1. **openings**: the mesh's own eye and mouth holes.  The boundary loops (edges used by
   one face) are grouped into connected loops; a mirrored pair of small loops side by
   side are the eyes, a loop on their midline, one to two eye distances below them, the
   mouth.  The eye is the centre of its loop, the mouth corners the loop's ends in X,
   brought forward to the pit where the lips meet in front of the rim.
2. **rig**: ARKit-style shape keys.  ``eyeBlink`` moves the upper lids: the eye is the
   middle of the lid's travel at the vertices it moves most.  ``mouthSmile`` moves the
   mouth corners most, ``jawOpen`` the lower lip: the corner is the vertex the smile
   moves most, lifted onto the mouth line (the top of the lower lip ``jawOpen`` moves).
   ``browInnerUp`` marks the inner brows, which bound the search for the glabella.
   Names may end in ``_L``/``_R``, ``.L``/``.R`` or ``Left``/``Right``; the sides are
   told apart by where the vertices lie, not by the names.
3. **geometry**, for a closed sculpt: the nose tip is the most forward point; the face is
   read as a depth image seen from the front (the nearest front-facing surface in each
   cell).  The eyes are the sockets, the deepest hollows either side of the nose at the
   height of the nasal bridge (on the face: not the concha of an ear, not the background
   round the silhouette), refined to the lid's bulge in a closed socket.  The search's
   windows and blurs are sized by the head's width, which the silhouette gives only
   roughly (it counts the ears): the search is run at sizes from 0.75 to 1.35 times the
   silhouette's width and the sizes kept are those whose eyes are closest to
   ``EYES_PER_WIDTH`` of it apart; their eyes are averaged.  The mouth line is the deepest
   point of the midline profile between the lips, and its corners the pits at the ends of
   the lip line.

The rest follows from the anchors on every rule, measured on the same depth image with
``E`` the distance between the eyes: the nose tip is the most forward point between the
mouth and the eyes; on the midline profile the nasion is the deepest point at the eyes'
height, the glabella the most forward point above it (up to the inner brows when the rig
marks them) and the chin the middle of the chin's front below the lower lip.  The brow's
outer end is ``0.25 E`` above the eye and as far out as the brow can reach: where the brow
ridge ends (the convexity of the vertical profile at the ridge's crest, followed outward
from the eye, falls to half its peak) or where the forehead turns into the temple (the knee
of the horizontal profile at the brow's height, where it stops turning away from the
front), whichever comes first; both are cut exactly from the mesh's triangles
(``Depth.section``), not read off the image's cells, since the surface there is steep.  The
hairline, which a bald mesh does not show, is ``0.9 E`` above the glabella; the cheekbone
is ``0.3 E`` out from and ``0.31 E`` below the eye.  Every point but the eye is then put on
the surface seen from the front.

A face no rule fits (no nose, no eyes: a sphere, a cube) gets the bounding-box guess of
``estimate_landmarks`` and a message saying so.  Pure NumPy; no loop over
vertices (only over the few boundary loops, the landmarks, a handful of passes over the
small depth image and some fifty profiles cut beside each eye).
"""

import numpy as np

from . import mesh

LANDMARKS = (
    ("hairline_center", "Hairline", "Middle of the hairline, where the forehead ends"),
    ("glabella", "Glabella", "Between the eyebrows, on the midline"),
    ("brow_outer_L", "Brow Outer (left)", "Outer end of the character's left eyebrow"),
    ("eye_L", "Eye (left)", "Centre of the character's left eye"),
    ("nose_tip", "Nose Tip", "Tip of the nose"),
    ("mouth_corner_L", "Mouth Corner (left)", "Corner of the mouth on the character's left"),
    ("chin", "Chin", "Front of the chin, on the midline"),
    ("cheekbone_L", "Cheekbone (left)", "Most prominent point of the left cheekbone"),
)


def estimate_landmarks(bbox_min, bbox_max):
    """Rough landmark guesses from the bounding box of a head (the artist confirms them)."""
    lo, hi = np.asarray(bbox_min, float), np.asarray(bbox_max, float)
    cx, w = 0.5 * (lo[0] + hi[0]), hi[0] - lo[0]
    z0, h = lo[2], hi[2] - lo[2]

    def p(dx, fz):
        return np.array([cx + dx * w, lo[1], z0 + fz * h])

    return {
        "hairline_center": p(0.0, 0.86),
        "glabella": p(0.0, 0.66),
        "brow_outer_L": p(0.30, 0.67),
        "eye_L": p(0.20, 0.61),
        "nose_tip": p(0.0, 0.47),
        "mouth_corner_L": p(0.15, 0.33),
        "chin": p(0.0, 0.20),
        "cheekbone_L": p(0.27, 0.50),
    }


RULES = ("openings", "rig", "geometry")
FALLBACK = "bounding box"
LABELS = {
    "openings": "the eye and mouth openings",
    "rig": "the shape keys (eyeBlink, jawOpen, browInnerUp, mouthSmile)",
    "geometry": "the shape of the face (nose, eye sockets, lips)",
    FALLBACK: "the face's bounding box",
}
FALLBACK_MESSAGE = ("No eye or mouth openings, ARKit shape keys or recognisable nose and eye "
                    "sockets were found: the landmarks are guessed from the face's bounding box. "
                    "Move each onto its feature before adding the muscle set")

# Proportions in units of E, the distance between the eye centres (module doc).
BROW_OUT = 0.26  # the outer brow when neither the ridge's end nor the temple shows
BROW_UP = 0.25
BROW_MIN, BROW_MAX = 0.15, 0.50  # the outer brow's bounds out from the eye
RIDGE_BAND = (0.12, 0.50)  # the brow ridge's crest is searched this high above the eye
RIDGE_CHORD = 0.06  # half the chord of the ridge's convexity
RIDGE_TRACK = 0.03  # how far the crest may move from one column (0.01 E) to the next
RIDGE_END = 0.5  # the ridge ends where its convexity is down to this share of its peak
TEMPLE_FROM, TEMPLE_MAX = 45.0, 75.0  # degrees the forehead has turned from the front
TEMPLE_BEND = 10.0  # degrees the profile turns, at least, over the run before the knee
TEMPLE_RUN = 0.08  # the run (E) over which the turn is compared before and after
TEMPLE_CUTS = (-0.04, 0.0, 0.04)  # the heights (E, round the brow's) the temple is cut at
HAIRLINE_UP = 0.90
CANTHUS = 0.22  # the eye's corners either side of its centre
CHEEK_OUT, CHEEK_DOWN = 0.30, 0.31
MOUTH_HALF_WIDTH = 0.38
CHIN_TILT = np.tan(np.radians(45.0))  # the chin's front ends where it turns this far under
EYES_PER_WIDTH = 0.40  # E over the head's width at the nose (63 mm over about 155 mm)
FACE_DEPTH = 0.25  # how far the face reaches behind the nose tip, in head widths
GRID = 220  # depth-image cells along the larger side of the front view


class NotFound(Exception):
    """A rule does not fit this face."""


# --------------------------------------------------------------------------
# Topology
# --------------------------------------------------------------------------
def polygons(faces):
    """``(corner_verts, starts, sizes)`` from an (F, k) array or from such a tuple."""
    if isinstance(faces, tuple) and len(faces) == 3:
        corner, starts, sizes = (np.asarray(a, np.int64).ravel() for a in faces)
        return corner, starts, sizes
    f = np.asarray(faces, np.int64)
    f = f.reshape(len(f), -1)
    k = f.shape[1]
    return f.ravel(), np.arange(len(f), dtype=np.int64) * k, np.full(len(f), k, np.int64)


def polygon_edges(corner, starts, sizes):
    """(C, 2) vertex pairs, one per face corner: the corner and the next one."""
    owner = np.repeat(np.arange(len(sizes)), sizes)
    local = np.arange(len(corner)) - starts[owner]
    nxt = starts[owner] + (local + 1) % sizes[owner]
    return np.stack([corner, corner[nxt]], axis=1)


def boundary_loops(corner, starts, sizes):
    """The boundary loops (edges used by one face) as a list of vertex-index arrays,
    largest first."""
    e = np.sort(polygon_edges(corner, starts, sizes), axis=1)
    uniq, count = np.unique(e, axis=0, return_counts=True)
    border = uniq[count == 1]
    if len(border) == 0:
        return []
    verts, index = np.unique(border, return_inverse=True)
    index = index.reshape(-1, 2)
    label = np.arange(len(verts))
    while True:  # min-label propagation with pointer jumping: a few dozen passes at most
        low = np.minimum(label[index[:, 0]], label[index[:, 1]])
        new = label.copy()
        np.minimum.at(new, index[:, 0], low)
        np.minimum.at(new, index[:, 1], low)
        new = new[new]
        if np.array_equal(new, label):
            break
        label = new
    _u, comp = np.unique(label, return_inverse=True)
    order = np.argsort(comp, kind="stable")
    counts = np.bincount(comp)
    loops = np.split(verts[order], np.cumsum(counts)[:-1])
    return sorted(loops, key=len, reverse=True)


# --------------------------------------------------------------------------
# The depth image: the nearest front-facing surface seen along +Y
# --------------------------------------------------------------------------
class Depth:
    """Depth image of the front view: ``y[row, col]`` (NaN where no front-facing surface
    is seen); column ``i`` is at x = x0 + i·cell, row ``j`` at z = z0 + j·cell."""

    def __init__(self, p, tris):
        tri_n = np.cross(p[tris[:, 1]] - p[tris[:, 0]], p[tris[:, 2]] - p[tris[:, 0]])
        front = tri_n[:, 1] < -0.05 * np.linalg.norm(tri_n, axis=1)
        t = tris[front]
        lo, hi = p.min(axis=0), p.max(axis=0)
        self.cell = max(hi[0] - lo[0], hi[2] - lo[2]) / GRID
        self.x0, self.z0 = lo[0], lo[2]
        nx = int((hi[0] - lo[0]) / self.cell) + 2
        nz = int((hi[2] - lo[2]) / self.cell) + 2
        # Sample each triangle densely enough that every cell it covers gets a sample.
        span = np.max(np.linalg.norm(p[t[:, [1, 2, 0]]] - p[t], axis=2), axis=1) if len(t) else np.zeros(0)
        k = int(np.clip(np.ceil(np.percentile(span, 99) / (0.7 * self.cell)) if len(t) else 1, 1, 12))
        ij = np.array([(i, j) for i in range(k + 1) for j in range(k + 1 - i)], float) / k
        bary = np.stack([1.0 - ij.sum(axis=1), ij[:, 0], ij[:, 1]], axis=1)
        pts = np.einsum("bk,tkd->tbd", bary, p[t]).reshape(-1, 3)
        col = np.clip(((pts[:, 0] - self.x0) / self.cell).round().astype(np.int64), 0, nx - 1)
        row = np.clip(((pts[:, 2] - self.z0) / self.cell).round().astype(np.int64), 0, nz - 1)
        y = np.full(nz * nx, np.inf)
        np.minimum.at(y, row * nx + col, pts[:, 1])
        self.y = np.where(np.isfinite(y), y, np.nan).reshape(nz, nx)
        self.shape = (nz, nx)
        self.tri = p[t]  # (T, 3, 3): the front-facing triangles, for exact sections

    def triangles_in(self, x_lo, x_hi, z_lo, z_hi):
        """The front-facing triangles (T, 3, 3) that reach into the box [x_lo, x_hi] x
        [z_lo, z_hi] of the front view: a region's sections cut only those."""
        lo, hi = self.tri.min(axis=1), self.tri.max(axis=1)
        keep = (hi[:, 0] >= x_lo) & (lo[:, 0] <= x_hi) & (hi[:, 2] >= z_lo) & (lo[:, 2] <= z_hi)
        return self.tri[keep]

    def section(self, axis, value, s, tri=None):
        """The front-most y of the front-facing surface along the line where coordinate
        ``axis`` (0: x, 2: z) is ``value``, at the other coordinate's values ``s`` (NaN
        where no surface is seen): exact, from the triangles (``tri``, by default all of
        them), not the image's cells."""
        s = np.asarray(s, np.float64).ravel()
        other = 2 - axis
        tri = self.tri if tri is None else tri
        d = tri[:, :, axis] - value
        up = d > 0.0
        cross = up.any(axis=1) & ~up.all(axis=1)
        tri, d, up = tri[cross], d[cross], up[cross]
        if len(tri) == 0:
            return np.full(len(s), np.nan)
        ends = []
        for i, j in ((0, 1), (1, 2), (2, 0)):  # the three edges; two of them cross
            e = up[:, i] != up[:, j]
            t = d[:, i] / np.where(e, d[:, i] - d[:, j], 1.0)
            ends.append((e, tri[:, i] + t[:, None] * (tri[:, j] - tri[:, i])))
        a = np.where(ends[0][0][:, None], ends[0][1], ends[1][1])
        b = np.where(ends[2][0][:, None], ends[2][1], ends[1][1])
        u0, u1 = a[:, other:other + 1], b[:, other:other + 1]
        span = u1 - u0
        t = (s[None, :] - u0) / np.where(np.abs(span) > 1e-12, span, 1.0)
        inside = (t >= 0.0) & (t <= 1.0) & (np.abs(span) > 1e-12)
        y = np.where(inside, a[:, 1:2] + t * (b[:, 1:2] - a[:, 1:2]), np.inf).min(axis=0)
        return np.where(np.isfinite(y), y, np.nan)

    def surface(self, x, z):
        """The front surface's y at (x, z), exact; the nearest seen cell's where the ray
        from the front meets no front-facing triangle (an opening)."""
        y = self.section(2, z, [x])[0]
        return float(y) if np.isfinite(y) else _surface_y(self, x, z)

    def col(self, x):
        return int(np.clip(round((x - self.x0) / self.cell), 0, self.shape[1] - 1))

    def row(self, z):
        return int(np.clip(round((z - self.z0) / self.cell), 0, self.shape[0] - 1))

    def xz(self, row, col):
        return self.x0 + col * self.cell, self.z0 + row * self.cell

    def profile(self, x, half_width):
        """The front-most y of every row within ``half_width`` of ``x`` (NaN where none)."""
        a, b = self.col(x - half_width), self.col(x + half_width)
        block = self.y[:, a:b + 1]
        ok = np.isfinite(block).any(axis=1)
        out = np.full(self.shape[0], np.nan)
        out[ok] = np.nanmin(block[ok], axis=1)
        return out

    def rows_between(self, z_lo, z_hi):
        return np.arange(self.row(min(z_lo, z_hi)), self.row(max(z_lo, z_hi)) + 1)


def blur(a, radius):
    """Box blur of a 2-D image over NaNs (NaN cells neither count nor get filled)."""
    r = max(int(radius), 1)
    ok = np.isfinite(a)
    v = np.where(ok, a, 0.0)
    w = ok.astype(float)
    for axis in (0, 1):
        v, w = _box(v, r, axis), _box(w, r, axis)
    out = np.full(a.shape, np.nan)
    out[w > 0] = v[w > 0] / w[w > 0]
    return out


def _box(a, r, axis):
    c = np.cumsum(np.pad(a, [(r + 1, r) if i == axis else (0, 0) for i in range(2)]), axis=axis)
    n = a.shape[axis]
    hi = np.take(c, np.arange(2 * r + 1, 2 * r + 1 + n), axis=axis)
    lo = np.take(c, np.arange(0, n), axis=axis)
    return hi - lo


def smooth1(a, radius):
    """Moving average of a 1-D profile over NaNs (a copy when ``radius`` < 1 cell)."""
    return blur(a[:, None], radius)[:, 0] if radius >= 1 else a.copy()


# --------------------------------------------------------------------------
# The rules: each returns the anchors (eye_L, eye_R, mouth_L, mouth_R as (3,) points)
# --------------------------------------------------------------------------
def _openings(p, loops, scale):
    """Rule 1: the eye and mouth boundary loops."""
    holes = []
    for v in loops:  # a handful of loops
        q = p[v]
        size = np.ptp(q, axis=0)
        if len(v) < 6 or max(size[0], size[2]) > 0.35 * scale:
            continue  # the neck, the edge of a face mask, a tiny slit
        holes.append((v, q.mean(axis=0), size))
    best = None
    for i, (_vi, ci, si) in enumerate(holes):
        for j, (_vj, cj, sj) in enumerate(holes):
            sep = ci[0] - cj[0]
            if sep <= 0 or abs(ci[2] - cj[2]) > 0.15 * sep or abs(ci[1] - cj[1]) > 0.2 * sep:
                continue
            if not (0.3 < si[0] / max(sj[0], 1e-12) < 3.0) or si[0] > 0.8 * sep or sj[0] > 0.8 * sep:
                continue
            mid = 0.5 * (ci + cj)
            for k, (vk, ck, sk) in enumerate(holes):
                if k in (i, j) or abs(ck[0] - mid[0]) > 0.15 * sep:
                    continue
                drop = mid[2] - ck[2]
                if not (0.6 * sep < drop < 1.9 * sep and 0.3 * sep < sk[0] < 1.6 * sep):
                    continue
                score = (abs(ci[2] - cj[2]) + abs(ck[0] - mid[0])
                         + abs(abs(ci[0] - mid[0]) - abs(cj[0] - mid[0])))
                if best is None or score < best[0]:
                    best = (score, ci, cj, vk)
    if best is None:
        raise NotFound("no eye and mouth openings")
    _s, eye_l, eye_r, mouth = best
    m = p[mouth]
    return {"eye_L": eye_l, "eye_R": eye_r, "mouth_L": m[np.argmax(m[:, 0])],
            "mouth_R": m[np.argmin(m[:, 0])]}, {"corner_pit": True, "rim": True}


def _keys_named(shape_keys, stem):
    """Shape keys whose name, lowercased without separators or side suffixes, is ``stem``."""
    out = []
    for name, co in shape_keys.items():  # a few dozen keys
        s = name.lower().replace("_", "").replace(".", "").replace(" ", "")
        for suffix in ("left", "right", "l", "r"):
            if s.endswith(suffix) and s[: -len(suffix)] == stem:
                s = stem
        if s == stem:
            out.append(np.asarray(co, np.float64))
    return out


def _motion(p, keys):
    """Per-vertex displacement (N, 3) of each key, stacked: (K, N, 3)."""
    return np.stack([k.reshape(-1, 3) - p for k in keys])


def _rig(p, shape_keys, scale):
    """Rule 2: the vertices eyeBlink, jawOpen, browInnerUp and mouthSmile move."""
    if not shape_keys:
        raise NotFound("no shape keys")
    blink, smile = _keys_named(shape_keys, "eyeblink"), _keys_named(shape_keys, "mouthsmile")
    jaw, brow = _keys_named(shape_keys, "jawopen"), _keys_named(shape_keys, "browinnerup")
    if not blink or not smile:
        raise NotFound("no eyeBlink and mouthSmile shape keys")
    n = len(p)
    if any(k.size != 3 * n for k in blink + smile + jaw + brow):
        raise NotFound("shape keys of another vertex count")
    d_blink = _motion(p, blink)
    amount = np.linalg.norm(d_blink, axis=2).max(axis=0)
    if amount.max() < 1e-4 * scale:
        raise NotFound("eyeBlink moves nothing")
    moved = amount > 0.2 * amount.max()
    mid_x = np.average(p[moved, 0], weights=amount[moved])
    disp = d_blink.sum(axis=0)
    out = {}
    for side, sign in (("L", 1.0), ("R", -1.0)):
        lid = (sign * (p[:, 0] - mid_x) > 0) & (amount > 0.8 * amount[sign * (p[:, 0] - mid_x) > 0].max())
        if not lid.any():
            raise NotFound("eyeBlink moves one eye only")
        eye = (p[lid] + 0.5 * disp[lid]).mean(axis=0)
        out[f"eye_{side}"] = eye
    sep = out["eye_L"][0] - out["eye_R"][0]
    if sep <= 0.05 * scale:
        raise NotFound("eyeBlink does not move two eyes")
    a_smile = np.linalg.norm(_motion(p, smile), axis=2).max(axis=0)
    a_jaw = np.linalg.norm(_motion(p, jaw), axis=2).max(axis=0) if jaw else None
    for side, sign in (("L", 1.0), ("R", -1.0)):
        half = sign * (p[:, 0] - mid_x) > 0.1 * sep
        corner = p[np.flatnonzero(half)[np.argmax(a_smile[half])]].copy()
        if a_jaw is not None:
            # The mouth line near the corner: the highest vertex the jaw moves at least
            # half as much as the lower lip, within a corner's width of the smile's peak.
            near = (np.abs(p[:, 0] - corner[0]) < 0.08 * sep) & (np.abs(p[:, 2] - corner[2]) < 0.25 * sep)
            near &= p[:, 1] < corner[1] + 0.15 * sep
            lower = near & (a_jaw > 0.5 * a_jaw[near].max()) if near.any() else near
            if lower.any():
                corner[2] = p[lower, 2].max()
        out[f"mouth_{side}"] = corner
    hints = {"corner_pit": True}
    if brow:
        a_brow = np.linalg.norm(_motion(p, brow), axis=2).max(axis=0)
        top = a_brow > 0.8 * a_brow.max()
        if top.any():
            hints["brow_z"] = float(p[top, 2].mean())
    if not (0.6 * sep < 0.5 * (out["eye_L"][2] + out["eye_R"][2]) - out["mouth_L"][2] < 1.9 * sep):
        raise NotFound("the shape keys' eyes and mouth are not where a face has them")
    return out, hints


def _enclosed(seen):
    """Cells with seen cells on all four sides along their row and column."""
    def between(a, axis):
        ahead = np.maximum.accumulate(a, axis=axis)
        behind = np.flip(np.maximum.accumulate(np.flip(a, axis), axis=axis), axis)
        return ahead & behind
    return between(seen, 0) & between(seen, 1)


def _find_eyes(depth, nose, scale):
    """The two eyes (side -> (3,) point) of the depth image, its windows and blurs sized
    by ``scale`` (a head's width); the nose tip at row, column ``nose``."""
    y, cell = depth.y, depth.cell
    r, c = nose
    nose_x, nose_z = depth.xz(r, c)
    # The deepest hollows (relative to a wide blur, holes counting as deep) either side
    # of the nose, above it, on the face only: not farther behind the nose tip than the
    # face reaches (the concha of an ear is a deep hollow too).
    seen = np.isfinite(y)
    hole = ~seen & _enclosed(seen)
    deep_fill = np.where(seen, y, np.nanmax(y))
    hollow = deep_fill - blur(deep_fill, 0.12 * scale / cell)
    hollow = blur(hollow, 0.02 * scale / cell)
    hollow[~(hole | (seen & (y < y[r, c] + FACE_DEPTH * scale)))] = np.nan
    bulge = blur(y, 0.04 * scale / cell) - y
    rows = depth.rows_between(nose_z + 0.08 * scale, nose_z + 0.45 * scale)
    eyes = {}
    for side, sign in (("L", 1.0), ("R", -1.0)):
        step = int(sign)
        cols = np.arange(depth.col(nose_x + sign * 0.08 * scale),
                         depth.col(nose_x + sign * 0.42 * scale) + step, step)
        block = hollow[np.ix_(rows, cols)]
        if not np.isfinite(block).any():
            raise NotFound("no eye sockets")
        i, j = np.unravel_index(np.nanargmax(block), block.shape)
        # The socket's centre: the centroid of its deepest part.
        peak = block[i, j]
        if not peak > 0.01 * scale:
            raise NotFound("no eye sockets")
        w = np.where(np.isfinite(block) & (block > 0.85 * peak), block, 0.0)
        ii, jj = np.meshgrid(np.arange(len(rows)), np.arange(len(cols)), indexing="ij")
        ri = rows[0] + float((w * ii).sum() / w.sum())
        cj = cols[0] + sign * float((w * np.abs(jj)).sum() / w.sum())
        ex, ez = depth.x0 + cj * cell, depth.z0 + ri * cell
        if np.isfinite(y[int(round(ri)), int(round(cj))]):
            # A closed eye: the lid bulges over the eyeball inside the socket; its centre
            # is the most forward point relative to its surroundings near the socket.
            rr = depth.rows_between(ez - 0.04 * scale, ez + 0.04 * scale)
            near, far = ex - sign * 0.02 * scale, ex + sign * 0.06 * scale
            cc = np.arange(depth.col(min(near, far)), depth.col(max(near, far)) + 1)
            patch = bulge[np.ix_(rr, cc)]
            if np.isfinite(patch).any() and np.nanmax(patch) > 0:
                w = np.where(np.isfinite(patch) & (patch > 0.7 * np.nanmax(patch)), patch, 0.0)
                i2, j2 = np.meshgrid(rr, cc, indexing="ij")
                ez = depth.z0 + float((w * i2).sum() / w.sum()) * cell
                ex = depth.x0 + float((w * j2).sum() / w.sum()) * cell
        eyes[side] = np.array([ex, _surface_y(depth, ex, ez), ez])
    return eyes


def _geometry(p, depth, scale):
    """Rule 3: the nose tip, the eye sockets and the lips of a closed surface."""
    y = depth.y
    if not np.isfinite(y).any():
        raise NotFound("nothing faces the front")
    cell = depth.cell
    # The nose tip: the most forward point, standing out of its surroundings.
    r, c = np.unravel_index(np.nanargmin(y), y.shape)
    nose_x, nose_z = depth.xz(r, c)
    seen = np.flatnonzero(np.isfinite(y[r]))
    scale = (seen[-1] - seen[0]) * cell  # first guess: the width of the head at the nose
    if scale <= 0:
        raise NotFound("no face")
    around = blur(y, 0.08 * scale / cell)
    if not np.isfinite(around[r, c]) or around[r, c] - y[r, c] < 0.03 * scale:
        raise NotFound("no nose stands out of the front")
    # That width counts the ears, whose size and shape vary from head to head, and the
    # hollows the search finds shift with the size it assumes (a small one settles on the
    # inner corners).  So the eyes are searched for at a range of sizes around it and the
    # size kept is the one whose eyes are as far apart as a head's eyes are for its width.
    tries = []
    for guess in scale * np.geomspace(0.75, 1.35, 21):  # 21 sizes (3 % apart)
        try:
            found = _find_eyes(depth, (r, c), guess)
        except NotFound:
            continue
        miss = abs((found["L"][0] - found["R"][0]) / guess - EYES_PER_WIDTH)
        tries.append((miss, guess, found))
    if not tries:
        raise NotFound("no eye sockets")
    # The sizes that fit about as well as the best one all count: their mean does not
    # jump when a small change of the head makes another of them the best.
    least = min(t[0] for t in tries)
    good = [t for t in tries if t[0] <= least + 0.02]
    scale = float(np.mean([t[1] for t in good]))
    eyes = {k: np.mean([t[2][k] for t in good], axis=0) for k in ("L", "R")}
    sep = eyes["L"][0] - eyes["R"][0]
    if sep < 0.1 * scale or abs(eyes["L"][2] - eyes["R"][2]) > 0.2 * sep:
        raise NotFound("no pair of eye sockets")
    mid_x = 0.5 * (eyes["L"][0] + eyes["R"][0])
    # The mouth line: the deepest point of the midline profile between the lips, below
    # the nose; the lips are the two most forward bumps under it.
    prof = smooth1(depth.profile(mid_x, 0.02 * sep), 0.01 * sep / cell)
    eye_z = 0.5 * (eyes["L"][2] + eyes["R"][2])
    band = depth.rows_between(eye_z - 1.7 * sep, nose_z - 0.25 * sep)
    mouth_row = _lip_line(prof, band)
    if mouth_row is None:
        raise NotFound("no lips under the nose")
    _mx, mouth_z = depth.xz(mouth_row, 0)
    # The corners: a closed mouth shows them too faintly to find, so they are put at the
    # mouth's usual half width (MOUTH_HALF_WIDTH E) either side of the midline.
    out = {"eye_L": eyes["L"], "eye_R": eyes["R"]}
    for side, sign in (("L", 1.0), ("R", -1.0)):
        x = mid_x + sign * MOUTH_HALF_WIDTH * sep
        out[f"mouth_{side}"] = np.array([x, _surface_y(depth, x, mouth_z), mouth_z])
    return out, {"corner_pit": True}


def _lip_line(prof, band):
    """Row of the mouth line: the deepest point between the two most forward bumps
    (the lips) of the profile ``prof`` within ``band`` (rows, bottom up), or None."""
    seg = prof[band]
    ok = np.isfinite(seg)
    if ok.sum() < 5:
        return None
    # Local minima of y (forward bumps) and maxima (hollows), ignoring NaNs.
    idx = np.flatnonzero(ok)
    s = seg[idx]
    bump = idx[1:-1][(s[1:-1] <= s[:-2]) & (s[1:-1] <= s[2:])]
    if len(bump) < 2:
        return None
    top2 = np.sort(bump[np.argsort(seg[bump])[:2]])
    lo, hi = top2
    if hi - lo < 2:
        return None
    between = np.arange(lo, hi + 1)
    between = between[np.isfinite(seg[between])]
    return int(band[between[np.argmax(seg[between])]])


def _chin(prof, zs, depth, mouth_z, sep):
    """z of the front of the chin: the middle of the chin's front face, from the
    mentolabial sulcus (the first hollow below the lower lip) down to where the profile
    turns under by more than 45 degrees."""
    lip = depth.rows_between(mouth_z - 0.3 * sep, mouth_z)
    seg = prof[lip]
    if not np.isfinite(seg).any():
        return mouth_z - 0.45 * sep
    r = int(lip[np.nanargmin(seg)])  # the lower lip, most forward
    stop = depth.row(mouth_z - 1.2 * sep)
    while r - 1 > stop and np.isfinite(prof[r - 1]) and prof[r - 1] >= prof[r]:
        r -= 1  # walk down the lip's underside to the sulcus (rows, not vertices)
    sulcus = r
    while r - 1 > stop and np.isfinite(prof[r - 1]) and prof[r - 1] - prof[r] < CHIN_TILT * depth.cell:
        r -= 1  # down the chin's front until it turns under
    return 0.5 * (zs[sulcus] + zs[r])


def _surface_y(depth, x, z):
    """The front surface's y at (x, z): the nearest seen cell around it."""
    r, c = depth.row(z), depth.col(x)
    for k in (0, 1, 2, 4, 8):  # widen until something is seen
        block = depth.y[max(r - k, 0):r + k + 1, max(c - k, 0):c + k + 1]
        if np.isfinite(block).any():
            return float(np.nanmin(block))
    return float(np.nanmin(depth.y))


# --------------------------------------------------------------------------
# From the anchors to the eight landmarks
# --------------------------------------------------------------------------
def _ridge_end(depth, eye_x, eye_z, sign, sep):
    """How far out from the eye (in x, >= 0) the brow ridge ends on one side, or None.

    Each column from the eye outward is cut vertically; the ridge's strength there is the
    convexity of that profile at its crest (the profile's forward bulge over a chord
    ``2 RIDGE_CHORD`` E long).  The crest is the most convex point ``RIDGE_BAND`` E above
    the eye in the eye's column, and in each further column the most convex point within
    ``RIDGE_TRACK`` E of the last one's (the ridge is a long band: a lid's bulge near the
    eye's corner does not take it over).  The ridge ends where its strength has fallen to
    ``RIDGE_END`` of the largest it had further in."""
    step = 0.005
    zs = eye_z + sep * np.arange(RIDGE_BAND[0] - RIDGE_CHORD, RIDGE_BAND[1] + RIDGE_CHORD + step, step)
    k = int(round(RIDGE_CHORD / step))
    reach = int(round(RIDGE_TRACK / step))
    offsets = sep * np.arange(0.0, BROW_MAX + 0.01, 0.01)
    xs = eye_x + sign * offsets
    tri = depth.triangles_in(xs.min(), xs.max(), zs[0], zs[-1])
    strength = np.full(len(offsets), np.nan)
    crest = None
    for i, x in enumerate(xs):  # some 50 columns
        y = depth.section(0, x, zs, tri)
        bulge = 0.5 * (y[:-2 * k] + y[2 * k:]) - y[k:-k]
        if crest is not None:
            window = np.full(len(bulge), np.nan)
            lo, hi = max(crest - reach, 0), crest + reach + 1
            window[lo:hi] = bulge[lo:hi]
            bulge = window
        if not np.isfinite(bulge).any():
            break  # the ridge's band is lost (an opening, the silhouette)
        crest = int(np.nanargmax(bulge))
        strength[i] = bulge[crest]
    strength = smooth1(strength, 1)
    peak = np.fmax.accumulate(strength)
    if not np.nanmax(peak, initial=-np.inf) > 0.0:
        return None
    after = np.arange(len(offsets)) >= np.searchsorted(offsets, BROW_MIN * sep)
    below = np.flatnonzero(after & ~(strength >= RIDGE_END * peak))
    if len(below) == 0 or below[0] == 0:
        return None
    j = int(below[0])
    # between the last column above the threshold and the first below it
    a, b = strength[j - 1] - RIDGE_END * peak[j - 1], strength[j] - RIDGE_END * peak[j]
    f = a / (a - b) if np.isfinite(b) and a > 0 else 0.0
    return float(offsets[j - 1] + f * (offsets[j] - offsets[j - 1]))


def _temple(depth, eye_x, brow_z, sign, sep):
    """How far out from the eye (in x, >= 0) the forehead turns into the temple at the
    brow's height on one side, or None.  The horizontal profile there, cut exactly, turns
    away from the front more and more toward the side; on a head with a temporal line the
    turn stops where the temple's flatter side begins.  That knee is where, past
    ``TEMPLE_FROM`` degrees and after a bend (at least ``TEMPLE_BEND`` degrees over the last
    ``TEMPLE_RUN`` E), the profile turns over the next ``TEMPLE_RUN`` E less than a third as
    much (either way: turning back is an ear or hair in front of the temple, not the knee),
    the most so; on a head whose side keeps turning evenly, it is where the profile has
    turned ``TEMPLE_MAX`` degrees."""
    step = 0.005 * sep
    offsets = np.arange(0.0, (BROW_MAX + TEMPLE_RUN) * sep + step, step)
    y = depth.section(2, brow_z, eye_x + sign * offsets)
    ok = np.flatnonzero(np.isfinite(y))
    edge = int(round(0.02 * sep / step))
    if len(ok) == 0 or ok[-1] - 2 * edge < 10:
        return None
    last = ok[-1] - edge  # without the smoothing's edge at the silhouette
    angle = np.degrees(np.arctan(np.gradient(smooth1(y[:ok[-1] + 1], edge), offsets[:ok[-1] + 1])))
    angle = angle[:last + 1]
    n = int(round(TEMPLE_RUN * sep / step))
    i = np.arange(len(angle))
    before = angle - angle[np.maximum(i - n, 0)]
    after = angle[np.minimum(i + n, len(angle) - 1)] - angle
    knee = (angle >= TEMPLE_FROM) & (before >= TEMPLE_BEND) & (np.abs(after) < before / 3.0)
    knee &= i + n < len(angle)
    knee &= offsets[:len(angle)] <= BROW_MAX * sep
    if knee.any():
        first = int(np.flatnonzero(knee)[0])
        run = first + int(np.argmin(knee[first:])) if not knee[first:].all() else len(knee)
        drop = (before - after)[first:run]
        return float(offsets[first + int(np.nanargmax(drop))])
    turned = np.flatnonzero(angle >= TEMPLE_MAX)
    return float(offsets[turned[0]]) if len(turned) else None


def _brow_outer(depth, eye, mid_x, sep):
    """The (x, z) of the brow's outer end: a quarter of E above the eye (``BROW_UP``), and
    out from the eye where the brow ridge ends (``_ridge_end``) or the forehead turns into
    the temple (``_temple``), whichever comes first, within ``BROW_MIN`` to ``BROW_MAX`` E
    of the eye; both sides are measured and the mean offset is kept.  Where neither
    shows (no ridge, no front to cut), ``BROW_OUT`` E."""
    brow_z = eye[2] + BROW_UP * sep
    ends = []
    for sign in (1.0, -1.0):
        eye_x = mid_x + sign * abs(eye[0] - mid_x)
        temple = [_temple(depth, eye_x, brow_z + dz * sep, sign, sep) for dz in TEMPLE_CUTS]
        temple = [t for t in temple if t is not None]
        found = [e for e in (_ridge_end(depth, eye_x, eye[2], sign, sep),
                             np.median(temple) if temple else None) if e is not None]
        if found:
            ends.append(min(found))
    out = float(np.clip(np.mean(ends), BROW_MIN * sep, BROW_MAX * sep)) if ends else BROW_OUT * sep
    return eye[0] + out, brow_z


def _complete(p, depth, anchors, hints):
    eye_l, eye_r = anchors["eye_L"], anchors["eye_R"]
    mouth_l, mouth_r = anchors["mouth_L"], anchors["mouth_R"]
    sep = eye_l[0] - eye_r[0]
    mid_x = 0.25 * (eye_l[0] + eye_r[0] + mouth_l[0] + mouth_r[0])
    eye_z = 0.5 * (eye_l[2] + eye_r[2])
    mouth_z = 0.5 * (mouth_l[2] + mouth_r[2])
    cell = depth.cell
    # The eye: the left eye mirrored onto the right one's, averaged (the two agree on a
    # symmetric face and the mean halves the noise of either).
    eye = 0.5 * (eye_l + eye_r * np.array([-1.0, 1.0, 1.0]) + np.array([2.0 * mid_x, 0.0, 0.0]))
    mouth = 0.5 * (mouth_l + mouth_r * np.array([-1.0, 1.0, 1.0]) + np.array([2.0 * mid_x, 0.0, 0.0]))
    if hints.get("corner_pit"):  # the corner of a closed mouth sits in a pit: the deepest spot near it
        r, c, k = depth.row(mouth[2]), depth.col(mouth[0]), max(int(0.05 * sep / depth.cell), 1)
        block = depth.y[max(r - k, 0):r + k + 1, max(c - k, 0):c + k + 1]
        if np.isfinite(block).any():
            pit = float(np.nanmax(block))
            # an opening's corner is its rim's end, inside the lips: the skin's corner, where
            # the lips meet in front of it, is no deeper (what the opening shows behind it, a
            # mouth's inside, is not the skin)
            mouth[1] = min(pit, mouth[1]) if hints.get("rim") else pit
    # The nose tip: the most forward vertex between the mouth and the eyes, near the midline.
    near = (np.abs(p[:, 0] - mid_x) < 0.3 * sep) & (p[:, 2] > mouth_z) & (p[:, 2] < eye_z)
    if not near.any():
        raise NotFound("no nose between the eyes and the mouth")
    nose = p[np.flatnonzero(near)[np.argmin(p[near, 1])]]
    prof = smooth1(depth.profile(mid_x, 0.03 * sep), 0.02 * sep / cell)
    zs = depth.z0 + np.arange(depth.shape[0]) * cell

    def extreme(z_lo, z_hi, deepest):
        rows = depth.rows_between(z_lo, z_hi)
        seg = prof[rows]
        if not np.isfinite(seg).any():
            return None
        return int(rows[np.nanargmax(seg) if deepest else np.nanargmin(seg)])

    nasion = extreme(eye_z - 0.1 * sep, eye_z + 0.2 * sep, True)
    nasion_z = zs[nasion] if nasion is not None else eye_z
    top = hints.get("brow_z", nasion_z + 0.3 * sep)
    top = min(max(top, nasion_z + 0.15 * sep), nasion_z + 0.3 * sep)
    g = extreme(nasion_z, top, False)
    glab_z = zs[g] if g is not None else eye_z + 0.3 * sep
    chin_z = _chin(prof, zs, depth, mouth_z, sep)
    # The eye's depth: the mean of the surface at its two corners (an eye may be an
    # opening, or a lid bulging out of its socket).
    eye = np.array([eye[0], 0.5 * (_surface_y(depth, eye[0] - CANTHUS * sep, eye[2])
                                   + _surface_y(depth, eye[0] + CANTHUS * sep, eye[2])), eye[2]])
    xz = {
        "hairline_center": (mid_x, glab_z + HAIRLINE_UP * sep),
        "glabella": (mid_x, glab_z),
        "brow_outer_L": _brow_outer(depth, eye, mid_x, sep),
        "nose_tip": None,
        "mouth_corner_L": None,
        "chin": (mid_x, chin_z),
        "cheekbone_L": (eye[0] + CHEEK_OUT * sep, eye[2] - CHEEK_DOWN * sep),
        "eye_L": None,
    }
    out = {}
    for key, _label, _desc in LANDMARKS:  # eight landmarks
        if xz[key] is None:
            continue
        x, z = xz[key]
        out[key] = np.array([x, depth.surface(x, z), z])
    out["nose_tip"] = np.asarray(nose, np.float64).copy()
    out["eye_L"] = eye
    out["mouth_corner_L"] = mouth
    return {k: out[k] for k, _l, _d in LANDMARKS}


# --------------------------------------------------------------------------
# Public API
# --------------------------------------------------------------------------
def find_landmarks(rest, faces, shape_keys=None, rules=RULES):
    """The eight landmarks of ``LANDMARKS`` on the face ``rest`` (N, 3).

    ``faces``: an (F, k) array of vertex indices or ``(corner_verts, starts, sizes)``.
    ``shape_keys``: optional ``{name: (N, 3) positions}`` (the key's shape, not its
    offsets) for the rig rule.  ``rules``: the rules to try, in this order.

    Returns ``(landmarks, method, message)``: ``landmarks`` maps every name of
    ``LANDMARKS`` to a face-local (3,) float64 point, ``method`` is the rule that
    fitted (one of ``RULES``) or ``FALLBACK``, ``message`` is empty unless the bounding box
    was used.
    """
    p = np.asarray(rest, np.float64).reshape(-1, 3)
    lo, hi = p.min(axis=0) if len(p) else np.zeros(3), p.max(axis=0) if len(p) else np.zeros(3)
    if len(p) >= 4:
        corner, starts, sizes = polygons(faces)
        tris = mesh.fan_triangles(corner, starts, sizes).astype(np.int64)
        scale = float(max(hi[0] - lo[0], hi[2] - lo[2]))
        if len(tris) and scale > 0:
            depth = None
            for rule in rules:
                try:
                    if rule == "openings":
                        anchors, hints = _openings(p, boundary_loops(corner, starts, sizes), scale)
                    elif rule == "rig":
                        anchors, hints = _rig(p, shape_keys, scale)
                    elif rule == "geometry":
                        depth = depth or Depth(p, tris)
                        anchors, hints = _geometry(p, depth, scale)
                    else:
                        raise ValueError(f"unknown rule {rule!r}")
                    depth = depth or Depth(p, tris)
                    return _complete(p, depth, anchors, hints), rule, ""
                except NotFound:
                    continue
    guess = estimate_landmarks(lo, hi)
    return {k: np.asarray(v, np.float64) for k, v in guess.items()}, FALLBACK, FALLBACK_MESSAGE
