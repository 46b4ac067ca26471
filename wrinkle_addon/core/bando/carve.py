# SPDX-License-Identifier: GPL-3.0-or-later
"""Fine-scale wrinkle furrows carved along a direction field: Bando, Kuratate & Nishita
2002, "A Simple Method for Modeling Wrinkles on Human Skin", §5.2 - §5.4.

Pure NumPy.  The mapped mesh (``uv`` (U, 2), ``tris`` (T, 3)) carries a direction field
``field`` (U, 2): one 2-D texture-space vector per vertex whose length is the magnitude
``m`` of §5.3.  :func:`carve` grows furrows along it and returns a *height image* (white,
lowered along the furrows) and a binary *occupancy image* (where no new furrow may start),
as §5.2 describes.

Image layout as in :mod:`..raster`: an (R, R) image, row ``j`` is ``v``, column ``i`` is
``u``; pixel ``(j, i)`` is the square ``[i, i + 1) x [j, j + 1)`` in pixel units
``(x, y) = (u R, v R)`` and its centre is ``(i + 0.5, j + 0.5)``.

The furrow of §5.2, steps 1 - 7, from a start point P, once with ``d`` and once with
``-d`` (two *ends* per furrow):

1. ``d`` is the field interpolated at P (barycentric, in the triangle drawn at P's pixel:
   the triangle's linear function evaluated at P itself, not at the pixel centre).
2. ``n = min(n, N(m))``, ``n`` starting at infinity (Equation 1).
3. ``d`` is rotated by ``theta = theta_max(m) r``, ``r`` uniform in (-1, 1).
4. ``Q = P + D(m) d``; where PQ meets another furrow's centre line, Q moves to the meeting
   point and ``n`` to 0.
5. / 6. PQ is drawn on the height image (depth and width from ``I``, ``W_h``) and on the
   occupancy image (width ``W_o``).
7. Stop if ``n = 0``, else ``P = Q``, ``n = n - 1``, repeat.

So an end that is never stopped draws ``N + 1`` segments.  The parameters are those of
Equation 1 (:func:`parameters`), taken at each step's P.

Vectorised, many furrows grow in lockstep: every round each live end takes one step.

* **Intersections (step 4)** are found on a furrow-id *label image* of the centre lines:
  every segment labels its *supercover*, all the pixels it passes through (a 4-connected
  chain: where it passes exactly through a pixel corner, a side pixel is taken too).  Two
  segments that cross share the pixel of their crossing point, so a new segment is
  scanned pixel by pixel from P and stops at the first pixel labelled by *another* furrow
  (a furrow never stops on its own pixels, so its previous segment is no obstacle).  Q
  is then the exact crossing with the segment that labelled that pixel when there is one
  inside the pixel, else the point where PQ enters the pixel (within a pixel diagonal of
  the other line).  The first furrow to label a pixel owns it: furrows never share a
  centre-line pixel (but for the pixel where one ends on another's line) and never
  cross.
* **Conflicts within a round**: the new segments of one round do not see each other in
  the label image.  Where segments of different furrows claim the same pixel, the lower
  furrow id (the earlier start) wins and the other end is cut where it enters that pixel
  (at the exact crossing when there is one) and stops; cuts are repeated until stable
  (a cut loser frees its later pixels, which may un-cut a third furrow), so the result
  is the same as letting the furrows take the round's steps one after another by id.
* **Pixels outside the mesh** stop an end where it enters them: no furrow is carved
  where the mesh is not mapped.

Seeding (end of §5.2).  A furrow may only START on a covered pixel whose occupancy is 0;
it then grows through the occupied pixels of others (only centre lines stop it).  Starts
are taken in batches that grow together:

* *random phase*: each batch draws random points, uniform on the covered pixels that
  have a direction (seeded ``numpy.random.default_rng(seed)``, the only generator used),
  about twice as many as thinning boxes (below) of the mean magnitude fit on the mesh;
  those on unoccupied pixels are candidates, in the order drawn.  The phase ends after
  the first batch whose fraction of free points is below :data:`RANDOM_PHASE_MIN_FREE`
  ("until many furrows fail to be generated").
* *fill phase*: every pixel still unoccupied is a candidate, in a fixed order (a seeded
  hash of the pixel index), a batch at most :data:`MAX_BATCH` of them, until none is left.

**Thinning rule** inside a batch, so that lockstep furrows keep apart as sequential ones
would: in the frame of its own direction, a candidate *reaches* the box ``|along| <
(N + 1) D`` (the length one end grows if nothing stops it) by ``|across| < W_o / 2``
(the occupancy band its line will draw).  Two candidates conflict when either lies in
the other's box, i.e. where the first one's straight furrow would have made the other's
start point occupied.  A batch keeps the greedy independent set in candidate order (the
first candidate is taken, every candidate conflicting with a taken one dropped, and so
on, computed in parallel).  Dropped candidates stay free and come back in later batches.
The box is at least 1.5 px wide and long, so two starts never share a pixel.

Images:

* **Occupancy**: 1 outside the mesh from the start (§5.2) and, per segment, on its
  supercover pixels and on the pixels whose centre lies within ``W_o / 2`` of it (a line
  of width ``W_o``, step 6).  So a new furrow starts at least ``W_o / 2`` from the centre
  line of any furrow grown in an earlier batch (up to the 1/sqrt(2) px between a random
  start point and its pixel centre).  Start pixels are marked too, so the fill phase
  always ends.  Pixels with a zero field are never candidates (their occupancy stays 0
  unless a furrow marks them).
* **Height**: 1 (white); step 5 draws the segment with intensity ``I = 1 - m^2``, i.e. the
  furrow's centre gets the grey value ``I``: it is lowered by ``1 - I = m^2``.  (§5.3:
  larger magnitudes make furrows "deeper and wider", so ``I`` is the grey level drawn,
  not the depth; ``m = 0`` draws nothing, and ``W_h = 0`` agrees.)  The cross profile at
  distance ``s`` from the segment is ``1 - m^2 (1 - s / r)^2`` for ``s < r``: a sharp
  crease at the centre that meets the white skin with zero slope at ``s = r``, with
  ``r = W_h / (2 - sqrt 2)`` so the profile is ``W_h`` wide at half depth, and ``r`` at
  least :data:`MIN_PROFILE_RADIUS` px so thin furrows stay continuous lines (as OpenGL
  draws a line thinner than a pixel one pixel wide).  Overlapping furrows take the
  minimum, never a sum.  Only covered pixels are lowered.

Units (§5.3): ``D``, ``W_h`` and ``W_o`` are in pixels times ``scale``; the default
``scale = R / 512`` makes every resolution carve the same furrows in texture space as
the paper's 512 x 512 images, with finer pixels (a 1024 image is the 512 one at twice
the detail).  Field magnitudes above 1 are clipped to 1 (the vector keeps its direction);
a zero vector has no direction: no furrow starts or continues there.

§5.4 (several body parts): ``initial`` gives the height, occupancy and label images
copied over the shared boundary from a part carved before (e.g. that part's
:class:`CarveResult`).  Its labelled pixels are centre lines the new furrows stop on, its
occupancy forbids starts, its height is kept (new furrows take the minimum with it), and
new furrow ids follow the largest initial label.
"""

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .. import raster

MAX_RESOLUTION = 8192
BASE_RESOLUTION = 512  # the paper's image size: scale = R / BASE_RESOLUTION by default
RANDOM_PHASE_MIN_FREE = 0.25  # the random phase ends when fewer drawn points are free
MAX_BATCH = 2048  # candidates thinned together in one batch
MIN_PROFILE_RADIUS = 1.5  # px: the height profile's radius never goes below this
MIN_BOX = 1.5  # px: least half-length and half-width of a candidate's thinning box
_HALF_WIDTH_AT_HALF_DEPTH = 1.0 - 2.0 ** -0.5  # (1 - s / r)^2 = 1/2 at s / r = 1 - 1/sqrt 2
_BIG = np.iinfo(np.int32).max  # no furrow id: ids are int32 like the label image
_CHUNK = 1 << 20  # pixels per chunk when drawing segment footprints


@dataclass(frozen=True)
class Parameters:
    """The six wrinkle parameters of Equation 1 (§5.3), arrays shaped like ``m``.

    ``theta_max`` is the largest perturbation angle (radians): ``theta = theta_max r``
    with ``r`` uniform in (-1, 1).  ``D``, ``W_h`` and ``W_o`` are in pixels times the
    ``scale`` given to :func:`parameters`; ``I`` is the grey level drawn on the height
    image (1 is white, no furrow)."""

    N: np.ndarray
    theta_max: np.ndarray
    D: np.ndarray
    I: np.ndarray
    W_h: np.ndarray
    W_o: np.ndarray


def parameters(m, scale=1.0):
    """Equation 1 of §5.3 at magnitude ``m`` (clipped to [0, 1]): ``N = floor(30 - 20 m)``,
    ``theta_max = 0.5 - 0.4 m``, ``D = 4 + 2 m``, ``I = 1 - m^2``, ``W_h = 2 m``,
    ``W_o = 1 + 12 m``, the lengths times ``scale``."""
    m = np.clip(np.asarray(m, dtype=np.float64), 0.0, 1.0)
    s = float(scale)
    return Parameters(
        N=np.floor(30.0 - 20.0 * m + 1e-9).astype(np.int64),  # + 1e-9: decimal m like 0.45 exact
        theta_max=0.5 - 0.4 * m,
        D=(4.0 + 2.0 * m) * s,
        I=1.0 - m * m,
        W_h=2.0 * m * s,
        W_o=(1.0 + 12.0 * m) * s,
    )


def profile_radius(w_h):
    """Radius (px) of the height profile of a furrow of width ``w_h`` (px): the
    ``(1 - s / r)^2`` profile is ``w_h`` wide at half depth, at least
    :data:`MIN_PROFILE_RADIUS`."""
    return np.maximum(np.asarray(w_h, np.float64) / (2.0 * _HALF_WIDTH_AT_HALF_DEPTH), MIN_PROFILE_RADIUS)


@dataclass(frozen=True)
class CarveState:
    """An initial state for §5.4: (R, R) ``height`` (float, 1 = white), ``occupancy``
    (bool) and ``labels`` (int, the furrow id of each centre-line pixel, -1 none).  A
    :class:`CarveResult` can be given in its place."""

    height: np.ndarray
    occupancy: np.ndarray
    labels: np.ndarray


@dataclass(frozen=True)
class Furrow:
    """One furrow: its ``id``, its polyline ``points`` (K, 2) in UV from the end grown
    along ``-d`` through the start point to the end grown along ``d``, the ``start``
    point (2,) in UV, and the ``batch`` it started in (0, 1, ... in order)."""

    id: int
    points: np.ndarray
    start: np.ndarray
    batch: int


@dataclass(frozen=True, eq=False)
class CarveResult:
    """What :func:`carve` returns.

    ``height`` (R, R) float32 in [0, 1], 1 where no furrow is (so ``height - 1`` is the
    displacement); ``occupancy`` (R, R) bool; ``labels`` (R, R) int32 furrow id of the
    centre-line pixels (-1: none); ``covered`` (R, R) bool, the mapped mesh.
    ``segments`` (S, 2, 2) float64 every furrow segment (P, Q) in UV, in the order carved,
    with its furrow id ``segment_furrow`` (S,), ``segment_side`` (S,) 0 for the end grown
    along ``d``, 1 along ``-d``, and ``segment_step`` (S,) its step in that end;
    ``furrow_ids`` (F,), ``starts`` (F, 2) UV and ``batches`` (F,) per furrow; ``lines``
    the same as polylines.  These hold the furrows of this call, not those of an initial
    state.  ``coverage``: the fraction of covered pixels lowered (height < 1; 0 without
    covered pixels).  ``furrows``: the number of furrows (those with at least one
    segment).  ``scale``: the pixel unit of Equation 1 that was used.
    """

    height: np.ndarray
    occupancy: np.ndarray
    labels: np.ndarray
    covered: np.ndarray
    segments: np.ndarray
    segment_furrow: np.ndarray
    furrow_ids: np.ndarray
    starts: np.ndarray
    batches: np.ndarray
    coverage: float
    scale: float
    segment_side: np.ndarray
    segment_step: np.ndarray

    @property
    def furrows(self):
        return len(self.furrow_ids)

    @cached_property
    def lines(self):
        """The furrows as a tuple of :class:`Furrow` (polylines in UV), by id."""
        order = np.lexsort((self.segment_step, self.segment_side, self.segment_furrow))
        fid = self.segment_furrow[order]
        side = self.segment_side[order]
        p1 = self.segments[order, 1]
        cuts = np.flatnonzero(np.diff(fid)) + 1
        starts = dict(zip(self.furrow_ids.tolist(), range(len(self.furrow_ids))))
        out = []
        for lo, hi in zip(np.concatenate([[0], cuts]), np.concatenate([cuts, [len(fid)]])):
            if hi <= lo:
                continue
            f = int(fid[lo])
            k = starts[f]
            s = side[lo:hi]
            pts = np.concatenate([p1[lo:hi][s == 1][::-1], self.starts[k][None], p1[lo:hi][s == 0]])
            out.append(Furrow(f, pts, self.starts[k].copy(), int(self.batches[k])))
        return tuple(out)


# --------------------------------------------------------------------------- checks
def _check(uv, tris, field, resolution, seed, scale, initial):
    try:
        R = int(resolution)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"resolution must be an integer, got {resolution!r}") from None
    if R != resolution or not 1 <= R <= MAX_RESOLUTION:
        raise ValueError(f"resolution must be an integer in [1, {MAX_RESOLUTION}], got {resolution!r}")
    uv = np.asarray(uv, dtype=np.float64)
    field = np.asarray(field, dtype=np.float64)
    tris = np.asarray(tris)
    if uv.ndim != 2 or uv.shape[1] != 2:
        raise ValueError(f"uv must be (U, 2), got shape {uv.shape}")
    if field.shape != uv.shape:
        raise ValueError(f"field must be (U, 2) like uv {uv.shape}, got shape {field.shape}")
    if tris.ndim != 2 or tris.shape[1] != 3:
        raise ValueError(f"tris must be (T, 3), got shape {tris.shape}")
    if tris.size and not np.issubdtype(tris.dtype, np.integer):
        raise ValueError(f"tris must hold integer indices, got dtype {tris.dtype}")
    tris = tris.astype(np.int64)
    if tris.size and (tris.min() < 0 or tris.max() >= len(uv)):
        raise ValueError(f"tris index outside uv (0 .. {len(uv) - 1})")
    if not np.isfinite(uv).all():
        raise ValueError("uv contains NaN or infinite values")
    if not np.isfinite(field).all():
        raise ValueError("field contains NaN or infinite values")
    if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    if scale is None:
        scale = R / BASE_RESOLUTION
    scale = float(scale)
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"scale must be a positive finite number, got {scale!r}")
    if initial is not None:
        shapes = [np.shape(getattr(initial, k, None)) for k in ("height", "occupancy", "labels")]
        if any(s != (R, R) for s in shapes):
            raise ValueError(f"initial height, occupancy and labels must be ({R}, {R}), got {shapes}")
        if not np.isfinite(np.asarray(initial.height, np.float64)).all():
            raise ValueError("initial height contains NaN or infinite values")
        if np.asarray(initial.labels).min() < -1:
            raise ValueError("initial labels must be furrow ids >= 0 or -1")
    return uv, tris, field, R, scale


# --------------------------------------------------------------------------- geometry
def _planes(corners, values, R):
    """Per triangle the coefficients (T, 3, 2) of the linear field ``base + gx x + gy y``
    in pixel units, as :func:`raster.rasterize` interpolates it (exact barycentrics)."""
    P = corners * R
    e1, e2 = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)[:, None]
    d1, d2 = values[:, 1] - values[:, 0], values[:, 2] - values[:, 0]
    gx = (d1 * e2[:, 1:2] - d2 * e1[:, 1:2]) * inv
    gy = (d2 * e1[:, 0:1] - d1 * e2[:, 0:1]) * inv
    base = values[:, 0] - gx * P[:, 0, 0:1] - gy * P[:, 0, 1:2]
    return np.stack([base, gx, gy], axis=1)


def _supercover(P, Q):
    """The pixels each segment PQ passes through, in order from P: ``(ix, iy, t_in,
    count)`` with ``ix``, ``iy`` (E, K) pixel columns / rows, ``t_in`` (E, K) the segment
    parameter where it enters each pixel (0 for P's pixel) and ``count`` (E,) the number
    of valid columns (the rest is padding).  A step through a pixel corner takes the x
    step first: the chain is 4-connected."""
    c0 = np.floor(P).astype(np.int64)
    c1 = np.floor(Q).astype(np.int64)
    n = np.abs(c1 - c0)  # (E, 2) steps along x, y
    d = Q - P
    sgn = np.where(d >= 0, 1, -1)
    count = n.sum(axis=1) + 1
    cols = []
    for a in (0, 1):
        k = np.arange(1, max(int(n[:, a].max(initial=0)), 0) + 1)
        if len(k) == 0:
            cols.append(np.zeros((len(P), 0)))
            continue
        bound = np.where(sgn[:, a:a + 1] > 0, c0[:, a:a + 1] + k, c0[:, a:a + 1] - k + 1)
        da = np.where(d[:, a:a + 1] != 0, d[:, a:a + 1], 1.0)
        t = np.clip((bound - P[:, a:a + 1]) / da, 0.0, 1.0)
        cols.append(np.where(k[None] <= n[:, a:a + 1], t, np.inf))
    t_all = np.concatenate(cols, axis=1)
    is_x = np.concatenate([np.ones(cols[0].shape, bool), np.zeros(cols[1].shape, bool)], axis=1)
    order = np.argsort(t_all, axis=1, kind="stable")
    t_s = np.take_along_axis(t_all, order, axis=1)
    x_s = np.take_along_axis(is_x, order, axis=1)
    fin = np.isfinite(t_s)
    ix = c0[:, :1] + np.concatenate([np.zeros((len(P), 1), np.int64),
                                     np.cumsum(fin & x_s, axis=1) * sgn[:, :1]], axis=1)
    iy = c0[:, 1:] + np.concatenate([np.zeros((len(P), 1), np.int64),
                                     np.cumsum(fin & ~x_s, axis=1) * sgn[:, 1:]], axis=1)
    t_in = np.concatenate([np.zeros((len(P), 1)), np.where(fin, t_s, 1.0)], axis=1)
    return ix, iy, t_in, count


def _crossing(P, Q, A, B, t_lo, t_hi):
    """Parameter ``t`` on PQ of its crossing with AB when it lies in [t_lo, t_hi] (and on
    AB), else NaN.  All (E, 2) / (E,)."""
    d, e, w = Q - P, B - A, A - P
    den = d[:, 0] * e[:, 1] - d[:, 1] * e[:, 0]
    ok = np.abs(den) > 1e-12
    den = np.where(ok, den, 1.0)
    t = (w[:, 0] * e[:, 1] - w[:, 1] * e[:, 0]) / den
    u = (w[:, 0] * d[:, 1] - w[:, 1] * d[:, 0]) / den
    eps = 1e-9
    ok &= (t >= t_lo - eps) & (t <= t_hi + eps) & (u >= -eps) & (u <= 1.0 + eps)
    return np.where(ok, np.clip(t, t_lo, t_hi), np.nan)


def _capsule_spans(p0, p1, radius, R):
    """The pixels whose centre lies within ``radius`` (S,) of the segments p0 p1 (S, 2)
    (pixel units), as row spans: ``(seg, row, i0, i1)``, columns ``i0 .. i1`` inclusive.

    A capsule is convex, so each row crosses it in one interval: the union of the
    intervals of its two end discs and of its rectangle (|along| within the segment,
    |across| <= radius), each found in closed form on the row's centre line."""
    S = len(p0)
    lo_y = np.minimum(p0[:, 1], p1[:, 1]) - radius
    hi_y = np.maximum(p0[:, 1], p1[:, 1]) + radius
    j0 = np.clip(np.ceil(lo_y - 0.5), 0, R).astype(np.int64)
    j1 = np.clip(np.floor(hi_y - 0.5), -1, R - 1).astype(np.int64)
    rows = np.maximum(j1 - j0 + 1, 0)
    seg = np.repeat(np.arange(S), rows)
    row = np.repeat(j0 - np.cumsum(rows) + rows, rows) + np.arange(int(rows.sum()))
    y = row + 0.5
    x0, y0 = p0[seg, 0], y - p0[seg, 1]  # y0: the row relative to p0
    ex, ey = (p1 - p0)[seg].T
    rho = radius[seg]
    xl = np.full(len(seg), np.inf)
    xr = np.full(len(seg), -np.inf)
    for cx, dy in ((x0, y0), (p1[seg, 0], y - p1[seg, 1])):  # the end discs
        h = rho * rho - dy * dy
        w = np.sqrt(np.maximum(h, 0.0))
        xl = np.where(h >= 0, np.minimum(xl, cx - w), xl)
        xr = np.where(h >= 0, np.maximum(xr, cx + w), xr)
    L2 = ex * ex + ey * ey
    L = np.sqrt(L2)
    with np.errstate(divide="ignore", invalid="ignore"):
        # along: 0 <= (x - x0) ex + y0 ey <= L^2
        a = np.where(ex != 0, -y0 * ey / ex, 0.0)
        b = np.where(ex != 0, (L2 - y0 * ey) / ex, 0.0)
        ok_a = (y0 * ey >= 0) & (y0 * ey <= L2)  # for ex == 0: every x or none
        al = np.where(ex != 0, np.minimum(a, b), np.where(ok_a, -np.inf, np.inf))
        ar = np.where(ex != 0, np.maximum(a, b), np.where(ok_a, np.inf, -np.inf))
        # across: |y0 ex - (x - x0) ey| <= rho L
        c = np.where(ey != 0, (y0 * ex - rho * L) / ey, 0.0)
        d = np.where(ey != 0, (y0 * ex + rho * L) / ey, 0.0)
        ok_c = np.abs(y0 * ex) <= rho * L
        cl = np.where(ey != 0, np.minimum(c, d), np.where(ok_c, -np.inf, np.inf))
        cr = np.where(ey != 0, np.maximum(c, d), np.where(ok_c, np.inf, -np.inf))
    rl = x0 + np.maximum(al, cl)
    rr = x0 + np.minimum(ar, cr)
    rect = (L2 > 0) & (rl <= rr)
    xl = np.where(rect, np.minimum(xl, rl), xl)
    xr = np.where(rect, np.maximum(xr, rr), xr)
    with np.errstate(invalid="ignore"):
        i0 = np.clip(np.ceil(xl - 0.5), 0, R).astype(np.int64)
        i1 = np.clip(np.floor(xr - 0.5), -1, R - 1).astype(np.int64)
    keep = np.isfinite(xl) & (i1 >= i0)
    return seg[keep], row[keep], i0[keep], i1[keep]


def _segment_pixels(p0, p1, radius, R):
    """Chunks ``(seg, flat, dist)`` of the pixels whose centre lies within ``radius`` of
    the segments p0 p1 (S, 2) in pixel units: segment index, flat pixel index and the
    distance (float32), at most about :data:`_CHUNK` pixels a chunk."""
    step = max(1, _CHUNK // int(np.max((2 * radius + 2) * (radius + 2 + np.abs(p1 - p0).max(axis=1)),
                                       initial=1)))
    for s0 in range(0, len(p0), step):
        s1 = min(s0 + step, len(p0))
        seg, row, i0, i1 = _capsule_spans(p0[s0:s1], p1[s0:s1], radius[s0:s1], R)
        n = i1 - i0 + 1
        ends = np.cumsum(n)
        k = np.arange(int(ends[-1]) if len(ends) else 0) - np.repeat(ends - n, n)
        sg = np.repeat(seg, n)
        col = np.repeat(i0, n) + k
        rw = np.repeat(row, n)
        # distance in float32, relative to the segment's start (small numbers)
        vx = (col + 0.5 - p0[s0 + sg, 0]).astype(np.float32)
        vy = (rw + 0.5 - p0[s0 + sg, 1]).astype(np.float32)
        e = (p1[s0:s1] - p0[s0:s1]).astype(np.float32)
        ee = np.einsum("ij,ij->i", e, e)
        inv = np.where(ee > 0, 1.0 / np.where(ee > 0, ee, 1.0), 0.0).astype(np.float32)
        ex, ey = e[sg, 0], e[sg, 1]
        t = np.clip((vx * ex + vy * ey) * inv[sg], 0.0, 1.0)
        dx = vx - t * ex
        dy = vy - t * ey
        yield s0 + sg, rw * R + col, np.sqrt(dx * dx + dy * dy)


def _fill_spans(mask, seg_row_i0_i1, R):
    """Set the spans' pixels in the flat bool ``mask`` (R * R): a difference array per
    row, so the cost is the number of spans plus one pass over the image."""
    _seg, row, i0, i1 = seg_row_i0_i1
    if len(row) == 0:
        return
    W = R + 1
    r0, r1 = int(row.min()), int(row.max()) + 1  # only the rows the spans touch
    diff = np.zeros((r1 - r0) * W, np.int32)
    np.add.at(diff, (row - r0) * W + i0, 1)
    np.add.at(diff, (row - r0) * W + i1 + 1, -1)
    hit = np.cumsum(diff.reshape(r1 - r0, W), axis=1, dtype=np.int32)[:, :R] > 0
    mask[r0 * R:r1 * R] |= hit.ravel()


def _mix(x, seed):
    """A seeded 64-bit hash (splitmix64 finaliser) of the integers ``x``: a fixed
    pseudo-random order of the pixels that needs no array over the whole image."""
    z = (x.astype(np.uint64) + np.uint64((seed * 0x9E3779B97F4A7C15) & 0xFFFFFFFFFFFFFFFF))
    with np.errstate(over="ignore"):
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


# --------------------------------------------------------------------------- carving
class _Carver:
    """The state of one carving: images, segment store, generator."""

    def __init__(self, uv, tris, field, R, scale, seed, initial):
        self.R, self.scale = R, scale
        self.seed = int(seed)
        self.rng = np.random.default_rng(self.seed)
        corners = uv[tris]
        mag = np.sqrt(np.einsum("ij,ij->i", field, field))
        field = np.where(mag[:, None] > 1.0, field / np.maximum(mag, 1.0)[:, None], field)  # clip m to 1
        img, covered, tri_img = raster.rasterize(corners, field[tris], R, index=True)
        self.covered = covered
        # no direction, no furrow: such pixels are never start candidates
        self.nodir = (np.einsum("ijk,ijk->ij", img, img) < 1e-24).ravel()
        del img
        self.tri = tri_img.ravel()
        self.coef = _planes(corners, field[tris], R)
        self.cov_flat = covered.ravel()
        if initial is None:
            self.height = np.ones((R, R), np.float32)
            self.labels = np.full(R * R, -1, np.int32)
            occ = ~covered
        else:
            self.height = np.clip(np.asarray(initial.height, np.float32), 0.0, 1.0).copy()
            self.labels = np.asarray(initial.labels).astype(np.int32).ravel().copy()
            occ = ~covered | np.asarray(initial.occupancy, bool)
        self.occ = occ.ravel() | (self.labels >= 0)
        self.seg_img = np.full(R * R, -1, np.int32)  # the segment that labelled a pixel
        self.next_id = int(self.labels.max(initial=-1)) + 1
        self.scratch = np.full(R * R, _BIG, np.int32)  # per pixel: the lowest id claiming it
        self.scratch_end = np.zeros(R * R, np.int32)  # and the end that claims it for that id
        cap = 1024
        self.sp0 = np.zeros((cap, 2))
        self.sp1 = np.zeros((cap, 2))
        self.sm = np.zeros(cap)
        self.sfid = np.zeros(cap, np.int64)
        self.sside = np.zeros(cap, np.int8)
        self.sstep = np.zeros(cap, np.int32)
        self.nseg = 0
        self.starts, self.start_ids, self.start_batch = [], [], []
        self.batch = 0

    # ------------------------------------------------------------------ field
    def field_at(self, pts):
        """Step 1: the field at points (E, 2) in pixel units, from the triangle drawn at
        each point's pixel; (E, 2) and the mask of points on covered pixels."""
        R = self.R
        ix = np.floor(pts[:, 0]).astype(np.int64)
        iy = np.floor(pts[:, 1]).astype(np.int64)
        inside = (ix >= 0) & (ix < R) & (iy >= 0) & (iy < R)
        cell = np.where(inside, iy * R + ix, 0)
        tri = np.where(inside, self.tri[cell], -1)
        ok = tri >= 0
        c = self.coef[np.maximum(tri, 0)]
        f = c[:, 0] + c[:, 1] * pts[:, 0:1] + c[:, 2] * pts[:, 1:2]
        return np.where(ok[:, None], f, 0.0), ok

    # ------------------------------------------------------------------ thinning
    def thin(self, pts):
        """The batch from candidates ``pts`` (K, 2) (pixel units) in priority order:
        ``(take, dead)``, the indices of the greedy independent set under the thinning
        rule, and those of the points with no direction (a zero field), which cannot
        start a furrow."""
        f, ok = self.field_at(pts)
        mag = np.sqrt(np.einsum("ij,ij->i", f, f))
        live = ok & (mag > 1e-12)
        dead = np.flatnonzero(~live)
        idx = np.flatnonzero(live)
        K = len(idx)
        if K <= 1:
            return idx, dead
        px, py = pts[idx, 0].astype(np.float32), pts[idx, 1].astype(np.float32)
        dx, dy = (f[idx] / mag[idx, None]).astype(np.float32).T
        prm = parameters(np.minimum(mag[idx], 1.0), self.scale)
        reach = np.maximum((prm.N + 1) * prm.D, MIN_BOX).astype(np.float32)
        half = np.maximum(prm.W_o / 2.0, MIN_BOX).astype(np.float32)
        # conflicting pairs (i, j), j < i: i is later in the order
        pi, pj = [], []
        step = max(1, (1 << 20) // K)
        for r0 in range(1, K, step):
            r1 = min(r0 + step, K)
            vx = px[None, :r1] - px[r0:r1, None]  # from i (rows) to j (columns)
            vy = py[None, :r1] - py[r0:r1, None]
            ix, iy = dx[r0:r1, None], dy[r0:r1, None]
            blk = ((np.abs(vx * ix + vy * iy) < reach[r0:r1, None])
                   & (np.abs(vy * ix - vx * iy) < half[r0:r1, None]))
            jx, jy = dx[None, :r1], dy[None, :r1]
            blk |= ((np.abs(vx * jx + vy * jy) < reach[None, :r1])
                    & (np.abs(vy * jx - vx * jy) < half[None, :r1]))
            blk &= np.arange(r1)[None, :] < np.arange(r0, r1)[:, None]
            i, j = np.nonzero(blk)
            pi.append(i + r0)
            pj.append(j)
        pi, pj = np.concatenate(pi), np.concatenate(pj)
        # greedy independent set in order, in parallel: a candidate is taken once no
        # earlier undecided candidate conflicts with it, dropped once a taken one does
        state = np.zeros(K, np.int8)  # 0 undecided, 1 taken, 2 dropped
        while len(pi):
            blocked = np.zeros(K, bool)
            blocked[pi[state[pj] == 0]] = True
            take = (state == 0) & ~blocked
            state[take] = 1
            state[pi[take[pj]]] = 2
            live = (state[pi] == 0) & (state[pj] == 0)
            pi, pj = pi[live], pj[live]
        state[state == 0] = 1
        return idx[state == 1], dead

    # ------------------------------------------------------------------ segment store
    def _store(self, p0, p1, m, fid, side, step):
        n = len(p0)
        need = self.nseg + n
        if need > len(self.sp0):
            cap = max(need, 2 * len(self.sp0))
            for name in ("sp0", "sp1", "sm", "sfid", "sside", "sstep"):
                old = getattr(self, name)
                new = np.zeros((cap,) + old.shape[1:], old.dtype)
                new[:self.nseg] = old[:self.nseg]
                setattr(self, name, new)
        s = slice(self.nseg, need)
        self.sp0[s], self.sp1[s], self.sm[s] = p0, p1, m
        self.sfid[s], self.sside[s], self.sstep[s] = fid, side, step
        self.nseg = need
        return np.arange(need - n, need)

    # ------------------------------------------------------------------ growth
    def _resolve(self, cells, fid, kb):
        """Within-round conflicts: ``kb`` (E,) the claims (pixels ``cells[e, :kb[e]]``)
        cut so that where ends of different furrows claim one pixel, the lowest furrow id
        keeps it and the others end before it.  Returns the cut ``kb`` and, per end, the
        end that won the pixel it was cut at (-1 if not cut)."""
        K = cells.shape[1]
        e_idx, k_idx = np.nonzero(np.arange(K)[None, :] < kb[:, None])
        c = cells[e_idx, k_idx]
        f = fid[e_idx].astype(np.int32)
        scratch = self.scratch
        cur = kb
        while True:
            act = k_idx < cur[e_idx]
            ca, fa = c[act], f[act]
            np.minimum.at(scratch, ca, fa)
            lost = scratch[c] < f
            new = kb.copy()
            if lost.any():
                np.minimum.at(new, e_idx[lost], k_idx[lost])
            if np.array_equal(new, cur):
                win = np.full(len(kb), -1, np.int64)
                cut = np.flatnonzero(new < kb)
                if len(cut):
                    owner = act & (scratch[c] == f)
                    self.scratch_end[c[owner]] = e_idx[owner]
                    win[cut] = self.scratch_end[cells[cut, new[cut]]]
                scratch[ca] = _BIG
                return new, win
            scratch[ca] = _BIG
            cur = new

    def grow(self, starts, fids):
        """Grow the furrows started at ``starts`` (B, 2) (pixel units) with ids ``fids``
        in lockstep, both ends at once, until every end stops (steps 1 - 7)."""
        R = self.R
        B = len(starts)
        pos = np.concatenate([starts, starts])
        fid = np.concatenate([fids, fids]).astype(np.int64)
        sign = np.concatenate([np.ones(B), -np.ones(B)])
        side = np.concatenate([np.zeros(B, np.int8), np.ones(B, np.int8)])
        n = np.full(2 * B, np.iinfo(np.int64).max, np.int64)  # infinity
        first = self.nseg
        step = 0
        labels, cov = self.labels, self.cov_flat
        while len(pos):
            # steps 1 - 3: direction, number of segments, perturbation
            f, ok = self.field_at(pos)
            mag = np.sqrt(np.einsum("ij,ij->i", f, f))
            ok &= mag > 1e-12
            r = self.rng.uniform(-1.0, 1.0, len(pos))
            pos, f, mag, fid, sign, side, n, r = (x[ok] for x in (pos, f, mag, fid, sign, side, n, r))
            if len(pos) == 0:
                break
            m = np.minimum(mag, 1.0)
            prm = parameters(m, self.scale)
            n = np.minimum(n, prm.N)
            theta = prm.theta_max * r
            d = f / mag[:, None] * sign[:, None]
            cs, sn = np.cos(theta), np.sin(theta)
            d = np.stack([d[:, 0] * cs - d[:, 1] * sn, d[:, 0] * sn + d[:, 1] * cs], axis=1)
            Q = pos + prm.D[:, None] * d
            # step 4: the first pixel of PQ outside the mesh or on another furrow's line
            ix, iy, t_in, count = _supercover(pos, Q)
            K = ix.shape[1]
            inside = (ix >= 0) & (ix < R) & (iy >= 0) & (iy < R)
            cells = np.where(inside, iy * R + ix, 0)
            lab = labels[cells]
            valid = np.arange(K)[None, :] < count[:, None]
            bad = valid & (~inside | ~cov[cells] | ((lab >= 0) & (lab != fid[:, None])))
            kb = np.where(bad.any(axis=1), bad.argmax(axis=1), count)
            kc, win = self._resolve(cells, fid, kb)
            stop = kc < count
            t_cut = np.ones(len(pos))
            e = np.flatnonzero(stop)
            if len(e):
                k = kc[e]
                t_lo = t_in[e, k]
                t_hi = np.where(k + 1 < count[e], t_in[e, np.minimum(k + 1, K - 1)], 1.0)
                # the segment to cut at: the winner's of this round, else the labeller's
                won = win[e] >= 0
                other = np.where(won, -1, self.seg_img[cells[e, k]])
                hit = won | ((other >= 0) & inside[e, k])
                A = np.where(won[:, None], pos[np.maximum(win[e], 0)], self.sp0[np.maximum(other, 0)])
                Bq = np.where(won[:, None], Q[np.maximum(win[e], 0)], self.sp1[np.maximum(other, 0)])
                tx = _crossing(pos[e], Q[e], A, Bq, t_lo, t_hi)
                t_cut[e] = np.where(hit & np.isfinite(tx), tx, t_lo)
            Qc = pos + t_cut[:, None] * (Q - pos)
            # steps 5 / 6: record the segment, label its pixels (the images are drawn per batch)
            keep = t_cut > 0
            seg = np.full(len(pos), -1, np.int64)
            seg[keep] = self._store(pos[keep], Qc[keep], m[keep], fid[keep], side[keep], step)
            e_idx, k_idx = np.nonzero(np.arange(K)[None, :] < kc[:, None])
            c = cells[e_idx, k_idx]
            new = labels[c] < 0
            c, e_idx = c[new], e_idx[new]
            labels[c] = fid[e_idx]
            self.seg_img[c] = seg[e_idx]
            self.occ[c] = True
            # step 7
            go = ~stop & (n > 0)
            pos, fid, sign, side, n = Qc[go], fid[go], sign[go], side[go], n[go] - 1
            step += 1
        return first

    # ------------------------------------------------------------------ images
    def draw_occupancy(self, first):
        """Step 6 for the segments from ``first`` on: width ``W_o``."""
        s = slice(first, self.nseg)
        w_o = parameters(self.sm[s], self.scale).W_o
        _fill_spans(self.occ, _capsule_spans(self.sp0[s], self.sp1[s], w_o / 2.0, self.R), self.R)

    def draw_height(self):
        """Step 5 for every segment: the ``(1 - s / r)^2`` crease, depth ``1 - I``,
        minimum over overlaps, on covered pixels only."""
        s = slice(0, self.nseg)
        prm = parameters(self.sm[s], self.scale)
        depth = (1.0 - prm.I).astype(np.float32)
        rad = profile_radius(prm.W_h)
        inv = (1.0 / rad).astype(np.float32)
        live = depth > 0
        idx = np.flatnonzero(live)
        h = self.height.ravel()
        for seg, flat, dist in _segment_pixels(self.sp0[idx], self.sp1[idx], rad[idx], self.R):
            g = idx[seg]
            u = np.maximum(1.0 - dist * inv[g], 0.0)
            val = 1.0 - depth[g] * u * u
            on = self.cov_flat[flat]
            np.minimum.at(h, flat[on], val[on])

    # ------------------------------------------------------------------ seeding
    def run_batch(self, pts):
        """Thin the candidates ``pts`` (priority order), start and grow the batch, draw
        its occupancy.  Returns the number of furrows started."""
        take, dead = self.thin(pts)
        R = self.R
        mark = np.concatenate([take, dead])
        cells = np.floor(pts[mark, 1]).astype(np.int64) * R + np.floor(pts[mark, 0]).astype(np.int64)
        if len(take) == 0:
            self.occ[cells] = True
            return 0
        fids = self.next_id + np.arange(len(take))
        self.next_id += len(take)
        first = self.grow(pts[take], fids)
        self.draw_occupancy(first)
        self.occ[cells] = True
        self.starts.append(pts[take])
        self.start_ids.append(fids)
        self.start_batch.append(np.full(len(take), self.batch))
        self.batch += 1
        return len(take)

    def run(self):
        R = self.R
        cov_idx = np.flatnonzero(self.cov_flat & ~self.nodir)  # the pixels a furrow may start on
        if len(cov_idx) == 0:
            return
        # random phase: a batch draws about twice the starts a saturated batch would hold
        sample = cov_idx[:: max(1, len(cov_idx) // 4096)]
        f, _ok = self.field_at(np.stack([sample % R + 0.5, sample // R + 0.5], axis=1).astype(np.float64))
        m = float(np.clip(np.sqrt(np.einsum("ij,ij->i", f, f)), 0, 1).mean())
        prm = parameters(m, self.scale)
        box = max(float((prm.N + 1) * prm.D), MIN_BOX) * max(float(prm.W_o) / 2.0, MIN_BOX) * 4.0
        draw = int(np.clip(2.0 * len(cov_idx) / box, 64, MAX_BATCH))
        while True:
            pick = cov_idx[self.rng.integers(0, len(cov_idx), draw)]
            jitter = self.rng.random((draw, 2))
            free = ~self.occ[pick]
            pts = np.stack([pick % R + jitter[:, 0], pick // R + jitter[:, 1]], axis=1)[free]
            if len(pts):
                self.run_batch(pts)
            if free.mean() < RANDOM_PHASE_MIN_FREE:
                break
        # fill phase: every free pixel, in the order of a seeded hash
        while True:
            free = np.flatnonzero(self.cov_flat & ~self.occ & ~self.nodir)
            if len(free) == 0:
                break
            key = _mix(free, self.seed)
            if len(free) > MAX_BATCH:
                part = np.argpartition(key, MAX_BATCH)[:MAX_BATCH]
                free, key = free[part], key[part]
            free = free[np.argsort(key, kind="stable")]
            self.run_batch(np.stack([free % R + 0.5, free // R + 0.5], axis=1).astype(np.float64))

    def result(self):
        self.draw_height()
        R = self.R
        s = slice(0, self.nseg)
        fid = self.sfid[s].copy()
        if self.starts:
            starts = np.concatenate(self.starts)
            ids = np.concatenate(self.start_ids)
            batches = np.concatenate(self.start_batch)
        else:
            starts, ids, batches = np.zeros((0, 2)), np.zeros(0, np.int64), np.zeros(0, np.int64)
        has = np.isin(ids, fid)
        cov = self.covered
        n_cov = int(cov.sum())
        coverage = float((self.height[cov] < 1.0).sum() / n_cov) if n_cov else 0.0
        return CarveResult(
            height=self.height,
            occupancy=self.occ.reshape(R, R),
            labels=self.labels.reshape(R, R),
            covered=cov,
            segments=np.stack([self.sp0[s], self.sp1[s]], axis=1) / R,
            segment_furrow=fid,
            furrow_ids=ids[has],
            starts=starts[has] / R,
            batches=batches[has],
            coverage=coverage,
            scale=self.scale,
            segment_side=self.sside[s].copy(),
            segment_step=self.sstep[s].copy(),
        )


def carve(uv, tris, field, resolution, *, seed=0, scale=None, initial=None):
    """Carve fine-scale wrinkle furrows along ``field`` (Bando et al. 2002, §5.2 - §5.4).

    ``uv`` (U, 2) texture coordinates in [0, 1] (outside, the image clips them),
    ``tris`` (T, 3) triangles into ``uv``, ``field`` (U, 2) the direction field per mapped
    vertex, its length the magnitude ``m`` (clipped to 1 above 1).  ``resolution`` R of
    the square images (1 .. 8192), ``seed`` of the only generator used, ``scale`` the
    pixel unit of Equation 1 (default ``R / 512``), ``initial`` a :class:`CarveState` or
    :class:`CarveResult` to start from (§5.4).  Same inputs and seed, same images bit for
    bit.  Returns a :class:`CarveResult`; raises ValueError on bad input.
    """
    uv, tris, field, R, scale = _check(uv, tris, field, resolution, seed, scale, initial)
    c = _Carver(uv, tris, field, R, scale, seed, initial)
    c.run()
    return c.result()
