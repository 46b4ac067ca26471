# SPDX-License-Identifier: GPL-3.0-or-later
"""Shared raster maths: per-vertex data baked into UV space, and smoothing on the mesh.

Pure NumPy, no ``bpy``.  Images are float32 ``(R, R, C)`` arrays in Blender's pixel order:
row 0 is the bottom of the image (v near 0), column 0 the left (u near 0), and pixel
``(j, i)`` has its centre at ``u = (i + 0.5) / R``, ``v = (j + 0.5) / R``.

* :func:`rasterize` - a scanline triangle rasteriser with barycentric (linear)
  interpolation, vectorised over (triangle, row) spans and processed in chunks of a fixed
  number of pixels, so memory stays bounded at any resolution.
* :func:`pad` - edge padding (dilation) beyond the UV islands.
* :func:`slopes` - the surface slopes of a height field in the tangent space of the UVs.
* :func:`soften` - soft borders of per-vertex memberships by diffusion on the mesh.

The wrinkle-map encodings built on these live in ``core.maps.uvmaps``.
"""

import numpy as np

from . import checks, mesh

_F = np.float32
CHUNK_PIXELS = 1 << 20  # pixels written per chunk: about 16 + 8 C bytes of temporaries each
CHUNK_SPANS = 1 << 18  # (triangle, row) spans generated per chunk


# --------------------------------------------------------------------------- rasteriser
def _spans(P, tri_rows, j0, R):
    """The (triangle, row) spans of the triangles ``tri_rows`` (their row counts given by
    the caller): per span the triangle, the row, and the first and end pixel column.

    Scanline rule (the classic polygon fill rule, so a mesh is covered without gaps and
    without double coverage): an edge crosses the row centre ``y`` if ``y`` lies in
    ``[y_low, y_high)`` of the edge; a pixel centre ``x`` is covered if
    ``x_left <= x < x_right``.  Each edge's crossing is computed from its end points in a
    canonical order, so the two triangles that share an edge compute the same bits.
    """
    tri, counts = tri_rows
    first = np.cumsum(counts) - counts
    span_tri = np.repeat(tri, counts)
    row = j0[span_tri] + (np.arange(len(span_tri)) - np.repeat(first, counts))
    y = row + 0.5
    x_lo = np.full(len(span_tri), np.inf)
    x_hi = np.full(len(span_tri), -np.inf)
    corners = P[span_tri]  # (S, 3, 2)
    for a, b in ((0, 1), (1, 2), (2, 0)):
        pa, pb = corners[:, a], corners[:, b]
        swap = (pb[:, 1] < pa[:, 1]) | ((pb[:, 1] == pa[:, 1]) & (pb[:, 0] < pa[:, 0]))
        lo = np.where(swap[:, None], pb, pa)
        hi = np.where(swap[:, None], pa, pb)
        dy = hi[:, 1] - lo[:, 1]
        active = (lo[:, 1] <= y) & (y < hi[:, 1])
        x = lo[:, 0] + (y - lo[:, 1]) * ((hi[:, 0] - lo[:, 0]) / np.where(dy > 0, dy, 1.0))
        x_lo = np.where(active, np.minimum(x_lo, x), x_lo)
        x_hi = np.where(active, np.maximum(x_hi, x), x_hi)
    ok = x_hi > x_lo
    i0 = np.clip(np.ceil(np.where(ok, x_lo, 0.0) - 0.5), 0, R).astype(np.int64)
    i1 = np.clip(np.ceil(np.where(ok, x_hi, 0.0) - 0.5), 0, R).astype(np.int64)
    return span_tri, row, i0, np.maximum(i1, i0)


def rasterize(uv, values, resolution, *, index=False, chunk_pixels=CHUNK_PIXELS):
    """Rasterise triangles in UV space with barycentric interpolation.

    ``uv`` (T, 3, 2) corner UVs; ``values`` (T, 3, C) per-corner values (or (T, 3) for
    one channel, or None for coverage only).  Returns ``(image, covered)``: the (R, R, C)
    float32 image (0 where nothing is drawn) and the (R, R) bool coverage mask; with
    ``index`` also the (R, R) int32 image of the triangle drawn at each pixel (-1: none).

    Interpolation is exact for values linear over the triangle: each triangle is the plane
    ``v0 + g . (p - p0)`` through its corners, evaluated at the pixel centres.  UVs
    outside [0, 1] are clipped, not wrapped; where triangles overlap in UV space the later
    one wins; triangles with no area in UV space draw nothing.
    """
    R = int(resolution)
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 3, 2)
    T = len(uv)
    if values is None:
        values = np.zeros((T, 3, 0), _F)
    values = np.asarray(values, dtype=np.float64)
    if values.ndim == 2:
        values = values[..., None]
    C = values.shape[-1]
    values = values.reshape(T, 3, C)
    image = np.zeros((R * R, C), _F)
    covered = np.zeros(R * R, bool)
    tri_image = np.full(R * R, -1, np.int32) if index else None

    P = uv * R  # pixel units
    e1, e2 = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    finite = np.isfinite(P).all(axis=(1, 2)) & np.isfinite(values).all(axis=(1, 2))
    good = finite & (np.abs(det) > 1e-12)
    inv = np.where(good, 1.0 / np.where(good, det, 1.0), 0.0)[:, None]
    d1, d2 = values[:, 1] - values[:, 0], values[:, 2] - values[:, 0]
    gx = (d1 * e2[:, 1:2] - d2 * e1[:, 1:2]) * inv  # (T, C) d value / d x (pixels)
    gy = (d2 * e1[:, 0:1] - d1 * e2[:, 0:1]) * inv
    # the plane through the corners: value at (x, y) = base + gx x + gy y
    base = values[:, 0] - gx * P[:, 0, 0:1] - gy * P[:, 0, 1:2]

    ys = np.where(good[:, None], P[:, :, 1], 0.0)
    j0 = np.clip(np.ceil(ys.min(axis=1) - 0.5), 0, R).astype(np.int64)
    j1 = np.clip(np.ceil(ys.max(axis=1) - 0.5), 0, R).astype(np.int64)
    rows = np.where(good, np.maximum(j1 - j0, 0), 0)
    tris = np.flatnonzero(rows)
    rows = rows[tris]
    # chunks of triangles with at most CHUNK_SPANS rows (one triangle has at most R)
    ends = np.cumsum(rows)
    start = 0
    while start < len(tris):
        stop = max(int(np.searchsorted(ends, ends[start] - rows[start] + CHUNK_SPANS, "right")), start + 1)
        span_tri, row, i0, i1 = _spans(P, (tris[start:stop], rows[start:stop]), j0, R)
        start = stop
        n = i1 - i0
        keep = n > 0
        span_tri, row, i0, n = span_tri[keep], row[keep], i0[keep], n[keep]
        # value at the span's first pixel, in float64 (no cancellation), then float32 steps
        # of gx along the span: value = start + gx k at its k-th pixel
        start_val = (base[span_tri] + gy[span_tri] * (row + 0.5)[:, None]
                     + gx[span_tri] * (i0 + 0.5)[:, None]).astype(_F)
        span_gx = gx[span_tri].astype(_F)
        span_flat = row * R + i0
        pix_end = np.cumsum(n)
        s0 = 0
        while s0 < len(n):  # sub-chunks of at most chunk_pixels pixels (a span has <= R)
            s1 = max(int(np.searchsorted(pix_end, pix_end[s0] - n[s0] + chunk_pixels, "right")), s0 + 1)
            cnt = n[s0:s1]
            k = np.arange(pix_end[s0] - cnt[0], pix_end[s1 - 1]) - np.repeat(pix_end[s0:s1] - cnt, cnt)
            flat = np.repeat(span_flat[s0:s1], cnt) + k
            covered[flat] = True
            if C:
                image[flat] = (np.repeat(start_val[s0:s1], cnt, axis=0)
                               + np.repeat(span_gx[s0:s1], cnt, axis=0) * k[:, None].astype(_F))
            if index:
                tri_image[flat] = np.repeat(span_tri[s0:s1], cnt)
            s0 = s1
    out = (image.reshape(R, R, C), covered.reshape(R, R))
    return out + (tri_image.reshape(R, R),) if index else out


# --------------------------------------------------------------------------- padding
def pad(image, covered, pixels=8):
    """Edge padding: extend the values ``pixels`` pixels beyond the covered area, in place.

    Each of the ``pixels`` iterations gives every uncovered pixel that touches a covered
    one (4-neighbourhood) the mean of those neighbours, and marks it covered; so bilinear
    filtering and mip-maps near UV seams read island values, not the background.  Only
    the frontier pixels are computed (found with boolean shifts over the image).  Works
    on (R, R, C) or (R, R) images; returns ``(image, covered)`` with the grown coverage
    (``covered`` itself is not modified).
    """
    R0, R1 = covered.shape
    img = image.reshape(R0 * R1, -1)  # a view: written in place
    cov = covered.copy()
    flat = cov.reshape(-1)
    grow = np.empty_like(cov)
    for _ in range(int(pixels)):
        grow[:] = False
        grow[1:] |= cov[:-1]
        grow[:-1] |= cov[1:]
        grow[:, 1:] |= cov[:, :-1]
        grow[:, :-1] |= cov[:, 1:]
        grow &= ~cov
        idx = np.flatnonzero(grow)
        if len(idx) == 0:
            break
        col = idx % R1
        total = np.zeros((len(idx), img.shape[1]), img.dtype)
        count = np.zeros(len(idx), img.dtype)
        for step, inside in ((-R1, idx >= R1), (R1, idx < (R0 - 1) * R1), (-1, col > 0), (1, col < R1 - 1)):
            nb = np.where(inside, idx + step, idx)
            ok = inside & flat[nb]
            total += np.where(ok[:, None], img[nb], 0.0)
            count += ok
        img[idx] = total / count[:, None]
        flat[idx] = True
    return image, cov


# --------------------------------------------------------------------------- UV islands
def uv_islands(uv, verts=None):
    """Island id (T,) int64 per triangle: triangles that share a UV corner are one island.

    Corners are shared when their UVs are equal (bit for bit) and, if ``verts`` (T, 3)
    vertex indices are given, they are the same mesh vertex too; with them, two islands
    that merely touch in UV space stay apart.  Union-find by pointer jumping: a few
    vectorised rounds, O(log T) of them in practice."""
    uv = np.ascontiguousarray(uv, dtype=np.float32).reshape(-1, 3, 2)
    T = len(uv)
    if T == 0:
        return np.zeros(0, np.int64)
    keys = uv.reshape(-1, 2).view(np.int64).reshape(-1, 1)  # exact bit pattern of (u, v)
    if verts is not None:
        keys = np.concatenate([keys, np.asarray(verts, np.int64).reshape(-1, 1)], axis=1)
    _u, corner = np.unique(keys, axis=0, return_inverse=True)
    corner = corner.reshape(T, 3)
    a = np.concatenate([corner[:, 0], corner[:, 1]])
    b = np.concatenate([corner[:, 1], corner[:, 2]])
    parent = np.arange(len(_u))
    while True:
        pa, pb = parent[a], parent[b]
        if np.array_equal(pa, pb):
            break
        np.minimum.at(parent, np.maximum(pa, pb), np.minimum(pa, pb))
        while True:  # pointer jumping: every node to its root
            nxt = parent[parent]
            if np.array_equal(nxt, parent):
                break
            parent = nxt
    return parent[corner[:, 0]]


# --------------------------------------------------------------------------- PD wrinkle map
def _frames(positions, uv):
    """Per triangle: ``(s_u, c, s_v)`` (T, 3), the unit tangent T (T, 3), the unit
    bitangent B (T, 3), the UV -> surface Jacobian's inverse rows and the triangle's
    area.  See :func:`uv_jacobian`."""
    p = np.asarray(positions, dtype=np.float64).reshape(-1, 3, 3)
    t = np.asarray(uv, dtype=np.float64).reshape(-1, 3, 2)
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    d1, d2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    det = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    ok = np.abs(det) > 1e-20
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)[:, None]
    ju = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * inv  # dP/du
    jv = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) * inv  # dP/dv
    su = np.sqrt(np.einsum("ij,ij->i", ju, ju))
    tan = ju / np.where(su > 0, su, 1.0)[:, None]
    c = np.einsum("ij,ij->i", jv, tan)
    perp = jv - c[:, None] * tan
    sv = np.sqrt(np.einsum("ij,ij->i", perp, perp))
    bit = perp / np.where(sv > 0, sv, 1.0)[:, None]
    bad = ~((su > 1e-12) & (sv > 1e-12) & np.isfinite(su) & np.isfinite(sv))
    frame = np.stack([su, c, sv], axis=1)
    frame[bad] = 0.0
    tan[bad] = 0.0
    bit[bad] = 0.0
    cross = np.cross(e1, e2)
    area = 0.5 * np.sqrt(np.einsum("ij,ij->i", cross, cross))
    # d(value)/du, d(value)/dv of a linear function with corner differences (f1, f2):
    # [f1, f2] = [fu, fv] [[d1u, d2u], [d1v, d2v]]  ->  fu = (f1 d2v - f2 d1v) / det, ...
    rows_u = np.stack([d2[:, 1], -d1[:, 1]], 1)
    rows_v = np.stack([-d2[:, 0], d1[:, 0]], 1)
    grad_rows = np.stack([rows_u, rows_v], 1) * inv[:, :, None]
    grad_rows[bad] = 0.0
    return frame, tan, bit, grad_rows, np.where(bad, 0.0, area)


def uv_jacobian(positions, uv):
    """Per triangle, the tangent frame of the UV -> surface map, as (T, 3) float64:
    ``(s_u, c, s_v)`` with ``s_u = |dP/du|``, ``c = dP/dv . T`` and ``s_v = |dP/dv - c T|``,
    where ``T = (dP/du) / s_u`` (the tangent) and ``B`` the unit ``dP/dv - c T`` (the
    bitangent, the direction of increasing v orthogonal to T).  Zero where the triangle
    has no area in UV or in space."""
    return _frames(positions, uv)[0]


def uv_frames(positions, uv):
    """Per triangle of the (T * 3, 3) corner ``positions`` and (T * 3, 2) corner ``uv``:
    ``(frame, tangent, bitangent, gradient rows, area)``, the frame as in
    :func:`uv_jacobian`, the unit tangent and bitangent (T, 3), the rows that turn corner
    differences into UV derivatives (T, 2, 2) and the 3-D area (T,)."""
    return _frames(positions, uv)


def vertex_slopes(uv, positions, heights, verts, weights=None):
    """Smooth tangent-space slopes per triangle corner (T, 3, 2): ``(a, b)`` of
    :func:`slopes` from the height's surface gradient averaged at the mesh vertices.

    Per triangle the linear height has the constant surface gradient ``g = a T + b B``
    (3-D); each vertex takes the area-weighted mean of the ``g`` of its triangles (across
    UV seams too: ``g`` is a vector on the skin, not in UV), and each corner projects it
    on its own triangle's ``T`` and ``B``.  It is the map counterpart of smooth shading,
    whose vertex normals are the area-weighted mean of the face normals.

    ``heights`` (T, 3) or, with ``weights``, (T, 3, L): L height fields, and ``weights``
    (V, L) how much each vertex follows each (rows summing to 1).  Vertex v then averages
    ``sum_l weights[v, l] g_l`` over its triangles, so where neighbouring vertices follow
    different fields the slopes pass smoothly from one field's to the other's; cutting
    the fields together into one height first would put a step, and so a streak of steep
    slopes, along every border.
    """
    frame, tan, bit, grad_rows, area = _frames(positions, uv)
    verts = np.asarray(verts, dtype=np.int64).reshape(-1, 3)
    h = np.asarray(heights, dtype=np.float64)
    h = h.reshape(len(verts), 3, -1) if weights is not None else h.reshape(-1, 3, 1)
    dh = np.stack([h[:, 1] - h[:, 0], h[:, 2] - h[:, 0]], 1)  # (T, 2, L)
    huv = np.einsum("tij,tjl->til", grad_rows, dh)  # (dh/du, dh/dv) per field
    su, c, sv = (x[:, None] for x in frame.T)
    ok = su > 0
    a = np.where(ok, huv[:, 0] / np.where(ok, su, 1.0), 0.0)
    b = np.where(ok, (huv[:, 1] - a * c) / np.where(ok, sv, 1.0), 0.0)
    g = (a[:, None] * tan[:, :, None] + b[:, None] * bit[:, :, None]) * area[:, None, None]  # (T, 3, L)
    if weights is None:
        corner_g = np.repeat(g[:, None, :, 0], 3, axis=1)  # (T, 3 corners, 3)
    else:  # each corner contributes the fields its vertex follows
        corner_g = np.einsum("tkl,tcl->tck", g, np.asarray(weights, np.float64)[verts])
    n = int(verts.max()) + 1 if verts.size else 0
    idx = verts.ravel()
    weight = np.bincount(idx, weights=np.repeat(area, 3), minlength=n)
    flat = corner_g.reshape(-1, 3)
    gv = np.stack([np.bincount(idx, weights=flat[:, k], minlength=n) for k in range(3)], 1)
    gv /= np.where(weight > 0, weight, 1.0)[:, None]
    corner_g = gv[verts]  # (T, 3, 3)
    return np.stack([np.einsum("tcj,tj->tc", corner_g, tan), np.einsum("tcj,tj->tc", corner_g, bit)], -1)


def _differences(h, valid, same_left, same_right, axis, R):
    """dh/d(u or v) per UV unit: central differences, one-sided where only one neighbour
    is usable, 0 where none is."""
    n = h.shape[axis]

    def sl(lo, hi):
        s = [slice(None)] * 2
        s[axis] = slice(lo, hi)
        return tuple(s)

    fwd = np.zeros_like(h)  # h[k+1] - h[k]
    fwd[sl(0, n - 1)] = h[sl(1, n)] - h[sl(0, n - 1)]
    back = np.zeros_like(h)  # h[k] - h[k-1]
    back[sl(1, n)] = fwd[sl(0, n - 1)]
    ok_f = valid & same_right
    ok_b = valid & same_left
    both = ok_f & ok_b
    d = np.where(both, 0.5 * (fwd + back), np.where(ok_f, fwd, np.where(ok_b, back, 0.0)))
    return d * _F(R)


def _neighbour_masks(island_img, axis):
    """(same island as the previous pixel, same as the next) along ``axis``; False
    outside the image or where either pixel is uncovered (island -1)."""
    n = island_img.shape[axis]
    prev = np.zeros(island_img.shape, bool)
    nxt = np.zeros(island_img.shape, bool)
    a = [slice(None)] * 2
    b = [slice(None)] * 2
    a[axis], b[axis] = slice(1, n), slice(0, n - 1)
    eq = (island_img[tuple(a)] == island_img[tuple(b)]) & (island_img[tuple(a)] >= 0)
    prev[tuple(a)] = eq
    nxt[tuple(b)] = eq
    return prev, nxt


def slopes(uv, positions, heights, resolution, *, smooth=False, verts=None, islands=None, padding=8,
           block_rows=256, chunk_pixels=CHUNK_PIXELS, weights=None):
    """The tangent-space PD slopes (R, R, 2) float32 and coverage of a height field.

    ``uv`` (T, 3, 2), ``positions`` (T, 3, 3) and ``heights`` (T, 3) per triangle corner;
    ``positions`` and ``heights`` in the same length unit (the face's local space).
    ``islands`` (T,) ids, default :func:`uv_islands`: finite differences never mix pixels
    of two islands that touch in UV space.

    The height ``h`` displaces the surface along its normal: ``P' = P + h N``.  With
    the tangent frame of :func:`uv_jacobian` (``T`` along dP/du, ``B`` along increasing v,
    as Blender's tangent space), the surface gradient of ``h`` is ``a T + b B`` with::

        a = (dh/du) / s_u                    (slope along T)
        b = (dh/dv - a c) / s_v              (slope along B; = (dh/dv) / |dP/dv| when the
                                              UVs are orthogonal, c = 0)

    and the displaced normal is ``n = normalize(-a, -b, 1)`` in (T, B, N): the normal
    tilts toward -u where the height increases with u.  So the PD values are
    ``n' = (n_x / n_z, n_y / n_z) = (-a, -b)``.

    Default (``smooth`` False): ``dh/du``, ``dh/dv`` are finite differences on the
    rasterised height (central; one-sided at island borders) and the frame ``(s_u, c,
    s_v)`` is the triangle's own at each pixel.  The height is linear over each triangle,
    so the slopes are constant per triangle: the map shows the facets, like flat shading.
    With ``smooth`` (needs ``verts`` (T, 3), the corners' mesh vertices), ``(a, b)`` come
    from :func:`vertex_slopes` at the corners and are interpolated over the triangles,
    like smooth shading; ``heights`` may then be (T, 3, L) fields with ``weights`` (V, L)
    per vertex (see :func:`vertex_slopes`).  The slopes are NOT clipped here (see
    :func:`pd_map`).  Then
    :func:`pad` extends them ``padding`` pixels beyond the islands; elsewhere they are 0.
    """
    R = int(resolution)
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 3, 2)
    if smooth:
        if verts is None:
            raise ValueError("smooth slopes need the corners' mesh vertices (verts)")
        ab = vertex_slopes(uv, positions, heights, verts, weights)
        out, covered = rasterize(uv, -ab, R, chunk_pixels=chunk_pixels)
        if padding:
            out, _cov = pad(out, covered, padding)
        return out, covered
    if weights is not None:
        raise ValueError("weighted height fields need smooth slopes")
    frame = uv_jacobian(positions, uv).astype(_F)
    if islands is None:
        islands = uv_islands(uv)
    islands = np.asarray(islands, dtype=np.int64)
    h, covered, tri = rasterize(uv, np.asarray(heights, np.float64).reshape(-1, 3), R, index=True,
                                chunk_pixels=chunk_pixels)
    h = h[..., 0]
    out = np.zeros((R, R, 2), _F)
    step = max(int(block_rows), 1)
    for r0 in range(0, R, step):  # blocks of rows with a one-row halo: bounded temporaries
        r1 = min(r0 + step, R)
        a0, a1 = max(r0 - 1, 0), min(r1 + 1, R)
        t = tri[a0:a1]
        isl = np.where(t >= 0, islands[np.maximum(t, 0)], -1)
        valid = t >= 0
        hb = h[a0:a1]
        p_u, n_u = _neighbour_masks(isl, 1)
        p_v, n_v = _neighbour_masks(isl, 0)
        hu = _differences(hb, valid, p_u, n_u, 1, R)
        hv = _differences(hb, valid, p_v, n_v, 0, R)
        f = frame[np.maximum(t, 0)]
        su, c, sv = f[..., 0], f[..., 1], f[..., 2]
        ok = valid & (su > 0)
        a = np.where(ok, hu / np.where(ok, su, 1.0), 0.0)
        b = np.where(ok, (hv - a * c) / np.where(ok, sv, 1.0), 0.0)
        inner = slice(r0 - a0, r0 - a0 + (r1 - r0))
        out[r0:r1, :, 0] = -a[inner]
        out[r0:r1, :, 1] = -b[inner]
    if padding:
        out, _cov = pad(out, covered, padding)
    return out, covered


def to_world(positions, tris, heights, matrix):
    """Positions (V, 3) and heights (V, ...) of a mesh in object space, moved to the space
    of ``matrix`` (3, 3), the object's world matrix without translation.

    Slopes are lengths over lengths, so a uniform scale leaves a map unchanged, but a
    non-uniform one stretches the surface unevenly: the map must be baked in the space it
    is rendered in.  A height ``h`` along the unit object-space normal ``N`` moves the
    surface by ``h M N``, whose part along the world normal ``M^-T N / |M^-T N|`` is
    ``h / |M^-T N|``.  Raises ValueError for a singular matrix (a zero scale).
    """
    m = np.asarray(matrix, np.float64).reshape(3, 3)
    if abs(np.linalg.det(m)) < 1e-12:
        raise ValueError("the object's scale is zero along an axis")
    p = np.asarray(positions, np.float64)
    n = mesh.vertex_normals(p, tris, len(p))
    stretch = np.linalg.norm(n @ np.linalg.inv(m), axis=1)  # |M^-T N| per vertex, as rows
    h = np.asarray(heights, np.float64)
    scale = np.where(stretch > 0, 1.0 / np.where(stretch > 0, stretch, 1.0), 1.0)
    return p @ m.T, h * scale.reshape((-1,) + (1,) * (h.ndim - 1))


def dilate_max(values, edges, iterations, *, inside=None):
    """``iterations`` steps of a max-filter on the mesh: each vertex takes the largest
    value among itself and its edge neighbours; with ``inside`` (V,) bool only vertices
    inside change, and only from inside neighbours.  (V,) float64."""
    x = np.array(values, dtype=np.float64).ravel()
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    if inside is not None:
        inside = np.asarray(inside, bool)
        edges = edges[inside[edges].all(axis=1)]
    if len(edges) == 0 or iterations <= 0:
        return x
    a, b = edges[:, 0], edges[:, 1]
    for _ in range(int(iterations)):
        nxt = x.copy()
        np.maximum.at(nxt, a, x[b])
        np.maximum.at(nxt, b, x[a])
        if np.array_equal(nxt, x):
            break
        x = nxt
    return x


class _Adjacency:
    """Neighbour sums over the mesh edges (unit weights): ``sum(x)`` is ``A x``."""

    def __init__(self, edges, n):
        edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
        edges = edges[(edges[:, 0] != edges[:, 1]) & (edges.max(axis=1) < n) & (edges.min(axis=1) >= 0)]
        self.src = np.concatenate([edges[:, 0], edges[:, 1]])
        dst = np.concatenate([edges[:, 1], edges[:, 0]])
        self.bins = mesh.Bins.of(dst, domain=np.arange(n))
        self.degree = np.bincount(dst, minlength=n).astype(np.float64)

    def sum(self, x):  # x (C, V) -> (C, V)
        return self.bins.sum(x[:, self.src])


MAX_BLUR_EDGES = 1_000_000  # a border wider than this many edges is refused (diffusion_time)


def diffusion_time(softness, edge_length):
    """The time ``t`` of :func:`diffuse` that blurs a border over about ``softness``.

    On a grid of edge length ``e``, ``(I + t L)^-1`` spreads a point over a variance of
    ``2 t e^2`` along each axis (the continuous-time random walk with rate 1 per edge,
    observed at an exponential time of mean t).  A border blurred with
    ``sigma = softness / 2`` ramps from 16 % to 84 % over ``softness``:
    ``t = sigma^2 / (2 e^2) = softness^2 / (8 e^2)``.

    0 for no softness, or an edge length of 0 (a mesh without edges: nothing to blur).
    Raises ValueError for a negative or non-finite softness or edge length, and for a
    border wider than ``MAX_BLUR_EDGES`` edges: :func:`diffuse` needs about ``sqrt(8 t)``
    iterations, one per edge crossed, and stops at 2000."""
    softness = checks.number("The border softness", softness, 0.0)
    edge_length = checks.number("The edge length", edge_length, 0.0)
    if softness == 0.0 or edge_length == 0.0:
        return 0.0
    ratio = softness / edge_length  # not squared first: 1e-163 squared is 0
    if not ratio <= MAX_BLUR_EDGES:
        raise ValueError(f"A border {softness:g} wide is {ratio:.3g} edges of {edge_length:g} wide, "
                         f"more than {MAX_BLUR_EDGES:,}: no blur can cross it. Use a smaller softness")
    return ratio * ratio / 8.0


def diffuse(values, edges, t, *, tol=1e-6, max_iterations=2000):
    """Smooth per-vertex values (V,) or (V, C) on the mesh: the implicit diffusion step
    ``(I + t L) x = values``, ``L = D - A`` the graph Laplacian of ``edges`` (unit weights).

    Solved by conjugate gradients, all channels at once (``I + t L`` is symmetric positive
    definite), until the largest residual is below ``tol``: about ``sqrt(8 t)`` iterations,
    so the cost grows linearly with the width of the blur, where explicit neighbour
    averaging grows with its square.  ``I + t L`` is an M-matrix whose inverse has
    non-negative rows summing to 1: values in [0, 1] stay in [0, 1] and a monotone border
    stays monotone (up to ``tol``).  Vertices without edges keep their value."""
    x0 = np.array(values, dtype=np.float64)
    one = x0.ndim == 1
    b = np.ascontiguousarray(x0.reshape(len(x0), -1).T)  # (C, V)
    if t <= 0 or b.size == 0 or len(edges) == 0:
        return x0
    adj = _Adjacency(edges, b.shape[1])
    diag = 1.0 + t * adj.degree

    def apply(v):
        return v * diag - t * adj.sum(v)

    x = b.copy()
    r = b - apply(x)
    p = r.copy()
    rs = np.einsum("cv,cv->c", r, r)
    for _ in range(int(max_iterations)):
        if np.abs(r).max() < tol:
            break
        ap = apply(p)
        pap = np.einsum("cv,cv->c", p, ap)
        alpha = np.where(pap > 0, rs / np.where(pap > 0, pap, 1.0), 0.0)
        x += alpha[:, None] * p
        r -= alpha[:, None] * ap
        rs_new = np.einsum("cv,cv->c", r, r)
        p = r + np.where(rs > 0, rs_new / np.where(rs > 0, rs, 1.0), 0.0)[:, None] * p
        rs = rs_new
    out = np.ascontiguousarray(x.T)
    return out.ravel() if one else out


def soften(memberships, edges, t):
    """Soft zone memberships (V, 8) float32 from raw ones in [0, 1].

    Soft borders are made ON THE MESH (:func:`diffuse` with time ``t``, see
    :func:`diffusion_time`), not by a blur in UV space: the mesh's neighbours are
    neighbours on the skin, so the blur crosses UV seams without a discontinuity, never
    leaks into an unrelated UV island that happens to lie next to the zone in the UV
    layout, and its width is a distance on the skin whatever the UV layout's scale.  Each
    zone is then scaled back to its raw maximum, so softening blurs a small zone's border
    without dimming it.  Last, where zones overlap, the memberships are divided by their
    sum where it exceeds 1, so the 8 masks never sum to more than 1 (the paper clamps the
    blended weight to [0, 1]; masks that sum to at most 1 keep an expression from counting
    twice where two of its zones meet).
    """
    m = np.clip(np.nan_to_num(np.asarray(memberships, np.float64)), 0.0, 1.0)
    m = m.reshape(len(m), -1)
    top = m.max(axis=0) if len(m) else np.zeros(m.shape[1])
    soft = np.clip(diffuse(m, edges, t).reshape(m.shape), 0.0, 1.0)
    peak = soft.max(axis=0) if len(m) else top
    soft *= np.where(peak > 0, top / np.where(peak > 0, peak, 1.0), 0.0)
    np.clip(soft, 0.0, 1.0, out=soft)
    total = soft.sum(axis=1, keepdims=True)
    soft = np.where(total > 1.0, soft / np.where(total > 1.0, total, 1.0), soft)
    return soft.astype(_F)



def uv_overlap(uv, resolution=512):
    """How much of the UV layout is covered twice: ``sum of the triangles' UV areas /
    covered area - 1`` at ``resolution`` (0 for a layout without overlaps, up to
    rasterisation noise of about 1/R per unit of island border; 1 when two halves of a
    face are stacked, as mirrored UVs are).  ``uv`` (T, 3, 2)."""
    uv = np.asarray(uv, dtype=np.float64).reshape(-1, 3, 2)
    inside = np.all((uv >= 0.0) & (uv <= 1.0), axis=(1, 2))
    t = uv[inside]
    if len(t) == 0:
        return 0.0
    e1, e2 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
    _img, covered = rasterize(t, None, resolution)
    n = covered.sum()
    return float(area * resolution * resolution / n - 1.0) if n else 0.0
