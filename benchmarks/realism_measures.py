# SPDX-License-Identifier: GPL-3.0-or-later
"""How real muscle wrinkles look, measured on a wrinkle height field.  Pure NumPy (the
rasteriser is the add-on's own ``wrinkle_addon.core.raster``), importable without bpy;
``benchmarks/realism.py`` feeds it the add-on's heights on real heads.

Everything is in millimetres, in the face's front plane: face-local coordinates (the face
looks toward -Y, Z up, the character's left +X), x across, z up, y the depth (smaller is
nearer the viewer).  Heights are along the skin normal, negative in a furrow, positive on a
bulge (Zhang's eq. 5: furrows at the cycle ends, bulges mid-cycle).

The grid
--------
:func:`front_grid` resamples per-vertex heights (and the depth y) onto a regular (x, z)
grid of cells ``step`` apart, as the face is seen from the front: the triangles facing the
viewer are rasterised with linear interpolation, nearest last, so each cell holds the
surface a viewer sees there.  Cells no front-facing triangle covers are invalid (NaN).
Lengths along a furrow are measured in 3D through the depth, so a sloping glabella is not
foreshortened.

Furrows as ridge-lines of minima (:func:`ridges`)
--------------------------------------------------
A furrow point is a cell whose height is at most ``-detect_mm`` and no higher than every
cell within ``window_mm`` on both sides *across* the expected furrow direction (along z
for the forehead's horizontal furrows, along x for the glabella's vertical ones; a cell
within ``window_mm`` of the grid's edge or of an invalid cell is never one).  Points in
neighbouring lines of the grid are linked when they are at most one cell apart across per
cell along, so a line at up to 45° is followed; a gap along the furrow of up to
``gap_mm`` (1 mm, invisible) is bridged.  Each connected set is a ridge-line; its position
across in each line of the grid is the vertex of the parabola through the minimum and its
two neighbours (sub-cell, so a slanting line is not a staircase).

Forehead, brow raise (:func:`forehead`)
---------------------------------------
The forehead is the grid between the outer brows (x) and from the top of the brows to the
hairline (z) (the benchmark takes these from the posed landmarks).  Furrow points at
0.1 mm or deeper (``detect_mm``; a visible fine line), window 1 mm.

* **Distinct furrows** (``furrows``, goal >= 3): ridge-lines running at least a tenth of
  the forehead's width (``min_fraction``; shorter ones are dimples), grouped into rows,
  longest first: a ridge-line continues the row whose nearest end lies closest across to
  its own facing end (each end averaged over 3 mm), if that is within half the median
  spacing of the ridge-lines (their gaps across wherever two share a column; ``merge_mm``,
  3 mm, when none do) and the two overlap along x by at most a quarter of the shorter.  So
  a furrow broken at the midline, or kinked where two muscles meet, counts once.
  ``furrows`` is the number of rows.
* **Continuity** (goal >= 0.5): per row, the x-extent of its longest ridge-line (what runs
  unbroken) over the forehead's width; the median over the rows.  0 without furrows.
* **Angle** (``angle_deg``, goal <= 15): per unbroken ridge-line, the angle of its
  least-squares line z = a + b x against the brow line (the benchmark's line through the
  posed outer brows); per row the extent-weighted mean of their absolute values; the
  median over the rows.  (A furrow that arches with the brow, symmetric about the middle,
  fits a level line.)
* **Spacing** (``spacing_cv``, goal <= 0.35): the rows' z at the forehead's centre x (on
  their fitted lines), sorted; the coefficient of variation (population standard
  deviation over mean) of the gaps between neighbours.  None with fewer than 3 rows (a
  single gap has no variation to measure).
* **Furrow to bulge** (``furrow_bulge_ratio``, goal > 1): in every grid column, between
  each pair of neighbouring furrows (each row's deepest point in that column), the depth
  of the two furrows (mean of -h) and the highest height between them (the bulge, at
  least 0); the ratio of the medians over all such pairs, capped at 100 (a furrow with
  no bulge at all).  None where no column has two furrows.

Glabella, brow down (:func:`glabella`)
--------------------------------------
The grid between the brows; the side of a cell is its x against the midline.  Furrow
points across x, at 0.05 mm or deeper (``detect_mm``: the whole furrow is followed, then
judged), window 1 mm.  Per ridge-line: its angle from vertical (line x = a + b z); its
**deep length**, the 3D length of its longest stretch (gaps up to ``gap_mm`` bridged)
where it is at least ``depth_mm`` (0.3 mm) deep, along its path smoothed over +-1 mm;
its depth, the largest -h on it.  A **frown line** is within ``max_angle_deg`` (30°) of
vertical with a deep length of at least ``length_mm`` (10 mm).

* ``glabella_furrows_per_side``: the frown lines on the side that has fewer (goal >= 1
  each side, so >= 1).
* ``glabella_length_mm``: on each side the largest deep length of a near-vertical
  ridge-line; the smaller of the two sides (goal >= 10).
* ``glabella_depth_mm``: on each side the deepest near-vertical ridge-line; the smaller
  of the two sides (goal >= 0.3).

Smile: the nasolabial fold (:func:`deepest_in_band`)
-----------------------------------------------------
Below the eyes (the grid from the chin to the eyes), the nasolabial bands are the cells
within a distance of the segment from beside the nose's wing to beside the mouth corner
(set by the benchmark from the landmarks).  ``nasolabial_deepest`` is True when the lowest
height of all valid cells below the eyes is negative (a furrow) and lies in a band.

Eyelids and lips (:func:`max_abs`)
-----------------------------------
``eyelid_lip_max_mm``: the largest |h| over the vertices of the add-on's own eyelid and
lip zones (``wrinkle_addon.core.zones.face_zones``), per vertex, no grid (goal: 0).
"""

from dataclasses import dataclass

import numpy as np

from wrinkle_addon.core import raster

__all__ = ["Grid", "front_grid", "ridges", "forehead", "glabella", "deepest_in_band", "segment_band",
           "max_abs", "RATIO_CAP"]

RATIO_CAP = 100.0


@dataclass
class Grid:
    """A field seen from the front: ``h`` and ``y`` (Z, X) with NaN where invalid; cell
    ``(k, i)`` is at ``x = xs[i]``, ``z = zs[k]``; ``step`` in mm."""

    h: np.ndarray
    y: np.ndarray
    xs: np.ndarray
    zs: np.ndarray
    step: float

    @property
    def valid(self):
        return np.isfinite(self.h)

    @classmethod
    def of(cls, h, step=0.5, x0=0.0, z0=0.0, y=None):
        """A grid from an array ``h`` (Z, X) (rows z up, columns x to the right)."""
        h = np.asarray(h, dtype=np.float64)
        y = np.zeros_like(h) if y is None else np.asarray(y, dtype=np.float64)
        return cls(h, np.where(np.isfinite(h), y, np.nan), x0 + step * np.arange(h.shape[1]),
                   z0 + step * np.arange(h.shape[0]), float(step))

    def crop(self, x_range, z_range):
        """The sub-grid inside ``x_range`` and ``z_range`` (inclusive, mm)."""
        ci = np.flatnonzero((self.xs >= x_range[0] - 1e-9) & (self.xs <= x_range[1] + 1e-9))
        ck = np.flatnonzero((self.zs >= z_range[0] - 1e-9) & (self.zs <= z_range[1] + 1e-9))
        if len(ci) == 0 or len(ck) == 0:
            return Grid(np.full((0, 0), np.nan), np.full((0, 0), np.nan), self.xs[:0], self.zs[:0], self.step)
        sl = (slice(ck[0], ck[-1] + 1), slice(ci[0], ci[-1] + 1))
        return Grid(self.h[sl], self.y[sl], self.xs[sl[1]], self.zs[sl[0]], self.step)


def front_grid(points, tris, heights, x_range, z_range, step=0.5, facing=0.1):
    """Resample per-vertex ``heights`` (N,) on the surface ``points`` (N, 3) (triangles
    ``tris`` (T, 3)) onto the (x, z) grid covering ``x_range`` x ``z_range``, as seen from
    the front (-Y).  Triangles whose normal's -y component is below ``facing`` (turned away
    or edge-on) are dropped; the rest are drawn farthest first, so the nearest wins."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    tris = np.asarray(tris, dtype=np.int64).reshape(-1, 3)
    h = np.asarray(heights, dtype=np.float64).reshape(-1)
    x0, z0 = float(x_range[0]), float(z_range[0])
    nx = int(np.floor((x_range[1] - x0) / step + 1e-9)) + 1
    nz = int(np.floor((z_range[1] - z0) / step + 1e-9)) + 1
    res = max(nx, nz)
    corners = p[tris]
    n = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(n, axis=1)
    front = -n[:, 1] >= facing * np.maximum(length, 1e-30)
    lo, hi = corners.min(axis=1), corners.max(axis=1)
    inside = ((hi[:, 0] >= x0 - step) & (lo[:, 0] <= x0 + res * step)
              & (hi[:, 2] >= z0 - step) & (lo[:, 2] <= z0 + res * step))
    keep = np.flatnonzero(front & inside & (length > 0))
    keep = keep[np.argsort(-corners[keep, :, 1].mean(axis=1), kind="stable")]  # farthest first
    c = corners[keep]
    # cell (k, i) has its centre at u = (i + 0.5) / res, v = (k + 0.5) / res
    span = res * step
    uv = np.stack([(c[..., 0] - x0) / span + 0.5 / res, (c[..., 2] - z0) / span + 0.5 / res], -1)
    values = np.stack([h[tris[keep]], c[..., 1]], -1)
    image, covered = raster.rasterize(uv, values, res)
    hh = np.where(covered, image[..., 0], np.nan)[:nz, :nx].astype(np.float64)
    yy = np.where(covered, image[..., 1], np.nan)[:nz, :nx].astype(np.float64)
    return Grid(hh, yy, x0 + step * np.arange(nx), z0 + step * np.arange(nz), float(step))


# --------------------------------------------------------------------------- ridge-lines
@dataclass
class Ridge:
    """One ridge-line of minima in the (across, along) frame: per along-line it passes,
    ``cols`` (ascending along index), ``across`` (mean across position, mm), ``along``
    (mm), ``depth`` (the largest -h there), ``y`` (depth of the surface there, mm) and
    ``cell`` (the across index of its deepest point there)."""

    cols: np.ndarray
    along: np.ndarray
    across: np.ndarray
    depth: np.ndarray
    y: np.ndarray
    cell: np.ndarray

    @property
    def extent(self):
        return float(self.along[-1] - self.along[0]) if len(self.along) else 0.0

    def fit(self):
        """(a, b) of the least-squares line across = a + b along (b = 0 for one point)."""
        return _line(self.along, self.across)


def _line(t, s):
    t, s = np.asarray(t, float), np.asarray(s, float)
    if len(t) < 2 or np.ptp(t) == 0:
        return (float(np.mean(s)) if len(s) else 0.0), 0.0
    b, a = np.polyfit(t, s, 1)
    return float(a), float(b)


def _shift(a, s, axis):
    """``a`` shifted by ``s`` along ``axis`` (out[k] = a[k + s]), NaN where it runs out."""
    out = np.full_like(a, np.nan)
    n = a.shape[axis]
    if abs(s) >= n:
        return out
    src = [slice(None)] * a.ndim
    dst = [slice(None)] * a.ndim
    src[axis] = slice(max(s, 0), n + min(s, 0))
    dst[axis] = slice(max(-s, 0), n - max(s, 0))
    out[tuple(dst)] = a[tuple(src)]
    return out


def minima(h, across_axis, window, detect):
    """Cells of ``h`` at most ``-detect`` and no higher than any cell within ``window``
    cells on both sides along ``across_axis`` (NaN neighbours, or the edge, disqualify)."""
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(h) & (h <= -detect)
        for s in range(1, max(int(window), 1) + 1):
            ok &= (h <= _shift(h, s, across_axis)) & (h <= _shift(h, -s, across_axis))
    return ok


def _components(pts, pairs):
    """Connected-component labels of ``len(pts)`` points linked by ``pairs`` (P, 2)."""
    lab = np.arange(len(pts))
    if len(pairs) == 0:
        return lab
    a, b = pairs[:, 0], pairs[:, 1]
    while True:
        low = np.minimum(lab[a], lab[b])
        new = lab.copy()
        np.minimum.at(new, a, low)
        np.minimum.at(new, b, low)
        new = new[new]  # pointer jumping
        if np.array_equal(new, lab):
            return lab
        lab = new


def ridges(grid, across, detect_mm, window_mm=1.0, gap_mm=1.0):
    """The ridge-lines of minima of ``grid`` across ``across`` ('z': horizontal furrows,
    'x': vertical ones), as :class:`Ridge` in that frame (see the module doc)."""
    step = grid.step
    if across == "z":
        h, y, across_pos, along_pos = grid.h, grid.y, grid.zs, grid.xs
    else:
        h, y, across_pos, along_pos = grid.h.T, grid.y.T, grid.xs, grid.zs
    if h.size == 0:
        return []
    window = max(1, int(round(window_mm / step)))
    gap = max(1, int(round(gap_mm / step)) + 1)  # along-steps linked: up to gap_mm missing
    m = minima(h, 0, window, detect_mm)
    ii, jj = np.nonzero(m)  # (across, along)
    if len(ii) == 0:
        return []
    index = np.full(h.shape, -1, np.int64)
    index[ii, jj] = np.arange(len(ii))
    pairs = []
    for g in range(1, gap + 1):
        for d in range(-g, g + 1):
            j2, i2 = jj + g, ii + d
            ok = (j2 < h.shape[1]) & (i2 >= 0) & (i2 < h.shape[0])
            other = np.full(len(ii), -1)
            other[ok] = index[i2[ok], j2[ok]]
            hit = other >= 0
            pairs.append(np.stack([np.flatnonzero(hit), other[hit]], 1))
    lab = _components(ii, np.concatenate(pairs))
    # sub-cell position of each minimum: the vertex of the parabola through it and its
    # two neighbours across (so a slanting line is not a staircase)
    hm, h0, hp = h[ii - 1, jj], h[ii, jj], h[ii + 1, jj]
    curv = hm - 2.0 * h0 + hp
    frac = np.where(curv > 0, 0.5 * (hm - hp) / np.where(curv > 0, curv, 1.0), 0.0)
    sub = across_pos[ii] + step * np.clip(frac, -0.5, 0.5)
    out = []
    for label in np.unique(lab):
        sel = lab == label
        ci, cj, cs = ii[sel], jj[sel], sub[sel]
        cols = np.unique(cj)
        pos = np.array([cs[cj == c].mean() for c in cols])
        depth_cells = -h[ci, cj]
        deepest = np.array([ci[cj == c][np.argmax(depth_cells[cj == c])] for c in cols])
        out.append(Ridge(cols=cols, along=along_pos[cols], across=pos, depth=-h[deepest, cols],
                         y=y[deepest, cols], cell=deepest))
    return out


# --------------------------------------------------------------------------- forehead
@dataclass
class Row:
    ridges: list
    a: float = 0.0
    b: float = 0.0

    def refit(self):
        self.a, self.b = _line(np.concatenate([r.along for r in self.ridges]),
                               np.concatenate([r.across for r in self.ridges]))

    def lo(self):
        return min(r.along[0] for r in self.ridges)

    def hi(self):
        return max(r.along[-1] for r in self.ridges)


def _end(r, at_start, span):
    """(along, across) of ``r``'s end: its first (or last) ``span`` mm, averaged."""
    sel = r.along <= r.along[0] + span if at_start else r.along >= r.along[-1] - span
    return (r.along[0] if at_start else r.along[-1]), float(np.mean(r.across[sel]))


def _spacing(found):
    """The median gap across between ridge-lines that share a column, or None."""
    per_col = {}
    for r in found:
        for c, a in zip(r.cols, r.across):
            per_col.setdefault(int(c), []).append(a)
    gaps = [g for v in per_col.values() if len(v) > 1 for g in np.diff(np.sort(v))]
    return float(np.median(gaps)) if gaps else None


def _rows(found, merge_mm, end_mm=3.0):
    """Ridge-lines grouped into furrow rows: each, longest first, continues the row whose
    nearest end lies closest across to its own facing end, if that is within
    ``merge_mm`` and they overlap along by at most a quarter of the shorter."""
    rows = []
    for r in sorted(found, key=lambda r: -r.extent):
        best, best_d = None, merge_mm
        for row in rows:
            overlap = min(row.hi(), r.along[-1]) - max(row.lo(), r.along[0])
            if overlap > 0.25 * min(row.hi() - row.lo(), r.extent):
                continue
            for other in row.ridges:
                left = other.along[-1] <= r.along[0] + 0.25 * r.extent  # other lies before r
                _t0, a0 = _end(other, not left, end_mm)
                _t1, a1 = _end(r, left, end_mm)
                if abs(a0 - a1) <= best_d:
                    best, best_d = row, abs(a0 - a1)
        if best is None:
            best = Row([])
            rows.append(best)
        best.ridges.append(r)
        best.refit()
    return rows


def forehead(grid, brow_angle_deg=0.0, detect_mm=0.1, window_mm=1.0, gap_mm=1.0, min_fraction=0.1,
             merge_mm=3.0):
    """The brow-raise measures on the forehead ``grid`` (see the module doc): a dict with
    ``furrows``, ``continuity``, ``angle_deg``, ``spacing_cv``, ``furrow_bulge_ratio``."""
    width = float(grid.xs[-1] - grid.xs[0]) if len(grid.xs) > 1 else 0.0
    found = [r for r in ridges(grid, "z", detect_mm, window_mm, gap_mm)
             if width > 0 and r.extent >= min_fraction * width]
    spacing = _spacing(found)
    rows = _rows(found, merge_mm if spacing is None else 0.5 * spacing)
    out = {"furrows": len(rows), "continuity": 0.0, "angle_deg": None, "spacing_cv": None,
           "furrow_bulge_ratio": None}
    if not rows:
        return out
    out["continuity"] = float(np.median([max(r.extent for r in row.ridges) / width for row in rows]))
    out["angle_deg"] = float(np.median([_row_angle(row, brow_angle_deg) for row in rows]))
    centre = 0.5 * (grid.xs[0] + grid.xs[-1])
    at_centre = np.sort([row.a + row.b * centre for row in rows])
    if len(rows) >= 3:
        gaps = np.diff(at_centre)
        out["spacing_cv"] = float(np.std(gaps) / np.mean(gaps)) if np.mean(gaps) > 0 else None
    out["furrow_bulge_ratio"] = _furrow_bulge(grid, rows)
    return out


def _row_angle(row, reference_deg):
    """The extent-weighted mean over a row's pieces of each one's angle to the reference."""
    angles = [abs(np.degrees(np.arctan(r.fit()[1])) - reference_deg) for r in row.ridges]
    weights = [max(r.extent, 1e-9) for r in row.ridges]
    return float(np.average(angles, weights=weights))


def _furrow_bulge(grid, rows):
    """Median furrow depth over median bulge height between neighbouring furrows."""
    per_col = {}
    for row in rows:
        for r in row.ridges:
            for c, cell in zip(r.cols, r.cell):
                per_col.setdefault(int(c), []).append(int(cell))
    depths, bulges = [], []
    for c, cells in per_col.items():
        cells = sorted(set(cells))
        col = grid.h[:, c]
        for k0, k1 in zip(cells[:-1], cells[1:]):
            between = col[k0:k1 + 1]
            if not np.all(np.isfinite(between)):
                continue
            depths.append(-0.5 * (col[k0] + col[k1]))
            bulges.append(max(float(np.max(between)), 0.0))
    if not depths:
        return None
    d, b = float(np.median(depths)), float(np.median(bulges))
    return RATIO_CAP if b * RATIO_CAP <= d else d / b


# --------------------------------------------------------------------------- glabella
def _deep_length(r, depth_mm, gap_cols, smooth):
    """The 3D length of ``r``'s longest stretch at least ``depth_mm`` deep, along its path
    smoothed over ``2 smooth + 1`` samples (grid noise would lengthen it)."""
    deep = r.depth >= depth_mm
    best = 0.0
    idx = np.flatnonzero(deep)
    if len(idx) == 0:
        return 0.0
    # stretches: runs of deep points whose along indices are at most gap_cols apart
    breaks = np.flatnonzero(np.diff(r.cols[idx]) > gap_cols)
    for seg in np.split(idx, breaks + 1):
        pts = np.stack([_smooth(r.across[seg], smooth), r.along[seg], _smooth(r.y[seg], smooth)], 1)
        length = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1))) if len(seg) > 1 else 0.0
        best = max(best, length)
    return best


def _smooth(v, half):
    """Moving average of ``v`` over ``2 half + 1`` samples (shrinking at the ends)."""
    if half < 1 or len(v) < 3:
        return v
    c = np.concatenate([[0.0], np.cumsum(v)])
    k = np.arange(len(v))
    lo, hi = np.maximum(k - half, 0), np.minimum(k + half + 1, len(v))
    return (c[hi] - c[lo]) / (hi - lo)


def glabella(grid, midline_x, detect_mm=0.05, window_mm=1.0, gap_mm=1.0, depth_mm=0.3, length_mm=10.0,
             max_angle_deg=30.0):
    """The brow-down measures on the glabella ``grid`` (see the module doc): a dict with
    ``glabella_furrows_per_side``, ``glabella_length_mm``, ``glabella_depth_mm``, and per
    side (``sides``) the ridge-lines as (angle from vertical, deep length, depth)."""
    gap_cols = max(1, int(round(gap_mm / grid.step)) + 1)
    smooth = int(round(1.0 / grid.step))  # +-1 mm
    sides = {"L": [], "R": []}
    for r in ridges(grid, "x", detect_mm, window_mm, gap_mm):
        _a, b = r.fit()
        angle = float(np.degrees(np.arctan(abs(b))))
        side = "L" if np.mean(r.across) >= midline_x else "R"
        sides[side].append((angle, _deep_length(r, depth_mm, gap_cols, smooth), float(np.max(r.depth))))
    counts, lengths, depths = [], [], []
    for found in sides.values():
        upright = [f for f in found if f[0] <= max_angle_deg]
        counts.append(sum(1 for f in upright if f[1] >= length_mm))
        lengths.append(max((f[1] for f in upright), default=0.0))
        depths.append(max((f[2] for f in upright), default=0.0))
    return {"glabella_furrows_per_side": int(min(counts)), "glabella_length_mm": float(min(lengths)),
            "glabella_depth_mm": float(min(depths)), "sides": sides}


# --------------------------------------------------------------------------- nasolabial
def segment_band(grid, a, b, half_width):
    """Cells of ``grid`` within ``half_width`` (mm) of the segment ``a``-``b`` ((x, z), mm)."""
    X, Z = np.meshgrid(grid.xs, grid.zs)
    a, b = np.asarray(a, float), np.asarray(b, float)
    d = b - a
    t = np.clip(((X - a[0]) * d[0] + (Z - a[1]) * d[1]) / max(float(d @ d), 1e-12), 0.0, 1.0)
    return np.hypot(X - a[0] - t * d[0], Z - a[1] - t * d[1]) <= half_width


def deepest_in_band(grid, band):
    """(whether the lowest valid height of ``grid`` is negative and in ``band`` (a bool
    array like the grid), that height, the lowest height outside the band)."""
    h = np.where(grid.valid, grid.h, np.inf)
    if not np.isfinite(h).any():
        return False, 0.0, 0.0
    k = np.unravel_index(np.argmin(h), h.shape)
    low = float(h[k])
    outside = np.where(band, np.inf, h)
    other = float(outside.min()) if np.isfinite(outside).any() else 0.0
    return bool(low < 0.0 and band[k]), low, other


def max_abs(values, mask):
    """The largest |value| where ``mask`` is True (0 for an empty mask)."""
    v = np.abs(np.asarray(values, float)[np.asarray(mask, bool)])
    return float(v.max()) if v.size else 0.0
