# SPDX-License-Identifier: GPL-3.0-or-later
"""Bando, Kuratate & Nishita 2002, "A Simple Method for Modeling Wrinkles on Human Skin":
the large-scale wrinkles of section 6, prepared for the amplitude modulation of section 7.

A wrinkle's furrow is a cubic Bezier curve drawn in texture (UV) space; each vertex near it
is displaced along its normal by the wrinkle shape function (eq. 2)::

    S(l) = d (l/w - 1) exp(-l/w),      integral_0^inf S dl = 0      (eq. 3)

with l the distance from the furrow measured perpendicular to it.  ``S(0) = -d`` is the
furrow (the minimum, with the slope ``2d/w``: sharp), the bulge peaks at ``l = 2w`` with
height ``d e^-2`` (zero slope: round).

What this module adds to the paper, and why:

* **Units.**  d and w are in scene units (metres); the curve lives in UV.  Each mapped
  vertex gets the metric ``G = J^T J`` of the UV -> surface map (J from
  :func:`raster.uv_jacobian`; ``G`` is averaged over the vertex's triangles weighted by
  their 3-D area), so a UV offset ``x`` has the surface length ``sqrt(x^T G x)``.  The foot
  point is the nearest point of the polyline *in that metric* and l its metric distance.
  Where the UV map is conformal (no stretch, the paper's assumption) this is exactly the
  paper's "perpendicular in texture space"; where it stretches, the foot is still the
  perpendicular on the skin, so l is the skin distance.  The metric is the one at the
  vertex (first order: exact where the UV map is affine, e.g. on a flat grid).
* **Cut-off.**  ``|S|`` falls below ``1e-3 d`` at ``l = 9w`` (``8 e^-9 = 9.9e-4``).  The
  profile is multiplied by :func:`window`, 1 up to ``8w`` and a smoothstep down to 0 at
  ``10w`` (C1); vertices at ``l >= 10w`` are untouched.  The windowed profile's integral
  is ``-1.20e-3 d w``, 0.33 % of the furrow's volume ``e^-1 d w``: eq. 3 holds to
  ``|integral| < 1.5e-3 d w``.
* **Ends.**  The arc length u of the foot is in scene units: the curve's samples are
  located in the mesh's triangles and u sums the 3-D chords between them (samples off
  the mesh use the curve's, else the mesh's, typical stretch).  u is extended past the
  ends along the end segments, so the smoothstep :func:`taper` (at least ``w`` long, at
  most half the curve) is 0 at and beyond the ends: a wrinkle never stops abruptly, and
  the vertices around an end (whose foot is the end point) get no height.
* **Nearest point.**  Exact on the polyline (see :func:`_nearest_on_curve`): the nearest
  sample by one matrix product per curve, its two segments, then only the few segments
  that could still be nearer.  The polyline stands for the Bezier curve: sample it
  densely (the glue does); one much denser than ``w / 8`` is resampled to that.
* **Speed.**  :func:`curve_plan` runs per edit, :func:`curve_heights` per frame: the plan
  stores per (curve, vertex) entry the static height ``S(l) taper(u) window(l)``, so a
  frame is one ``np.bincount`` over the entries after multiplying by ``M(s)`` (eq. 5).
  The mesh's part of the plan (:func:`curve_surface`) can be kept while only curves
  change, and plans of single curves joined with :func:`merge_plans`.
"""

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from .. import checks, mesh, raster

WINDOW_START = 8.0  # the window starts falling at l = 8 w ...
CUTOFF = 10.0  # ... and is 0 from l = 10 w on: vertices farther away are untouched
WINDOWED_INTEGRAL = -1.1993e-3  # integral_0^inf S(l) window(l) dl / (d w)

_TINY = 1e-12
_DENSE = 8.0  # polylines are resampled to w / _DENSE if much denser
_PAIRS = 1 << 21  # (vertex, sample) distances per matrix product of the nearest-sample search


# --------------------------------------------------------------------------- profile
def profile(l, d, w):
    """The wrinkle shape function ``S(l) = d (l/w - 1) exp(-l/w)`` (Bando et al. 2002, §6,
    eq. 2) for distances ``l >= 0``; broadcasts over ``l``, ``d`` and ``w``."""
    x = np.asarray(l, dtype=np.float64) / w
    return d * (x - 1.0) * np.exp(-x)


def window(l, w):
    """The C1 cut-off of the profile: 1 for ``l <= 8w``, 0 for ``l >= 10w``, a smoothstep
    between (see the module notes for what it costs eq. 3)."""
    x = np.asarray(l, dtype=np.float64) / w
    return 1.0 - mesh.smoothstep((x - WINDOW_START) / (CUTOFF - WINDOW_START))


def taper(u, length, taper):
    """The C1 end fade along a curve of arc length ``length``: 1 in the middle, 0 at and
    beyond the ends (``u <= 0``, ``u >= length``), smoothstep ramps of length ``taper``
    clamped to ``[0, length / 2]``.  ``taper = 0`` gives a hard step (no fade)."""
    u = np.asarray(u, dtype=np.float64)
    length = np.asarray(length, dtype=np.float64)
    ramp = np.minimum(np.maximum(np.asarray(taper, dtype=np.float64), 0.0), 0.5 * length)
    has = ramp > 0
    safe = np.where(has, ramp, 1.0)
    up = np.where(has, mesh.smoothstep(u / safe), 1.0)
    down = np.where(has, mesh.smoothstep((length - u) / safe), 1.0)
    return np.where((u > 0) & (u < length), up * down, 0.0)


def pigment(base, melanin, hemoglobin, a_m, a_h):
    """Skin colour from pigment amounts (Bando et al. 2002, §8, eq. 6):
    ``c = b - m a_m - h a_h``, clipped to [0, 1].  ``base``, ``a_m``, ``a_h`` are colours
    (..., 3); ``melanin`` and ``hemoglobin`` broadcast over the leading axes."""
    m = np.asarray(melanin, dtype=np.float64)[..., None]
    h = np.asarray(hemoglobin, dtype=np.float64)[..., None]
    c = np.asarray(base, dtype=np.float64) - m * np.asarray(a_m, np.float64) - h * np.asarray(a_h, np.float64)
    return np.clip(c, 0.0, 1.0)


# --------------------------------------------------------------------------- curves
def _dedupe(polyline):
    """The polyline without repeated consecutive samples."""
    step = np.sqrt((np.diff(polyline, axis=0) ** 2).sum(axis=1))
    scale = max(float(np.abs(polyline).max()), 1.0)
    keep = np.concatenate([[True], step > _TINY * scale])
    return polyline[keep]


def resample(polyline, spacing):
    """Resample a polyline (k, dim) uniformly by arc length: the end points are kept and
    consecutive samples are ``<= spacing`` apart (exactly ``length / ceil(length /
    spacing)``).  Raises ValueError for fewer than 2 finite points, a spacing that is not
    a positive number, or one that would need more than ``checks.MAX_SAMPLES`` samples."""
    p = np.asarray(polyline, dtype=np.float64)
    if p.ndim != 2 or len(p) < 2 or not np.isfinite(p).all():
        raise ValueError("A polyline needs at least 2 finite points")
    try:
        spacing = checks.number("The resampling spacing", spacing)
    except ValueError:
        raise ValueError("The resampling spacing must be a positive number") from None
    if not spacing > 0:
        raise ValueError("The resampling spacing must be a positive number")
    with np.errstate(over="ignore"):  # a polyline beyond the float range is refused below
        p = _dedupe(p)
        if len(p) < 2:
            raise ValueError("The polyline has zero length: all its points coincide")
        s = np.concatenate([[0.0], np.cumsum(np.sqrt((np.diff(p, axis=0) ** 2).sum(axis=1)))])
    n = max(1, math.ceil(checks.samples("The polyline", s[-1], spacing) - 1e-9))
    t = np.linspace(0.0, s[-1], n + 1)
    return np.stack([np.interp(t, s, p[:, k]) for k in range(p.shape[1])], axis=1)


def chain_order(edges):
    """Order an edge chain (a user's selected edges forming one path or one loop) into
    its vertex sequence: E edges give E + 1 vertices; a loop ends on its first vertex.
    A path starts at its end with the lower vertex index, a loop at its lowest vertex
    towards the lower neighbour.  Raises ValueError for no edge, a branch, a self-loop or
    a selection in several pieces."""
    e = np.asarray(edges, dtype=np.int64)
    if e.size == 0:
        raise ValueError("Select at least one edge to place a wrinkle along")
    e = e.reshape(-1, 2)
    if (e[:, 0] == e[:, 1]).any():
        raise ValueError("The selected edges contain an edge from a vertex to itself")
    e = np.unique(np.sort(e, axis=1), axis=0)  # the same edge selected twice counts once
    verts, local = np.unique(e, return_inverse=True)
    local = local.reshape(-1, 2)
    n = len(verts)
    deg = np.bincount(local.ravel(), minlength=n)
    if deg.max() > 2:
        raise ValueError(
            f"The selected edges branch at vertex {int(verts[np.argmax(deg)])}: "
            "select a single path or loop of edges"
        )
    ends = np.flatnonzero(deg == 1)
    closed = len(ends) == 0
    if len(ends) not in (0, 2) or len(e) != (n if closed else n - 1):
        raise ValueError("The selected edges are in several pieces: select one connected path or loop")
    offsets, inc = mesh.vertex_incidence(local, n)  # every vertex has 1 or 2 edges
    other = local[inc].sum(axis=1) - np.repeat(np.arange(n), np.diff(offsets))
    first = other[offsets[:-1]]
    second = np.where(deg == 2, other[np.minimum(offsets[:-1] + 1, len(other) - 1)], -1)
    nb = np.stack([np.minimum(first, np.where(second < 0, first, second)),
                   np.maximum(first, second)], axis=1).tolist()
    cur = int(ends[0]) if not closed else 0
    prev = -1
    seq = [cur]
    for _ in range(len(e)):  # a walk along the selection, not over the mesh
        a, b = nb[cur]
        nxt = a if a != prev and a >= 0 else b
        prev, cur = cur, nxt
        seq.append(cur)
    if len(set(seq)) != n:
        raise ValueError("The selected edges are in several pieces: select one connected path or loop")
    return verts[np.asarray(seq)]


# --------------------------------------------------------------------------- input
@dataclass(frozen=True)
class Curve:
    """One large-scale wrinkle: its furrow as a UV polyline (k, 2), depth ``d`` and width
    ``w`` (scene units, eq. 2) and the length of its end fade ``taper`` (scene units;
    :func:`curve_plan` uses at least ``w`` so the wrinkle never stops abruptly)."""

    polyline_uv: np.ndarray
    d: float
    w: float
    taper: float = 0.0


def _field(c, name, default=None):
    if isinstance(c, Mapping):
        v = c.get(name, default)
    else:
        v = getattr(c, name, default)
    if v is None:
        raise ValueError(f"A wrinkle curve has no '{name}'")
    return v


def _check_curve(c, i):
    """(polyline (k, 2) without repeated samples, d, w, taper) of curve ``i``, validated."""
    if isinstance(c, tuple | list):
        c = Curve(*c)
    name = f"Wrinkle curve {i + 1}"
    p = np.asarray(_field(c, "polyline_uv"), dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"{name}: its UV samples must be a list of (u, v) pairs")
    if len(p) < 2:
        raise ValueError(f"{name}: needs at least 2 samples to have a direction")
    if not np.isfinite(p).all():
        raise ValueError(f"{name}: its UV samples contain NaN or infinity (is it on the mesh?)")
    try:
        d, w, tp = (float(_field(c, k, 0.0 if k == "taper" else None)) for k in ("d", "w", "taper"))
    except (TypeError, ValueError) as err:
        raise ValueError(f"{name}: depth, width and taper must be numbers") from err
    if not math.isfinite(d):
        raise ValueError(f"{name}: the depth is not a finite number")
    if not (math.isfinite(w) and w > 0):
        raise ValueError(f"{name}: the width must be greater than zero")
    if not (math.isfinite(tp) and tp >= 0):
        raise ValueError(f"{name}: the taper length must be zero or more")
    if not ((p >= 0) & (p <= 1)).all(axis=1).any():
        raise ValueError(f"{name}: lies entirely outside the UV square [0, 1]; "
                         "draw it on the UV-mapped surface")
    p = _dedupe(p)
    if len(p) < 2:
        raise ValueError(f"{name}: has zero length (all its samples are at one point)")
    return p, d, w, tp


# --------------------------------------------------------------------------- spatial bins
class _Grid:
    """Items (UV boxes) binned into an n x n grid over a UV rectangle, CSR by cell."""

    def __init__(self, lo, hi, bounds, n):
        self.origin = bounds[0]
        self.n = n
        self.cell = np.maximum((bounds[1] - bounds[0]) / n, _TINY)
        cells, item = self._cells(self._index(lo), self._index(hi))
        counts = np.bincount(cells, minlength=n * n)
        self.offsets = np.zeros(n * n + 1, dtype=np.int64)
        np.cumsum(counts, out=self.offsets[1:])
        self.items = item[np.argsort(cells, kind="stable")]

    def _index(self, p):
        return np.clip(np.floor((p - self.origin) / self.cell), 0, self.n - 1).astype(np.int64)

    def _cells(self, i0, i1):
        """The cells of the boxes ``[i0, i1]`` (inclusive cell ranges): (cell ids, box)."""
        nx = i1[:, 0] - i0[:, 0] + 1
        count = nx * (i1[:, 1] - i0[:, 1] + 1)
        box = np.repeat(np.arange(len(i0)), count)
        k = np.arange(len(box)) - (np.cumsum(count) - count)[box]
        cx = i0[box, 0] + k % nx[box]
        cy = i0[box, 1] + k // nx[box]
        return cy * self.n + cx, box

    def query(self, lo, hi):
        """The items in the cells the UV boxes ``[lo, hi]`` touch: (box, item) pairs,
        grouped by box (an item in several cells comes once per cell)."""
        cells, box = self._cells(self._index(lo), self._index(hi))
        row, item = mesh.gather_incident(self.offsets, self.items, cells)
        return box[row], item


def _grid_size(n_items, per_cell):
    return int(min(max(math.ceil(math.sqrt(n_items / per_cell)), 1), 1024))


def _box_distance(p, lo, hi):
    """Euclidean UV distance from points (N, 2) to boxes (N, 2) x 2; 0 inside."""
    q = np.maximum(np.maximum(lo - p, p - hi), 0.0)
    return np.sqrt((q * q).sum(axis=1))


def _metric_sq(x, g):
    """``x^T G x`` for UV offsets (N, 2) and metrics (N, 3) = (g_uu, g_uv, g_vv)."""
    return g[:, 0] * x[:, 0] ** 2 + 2.0 * g[:, 1] * x[:, 0] * x[:, 1] + g[:, 2] * x[:, 1] ** 2


def _vertex_metric(uv, tris, positions):
    """Per mapped vertex the UV -> surface metric ``G = J^T J`` (U, 3), area-weighted over
    its triangles, the roots of its smaller and larger eigenvalues (U,) (the least and
    most stretch: a UV distance x is between ``s x`` and ``smax x`` on the skin), and
    whether it is usable (U,)."""
    U = len(uv)
    corners = tris.ravel()
    su, c, sv = raster.uv_jacobian(positions[corners], uv[corners]).T
    p = positions[tris]
    cross = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    area = np.where(su > 0, 0.5 * np.sqrt((cross * cross).sum(axis=1)), 0.0)
    # dP = (s_u du + c dv) T + s_v dv B  ->  |dP|^2 = x^T G x
    g = np.stack([su * su, su * c, c * c + sv * sv], axis=1) * area[:, None]
    wsum = np.bincount(corners, weights=np.repeat(area, 3), minlength=U)
    G = np.stack([np.bincount(corners, weights=np.repeat(g[:, k], 3), minlength=U) for k in range(3)], 1)
    G = G.astype(np.float64)  # (an empty bincount is int)
    G /= np.where(wsum > 0, wsum, 1.0)[:, None]
    half_tr = 0.5 * (G[:, 0] + G[:, 2])
    lam = half_tr - np.sqrt((0.5 * (G[:, 0] - G[:, 2])) ** 2 + G[:, 1] ** 2)
    ok = (wsum > 0) & (lam > 1e-9 * half_tr) & np.isfinite(lam)
    lam_max = 2.0 * half_tr - lam
    return G, np.sqrt(np.where(ok, lam, 0.0)), np.sqrt(np.where(ok, lam_max, 0.0)), ok


@dataclass
class CurveSurface:
    """The mapped mesh's part of :func:`curve_plan`, reusable while the mesh and its UVs
    stay the same (only the curves change): the per-vertex metric and the UV bins."""

    uv: np.ndarray  # (U, 2) float64
    tris: np.ndarray  # (T, 3) int64
    positions: np.ndarray  # (U, 3) float64
    G: np.ndarray  # (U, 3) metric (g_uu, g_uv, g_vv)
    s: np.ndarray  # (U,) least stretch
    smax: np.ndarray  # (U,) most stretch
    ok: np.ndarray  # (U,) bool: has a metric
    usable: np.ndarray  # (N,) the vertices with a metric
    typical: float  # a typical stretch, for curve samples off the mesh
    vgrid: "_Grid"  # the usable vertices, binned
    tgrid: "_Grid"  # the triangles, binned by their UV boxes
    tri_uv: np.ndarray  # (T, 3, 2)


def curve_surface(uv, tris, positions):
    """Validate the mapped mesh and prepare it for :func:`curve_plan` (pass the result as
    its ``surface`` to skip this O(U + T) step when only the curves changed)."""
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 2)
    positions = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    tris = np.asarray(tris, dtype=np.int64).reshape(-1, 3)
    U = len(uv)
    if len(positions) != U:
        raise ValueError("The mapped mesh has different numbers of UVs and positions")
    if not (np.isfinite(uv).all() and np.isfinite(positions).all()):
        raise ValueError("The mesh's UV map or vertex positions contain NaN or infinity")
    if len(tris) and (tris.min() < 0 or tris.max() >= U):
        raise ValueError("The mapped mesh has triangles with invalid vertex indices")
    G, s, smax, ok = _vertex_metric(uv, tris, positions)
    usable = np.flatnonzero(ok)
    typical = float(np.median(np.sqrt(0.5 * (G[ok, 0] + G[ok, 2])))) if len(usable) else 1.0
    bounds = (uv.min(axis=0), uv.max(axis=0)) if U else (np.zeros(2), np.ones(2))
    vgrid = _Grid(uv[usable], uv[usable], bounds, _grid_size(len(usable), 4.0))
    tri_uv = uv[tris]
    tgrid = _Grid(tri_uv.min(axis=1), tri_uv.max(axis=1), bounds, _grid_size(len(tris), 2.0))
    return CurveSurface(uv, tris, positions, G, s, smax, ok, usable, typical, vgrid, tgrid, tri_uv)


def _locate(surf, points):
    """The 3-D barycentric weights of UV points in the mapped mesh: (triangle (K,),
    weights (K, 3), found (K,)); a point in no triangle is not found."""
    K = len(points)
    tri_uv = surf.tri_uv
    row, tri = surf.tgrid.query(points, points)
    a, b, c = tri_uv[tri, 0], tri_uv[tri, 1], tri_uv[tri, 2]
    e0, e1, q = b - a, c - a, points[row] - a
    det = e0[:, 0] * e1[:, 1] - e0[:, 1] * e1[:, 0]
    ok = np.abs(det) > _TINY * np.maximum((e0 * e0).sum(1) + (e1 * e1).sum(1), _TINY)
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    beta = (q[:, 0] * e1[:, 1] - q[:, 1] * e1[:, 0]) * inv
    gamma = (e0[:, 0] * q[:, 1] - e0[:, 1] * q[:, 0]) * inv
    bary = np.stack([1.0 - beta - gamma, beta, gamma], axis=1)
    score = np.where(ok, bary.min(axis=1), -np.inf)
    order = np.lexsort((-score, row))  # per point, the most-inside triangle first
    first = order[np.r_[True, np.diff(row[order]) != 0]] if len(order) else order
    found = np.zeros(K, bool)
    tri_of = np.zeros(K, np.int64)
    weights = np.zeros((K, 3))
    good = first[score[first] >= -1e-7]
    found[row[good]] = True
    tri_of[row[good]] = tri[good]
    weights[row[good]] = bary[good]
    return tri_of, weights, found


# --------------------------------------------------------------------------- the plan
@dataclass
class CurvePlan:
    """What :func:`curve_plan` found: one entry per (curve, vertex within the cut-off),
    sorted by curve then vertex; curve ``c`` owns ``entries(c)``.

    ``static`` is the height ``S(l) taper(u) window(l)`` (scene units, along the normal);
    a frame's height is ``static * M(s)``, summed per vertex by :func:`curve_heights`.
    ``tangent`` is the unit UV tangent of the furrow at the foot point (the wrinkle's
    direction of §7, across which shrinkage is measured), ``foot`` the foot point in UV,
    ``l`` the skin distance to it and ``u`` its arc length (scene units, extended past the
    ends: negative before the start, above ``lengths[c]`` after the end)."""

    n_verts: int
    verts: np.ndarray  # (E,) int64 mapped vertex ids
    curve: np.ndarray  # (E,) int64 curve index
    static: np.ndarray  # (E,) float64
    tangent: np.ndarray  # (E, 2) float64, unit, in UV
    foot: np.ndarray  # (E, 2) float64, UV
    l: np.ndarray  # (E,) float64, scene units
    u: np.ndarray  # (E,) float64, scene units
    offsets: np.ndarray  # (C + 1,) int64
    lengths: np.ndarray  # (C,) float64, each curve's arc length on the skin
    footprint: np.ndarray  # (F,) int64, sorted unique vertex ids over all curves

    def entries(self, c):
        return slice(int(self.offsets[c]), int(self.offsets[c + 1]))


def _curve_geometry(polys, surf):
    """Concatenated samples, segments, tangents and arc lengths of all curves."""
    C = len(polys)
    k = np.array([len(p) for p in polys], dtype=np.int64)
    P = np.concatenate(polys)
    s_off = np.zeros(C + 1, np.int64)
    np.cumsum(k, out=s_off[1:])
    owner = np.repeat(np.arange(C), k)
    seg_a = np.flatnonzero(owner[:-1] == owner[1:])  # segment j runs from sample a to a + 1
    seg_curve = owner[seg_a]
    nseg = k - 1
    seg_off = np.zeros(C + 1, np.int64)
    np.cumsum(nseg, out=seg_off[1:])
    E = P[seg_a + 1] - P[seg_a]
    len_uv = np.sqrt((E * E).sum(axis=1))
    unit = E / len_uv[:, None]
    # sample tangents: the mean of the adjacent segments' directions
    tan = np.zeros_like(P)
    np.add.at(tan, seg_a, unit)
    np.add.at(tan, seg_a + 1, unit)
    tan /= np.maximum(np.sqrt((tan * tan).sum(axis=1)), _TINY)[:, None]
    # arc length on the skin: the samples located in the mesh, 3-D chords between them
    tri, bary, found = _locate(surf, P)
    p3 = np.einsum("kc,kcd->kd", bary, surf.positions[surf.tris[tri]])
    d3 = p3[seg_a + 1] - p3[seg_a]
    len3 = np.sqrt((d3 * d3).sum(axis=1))
    good = found[seg_a] & found[seg_a + 1]
    num = np.bincount(seg_curve[good], weights=len3[good], minlength=C)
    den = np.bincount(seg_curve[good], weights=len_uv[good], minlength=C)
    ratio = np.where(den > 0, num / np.where(den > 0, den, 1.0), surf.typical)  # off the mesh
    len3 = np.where(good, len3, len_uv * ratio[seg_curve])
    # per curve, so that a curve's plan does not depend on the curves before it
    u0 = np.concatenate([np.cumsum(x) - x for x in np.split(len3, seg_off[1:-1])])
    lengths = np.bincount(seg_curve, weights=len3, minlength=C)
    return dict(
        P=P, s_off=s_off, seg_a=seg_a, seg_curve=seg_curve, seg_off=seg_off, E=E, tan=tan,
        u0=u0, len3=len3, lengths=lengths,
        bb_lo=np.minimum.reduceat(P, s_off[:-1]), bb_hi=np.maximum.reduceat(P, s_off[:-1]),
    )


def _segment_d2(p, g, x, e, seg):
    """Nearest points of UV points ``p`` (M, 2) on the segments ``seg`` (M,) of a polyline
    with samples ``x`` and steps ``e`` (segment j runs from ``x[j]`` to ``x[j] + e[j]``), in
    the metrics ``g`` (M, 3): (t, t unclamped, squared distance)."""
    e = e[seg]
    q = p - x[seg]
    ge = np.stack([g[:, 0] * e[:, 0] + g[:, 1] * e[:, 1], g[:, 1] * e[:, 0] + g[:, 2] * e[:, 1]], 1)
    t_raw = (q * ge).sum(axis=1) / np.maximum((e * ge).sum(axis=1), _TINY * _TINY)
    t = np.clip(t_raw, 0.0, 1.0)
    return t, t_raw, _metric_sq(q - t[:, None] * e, g)


def _around(j, p, g, x, e, rows):
    """The better of the two segments meeting at sample ``j`` (M,) for the points
    ``p[rows]``: (segment, t, t unclamped, squared distance)."""
    seg = np.stack([np.maximum(j - 1, 0), np.minimum(j, len(e) - 1)], axis=1).ravel()
    rr = np.repeat(rows, 2)
    t, t_raw, d2 = _segment_d2(p[rr], g[rr], x, e, seg)
    pick = np.arange(len(j)) * 2 + (d2[1::2] < d2[0::2])
    return seg[pick], t[pick], t_raw[pick], d2[pick]


def _nearest_on_curve(pv, g, smax, x):
    """The nearest point of the polyline ``x`` (k, 2) to each UV point ``pv`` (N, 2), in the
    point's own metric ``g`` (N, 3) (``smax`` (N,): the root of its larger eigenvalue):
    (segment, t, t unclamped, squared distance).  Exact, in three steps:

    1. the nearest sample j*: ``(p - x)^T G (p - x)`` less the per-point constant
       ``p^T G p`` is a dot product of 5-vectors, so all N x k distances are one matrix
       product (BLAS), in row batches of bounded memory;
    2. the nearest point l1 on the two segments meeting at j*;
    3. a segment of length h holding a point nearer than l1 has an end sample nearer than
       ``sqrt(l1^2 + h^2 / 4)`` (and j* is at least l1 away), so only the segments at the
       samples under that bound (other than j*) are tried.  Beside a smooth furrow, closer
       than its radius of curvature, those are the other end of the foot's segment at
       most; more only behind strong bends, where two parts of the furrow compete.
    """
    centre = 0.5 * (x.min(axis=0) + x.max(axis=0))  # small coordinates: little cancellation
    x = x - centre
    p = pv - centre
    e = np.diff(x, axis=0)
    gp0 = g[:, 0] * p[:, 0] + g[:, 1] * p[:, 1]
    gp1 = g[:, 1] * p[:, 0] + g[:, 2] * p[:, 1]
    A = np.stack([-2.0 * gp0, -2.0 * gp1, g[:, 0], 2.0 * g[:, 1], g[:, 2]], axis=1)
    B = np.stack([x[:, 0], x[:, 1], x[:, 0] ** 2, x[:, 0] * x[:, 1], x[:, 1] ** 2])
    pgp = gp0 * p[:, 0] + gp1 * p[:, 1]
    step = max(1, _PAIRS // len(x))
    batches = [slice(i, i + step) for i in range(0, len(p), step)]
    j = np.concatenate([np.argmin(A[b] @ B, axis=1) for b in batches])
    seg, t, t_raw, d2 = _around(j, p, g, x, e, np.arange(len(p)))
    # step 3: per sample the longer of its segments, squared, over 4
    elen2 = (e * e).sum(axis=1)
    h2 = 0.25 * np.maximum(np.r_[elen2, 0.0], np.r_[0.0, elen2])
    slack = 1e-12 * (g[:, 0] + g[:, 2]) * (1.0 + (p * p).sum(axis=1))  # rounding of the product
    A3 = np.concatenate([A, -(smax * smax)[:, None]], axis=1)  # the bound folded into the product
    B3 = np.concatenate([B, h2[None]])
    bound = d2 + slack - pgp
    rows, js = [], []
    for b in batches:
        r, jj = np.nonzero(A3[b] @ B3 < bound[b, None])
        other = jj != j[b][r]
        rows.append(r[other] + b.start)
        js.append(jj[other])
    rows, js = np.concatenate(rows), np.concatenate(js)
    if len(rows):
        s2, t2, r2, d22 = _around(js, p, g, x, e, rows)
        order = np.lexsort((d22, rows))
        first = order[np.r_[True, rows[order][1:] != rows[order][:-1]]]
        better = first[d22[first] < d2[rows[first]]]
        w = rows[better]
        seg[w], t[w], t_raw[w], d2[w] = s2[better], t2[better], r2[better], d22[better]
    return seg, t, t_raw, d2


def curve_plan(uv, tris, positions, curves, *, surface=None):
    """The footprint and static heights of large-scale wrinkles (Bando et al. 2002, §6),
    for the amplitude modulation of §7: see :class:`CurvePlan` and the module notes.

    ``uv`` (U, 2), ``tris`` (T, 3) into it and ``positions`` (U, 3) are the mapped mesh
    (rest positions, scene units); ``surface``, from :func:`curve_surface` on the same
    mesh, saves preparing it again.  ``curves`` is a list of :class:`Curve`, dicts or
    objects with ``polyline_uv`` (k, 2), ``d``, ``w`` and ``taper``.  Raises ValueError
    with an artist-readable message for unusable curves or a mesh with NaNs.

    Cost: O(U + T) to prepare the surface (metric, UV bins; reusable).  Per curve: the
    vertices in the grid cells of its box grown by the cut-off (a bounding-box prefilter,
    never all U), then for those N_c candidates one (N_c x 5) @ (5 x k) matrix product and
    an argmin for the nearest sample, and O(1) segments each: O(N_c k) multiply-adds in
    BLAS, O(N_c) NumPy work otherwise.  Vertices whose triangles are all degenerate (in UV
    or in 3-D) have no metric and are never touched.
    """
    checked = [_check_curve(c, i) for i, c in enumerate(curves)]
    surf = curve_surface(uv, tris, positions) if surface is None else surface
    sizes = (len(np.asarray(tris).reshape(-1, 3)), len(np.asarray(uv).reshape(-1, 2)))
    if sizes != (len(surf.tris), len(surf.uv)):
        raise ValueError("The prepared surface does not belong to this mesh")
    uv, G, s, smax = surf.uv, surf.G, surf.s, surf.smax
    U = len(uv)
    C = len(checked)
    empty = np.zeros(0, np.int64)
    if C == 0 or len(surf.tris) == 0 or len(surf.usable) == 0:
        return CurvePlan(U, empty, empty, np.zeros(0), np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0),
                         np.zeros(0), np.zeros(C + 1, np.int64), np.zeros(C), empty)
    polys = [c[0] for c in checked]
    d, w, tp = (np.array([c[j] for c in checked]) for j in (1, 2, 3))
    cutoff = CUTOFF * w
    geo = _curve_geometry(polys, surf)
    # polylines much denser than the wrinkle's scale cost time for nothing: resample them
    # to w / 8 on the skin (the chords then stray from the curve by under w / 512 where it
    # bends no tighter than w)
    length_uv = np.array([np.sqrt((np.diff(p, axis=0) ** 2).sum(axis=1)).sum() for p in polys])
    spacing_uv = w / (_DENSE * geo["lengths"] / length_uv)
    dense = np.array([len(p) for p in polys]) > 1.5 * length_uv / spacing_uv + 2
    if dense.any():
        polys = [resample(p, h) if dn else p for p, h, dn in zip(polys, spacing_uv, dense)]
        geo = _curve_geometry(polys, surf)

    # candidates: the usable vertices in the grid cells of each curve's grown box
    grow = (cutoff / float(s[surf.usable].min()))[:, None]
    cc, item = surf.vgrid.query(geo["bb_lo"] - grow, geo["bb_hi"] + grow)
    cv = surf.usable[item]
    near = s[cv] * _box_distance(uv[cv], geo["bb_lo"][cc], geo["bb_hi"][cc]) < cutoff[cc]
    cc, cv = cc[near], cv[near]

    # per curve: the nearest sample (a matrix product), then the nearest point on its two
    # segments; candidates come grouped by curve
    seg, t, t_raw, d2 = (np.zeros(len(cv), np.int64), np.zeros(len(cv)), np.zeros(len(cv)),
                         np.zeros(len(cv)))
    bounds = np.searchsorted(cc, np.arange(C + 1))
    for c in range(C):  # a handful of curves; each is vectorised over its vertices
        r = slice(bounds[c], bounds[c + 1])
        if r.start < r.stop:
            x = geo["P"][geo["s_off"][c]:geo["s_off"][c + 1]]
            found = _nearest_on_curve(uv[cv[r]], G[cv[r]], smax[cv[r]], x)
            seg[r] = geo["seg_off"][c] + found[0]
            t[r], t_raw[r], d2[r] = found[1:]
    near = d2 < cutoff[cc] ** 2
    vert, cur, seg, t, t_raw, d2 = cv[near], cc[near], seg[near], t[near], t_raw[near], d2[near]
    l = np.sqrt(d2)
    # arc length, extended past the ends along the end segments
    seg_off = geo["seg_off"]
    beyond = ((seg == seg_off[cur]) & (t_raw < 0)) | ((seg == seg_off[cur + 1] - 1) & (t_raw > 1))
    u = geo["u0"][seg] + np.where(beyond, t_raw, t) * geo["len3"][seg]
    lengths = geo["lengths"]
    fade = window(l, w[cur]) * taper(u, lengths[cur], np.maximum(tp, w)[cur])
    keep = fade > 0
    order = np.lexsort((vert[keep], cur[keep]))
    idx = np.flatnonzero(keep)[order]
    vert, cur, seg, t, l, u = vert[idx], cur[idx], seg[idx], t[idx], l[idx], u[idx]
    static = profile(l, d[cur], w[cur]) * fade[idx]
    a = geo["seg_a"][seg]
    P, tan = geo["P"], geo["tan"]
    foot = P[a] + t[:, None] * geo["E"][seg]
    tangent = (1.0 - t)[:, None] * tan[a] + t[:, None] * tan[a + 1]
    tangent /= np.maximum(np.sqrt((tangent * tangent).sum(axis=1)), _TINY)[:, None]
    offsets = np.zeros(C + 1, np.int64)
    np.cumsum(np.bincount(cur, minlength=C), out=offsets[1:])
    return CurvePlan(U, vert, cur, static, tangent, foot, l, u, offsets, lengths, np.unique(vert))


def curve_heights(plan, modulation_per_entry=None):
    """The frame's heights (U,) along the normals: ``sum over curves of static * M``
    (Bando et al. 2002, §6-7); vertices near two curves get the sum.  ``modulation_per_entry``
    is M(s) per plan entry (E,), a scalar, or None for the rest heights."""
    weights = plan.static if modulation_per_entry is None else plan.static * modulation_per_entry
    return np.bincount(plan.verts, weights=weights, minlength=plan.n_verts)


def merge_plans(plans):
    """One plan from the plans of several curve lists on the same mesh (curves numbered
    in order), e.g. to re-plan only the curve an artist edited."""
    plans = list(plans)
    if not plans:
        raise ValueError("Nothing to merge: no wrinkle plans")
    n = plans[0].n_verts
    if any(p.n_verts != n for p in plans):
        raise ValueError("The wrinkle plans belong to different meshes")
    first_curve = np.cumsum([0] + [len(p.lengths) for p in plans])
    first_entry = np.cumsum([0] + [len(p.verts) for p in plans])
    verts = np.concatenate([p.verts for p in plans])
    offsets = np.concatenate([[0]] + [p.offsets[1:] + e for p, e in zip(plans, first_entry)])
    return CurvePlan(
        n, verts, np.concatenate([p.curve + c for p, c in zip(plans, first_curve)]),
        np.concatenate([p.static for p in plans]), np.concatenate([p.tangent for p in plans]),
        np.concatenate([p.foot for p in plans]), np.concatenate([p.l for p in plans]),
        np.concatenate([p.u for p in plans]), offsets.astype(np.int64),
        np.concatenate([p.lengths for p in plans]), np.unique(verts),
    )


# --------------------------------------------------------------------------- refinement
REFINE_REACH, REFINE_NEAR, REFINE_FAR = 4.0, 0.45, 1.2  # in wrinkle widths


def edge_limits(positions, edges, polylines, widths):
    """The longest each edge may be (E,) for the large-scale wrinkles of §6 (inf where no
    curve reaches): the paper refines "around the specified wrinkle locations" when the mesh
    is too coarse for them.  Within ``REFINE_REACH`` widths of a curve, where the furrow and
    the bulges' flanks are, an edge spans at most ``REFINE_NEAR`` widths (the furrow's sharp
    bottom needs about two edges across it); out to the cut-off (``CUTOFF`` widths),
    ``REFINE_FAR`` widths.  ``polylines``: the curves as dense 3-D samples (k, 3) in the
    positions' space; ``widths`` their w.  An edge's distance is its nearest point of three
    (ends and middle) to the nearest sample: per curve, only the edges in its box grown by
    the cut-off are compared, in chunks."""
    p = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    e = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    limit = np.full(len(e), np.inf)
    a, b = p[e[:, 0]], p[e[:, 1]]
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    for poly, w in zip(polylines, widths):  # a handful of curves
        s = np.asarray(poly, dtype=np.float64).reshape(-1, 3)
        if len(s) == 0 or not w > 0:
            continue
        reach = CUTOFF * w
        box = np.flatnonzero(((lo < s.max(axis=0) + reach) & (hi > s.min(axis=0) - reach)).all(axis=1))
        near = np.full(len(box), np.inf)
        for start in range(0, len(box), 1024):  # chunks bound the (chunk, k) distance array
            idx = box[start:start + 1024]
            for q in (a[idx], 0.5 * (a[idx] + b[idx]), b[idx]):
                d2 = ((q[:, None, :] - s[None, :, :]) ** 2).sum(axis=2).min(axis=1)
                near[start:start + len(idx)] = np.minimum(near[start:start + len(idx)], np.sqrt(d2))
        cap = np.where(near < REFINE_REACH * w, REFINE_NEAR * w,
                       np.where(near < reach, REFINE_FAR * w, np.inf))
        limit[box] = np.minimum(limit[box], cap)
    return limit
