# SPDX-License-Identifier: GPL-3.0-or-later
"""Direction fields and skin shrinkage on the mapped mesh (Bando et al. 2002, §4, §5.1, §7).

Bando, Kuratate & Nishita 2002, "A Simple Method for Modeling Wrinkles on Human Skin".
Pure NumPy, no loop over vertices, triangles or edges.

**The mapped mesh.**  The paper works on the mesh mapped to texture space (§4).  Blender's
UVs are per corner, so the caller splits the vertices at UV seams: ``uv`` (U, 2), ``tris``
(T, 3) indices into ``uv``, and ``positions`` (U, 3) the 3-D positions of those mapped
vertices (rest, or deformed per frame).  A vertex on a seam appears once per island, and
the islands are disconnected from each other in this mesh.

* :func:`spring_laplacian` - the spring system of §4 with the harmonic-map spring
  constants of Eck et al. (cotangent weights of the 3-D rest triangles), applied
  matrix-free with ``np.bincount`` over the edge list.
* :func:`interpolate` - minimise the spring energy with some vertices held (§4, §5.1):
  Jacobi-preconditioned conjugate gradients on the free vertices.
* :func:`direction_field`, :func:`rotate`, :func:`stroke_constraints` - the fine-wrinkle
  direction field of §5.1, its second field, and constraints from artist strokes.
* :func:`deformation_field` - a direction field from the face's own poses (beyond the
  paper): wrinkles run across the direction of strongest compression.
* :func:`shrinkage_plan`, :func:`shrinkage`, :func:`modulation` - the shrinkage ``s`` of
  §7, eq. 4 (Fig. 9), split into a static plan and a fast per-frame evaluation, and the
  amplitude modulation ``M(s)`` of eq. 5.

Bad input (mismatched shapes, NaN or infinite values, indices out of range, an empty set
of held vertices) raises ``ValueError``; the results never contain NaN.
"""

from dataclasses import dataclass

import numpy as np

MIN_WEIGHT = 1e-3  # smallest spring constant (cotangent weights are dimensionless, ~0.5-1)
MAX_WEIGHT = 1e4  # largest one: the cotangent of a 0.006 degree angle
C_REF = 0.15  # compression (1 - stretch) that gives a deformation field magnitude of 1
_TINY = 1e-30  # guards divisions by lengths that may collapse to zero
_WEDGE_TOL = 1e-9  # relative tolerance of the wedge test of the shrinkage plan
_CHUNK = 1 << 22  # distances evaluated per chunk by the nearest-vertex search


# --------------------------------------------------------------------------- validation
def _finite(name, a, dtype=np.float64):
    a = np.asarray(a, dtype=dtype)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return a


def _points(name, a, n=None, dim=3, dtype=np.float64):
    """``a`` as an (n, dim) finite array; ``n`` None accepts any count."""
    a = _finite(name, a, dtype)
    if a.ndim != 2 or a.shape[1] != dim or (n is not None and len(a) != n):
        want = f"({n if n is not None else 'N'}, {dim})"
        raise ValueError(f"{name} must have shape {want}, got {a.shape}")
    return a


def _tris(tris, n):
    t = np.asarray(tris)
    if t.size == 0:
        return np.zeros((0, 3), np.int64)
    if t.ndim != 2 or t.shape[1] != 3:
        raise ValueError(f"tris must have shape (T, 3), got {t.shape}")
    if not np.issubdtype(t.dtype, np.integer):
        raise ValueError("tris must hold integer vertex indices")
    t = t.astype(np.int64)
    if t.min() < 0 or t.max() >= n:
        raise ValueError(f"tris index vertices outside [0, {n})")
    return t


def _indices(name, idx, n):
    i = np.asarray(idx)
    if i.size == 0:
        raise ValueError(f"{name} is empty: at least one vertex must be held")
    if i.ndim != 1 or not np.issubdtype(i.dtype, np.integer):
        raise ValueError(f"{name} must be a 1-D array of integer vertex indices")
    i = i.astype(np.int64)
    if i.min() < 0 or i.max() >= n:
        raise ValueError(f"{name} holds indices outside [0, {n})")
    if len(np.unique(i)) != len(i):
        raise ValueError(f"{name} holds a vertex more than once")
    return i


# --------------------------------------------------------------------------- the springs
def _edges(tris, n):
    """Unique undirected edges (E, 2) (smaller index first) and, per triangle corner
    ``k``, the edge opposite it: ``opposite`` (T, 3) indices into the edges."""
    t = np.asarray(tris, np.int64)
    a = np.concatenate([t[:, 1], t[:, 2], t[:, 0]])  # corner k's opposite edge is (k+1, k+2)
    b = np.concatenate([t[:, 2], t[:, 0], t[:, 1]])
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    keys, inverse = np.unique(lo * n + hi, return_inverse=True)
    edges = np.stack([keys // n, keys % n], axis=1) if n else np.zeros((0, 2), np.int64)
    return edges, inverse.reshape(3, -1).T


def _components(edges, n):
    """Connected component label (n,) per vertex: the smallest vertex index of its
    component.  Union by minimum label and pointer jumping: a few vectorised rounds."""
    parent = np.arange(n)
    if len(edges) == 0:
        return parent
    a, b = edges[:, 0], edges[:, 1]
    while True:
        pa, pb = parent[a], parent[b]
        if np.array_equal(pa, pb):
            return parent
        np.minimum.at(parent, np.maximum(pa, pb), np.minimum(pa, pb))
        while True:
            nxt = parent[parent]
            if np.array_equal(nxt, parent):
                break
            parent = nxt


@dataclass(frozen=True)
class SpringLaplacian:
    """The spring system of Bando et al. 2002, §4: springs along the edges, energy
    ``sum w_ij |x_i - x_j|^2``, whose gradient is (twice) the Laplacian ``L x`` with
    ``(L x)_i = sum_j w_ij (x_i - x_j)``.

    ``edges`` (E, 2), ``weights`` (E,), ``diagonal`` (n,) the row sums ``sum_j w_ij`` and
    ``component`` (n,) the connected component of each vertex (its smallest index).
    Build it with :func:`spring_laplacian`; :meth:`apply` is matrix-free, two
    ``np.bincount`` per channel over the edge list, O(E c).
    """

    n: int
    edges: np.ndarray
    weights: np.ndarray
    diagonal: np.ndarray
    component: np.ndarray

    def apply(self, x):
        """``L x`` for ``x`` (n,) or (n, c): float64 of the same shape."""
        x = np.asarray(x, np.float64)
        one = x.ndim == 1
        x = x.reshape(self.n, -1)
        a, b = self.edges[:, 0], self.edges[:, 1]
        out = np.empty_like(x)
        for c in range(x.shape[1]):  # channels (two for a direction field), not vertices
            flow = self.weights * (x[a, c] - x[b, c])
            out[:, c] = (np.bincount(a, flow, minlength=self.n) - np.bincount(b, flow, minlength=self.n))
        return out.ravel() if one else out


def spring_laplacian(positions, tris, *, min_weight=MIN_WEIGHT, max_weight=MAX_WEIGHT):
    """The spring Laplacian of the mapped mesh (Bando et al. 2002, §4 and §5.1).

    Spring constants as Eck et al. set them for harmonic maps, from the 3-D rest
    triangles: Eck's ``k_ij = sum (|e_ik|^2 + |e_jk|^2 - |e_ij|^2) / A_ijk`` over the two
    triangles ``ijk`` on edge ``ij`` is ``4 (cot a + cot b)``, ``a`` and ``b`` the angles
    opposite the edge, so we use the cotangent weights ``w_ij = (cot a + cot b) / 2`` (a
    constant factor does not move the minimum).  A boundary edge has one term.

    Cotangent weights are negative on edges whose opposite angles sum to more than 180
    degrees (a non-Delaunay edge) and zero on the diagonals of right-angled grids; the
    system is then no longer positive definite, or an edge no longer connects its
    vertices.  Every weight is therefore clamped to ``[min_weight, max_weight]`` (1e-3 and
    1e4 by default; cotangent weights are dimensionless, about 0.5 on a regular mesh), so
    the system stays symmetric positive definite on the free vertices of every component
    with a held vertex.  The clamp only touches edges that are nearly non-Delaunay (where
    linear functions are then reproduced only approximately) or sliver triangles; a
    triangle without area contributes nothing, its edges keep ``min_weight`` (they still
    connect).  ``positions`` (U, 3) float, ``tris`` (T, 3) int.
    """
    p = _points("positions", positions)
    n = len(p)
    t = _tris(tris, n)
    if not (0 < min_weight <= max_weight):
        raise ValueError("spring weights need 0 < min_weight <= max_weight")
    edges, opposite = _edges(t, n)
    total = np.zeros(len(edges))
    if len(t):
        corners = p[t]  # (T, 3, 3)
        for k in range(3):  # the three corners of every triangle at once
            u = corners[:, (k + 1) % 3] - corners[:, k]
            v = corners[:, (k + 2) % 3] - corners[:, k]
            cross = np.linalg.norm(np.cross(u, v), axis=1)
            scale = np.einsum("ij,ij->i", u, u) + np.einsum("ij,ij->i", v, v)
            ok = cross > 1e-12 * scale
            cot = np.where(ok, np.einsum("ij,ij->i", u, v) / np.where(ok, cross, 1.0), 0.0)
            total += np.bincount(opposite[:, k], 0.5 * cot, minlength=len(edges))
    weights = np.clip(total, min_weight, max_weight)
    diagonal = np.bincount(edges[:, 0], weights, minlength=n) + np.bincount(edges[:, 1], weights, minlength=n)
    return SpringLaplacian(n, edges, weights, diagonal, _components(edges, n))


def interpolate(positions, tris, fixed, values, *, laplacian=None, initial=None, tol=1e-10,
                max_iterations=10000):
    """Minimise the spring energy ``sum w_ij |x_i - x_j|^2`` with ``x`` held at
    ``values`` on the vertices ``fixed`` (Bando et al. 2002, §4; §5.1 for direction
    vectors).

    ``positions`` (U, 3) the 3-D rest positions of the mapped mesh (they give the spring
    constants, see :func:`spring_laplacian`; pass a prebuilt ``laplacian`` to reuse it),
    ``tris`` (T, 3), ``fixed`` (K,) unique vertex indices, ``values`` (K,) or (K, c).
    Returns float64 (U,) for (K,) values, (U, c) for (K, c).  ``initial``, same shape as
    the result: a first guess for the free vertices (e.g. the previous result after an
    edit of the held values), which shortens the solve.

    The minimum solves ``L_ff x_f = -L_fk x_k`` on the free vertices: Jacobi-preconditioned
    conjugate gradients, matrix-free, all channels at once, until the residual of every
    channel is below ``tol`` times its right-hand side (or ``max_iterations``).  Jacobi-PCG
    on a Laplacian needs a few times ``sqrt(U)`` iterations: measured about 1400 of 2.7 ms
    each (two channels), some 4 s, for 50 000 vertices with 20 held, a one-off set-up cost,
    not a per-frame one.  The held values are returned unchanged; vertices in a connected component
    without a held vertex get 0 (the energy does not fix them).  Deterministic.
    """
    lap = laplacian if laplacian is not None else spring_laplacian(positions, tris)
    n = lap.n
    if laplacian is not None:
        _points("positions", positions, n)
        _tris(tris, n)
    fixed = _indices("fixed", fixed, n)
    vals = _finite("values", values)
    if vals.ndim not in (1, 2) or len(vals) != len(fixed):
        raise ValueError(f"values must have shape ({len(fixed)},) or ({len(fixed)}, c), got {vals.shape}")
    one = vals.ndim == 1
    vals = vals.reshape(len(fixed), -1)
    x = np.zeros((n, vals.shape[1]))
    x[fixed] = vals
    held = np.zeros(n, bool)
    held[fixed] = True
    constrained = np.zeros(n, bool)
    constrained[lap.component[fixed]] = True
    free = ~held & constrained[lap.component]
    if free.any():
        y0 = np.zeros_like(x)
        if initial is not None:
            guess = _finite("initial", initial)
            if guess.shape != ((n,) if one else x.shape):
                raise ValueError(f"initial must have shape {(n,) if one else x.shape}, got {guess.shape}")
            y0[free] = guess.reshape(n, -1)[free]
        x[free] = _cg(lap, x, y0, free, tol, max_iterations)[free]
    return x.ravel() if one else x


def _cg(lap, x0, y0, free, tol, max_iterations):
    """Solve ``L_ff y = -L_fk x_k`` (Jacobi-preconditioned CG, per channel, matrix-free)
    from the first guess ``y0`` (zero off the free rows): the full (n, c) array with the
    solution on the free rows and 0 elsewhere."""
    mask = free[:, None].astype(np.float64)
    inv_diag = np.where(free, 1.0 / np.where(lap.diagonal > 0, lap.diagonal, 1.0), 0.0)[:, None]
    held = x0 * (1.0 - mask)
    b = -lap.apply(held) * mask
    y = y0.copy()
    r = b - lap.apply(y) * mask
    z = r * inv_diag
    p = z.copy()
    rz = np.einsum("ij,ij->j", r, z)
    limit = tol * np.sqrt(np.einsum("ij,ij->j", b, b))
    for _ in range(int(max_iterations)):  # CG iterations, each one vectorised
        if np.all(np.sqrt(np.einsum("ij,ij->j", r, r)) <= limit):
            break
        ap = lap.apply(p) * mask
        pap = np.einsum("ij,ij->j", p, ap)
        alpha = np.where(pap > 0, rz / np.where(pap > 0, pap, 1.0), 0.0)
        y += alpha * p
        r -= alpha * ap
        z = r * inv_diag
        rz_new = np.einsum("ij,ij->j", r, z)
        beta = np.where(rz > 0, rz_new / np.where(rz > 0, rz, 1.0), 0.0)
        p = z + beta * p
        rz = rz_new
    return y


# --------------------------------------------------------------------------- direction fields
def _clip_length(v, top=1.0):
    length = np.sqrt(np.einsum("ij,ij->i", v, v))
    scale = np.where(length > top, top / np.where(length > top, length, 1.0), 1.0)
    return v * scale[:, None]


def direction_field(positions, uv, tris, fixed, vectors, *, laplacian=None, **solver):
    """The fine-wrinkle direction field (Bando et al. 2002, §5.1): UV-space direction
    vectors at the vertices ``fixed`` (K,), ``vectors`` (K, 2), interpolated to every
    mapped vertex by minimising the spring energy of §4 with them held.

    The magnitude ``m`` of a vector is the wrinkles' strength in [0, 1] (§5.3): given
    vectors longer than 1 are shortened to 1 and so is the result.  As in the paper the
    vectors are interpolated component-wise, so opposite vectors cancel (two held vectors
    ``d`` and ``-d`` fade to zero between them although both describe the same furrow
    direction): the artist should give neighbouring vectors consistent signs.  ``uv`` only
    fixes the vertex count (directions are UV-space vectors, the springs are 3-D).
    ``solver``: ``initial``, ``tol``, ``max_iterations`` of :func:`interpolate`.  Returns
    (U, 2).
    """
    p = _points("positions", positions)
    _points("uv", uv, len(p), 2)
    vec = _points("vectors", vectors, None, 2)
    field = interpolate(p, tris, fixed, _clip_length(vec), laplacian=laplacian, **solver)
    return _clip_length(field)


def rotate(field, angle):
    """Each 2-D vector of ``field`` (U, 2) rotated counter-clockwise by ``angle`` radians
    (a scalar or (U,)): the second fine-wrinkle field of Bando et al. 2002, §5 (furrows run
    locally in two directions, §3), the first one turned by an artist's angle.  Lengths
    (the magnitudes m) are kept."""
    f = _points("field", field, None, 2)
    a = _finite("angle", angle)
    if a.ndim > 1 or (a.ndim == 1 and len(a) != len(f)):
        raise ValueError(f"angle must be a scalar or have shape ({len(f)},), got {a.shape}")
    c, s = np.cos(a), np.sin(a)
    return np.stack([c * f[:, 0] - s * f[:, 1], s * f[:, 0] + c * f[:, 1]], axis=1)


def _nearest(points, samples, candidates):
    """The nearest of the ``candidates`` (indices into ``points``) to each sample, and
    its distance; brute force in chunks of ``_CHUNK`` distances (a one-off cost of
    O(samples x vertices), a BLAS product per chunk)."""
    cand = points[candidates]
    sq = np.einsum("ij,ij->i", cand, cand)
    step = max(1, _CHUNK // max(len(cand), 1))
    best = np.empty(len(samples), np.int64)
    for i in range(0, len(samples), step):  # chunks of samples, to bound the memory
        s = samples[i : i + step]
        best[i : i + step] = np.argmin(sq[None, :] - 2.0 * (s @ cand.T), axis=1)
    d = samples - cand[best]
    return candidates[best], np.sqrt(np.einsum("ij,ij->i", d, d))


def _polyline_distance(points, polyline):
    """Distance (N,) from each point to a polyline (k, 2), in chunks of segments."""
    a, seg = polyline[:-1], np.diff(polyline, axis=0)
    seg_sq = np.einsum("ij,ij->i", seg, seg)
    inv = np.where(seg_sq > 0, 1.0 / np.where(seg_sq > 0, seg_sq, 1.0), 0.0)
    best = np.full(len(points), np.inf)
    step = max(1, _CHUNK // 8 // max(len(points), 1))  # temporaries of ~8 floats per pair
    for i in range(0, len(seg), step):  # chunks of segments, to bound the memory
        rel = points[:, None, :] - a[None, i : i + step]  # (N, S, 2)
        f = np.clip(np.einsum("nsj,sj->ns", rel, seg[i : i + step]) * inv[i : i + step], 0.0, 1.0)
        d = rel - f[:, :, None] * seg[None, i : i + step]
        best = np.minimum(best, np.einsum("nsj,nsj->ns", d, d).min(axis=1))
    return np.sqrt(best)


def _resample(stroke, spacing):
    """Points about ``spacing`` apart along a polyline (both ends included) and the
    unit tangent of the segment each lies on."""
    seg = np.diff(stroke, axis=0)
    seg_len = np.sqrt(np.einsum("ij,ij->i", seg, seg))
    cum = np.concatenate([[0.0], np.cumsum(seg_len)])
    count = int(min(max(np.ceil(cum[-1] / spacing), 1), 100000)) + 1
    t = np.linspace(0.0, cum[-1], count)
    # the segment of each sample: zero-length segments are never chosen
    k = np.clip(np.searchsorted(cum, t, side="right") - 1, 0, len(seg) - 1)
    nonzero = np.flatnonzero(seg_len > 0)
    k = nonzero[np.clip(np.searchsorted(nonzero, k), 0, len(nonzero) - 1)]
    f = np.clip((t - cum[k]) / seg_len[k], 0.0, 1.0)
    return stroke[k] + f[:, None] * seg[k], seg[k] / seg_len[k][:, None]


def stroke_constraints(uv, tris, strokes, reference_length):
    """Held direction vectors for :func:`direction_field` from artist strokes in UV space
    (a way of entering the "direction vectors specified at several vertices" of Bando et
    al. 2002, §5.1, Fig. 4a).

    ``strokes``: UV polylines, each (k, 2) with k >= 2 and a positive length.  Each stroke
    is resampled at about half the local edge length of the mapped mesh (the shortest mean
    UV edge length at the vertices nearest to a first pass at the median edge length), so
    consecutive samples cannot skip a vertex; every sample gives its nearest mapped vertex
    (one that belongs to a triangle; samples farther from it than the vertex's mean edge
    length, off the mesh, are dropped) the stroke's unit tangent there times
    ``m = min(1, stroke_length / reference_length)`` (§5.3: a longer stroke, a stronger
    wrinkle).  Where several samples (of one or more strokes) reach a vertex their vectors
    are averaged, so crossing strokes blend and opposite ones cancel.  If vertices share a
    UV position the lowest index is chosen.

    Returns ``(fixed, vectors)``: sorted unique int64 vertex indices (K,) and float64
    (K, 2); empty when no stroke reaches the mesh.  Cost: O(U x stroke points) to find
    the vertices within the longest UV edge length of each stroke (any sample's nearest
    vertex is among them), then O(samples x those vertices); a one-off, not per frame.
    """
    uv = _points("uv", uv, None, 2)
    n = len(uv)
    t = _tris(tris, n)
    ref = float(reference_length)
    if not (np.isfinite(ref) and ref > 0):
        raise ValueError("reference_length must be a positive number")
    polylines = []
    for i, s in enumerate(strokes):  # strokes, a handful: not vertices
        s = _finite(f"stroke {i}", s)
        if s.ndim != 2 or s.shape[1] != 2 or len(s) < 2:
            raise ValueError(f"stroke {i} must have shape (k, 2) with k >= 2, got {s.shape}")
        if not np.any(np.diff(s, axis=0)):
            raise ValueError(f"stroke {i} has zero length")
        polylines.append(s)
    empty = (np.zeros(0, np.int64), np.zeros((0, 2)))
    if not polylines or len(t) == 0:
        return empty
    edges, _ = _edges(t, n)
    d = uv[edges[:, 1]] - uv[edges[:, 0]]
    length = np.sqrt(np.einsum("ij,ij->i", d, d))
    count = np.bincount(edges.ravel(), minlength=n)
    local = np.bincount(edges.ravel(), np.repeat(length, 2), minlength=n) / np.maximum(count, 1)
    used = np.flatnonzero(count > 0)
    coarse, longest = float(np.median(length)), float(length.max())
    if not coarse > 0:
        return empty
    verts, vecs = [], []
    for s in polylines:
        # a sample on the mesh lies in a triangle, so its nearest vertex is at most the
        # longest UV edge away: only vertices that close to the stroke can be the nearest
        candidates = used[_polyline_distance(uv[used], s) <= longest]
        if len(candidates) == 0:
            continue
        pts, _tan = _resample(s, coarse)
        near, _dist = _nearest(uv, pts, candidates)
        spacing = 0.5 * max(float(local[near].min()), coarse * 1e-3)
        pts, tangent = _resample(s, spacing)
        near, dist = _nearest(uv, pts, candidates)
        keep = dist <= local[near]
        seg = np.diff(s, axis=0)
        m = min(1.0, float(np.sum(np.sqrt(np.einsum("ij,ij->i", seg, seg)))) / ref)
        verts.append(near[keep])
        vecs.append(m * tangent[keep])
    if not verts or sum(len(v) for v in verts) == 0:
        return empty
    verts, vecs = np.concatenate(verts), np.concatenate(vecs)
    fixed, inverse = np.unique(verts, return_inverse=True)
    hits = np.bincount(inverse, minlength=len(fixed))
    out = np.stack([np.bincount(inverse, vecs[:, c], minlength=len(fixed)) for c in range(2)], axis=1)
    return fixed, out / hits[:, None]


# --------------------------------------------------------------------------- from the poses
def _sym_eig(a, b, d):
    """Closed-form eigen-decomposition of symmetric 2x2 matrices ``[[a, b], [b, d]]``:
    ``(lam_max, lam_min, cos, sin)`` with ``(cos, sin)`` the unit eigenvector of
    ``lam_max`` (the one of ``lam_min`` is ``(-sin, cos)``).  Continuous where the
    eigenvalues are distinct; an arbitrary orthonormal pair where they are equal."""
    mean = 0.5 * (a + d)
    rad = np.hypot(0.5 * (a - d), b)
    theta = 0.5 * np.arctan2(2.0 * b, a - d)
    return mean + rad, mean - rad, np.cos(theta), np.sin(theta)


def deformation_field(rest, deformed_list, uv, tris, weights=None, *, c_ref=C_REF, fill_threshold=None,
                      floor=0.0, laplacian=None):
    """A wrinkle direction field from the face's own poses (beyond Bando et al. 2002,
    whose §3 observes that wrinkles become pronounced when the skin shrinks perpendicularly
    to them, and whose §7 measures that shrinkage).

    For each triangle and pose: the UV -> 3-D Jacobians ``J_r`` (rest) and ``J_d`` (pose),
    the metrics ``G_r = J_r^T J_r`` and ``G_d = J_d^T J_d``, and the generalized eigenproblem
    ``G_d v = lam G_r v``, whose eigenvalues are the principal squared stretches along the
    UV directions ``v``.  It is solved in closed form in an orthonormal frame of the rest
    triangle, where it is the symmetric 2x2 eigenproblem of the right Cauchy-Green tensor
    ``C = F^T F``; the two eigenvectors are orthogonal in the rest metric.  An eigenvalue
    ``lam < 1`` is a compression ``c = 1 - sqrt(lam)``; wrinkles run perpendicular to it in
    the rest metric, along the other eigenvector ``w`` (taken as a unit UV vector).  Each
    pose adds ``c_min^2 w_max w_max^T + c_max^2 w_min w_min^T`` (normally only the first
    term: the second is the compression along the other axis, if any; it makes a uniform
    squeeze isotropic instead of picking an arbitrary direction) times its weight
    (``weights`` (P,) >= 0, normalised to sum 1; equal by default) to a sign-free
    orientation tensor per triangle.  The tensors are averaged to the vertices by rest
    area; the principal eigenvector (2x2 closed form) is the direction and the root mean
    square compression along it, ``c_rms = sqrt(lam_1)`` (the compression of a single pose
    there), gives the magnitude ``m = clip(c_rms / c_ref, 0, 1)``, ``c_ref`` 0.15 by
    default (skin compressed by 15 % wrinkles fully).  Vertices without compression get
    a zero vector; triangles without area in space or UV contribute nothing.

    The result is a line field: ``w`` and ``-w`` are the same wrinkle.  Signs are chosen
    so that every vector points within 90 degrees of the dominant orientation of the whole
    mesh (the principal eigenvector of the summed tensors), which makes neighbouring
    vectors agree for component-wise interpolation except where the field turns more than
    90 degrees away from it.

    ``fill_threshold``: optional smoothing and filling of the directions.  With a value in
    (0, 1], the vertices whose ``m`` is at least that keep their tensor and every other
    vertex of their connected component takes its orientation from the tensors of the
    strong vertices, normalised to unit strength, interpolated through :func:`interpolate`
    (the spring energy of §4): tensors, not vectors, so opposite signs cannot cancel.
    Weakly compressed skin thus follows the orientation of the strong areas instead of
    its own noise, and uncompressed skin gets a direction too.  Magnitudes stay each
    vertex's own ``m``; ``floor`` (default 0) raises them to at least that wherever a
    direction is defined, e.g. for fine wrinkles everywhere (§5.3's m = 0 already gives
    short, shallow furrows).  ``None`` (default): the raw area-averaged field, where
    uncompressed vertices get a zero vector.  (Interpolating the full tensors would not
    do: with the strong vertices as the only constraints the spring energy spreads their
    strength, undiminished, over the whole component.)

    ``rest`` (U, 3), ``deformed_list`` a sequence of (U, 3) poses (or a (P, U, 3) array),
    ``uv`` (U, 2), ``tris`` (T, 3).  Returns float64 (U, 2), UV-space vectors of length m.
    """
    rest = _points("rest", rest)
    n = len(rest)
    uv = _points("uv", uv, n, 2)
    t = _tris(tris, n)
    poses = [_points(f"pose {i}", d, n) for i, d in enumerate(deformed_list)]
    if not poses:
        raise ValueError("deformed_list is empty: at least one pose is needed")
    w = np.ones(len(poses)) if weights is None else _finite("weights", weights)
    if w.shape != (len(poses),) or np.any(w < 0) or not w.sum() > 0:
        raise ValueError(f"weights must be {len(poses)} non-negative numbers, not all zero")
    w = w / w.sum()
    if not (np.isfinite(c_ref) and c_ref > 0):
        raise ValueError("c_ref must be a positive number")
    if fill_threshold is not None and not 0 < fill_threshold <= 1:
        raise ValueError("fill_threshold must be in (0, 1]")
    if not 0 <= floor <= 1:
        raise ValueError("floor must be in [0, 1]")

    # rest frame per triangle: p1 = (l1, 0), p2 = (x2, y2); UV edges d1, d2
    r0 = rest[t[:, 0]]
    e1, e2 = rest[t[:, 1]] - r0, rest[t[:, 2]] - r0
    l1 = np.sqrt(np.einsum("ij,ij->i", e1, e1))
    x2 = np.einsum("ij,ij->i", e2, e1) / np.where(l1 > 0, l1, 1.0)
    y2 = np.sqrt(np.maximum(np.einsum("ij,ij->i", e2, e2) - x2 * x2, 0.0))
    u0 = uv[t[:, 0]]
    d1, d2 = uv[t[:, 1]] - u0, uv[t[:, 2]] - u0
    det_uv = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    scale = np.einsum("ij,ij->i", e1, e1) + np.einsum("ij,ij->i", e2, e2)
    scale_uv = np.einsum("ij,ij->i", d1, d1) + np.einsum("ij,ij->i", d2, d2)
    ok = (l1 * y2 > 1e-12 * scale) & (np.abs(det_uv) > 1e-12 * scale_uv)
    l1, y2 = np.where(ok, l1, 1.0), np.where(ok, y2, 1.0)
    # P^-1 = [[1/l1, -x2/(l1 y2)], [0, 1/y2]] maps rest-frame vectors to edge coordinates
    i11, i12, i22 = 1.0 / l1, -x2 / (l1 * y2), 1.0 / y2

    def to_uv(c, s):  # a rest-frame vector (c, s) as a unit UV vector D P^-1 (c, s)
        xi1, xi2 = i11 * c + i12 * s, i22 * s
        v = d1 * xi1[:, None] + d2 * xi2[:, None]
        length = np.sqrt(np.einsum("ij,ij->i", v, v))
        return v / np.where(length > 0, length, 1.0)[:, None]

    tensor = np.zeros((len(t), 3))  # (s11, s12, s22) per triangle
    for weight, pose in zip(w, poses):  # poses, a handful
        q0 = pose[t[:, 0]]
        f1, f2 = pose[t[:, 1]] - q0, pose[t[:, 2]] - q0
        g11, g12, g22 = (np.einsum("ij,ij->i", f1, f1), np.einsum("ij,ij->i", f1, f2),
                         np.einsum("ij,ij->i", f2, f2))
        # C = P^-T G_E P^-1 with G_E the Gram matrix of the deformed edges
        c11 = i11 * i11 * g11
        c12 = i11 * (i12 * g11 + i22 * g12)
        c22 = i12 * i12 * g11 + 2.0 * i12 * i22 * g12 + i22 * i22 * g22
        lam_max, lam_min, cos, sin = _sym_eig(c11, c12, c22)
        c_min = 1.0 - np.sqrt(np.clip(lam_min, 0.0, 1.0))
        c_max = 1.0 - np.sqrt(np.clip(lam_max, 0.0, 1.0))
        w_max, w_min = to_uv(cos, sin), to_uv(-sin, cos)  # wrinkles across v_min run along v_max
        for k, (i, j) in enumerate(((0, 0), (0, 1), (1, 1))):
            tensor[:, k] += weight * (c_min**2 * w_max[:, i] * w_max[:, j]
                                      + c_max**2 * w_min[:, i] * w_min[:, j])
    cross = np.cross(e1, e2)
    area = np.where(ok, 0.5 * np.sqrt(np.einsum("ij,ij->i", cross, cross)), 0.0)
    corner_w = np.repeat(area, 3)
    vert_area = np.bincount(t.ravel(), corner_w, minlength=n)
    corner_t = np.repeat(tensor, 3, axis=0) * corner_w[:, None]  # (3 T, 3), as t.ravel()
    s = np.stack([np.bincount(t.ravel(), corner_t[:, k], minlength=n) for k in range(3)], axis=1)
    s /= np.where(vert_area > 0, vert_area, 1.0)[:, None]
    lam1 = _sym_eig(s[:, 0], s[:, 1], s[:, 2])[0]
    defined = lam1 > 1e-12 * c_ref * c_ref  # some compression: a direction
    m = np.where(defined, np.clip(np.sqrt(np.maximum(lam1, 0.0)) / c_ref, 0.0, 1.0), 0.0)
    orient = s
    if fill_threshold is not None:
        strong = np.flatnonzero(defined & (m >= fill_threshold))
        if len(strong):  # unit-strength tensors: only the orientation is interpolated
            filled = interpolate(rest, t, strong, s[strong] / lam1[strong, None], laplacian=laplacian)
            got = _sym_eig(filled[:, 0], filled[:, 1], filled[:, 2])[0] > 1e-12  # a held component
            orient = np.where(got[:, None], filled, s)
            defined |= got
    _l1, _l2, cos, sin = _sym_eig(orient[:, 0], orient[:, 1], orient[:, 2])
    direction = np.stack([cos, sin], axis=1)
    _g1, _g2, gc, gs = _sym_eig(*s.sum(axis=0))
    direction[direction @ np.array([gc, gs]) < 0] *= -1.0
    return direction * np.where(defined, np.maximum(m, floor), 0.0)[:, None]


# --------------------------------------------------------------------------- shrinkage
@dataclass(frozen=True)
class ShrinkagePlan:
    """The static part of the shrinkage of Bando et al. 2002, §7 (eq. 4, Fig. 9), from
    :func:`shrinkage_plan`.

    Per chosen corner (at most two per vertex: the triangle in direction ``+d_p`` and the
    one in ``-d_p``): ``vertex`` v1, ``ends`` (C, 2) the far ends v2, v3 of its edges,
    ``alpha``, ``beta`` (``±d_p = alpha a + beta b``, both >= 0), ``rest_lengths`` (C, 2)
    the rest 3-D lengths ``|v1v2|``, ``|v1v3|``, and ``side`` (+1 or -1).  The rest are
    the per-vertex slots :func:`shrinkage` evaluates.
    """

    n_verts: int
    vertex: np.ndarray
    ends: np.ndarray
    alpha: np.ndarray
    beta: np.ndarray
    rest_lengths: np.ndarray
    side: np.ndarray
    slot_ends: np.ndarray  # (4, U) far ends: (+d_p: v2, v3), (-d_p: v2, v3)
    slot_coef: np.ndarray  # (4, U) 2 alpha R2 / (alpha + beta), 2 beta R3 / (alpha + beta) per side
    share: np.ndarray  # (U,) 1 where the vertex has a corner, else 0
    none: np.ndarray  # vertices without a corner (their s is 0)
    slot_coef32: np.ndarray  # float32 copies for float32 positions
    share32: np.ndarray


def shrinkage_plan(uv, tris, direction, rest):
    """The static plan of the shrinkage ``s`` (Bando et al. 2002, §7, eq. 4, Fig. 9).

    ``direction`` (U, 2) the wrinkle direction per mapped vertex, in UV (a fine field or
    a large wrinkle's tangent; its length does not matter, a zero vector means no
    wrinkle); ``rest`` (U, 3) the rest 3-D positions (for the rest edge lengths).  At each
    vertex ``v1``, ``d_p`` is the unit UV perpendicular of the direction.  For each
    triangle corner ``(v1, v2, v3)`` with ``a = uv[v2] - uv[v1]``, ``b = uv[v3] - uv[v1]``
    we solve ``d_p = alpha a + beta b``; the corner's wedge holds ``+d_p`` where
    ``alpha, beta >= 0`` and ``-d_p`` where both are <= 0 (then ``-alpha, -beta`` are
    used).  The distance from v1 to the edge v2v3 along ``d_p`` is ``L = 1 / (alpha +
    beta)``; with the edges v1v2, v1v3 scaled by ``t2``, ``t3`` (deformed / rest 3-D
    lengths, assumed to scale the UV edges alike), ``L' = 1 / (alpha/t2 + beta/t3)`` and
    ``s = 1 - L'/L = 1 - (alpha + beta) / (alpha/t2 + beta/t3)`` (eq. 4).

    One corner per side and vertex: where ``d_p`` runs along an edge (exactly, or within a
    relative 1e-9) both wedges beside it qualify, and the one with ``d_p`` deepest inside
    (largest ``min(alpha, beta) / (alpha + beta)``), then the lowest corner index, is
    taken, deterministically.  Triangles without area in UV, or with a rest edge of zero
    length, are skipped.  The two sides are averaged (the paper's "two triangles located
    in direction d_p and -d_p"); a vertex on a boundary or seam with one side uses that
    one; a vertex with none (a zero direction) gets s = 0.
    """
    uv = _points("uv", uv, None, 2)
    n = len(uv)
    t = _tris(tris, n)
    d = _points("direction", direction, n, 2)
    rest = _points("rest", rest, n)
    length = np.sqrt(np.einsum("ij,ij->i", d, d))
    has_dir = length > 1e-12
    d = d / np.where(has_dir, length, 1.0)[:, None]
    dp = np.stack([-d[:, 1], d[:, 0]], axis=1)

    v1 = t.T.ravel()  # corner k of triangle i is row k T + i
    v2 = t[:, [1, 2, 0]].T.ravel()
    v3 = t[:, [2, 0, 1]].T.ravel()
    a, b = uv[v2] - uv[v1], uv[v3] - uv[v1]
    det = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    r2 = np.linalg.norm(rest[v2] - rest[v1], axis=1)
    r3 = np.linalg.norm(rest[v3] - rest[v1], axis=1)
    q = dp[v1]
    ok = (has_dir[v1] & (np.abs(det) > 1e-12 * (np.einsum("ij,ij->i", a, a) + np.einsum("ij,ij->i", b, b)))
          & (r2 > _TINY) & (r3 > _TINY))
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    alpha = (q[:, 0] * b[:, 1] - q[:, 1] * b[:, 0]) * inv
    beta = (a[:, 0] * q[:, 1] - a[:, 1] * q[:, 0]) * inv
    tol = _WEDGE_TOL * (np.abs(alpha) + np.abs(beta))
    plus = ok & (alpha >= -tol) & (beta >= -tol)
    minus = ok & (alpha <= tol) & (beta <= tol)
    corner = np.concatenate([np.flatnonzero(plus), np.flatnonzero(minus)])
    side = np.concatenate([np.ones(plus.sum(), np.int64), -np.ones(minus.sum(), np.int64)])
    al = np.maximum(alpha[corner] * side, 0.0)
    be = np.maximum(beta[corner] * side, 0.0)
    score = np.minimum(al, be) / (al + be)
    key = v1[corner] * 2 + (side < 0)
    order = np.lexsort((corner, -score, key))
    first = order[np.concatenate([[True], key[order][1:] != key[order][:-1]])] if len(order) else order
    corner, side, al, be = corner[first], side[first], al[first], be[first]
    vert = v1[corner]
    ends = np.stack([v2[corner], v3[corner]], axis=1)
    rest_lengths = np.stack([r2[corner], r3[corner]], axis=1)

    # per-vertex slots: side s of vertex v at column v of rows (2 s, 2 s + 1); a missing
    # side repeats the other one (so the two halves average to it); no side at all:
    # far ends the vertex itself and coefficients 1 (a finite, tiny term), s set to 0
    sides = np.bincount(vert, minlength=n)
    share = (sides > 0).astype(np.float64)
    slot = np.zeros((2, n), np.int64) - 1
    slot[(side < 0).astype(np.int64), vert] = np.arange(len(vert))
    slot = np.where(slot < 0, slot[::-1], slot)  # the missing side borrows the other one
    none = np.flatnonzero(sides == 0)
    total = al + be
    # the half of s = 1 - 1 / (a' / l2 + b' / l3) per side, a' = 2 alpha R2 / (alpha + beta)
    coef = np.stack([2.0 * al * rest_lengths[:, 0] / total, 2.0 * be * rest_lengths[:, 1] / total], axis=1)
    slot_ends = np.empty((4, n), np.intp)
    slot_coef = np.ones((4, n))
    for s_ in range(2):  # the two sides
        has = slot[s_] >= 0
        for e in range(2):  # gathered only where a side exists: there may be no corner at all
            slot_ends[2 * s_ + e] = np.arange(n)
            slot_ends[2 * s_ + e][has] = ends[slot[s_][has], e]
            slot_coef[2 * s_ + e][has] = coef[slot[s_][has], e]
    return ShrinkagePlan(n, vert, ends, al, be, rest_lengths, side, slot_ends, slot_coef, share, none,
                         slot_coef.astype(np.float32), share.astype(np.float32))


def shrinkage(plan, positions):
    """Per-frame shrinkage ``s`` (U,) (Bando et al. 2002, §7, eq. 4) of the mapped vertices
    at ``positions`` (U, 3), from a :func:`shrinkage_plan`.

    ``s = 1 - L'/L``: 0 at rest, up to 1 as the skin across the wrinkle shrinks, negative
    where it stretches.  Per vertex, for each of its (at most two) corners,
    ``1 / (a'/l2 + b'/l3)`` from the deformed 3-D lengths ``l2``, ``l3`` of its two edges
    and the plan's coefficients, then ``s = share - sum`` (the average of the two sides'
    ``1 - L'/L``).  Computed in the dtype of ``positions``: float32 (Blender's) is the fast
    path.  Cost: one gather of 4U position rows, about ten elementwise passes over (4, U)
    and (2, U) arrays, no bincount: measured about 0.7 ms for 50 000 vertices in float32
    and 1.1 ms in float64 on a shared 2-core development machine (the gather alone
    is 0.37 ms).  A collapsed edge gives s -> 1, never
    NaN.
    """
    p = np.asarray(positions)
    if p.dtype not in (np.float32, np.float64):
        p = p.astype(np.float64)
    if p.shape != (plan.n_verts, 3):
        raise ValueError(f"positions must have shape ({plan.n_verts}, 3), got {p.shape}")
    p = np.ascontiguousarray(p)
    single = p.dtype == np.float32
    coef = plan.slot_coef32 if single else plan.slot_coef
    with np.errstate(all="ignore"):  # non-finite input is reported below
        g = np.take(p, plan.slot_ends, axis=0)  # (4, U, 3): the far end of each edge
        flat = g.reshape(4, -1)
        np.subtract(flat, p.ravel(), out=flat)  # minus the vertex itself
        np.multiply(g, g, out=g)
        length = (g.reshape(-1, 3) @ np.ones(3, p.dtype)).reshape(4, -1)
        np.sqrt(length, out=length)
        np.maximum(length, _TINY, out=length)
        np.divide(coef, length, out=length)
        den = length[0::2] + length[1::2]  # (2, U): a'/l2 + b'/l3 per side
        np.reciprocal(den, out=den)
        s = (plan.share32 if single else plan.share) - (den[0] + den[1])
    if not np.all(np.isfinite(s)):
        raise ValueError("positions contain NaN or infinite values")
    if len(plan.none):
        s[plan.none] = 0.0
    return s


def modulation(s, r):
    """The amplitude modulation function ``M(s)`` (Bando et al. 2002, §7, eq. 5):
    ``(1 - r) s + r`` for ``s >= 0`` and ``r exp((1/r - 1) s)`` for ``s < 0``; C¹ at
    ``s = 0`` (value ``r``, slope ``1 - r``), 1 at ``s = 1``.  ``r`` in [0, 1] (scalar or
    broadcastable to ``s``) is the rest height relative to the maximum: ``r = 0`` gives 0
    for ``s < 0`` (no wrinkle unless the skin shrinks), ``r = 1`` gives 1.  ``s`` is
    clipped to <= 1 (shrinkage cannot exceed 1).  No division by zero, no warnings."""
    s = np.minimum(_finite("s", s), 1.0)
    r = _finite("r", r)
    if np.any((r < 0) | (r > 1)):
        raise ValueError("r must be in [0, 1]")
    pos = r > 1e-12  # below, r exp((1/r - 1) s) is r (< 1e-12) or less: taken as 0
    k = np.where(pos, 1.0 / np.where(pos, r, 1.0) - 1.0, 0.0)
    neg = np.where(pos, r * np.exp(k * np.minimum(s, 0.0)), 0.0)
    return np.where(s >= 0, (1.0 - r) * s + r, neg)


# --------------------------------------------------------------------------- many at once
@dataclass(frozen=True)
class EdgeSlots:
    """Rows of one or more :class:`ShrinkagePlan` gathered for a per-frame evaluation on the
    skin (``n_verts``, 3) of the face's own vertices (see :func:`edge_slots`): the 3-D edges
    the rows use, listed once (``ends``: two (E,) intp arrays of mesh vertices; ``flat``
    (2, 3, E) intp: the flat indices of their x, y, z in the skin), and per row its four
    edges (``slot_edge`` (4, R) intp), coefficients (``slot_coef`` (4, R) float32), ``share``
    (R,) float32 and ``none`` (R,) bool (s = 0).  ``offsets`` (P + 1,): part p owns rows
    ``offsets[p]:offsets[p + 1]``.  ``work``: the per-frame scratch arrays of
    :func:`edge_slot_shrinkage` (one evaluation at a time)."""

    n_verts: int
    ends: tuple
    flat: np.ndarray
    slot_edge: np.ndarray
    slot_coef: np.ndarray
    share: np.ndarray
    none: np.ndarray
    offsets: np.ndarray
    work: tuple


def edge_slots(parts, n_verts):
    """The :class:`EdgeSlots` of ``parts``, each ``(plan, rows, vert_of)``: a
    :class:`ShrinkagePlan`, the plan's vertices to evaluate (R_p,) (-1: none, s = 0) and the
    mesh vertex (of ``n_verts``) of each of the plan's vertices.  Each edge is measured once
    a frame however many rows and parts use it: gathers of positions are the cost, and two
    rows of the same vertex (two fields, two curves) share its edges.  A row with s = 0
    measures nothing of its own (its slots point at another row's edge)."""
    keys, coefs, shares, nones, counts = [], [], [], [], []
    for plan, rows, vert_of in parts:
        rows = np.asarray(rows, np.int64)
        has = rows >= 0
        r = np.where(has, rows, 0)
        vert_of = np.asarray(vert_of, np.int64)
        here = vert_of[r]
        far = vert_of[plan.slot_ends[:, r]]  # (4, R)
        keys.append(np.minimum(here, far) * n_verts + np.maximum(here, far))
        coefs.append(plan.slot_coef[:, r])
        none = np.zeros(plan.n_verts, bool)
        none[plan.none] = True
        shares.append(np.where(has, plan.share[r], 0.0))
        nones.append(none[r] | ~has)
        counts.append(len(rows))
    if not keys:
        raise ValueError("edge_slots needs at least one shrinkage plan")
    keys = np.concatenate(keys, axis=1)
    nones = np.concatenate(nones)
    if not nones.all():  # instead of the zero-length edges to the row's own vertex
        keys[:, nones] = keys[0, np.argmin(nones)]
    unique, slot_edge = np.unique(keys, return_inverse=True)
    ends = np.stack([unique // n_verts, unique % n_verts]).astype(np.intp)
    offsets = np.zeros(len(counts) + 1, np.int64)
    np.cumsum(counts, out=offsets[1:])
    work = (np.empty((2, 3, len(unique)), np.float32), np.empty(len(unique), np.float32),
            np.empty(keys.shape, np.float32))
    return EdgeSlots(int(n_verts), (ends[0], ends[1]), ends[:, None, :] * 3 + np.arange(3)[:, None],
                     np.ascontiguousarray(slot_edge.reshape(keys.shape), np.intp),
                     np.ascontiguousarray(np.concatenate(coefs, axis=1), np.float32),
                     np.concatenate(shares).astype(np.float32), nones, offsets, work)


def edge_slot_shrinkage(slots, skin, out=None):
    """The shrinkage (R,) float32 of every row of ``slots`` for the face's skin (N, 3), into
    ``out`` (R,) float32 when given: equal to :func:`shrinkage` of each row's plan at its
    vertex (to float32 rounding).

    Per frame, in float32 and in the plan's scratch arrays (no temporaries: fresh memory
    costs as much as the arithmetic here): one gather of both ends' x, y, z of every edge
    and its length ``l``, then per row ``share - sum over its two sides of
    1 / (a' / l2 + b' / l3)`` from one gather of ``l`` at its four slots.  A division per
    slot, as eq. 4 is written (``a' * (1 / l2)`` rounds differently: a skin at rest would
    no longer give exactly the same s, which a wrinkle with r = 0 must keep at 0)."""
    p = np.asarray(skin, np.float32)
    if p.shape != (slots.n_verts, 3):
        raise ValueError(f"skin must have shape ({slots.n_verts}, 3), got {p.shape}")
    ends, length, q = slots.work
    np.take(p.reshape(-1), slots.flat, out=ends, mode="clip")  # clip: no bounds check, in range
    d = ends[1]
    d -= ends[0]
    d *= d
    np.add(d[0], d[1], out=length)
    length += d[2]
    np.sqrt(length, out=length)
    np.maximum(length, np.float32(_TINY), out=length)
    np.take(length, slots.slot_edge, out=q, mode="clip")
    np.divide(slots.slot_coef, q, out=q)  # a'/l2, b'/l3 per side
    side = q[0::2]
    side += q[1::2]
    np.reciprocal(side, out=side)
    side[0] += side[1]
    s = np.subtract(slots.share, side[0], out=out)
    s[slots.none] = 0.0
    return s
