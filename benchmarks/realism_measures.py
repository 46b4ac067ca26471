# SPDX-License-Identifier: GPL-3.0-or-later
"""How real muscle wrinkles look, measured on a wrinkle height field (pure NumPy, importable
without bpy; ``benchmarks/realism.py`` feeds it the add-on's heights on real heads).

Every measure, its units and how it is computed: docs/benchmarks/realism_measures.md.
"""

from dataclasses import dataclass

import numpy as np

from wrinkle_addon.core import mesh, raster

__all__ = ["Grid", "front_grid", "ridges", "forehead", "glabella", "procerus", "crows_feet_side",
           "crows_feet", "knots", "deepest_in_band", "segment_band", "max_abs", "curvatures", "RATIO_CAP",
           "glabella_offset", "triangle_compression", "vertex_compression", "pearson", "vertex_normals",
           "corner_max_abs", "lr_ratio", "lr_balance", "forehead_sides", "band_deepest",
           "ridge_curvature_max", "slits"]

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
    ``cell`` (the across index of its deepest point there); ``peak`` (the depth of the
    vertex of the parabola through that point and its two neighbours across: sub-cell)."""

    cols: np.ndarray
    along: np.ndarray
    across: np.ndarray
    depth: np.ndarray
    y: np.ndarray
    cell: np.ndarray
    peak: np.ndarray = None

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


def _parabola(h, ii, jj):
    """The vertex of the parabola through each minimum ``h[ii, jj]`` and its two neighbours
    across (axis 0): its offset in cells (within half a cell: ``h[ii, jj]`` is a minimum),
    so a slanting line is not a staircase, and its height."""
    hm, h0, hp = h[ii - 1, jj], h[ii, jj], h[ii + 1, jj]
    curv = hm - 2.0 * h0 + hp
    safe = np.where(curv > 0, curv, 1.0)
    frac = np.clip(np.where(curv > 0, 0.5 * (hm - hp) / safe, 0.0), -0.5, 0.5)
    return frac, h0 - np.where(curv > 0, (hm - hp) ** 2 / (8.0 * safe), 0.0)


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
    'x': vertical ones), as :class:`Ridge` in that frame (docs/benchmarks/realism_measures.md)."""
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
    frac, peak_h = _parabola(h, ii, jj)
    sub = across_pos[ii] + step * frac
    peak_of = np.full(h.shape, np.nan)
    peak_of[ii, jj] = -peak_h
    out = []
    for label in np.unique(lab):
        sel = lab == label
        ci, cj, cs = ii[sel], jj[sel], sub[sel]
        cols = np.unique(cj)
        pos = np.array([cs[cj == c].mean() for c in cols])
        depth_cells = -h[ci, cj]
        deepest = np.array([ci[cj == c][np.argmax(depth_cells[cj == c])] for c in cols])
        out.append(Ridge(cols=cols, along=along_pos[cols], across=pos, depth=-h[deepest, cols],
                         y=y[deepest, cols], cell=deepest, peak=peak_of[deepest, cols]))
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
    """The brow-raise measures on the forehead ``grid`` (docs/benchmarks/realism_measures.md): a dict with
    ``furrows``, ``continuity``, ``angle_deg``, ``spacing_cv``, ``furrow_bulge_ratio``,
    ``depth_cv_along``, ``taper_mm``."""
    width = float(grid.xs[-1] - grid.xs[0]) if len(grid.xs) > 1 else 0.0
    found = [r for r in ridges(grid, "z", detect_mm, window_mm, gap_mm)
             if width > 0 and r.extent >= min_fraction * width]
    spacing = _spacing(found)
    rows = _rows(found, merge_mm if spacing is None else 0.5 * spacing)
    out = {"furrows": len(rows), "continuity": 0.0, "angle_deg": None, "spacing_cv": None,
           "furrow_bulge_ratio": None, "depth_cv_along": None, "taper_mm": None}
    if not rows:
        return out
    smooth = int(round(1.0 / grid.step))  # +-1 mm
    window = max(1, int(round(window_mm / grid.step)))
    reach = int(round((window_mm + gap_mm) / grid.step))
    cvs, tapers = [], []
    for row in rows:
        longest = max(row.ridges, key=lambda r: r.extent)
        samples = _depth_profile(longest, smooth)[2]
        cvs.append(float(np.std(samples) / np.mean(samples)) if np.mean(samples) > 0 else 0.0)
        for r in row.ridges:
            s_len, depth, samples = _depth_profile(r, smooth)
            typical = float(np.median(samples))
            if typical < 2.0 * detect_mm:  # all fade: no room to taper
                continue
            for at_start in (True, False):
                if not _cut(grid.h, r, at_start, window, reach):
                    tapers.append(_taper(s_len, depth, typical, at_start))
    out["depth_cv_along"] = float(np.median(cvs))
    out["taper_mm"] = float(min(tapers)) if tapers else None
    out["continuity"] = float(np.median([max(r.extent for r in row.ridges) / width for row in rows]))
    out["angle_deg"] = float(np.median([_row_angle(row, brow_angle_deg) for row in rows]))
    centre = 0.5 * (grid.xs[0] + grid.xs[-1])
    at_centre = np.sort([row.a + row.b * centre for row in rows])
    if len(rows) >= 3:
        gaps = np.diff(at_centre)
        out["spacing_cv"] = float(np.std(gaps) / np.mean(gaps)) if np.mean(gaps) > 0 else None
    out["furrow_bulge_ratio"] = _furrow_bulge(grid, rows)
    return out


def _path_length(r, smooth):
    """Cumulative 3D length (n,) along ``r``'s path, its across and depth y smoothed over
    ``2 smooth + 1`` samples."""
    pts = np.stack([_smooth(r.across, smooth), r.along, _smooth(r.y, smooth)], 1)
    if len(pts) < 2:
        return np.zeros(len(pts))
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])


def _depth_profile(r, smooth, spacing=1.0):
    """(path length at each point, depth at each point (the parabola vertex), the depth
    sampled every ``spacing`` mm of path, linearly interpolated)."""
    s_len = _path_length(r, smooth)
    depth = np.asarray(r.peak if r.peak is not None else r.depth, float)
    t = np.arange(0.0, s_len[-1] + 1e-9, spacing)
    return s_len, depth, np.interp(t, s_len, depth)


def _taper(s_len, depth, typical, at_start):
    """The path length from ``r``'s start (or end) inward to where its depth first reaches
    ``typical`` (linearly interpolated between points)."""
    if not at_start:
        s_len, depth = s_len[-1] - s_len[::-1], depth[::-1]
    reach = np.flatnonzero(depth >= typical)
    if len(reach) == 0:
        return float(s_len[-1])
    i = int(reach[0])
    if i == 0:
        return 0.0
    f = (typical - depth[i - 1]) / max(depth[i] - depth[i - 1], 1e-12)
    return float(s_len[i - 1] + f * (s_len[i] - s_len[i - 1]))


def _cut(h, r, at_start, window, reach):
    """Whether ``r``'s start (or end) may be cut off by the region: a cell up to ``reach``
    cells beyond it along, within ``window`` across of its last point, lies off the grid
    ``h`` (across, along) or is invalid."""
    j, k = (r.cols[0], r.cell[0]) if at_start else (r.cols[-1], r.cell[-1])
    sign = -1 if at_start else 1
    for m in range(1, reach + 1):
        jj = int(j) + sign * m
        lo, hi = int(k) - window, int(k) + window
        if jj < 0 or jj >= h.shape[1] or lo < 0 or hi >= h.shape[0]:
            return True
        if not np.all(np.isfinite(h[lo:hi + 1, jj])):
            return True
    return False


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


def glabella(grid, midline_x, detect_mm=0.05, window_mm=1.0, gap_mm=1.0, depth_mm=0.3, count_mm=3.0,
             max_angle_deg=30.0):
    """The brow-down measures on the glabella ``grid`` (docs/benchmarks/realism_measures.md): a dict with
    ``glabella_furrows_per_side``, ``glabella_separation_mm``, ``glabella_length_mm``,
    ``glabella_depth_mm``, per side (``sides``) the ridge-lines as (angle from
    vertical, deep length, depth), and per side (``lines``) the frown lines as
    :class:`Ridge` (across x, along z)."""
    gap_cols = max(1, int(round(gap_mm / grid.step)) + 1)
    smooth = int(round(1.0 / grid.step))  # +-1 mm
    sides = {"L": [], "R": []}
    lines = {"L": [], "R": []}
    for r in ridges(grid, "x", detect_mm, window_mm, gap_mm):
        _a, b = r.fit()
        angle = float(np.degrees(np.arctan(abs(b))))
        side = "L" if np.mean(r.across) >= midline_x else "R"
        found = (angle, _deep_length(r, depth_mm, gap_cols, smooth), float(np.max(r.depth)))
        sides[side].append(found)
        if found[0] <= max_angle_deg and found[1] >= count_mm:
            lines[side].append(r)
    counts, lengths, depths, gaps = [], [], [], []
    for side, found in sides.items():
        upright = [f for f in found if f[0] <= max_angle_deg]
        counts.append(len(lines[side]))
        lengths.append(max((f[1] for f in upright), default=0.0))
        depths.append(max((f[2] for f in upright), default=0.0))
        got = lines[side]
        gaps += [_separation(a, b) for i, a in enumerate(got) for b in got[i + 1:]]
    return {"glabella_furrows_per_side": int(min(counts)),
            "glabella_separation_mm": float(min(gaps)) if gaps else None,
            "glabella_length_mm": float(min(lengths)), "glabella_depth_mm": float(min(depths)),
            "sides": sides, "lines": lines}


def _separation(a, b):
    """The distance across between ridge-lines ``a`` and ``b``: the median over the grid
    lines both pass, else the smallest distance between their points."""
    shared, ia, ib = np.intersect1d(a.cols, b.cols, return_indices=True)
    if len(shared):
        return float(np.median(np.abs(a.across[ia] - b.across[ib])))
    d = np.hypot(a.across[:, None] - b.across[None], a.along[:, None] - b.along[None])
    return float(d.min())


# --------------------------------------------------------------------------- procerus
def procerus(grid, detect_mm=0.05, window_mm=1.0, gap_mm=1.0, depth_mm=0.2, length_mm=5.0,
             max_angle_deg=30.0):
    """The anger measure on the nose-root ``grid`` (docs/benchmarks/realism_measures.md): a dict with
    ``procerus_line`` and ``lines``, the ridge-lines as (angle from horizontal, deep
    length, depth)."""
    gap_cols = max(1, int(round(gap_mm / grid.step)) + 1)
    smooth = int(round(1.0 / grid.step))
    lines = []
    for r in ridges(grid, "z", detect_mm, window_mm, gap_mm):
        _a, b = r.fit()
        lines.append((float(np.degrees(np.arctan(abs(b)))), _deep_length(r, depth_mm, gap_cols, smooth),
                      float(np.max(r.depth))))
    hit = any(a <= max_angle_deg and length >= length_mm for a, length, _d in lines)
    return {"procerus_line": bool(hit), "lines": lines}


# --------------------------------------------------------------------------- crow's feet
def _sample(grid, values, X, Z):
    """``values`` (a grid-shaped array) bilinearly at the points (X, Z); NaN off the grid or
    where a corner is invalid."""
    nz, nx = grid.h.shape
    out = np.full(np.shape(X), np.nan)
    if nz < 2 or nx < 2:
        return out
    fi = (np.asarray(X, float) - grid.xs[0]) / grid.step
    fk = (np.asarray(Z, float) - grid.zs[0]) / grid.step
    ok = (fi >= 0) & (fk >= 0) & (fi <= nx - 1) & (fk <= nz - 1)
    i0 = np.clip(np.floor(np.where(ok, fi, 0)).astype(int), 0, nx - 2)
    k0 = np.clip(np.floor(np.where(ok, fk, 0)).astype(int), 0, nz - 2)
    a, c = fi - i0, fk - k0
    v = (values[k0, i0] * (1 - a) * (1 - c) + values[k0, i0 + 1] * a * (1 - c)
         + values[k0 + 1, i0] * (1 - a) * c + values[k0 + 1, i0 + 1] * a * c)
    return np.where(ok, v, np.nan)


def crows_feet_side(grid, corner, outward, interocular, detect_mm=0.1, window_mm=1.0, gap_mm=1.0,
                    depth_mm=0.2, count_mm=4.0, inner=0.1, outer=0.6, half_height=0.45, radius_max=0.75):
    """The crow's feet of one side on ``grid`` around the outer eye ``corner`` ((x, z),
    mm), ``outward`` +1 (toward +x) or -1, ``interocular`` the eyes' distance E (mm)
    (docs/benchmarks/realism_measures.md).  A dict: ``count``, ``fan_deg`` (None without crow's feet),
    ``depth`` (0 without), ``lengths`` (of the crow's feet), and ``furrows``, every
    ridge-line as (direction deg, deep length, depth, inner and outer radius of its deep
    stretch)."""
    cx, cz = float(corner[0]), float(corner[1])
    e, step = float(interocular), grid.step
    out = {"count": 0, "fan_deg": None, "depth": 0.0, "lengths": [], "furrows": []}
    r0, r1 = inner * e, radius_max * e
    if not (e > 0 and r1 > r0 and grid.h.size):
        return out
    radius = r0 + step * np.arange(int(np.floor((r1 - r0) / step + 1e-9)) + 1)
    dtheta = step / radius[-1]
    n_half = int(np.floor(0.5 * np.pi / dtheta))
    theta = dtheta * np.arange(-n_half, n_half + 1)
    T, R = np.meshgrid(theta, radius, indexing="ij")  # (angle, radius)
    X, Z = cx + outward * R * np.cos(T), cz + R * np.sin(T)
    lateral = outward * (X - cx)
    inside = ((lateral >= inner * e - 1e-9) & (lateral <= outer * e + 1e-9)
              & (np.abs(Z - cz) <= half_height * e + 1e-9))
    h = np.where(inside, _sample(grid, grid.h, X, Z), np.nan)
    y = np.where(inside, _sample(grid, grid.y, X, Z), np.nan)
    # furrow points: minima across the angle within window_mm of arc (more samples near the corner)
    win = np.maximum(1, np.round(window_mm / (radius * dtheta))).astype(int)
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(h) & (h <= -detect_mm)
        for sft in range(1, int(win.max()) + 1):
            active = (win >= sft)[None, :]
            ok &= ((h <= _shift(h, sft, 0)) & (h <= _shift(h, -sft, 0))) | ~active
    ii, jj = np.nonzero(ok)  # (angle, radius)
    if len(ii) == 0:
        return out
    index = np.full(h.shape, -1, np.int64)
    index[ii, jj] = np.arange(len(ii))
    gap = max(1, int(round(gap_mm / step)) + 1)
    pairs = []
    for g in range(1, gap + 1):
        r_mid = radius[jj] + 0.5 * g * step
        dmax = int(np.ceil(g * step / (radius[0] * dtheta)))
        for d in range(-dmax, dmax + 1):
            i2, j2 = ii + d, jj + g
            fine = ((j2 < h.shape[1]) & (i2 >= 0) & (i2 < h.shape[0])
                    & (abs(d) * dtheta * r_mid <= g * step + 1e-9))
            other = np.full(len(ii), -1)
            other[fine] = index[i2[fine], j2[fine]]
            hit = other >= 0
            pairs.append(np.stack([np.flatnonzero(hit), other[hit]], 1))
    lab = _components(ii, np.concatenate(pairs))
    sub = theta[ii] + dtheta * _parabola(h, ii, jj)[0]
    smooth = int(round(1.0 / step))
    for label in np.unique(lab):
        sel = lab == label
        ci, cj, cs = ii[sel], jj[sel], sub[sel]
        cols = np.unique(cj)
        ang = np.array([cs[cj == c].mean() for c in cols])
        dep = -h[ci, cj]
        deepest = np.array([ci[cj == c][np.argmax(dep[cj == c])] for c in cols])
        depth = -h[deepest, cols]
        yy = y[deepest, cols]
        length, seg = _polar_stretch(cols, ang, yy, radius, depth, depth_mm, gap, smooth, cx, cz, outward)
        if len(seg) == 0:
            out["furrows"].append((None, 0.0, float(depth.max()), None, None))
            continue
        px = cx + outward * radius[cols[seg]] * np.cos(ang[seg])
        pz = cz + radius[cols[seg]] * np.sin(ang[seg])
        out["furrows"].append((_direction(px, pz, cx, cz, outward), length, float(depth.max()),
                               float(radius[cols[seg[0]]]), float(radius[cols[seg[-1]]])))
    feet = [f for f in out["furrows"] if f[1] >= count_mm]
    out["count"] = len(feet)
    if feet:
        dirs = [f[0] for f in feet]
        out["fan_deg"] = float(max(dirs) - min(dirs))
        out["depth"] = float(max(f[2] for f in feet))
        out["lengths"] = [f[1] for f in feet]
    return out


def _polar_stretch(cols, ang, yy, radius, depth, depth_mm, gap_cols, smooth, cx, cz, outward):
    """(3D length, indices into ``cols``) of a polar ridge-line's longest stretch at least
    ``depth_mm`` deep (gaps up to ``gap_cols`` bridged), its angle and depth y smoothed."""
    idx = np.flatnonzero(depth >= depth_mm)
    if len(idx) == 0:
        return 0.0, idx
    best, best_seg = -1.0, idx[:0]
    for seg in np.split(idx, np.flatnonzero(np.diff(cols[idx]) > gap_cols) + 1):
        a, r = _smooth(ang[seg], smooth), radius[cols[seg]]
        pts = np.stack([cx + outward * r * np.cos(a), cz + r * np.sin(a), _smooth(yy[seg], smooth)], 1)
        length = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1))) if len(seg) > 1 else 0.0
        if length > best:
            best, best_seg = length, seg
    return best, best_seg


def _direction(px, pz, cx, cz, outward):
    """The angle (deg) from the outward horizontal of the principal axis of the points
    (px, pz); one point: its polar angle about (cx, cz)."""
    if len(px) < 2:
        return float(np.degrees(np.arctan2(pz[0] - cz, outward * (px[0] - cx))))
    d = np.stack([outward * (px - px.mean()), pz - pz.mean()], 1)
    _w, v = np.linalg.eigh(d.T @ d)
    vx, vz = v[:, -1]
    if vx < 0:
        vx, vz = -vx, -vz
    return float(np.degrees(np.arctan2(vz, vx)))


def crows_feet(sides):
    """The squint measures from the per-side results of :func:`crows_feet_side`:
    ``crows_feet_per_side``, ``crows_feet_fan_deg``, ``crows_feet_length_mm``,
    ``crows_feet_depth_mm`` (docs/benchmarks/realism_measures.md)."""
    fans = [s["fan_deg"] for s in sides if s["fan_deg"] is not None]
    lengths = [v for s in sides for v in s["lengths"]]
    return {"crows_feet_per_side": int(min(s["count"] for s in sides)),
            "crows_feet_fan_deg": float(max(fans)) if fans else None,
            "crows_feet_length_mm": float(min(lengths)) if lengths else None,
            "crows_feet_depth_mm": float(min(s["depth"] for s in sides))}


# --------------------------------------------------------------------------- knots
def blur(h, sigma_mm, step):
    """``h`` smoothed with a Gaussian of ``sigma_mm`` (separable, over the valid cells
    only); invalid cells stay NaN."""
    h = np.asarray(h, float)
    valid = np.isfinite(h)
    if sigma_mm <= 0 or not valid.any():
        return h.copy()
    sigma = sigma_mm / step
    r = int(np.ceil(3.0 * sigma))
    kernel = np.exp(-0.5 * (np.arange(-r, r + 1) / sigma) ** 2)
    a, w = np.where(valid, h, 0.0), valid.astype(float)
    for axis in (0, 1):
        a2, w2 = np.zeros_like(a), np.zeros_like(w)
        for off, k in zip(range(-r, r + 1), kernel):
            a2 += k * np.nan_to_num(_shift(a, off, axis))
            w2 += k * np.nan_to_num(_shift(w, off, axis))
        a, w = a2, w2
    return np.where(valid, a / np.where(w > 0, w, 1.0), np.nan)


def curvatures(h, step):
    """The eigenvalues (k1 <= k2) of the Hessian of ``h`` (central differences), each
    like ``h``; NaN where a difference meets an invalid cell (or the grid is too small)."""
    if min(h.shape) < 3:
        nan = np.full(h.shape, np.nan)
        return nan, nan.copy()
    hz, hx = np.gradient(h, step)
    hzz, hzx = np.gradient(hz, step)
    hxz, hxx = np.gradient(hx, step)
    b = 0.5 * (hzx + hxz)
    mean = 0.5 * (hxx + hzz)
    disc = np.sqrt(np.maximum(0.25 * (hxx - hzz) ** 2 + b * b, 0.0))
    return mean - disc, mean + disc


def _strict_minima(h, window, detect):
    """Cells that are :func:`minima` along x or along z and lower than both cells
    ``window`` away in that direction (so a furrow's flank, level along it, is not one)."""
    out = np.zeros(h.shape, bool)
    with np.errstate(invalid="ignore"):
        for axis in (0, 1):
            out |= (minima(h, axis, window, detect) & (h < _shift(h, window, axis))
                    & (h < _shift(h, -window, axis)))
    return out


def knots(grid, slit_factor=2.0, nub_factor=2.0, slit_mm=0.3, nub_mm=0.2, kappa=0.2, near_mm=2.5,
          sigma_mm=0.5, detect_mm=0.1, window_mm=1.0):
    """The smile's knots on ``grid`` (docs/benchmarks/realism_measures.md): a dict with ``knots`` and
    ``where``, per knot (x, z, height) of its highest nub cell and the distance to its
    nearest slit cell, and ``furrow_depth`` (D) and ``bulge`` (B), the region's typical."""
    h, step = grid.h, grid.step
    out = {"knots": 0, "where": [], "furrow_depth": 0.0, "bulge": 0.0}
    if h.size == 0 or not grid.valid.any():
        return out
    w = max(1, int(round(window_mm / step)))
    furrow = _strict_minima(h, w, detect_mm)
    crest = _strict_minima(-h, w, 0.5 * detect_mm)
    d = float(np.median(-h[furrow])) if furrow.any() else 0.0
    b = float(np.median(h[crest])) if crest.any() else 0.0
    out["furrow_depth"], out["bulge"] = d, b
    k1, k2 = curvatures(blur(h, sigma_mm, step), step)
    with np.errstate(invalid="ignore"):
        slit = grid.valid & (-h >= max(slit_factor * d, slit_mm)) & (k2 >= kappa)
        nub = grid.valid & (h >= max(nub_factor * b, nub_mm)) & (k1 <= -kappa)
    if not slit.any() or not nub.any():
        return out
    kk, ii = np.nonzero(nub)
    index = np.full(h.shape, -1, np.int64)
    index[kk, ii] = np.arange(len(kk))
    pairs = []
    for dk, di in ((0, 1), (1, -1), (1, 0), (1, 1)):
        k2_, i2 = kk + dk, ii + di
        fine = (k2_ < h.shape[0]) & (i2 >= 0) & (i2 < h.shape[1])
        other = np.full(len(kk), -1)
        other[fine] = index[k2_[fine], i2[fine]]
        hit = other >= 0
        pairs.append(np.stack([np.flatnonzero(hit), other[hit]], 1))
    lab = _components(kk, np.concatenate(pairs))
    sk, si = np.nonzero(slit)
    sx, sz = grid.xs[si], grid.zs[sk]
    for label in np.unique(lab):
        sel = np.flatnonzero(lab == label)
        nx_, nz_ = grid.xs[ii[sel]], grid.zs[kk[sel]]
        dist = np.hypot(nx_[:, None] - sx[None], nz_[:, None] - sz[None]).min()
        if dist <= near_mm + 1e-9:
            top = sel[np.argmax(h[kk[sel], ii[sel]])]
            out["where"].append((float(grid.xs[ii[top]]), float(grid.zs[kk[top]]), float(h[kk[top], ii[top]]),
                                 float(dist)))
    out["knots"] = len(out["where"])
    return out


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


# --------------------------------------------------------------------------- glabella offset
def glabella_offset(lines, inner_x, depth_mm=0.3):
    """How far each side's frown line lies from the inner end of its brow (see the module
    doc).  ``lines``: :func:`glabella`'s ``lines`` (per side its frown lines), ``inner_x``:
    {'L': x, 'R': x} of the inner brow ends (mm).  A dict: ``glabella_offset_mm`` (None
    when a side has no frown line) and ``sides``, per side (the line's centre x, the inner
    brow's x, their distance) or None."""
    sides = {}
    for side in ("L", "R"):
        found = lines.get(side, [])
        if not found:
            sides[side] = None
            continue
        r = max(found, key=lambda r: float(np.max(r.depth)))
        deep = r.depth >= depth_mm
        centre = float(np.mean(r.across[deep] if deep.any() else r.across))
        x = float(inner_x[side])
        sides[side] = (centre, x, abs(centre - x))
    offsets = [v[2] for v in sides.values() if v is not None]
    return {"glabella_offset_mm": float(max(offsets)) if len(offsets) == 2 else None, "sides": sides}


# --------------------------------------------------------------------------- compression
def _edges_2d(corners):
    """Each triangle's edges 0->1 and 0->2 in its own plane, as the columns of a (T, 2, 2)
    matrix (the first edge along the first axis), and the triangle's area."""
    e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    n = np.cross(e1, e2)
    l1, ln = np.linalg.norm(e1, axis=1), np.linalg.norm(n, axis=1)
    u = e1 / np.maximum(l1, 1e-30)[:, None]
    w = np.cross(n, u) / np.maximum(ln, 1e-30)[:, None]
    m = np.zeros((len(corners), 2, 2))
    m[:, 0, 0] = l1
    m[:, 0, 1] = np.einsum("ij,ij->i", e2, u)
    m[:, 1, 1] = np.einsum("ij,ij->i", e2, w)
    return m, 0.5 * ln


def triangle_compression(rest, posed, tris):
    """Per triangle (rest -> posed, each in its own plane): the compression max(0, 1 -
    lambda_min), lambda_min the smaller singular value of its 2D deformation gradient, and
    its rest area (degenerate triangles: compression 0, area 0)."""
    tris = np.asarray(tris, np.int64).reshape(-1, 3)
    rest_m, area = _edges_2d(np.asarray(rest, np.float64)[tris])
    posed_m, _ = _edges_2d(np.asarray(posed, np.float64)[tris])
    ok = (area > 0) & (rest_m[:, 0, 0] > 0) & (rest_m[:, 1, 1] != 0)
    c = np.zeros(len(tris))
    if ok.any():
        f = posed_m[ok] @ np.linalg.inv(rest_m[ok])
        lam = np.linalg.svd(f, compute_uv=False)[:, -1]
        c[ok] = np.maximum(0.0, 1.0 - lam)
    return c, np.where(ok, area, 0.0)


def vertex_compression(rest, posed, tris):
    """Per vertex the rest-area-weighted mean of its triangles' :func:`triangle_compression`
    (0 for a vertex on no triangle)."""
    tris = np.asarray(tris, np.int64).reshape(-1, 3)
    c, area = triangle_compression(rest, posed, tris)
    n = len(rest)
    num = np.bincount(tris.ravel(), weights=np.repeat(c * area, 3), minlength=n)
    den = np.bincount(tris.ravel(), weights=np.repeat(area, 3), minlength=n)
    return np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)


def pearson(a, b, min_count=20, tol=1e-6):
    """The Pearson correlation of ``a`` and ``b`` over the entries where both are finite;
    None with fewer than ``min_count`` of them or no variance in either (a standard
    deviation under ``tol`` times max(1, its largest |value|): float32 round-off is none)."""
    a, b = np.asarray(a, float).ravel(), np.asarray(b, float).ravel()
    ok = np.isfinite(a) & np.isfinite(b)
    a, b = a[ok], b[ok]
    if len(a) < min_count:
        return None
    da, db = a - a.mean(), b - b.mean()
    if any(np.sqrt(np.mean(d * d)) < tol * max(1.0, float(np.abs(v).max())) for d, v in ((da, a), (db, b))):
        return None
    return float((da @ db) / np.sqrt((da @ da) * (db @ db)))


def vertex_normals(points, tris):
    """Area-weighted vertex normals (unit; 0 for a vertex on no triangle): the add-on's own
    (``wrinkle_addon.core.mesh.vertex_normals``)."""
    p = np.asarray(points, np.float64)
    return mesh.vertex_normals(p, np.asarray(tris, np.int64).reshape(-1, 3), len(p))


def corner_max_abs(points, values, corner, outward, radius, exclude=None):
    """(the largest |value|, the number of vertices) over the ``points`` within ``radius``
    (3D) of ``corner`` on its lateral side (``outward`` (x - corner x) >= 0), outside
    ``exclude`` (a bool per point)."""
    p = np.asarray(points, np.float64)
    c = np.asarray(corner, np.float64)
    mask = (np.linalg.norm(p - c, axis=1) <= radius) & (outward * (p[:, 0] - c[0]) >= 0.0)
    if exclude is not None:
        mask &= ~np.asarray(exclude, bool)
    return max_abs(values, mask), int(mask.sum())


# --------------------------------------------------------------------------- left/right balance
def lr_ratio(left, right):
    """The deeper side's depth over the shallower's (>= 1); None when either is None or not
    positive (that side has nothing)."""
    if left is None or right is None or not (left > 0 and right > 0):
        return None
    return float(max(left, right) / min(left, right))


def lr_balance(deepest, counts):
    """{'ratio': :func:`lr_ratio` of ``deepest`` ({'L': depth or None, 'R': ...}),
    'counts': [L, R] of ``counts``}."""
    return {"ratio": lr_ratio(deepest["L"], deepest["R"]), "counts": [int(counts["L"]), int(counts["R"])]}


def forehead_sides(grid, split_x, detect_mm=0.1, window_mm=1.0, gap_mm=1.0, min_fraction=0.1):
    """The forehead's halves split at ``split_x`` (L: x >= split_x): per side (the deepest
    depth, -min h there, or None without a valid cell; the ridge-lines that run at least
    ``min_fraction`` of the whole grid's width within that half)."""
    xs = grid.xs
    width = float(xs[-1] - xs[0]) if len(xs) > 1 else 0.0
    found = ridges(grid, "z", detect_mm, window_mm, gap_mm) if width > 0 else []
    out = {}
    for side in ("L", "R"):
        cols = xs >= split_x if side == "L" else xs < split_x
        h = grid.h[:, cols]
        deepest = float(-np.nanmin(h)) if np.isfinite(h).any() else None
        count = 0
        for r in found:
            along = r.along[r.along >= split_x] if side == "L" else r.along[r.along < split_x]
            if len(along) and float(along.max() - along.min()) >= min_fraction * width:
                count += 1
        out[side] = (deepest, count)
    return out


def band_deepest(grid, band):
    """-min h over the valid cells of ``band`` (a bool array like the grid), or None."""
    h = grid.h[np.asarray(band, bool) & grid.valid]
    return float(-h.min()) if h.size else None


# --------------------------------------------------------------------------- curvature
def ridge_curvature_max(grid, min_mm=0.1, sigma_mm=0.5):
    """The sharpest crease or crest on ``grid`` (docs/benchmarks/realism_measures.md): a dict with
    ``ridge_curvature_max`` (1/mm; 0 when no cell is ``min_mm`` deep or high) and
    ``where``, (x, z, h) of that cell (None without one)."""
    out = {"ridge_curvature_max": 0.0, "where": None}
    h = grid.h
    if h.size == 0 or not grid.valid.any():
        return out
    k1, k2 = curvatures(blur(h, sigma_mm, grid.step), grid.step)
    k = np.fmax(np.abs(k1), np.abs(k2))
    with np.errstate(invalid="ignore"):
        mask = grid.valid & (np.abs(h) >= min_mm) & np.isfinite(k)
    if not mask.any():
        return out
    kk, ii = np.unravel_index(np.argmax(np.where(mask, k, -np.inf)), h.shape)
    out["ridge_curvature_max"] = float(k[kk, ii])
    out["where"] = (float(grid.xs[ii]), float(grid.zs[kk]), float(h[kk, ii]))
    return out


# --------------------------------------------------------------------------- slits
def _crossing(h, k0, j, sign, max_cells):
    """Per point (``k0`` across, ``j`` along) of ``h`` (across, along): the distance in
    cells from it, going ``sign`` across, to where ``h`` first reaches 0 (linear between
    cells); NaN where the walk meets an invalid cell or the edge first, or runs farther
    than ``max_cells``."""
    o = np.arange(int(np.floor(max_cells)) + 2)
    kk = k0[:, None] + sign * o[None]
    inside = (kk >= 0) & (kk < h.shape[0])
    v = np.where(inside, h[np.clip(kk, 0, h.shape[0] - 1), j[:, None]], np.nan)
    with np.errstate(invalid="ignore"):
        reached = v >= 0.0
    first = np.argmax(reached, axis=1)
    bad = (~np.isfinite(v) & (o[None] < first[:, None])).any(axis=1) | ~reached.any(axis=1)
    first = np.maximum(first, 1)
    rows = np.arange(len(k0))
    prev, cur = v[rows, first - 1], v[rows, first]
    with np.errstate(invalid="ignore", divide="ignore"):
        t = (first - 1) + (-prev) / (cur - prev)
    return np.where(bad | ~(t <= max_cells + 1e-9), np.nan, t)


def slits(grid, across, detect_mm=0.1, ratio=3.0, window_mm=1.0, gap_mm=1.0, max_mm=10.0):
    """The furrows of ``grid`` that are slits (docs/benchmarks/realism_measures.md): the ridge-lines of
    minima across ``across`` ('z' or 'x', as :func:`ridges`) at least ``detect_mm`` deep
    whose median width (between the zero crossings across) over depth, at their deepest
    10 %, is under ``ratio``.  A dict: ``slit_count``; ``slits``, per slit (x, z of its
    deepest point, the median width, the median depth over its measured points, mm); and
    ``lines``, the same for every ridge-line with the ratio (None, width and depth too,
    where no point's width is known)."""
    out = {"slit_count": 0, "slits": [], "lines": []}
    h = grid.h if across == "z" else grid.h.T  # (across, along)
    if h.size == 0:
        return out
    max_cells = max_mm / grid.step
    for r in ridges(grid, across, detect_mm, window_mm, gap_mm):
        heights = -r.depth
        sel = np.flatnonzero(heights <= np.percentile(heights, 10.0))
        k0, j = r.cell[sel].astype(np.int64), r.cols[sel].astype(np.int64)
        widths = grid.step * (_crossing(h, k0, j, 1, max_cells) + _crossing(h, k0, j, -1, max_cells))
        known = np.isfinite(widths)
        d = r.depth[sel]
        top = sel[np.argmax(d)]
        x, z = (r.along[top], r.across[top]) if across == "z" else (r.across[top], r.along[top])
        if not known.any():
            out["lines"].append((float(x), float(z), None, None, None))
            continue
        w, dk = widths[known], d[known]
        q = float(np.median(w / dk))
        line = (float(x), float(z), float(np.median(w)), float(np.median(dk)), q)
        out["lines"].append(line)
        if q < ratio:
            out["slits"].append(line[:4])
    out["slit_count"] = len(out["slits"])
    return out
