# SPDX-License-Identifier: GPL-3.0-or-later
"""Fine wrinkles over several body parts (Bando, Kuratate & Nishita 2002, §5.4).

"The divided body-part meshes share their boundary portion.  After wrinkles are
generated over one body part, the direction field and the height field over the shared
portion of the mesh are copied to the other body-part mesh.  Starting with this initial
state, wrinkles are generated over the other body part."

* :func:`shared_portion` finds the shared portion: the triangles of part B whose three
  corners lie on the corners of a triangle of part A (positions equal within a tolerance,
  both in one space), with the corner correspondence.
* :func:`copy_heights` copies A's height image over the shared triangles into B's texture
  space, at B's resolution, as the :class:`carve.CarveState` B is carved from: the copied
  heights; every pixel of the shared portion occupied (no new furrow starts there, it is
  carved already); and the copied furrows' pixels (height below 1) labelled as one earlier
  furrow, id 0, so B's new furrows stop where they meet them (§5.2, step 4).
* :func:`copy_field` copies A's direction vectors at the shared corners into B's texture
  space: through the affine map between each pair of matching triangles, the direction
  turned and the length (the magnitude m, a length on the skin) kept.

Both parts' UV maps may differ in scale, offset and rotation; a mirrored one (opposite
handedness) also maps right, but then the second field (the first turned by an angle)
turns the other way on the skin.
"""

import numpy as np

from .. import raster
from .carve import CarveState

_F = np.float32


def match_points(a, b, tol):
    """For each point of ``b`` (Nb, 3) the index of a point of ``a`` (Na, 3) within ``tol``
    of it in every coordinate, or -1; where several qualify the nearest wins.  Hashed on a
    grid of cell ``tol`` and looked up in the 2^3 cells around the point's nearest grid
    corner, so every pair within ``tol / 2`` is found (parts that share vertices by
    construction differ by rounding only).  A cell is assumed to hold at most two of
    ``a``'s points (points closer than ``tol`` are rare in a mesh)."""
    a = np.asarray(a, np.float64).reshape(-1, 3)
    b = np.asarray(b, np.float64).reshape(-1, 3)
    out = np.full(len(b), -1, np.int64)
    if len(a) == 0 or len(b) == 0:
        return out
    if not tol > 0:
        raise ValueError(f"tol must be > 0, got {tol}")
    origin = np.minimum(a.min(axis=0), b.min(axis=0))
    ca = np.floor((a - origin) / tol).astype(np.int64)
    cb = np.floor((b - origin) / tol - 0.5).astype(np.int64)  # the lower of the two cells per axis
    span = np.maximum(ca.max(axis=0), cb.max(axis=0)) + 3

    def key(c):
        return (c[:, 0] * span[1] + c[:, 1]) * span[2] + c[:, 2]

    ka = key(ca)
    order = np.argsort(ka, kind="stable")
    ka_sorted = ka[order]
    best = np.full(len(b), np.inf)
    for dx in (0, 1):
        for dy in (0, 1):
            for dz in (0, 1):  # 8 neighbour cells, each a vectorised lookup
                k = key(np.maximum(cb + (dx, dy, dz), 0))
                lo = np.searchsorted(ka_sorted, k, side="left")
                hi = np.searchsorted(ka_sorted, k, side="right")
                # a cell holds one point unless points are closer than tol: try the first two
                for off in (0, 1):
                    j = lo + off
                    ok = j < hi
                    cand = order[np.where(ok, j, 0)]
                    d = np.abs(a[cand] - b).max(axis=1)
                    take = ok & (d <= tol) & (d < best)
                    out[take] = cand[take]
                    best[take] = d[take]
    return out


def shared_portion(pos_a, tris_a, pos_b, tris_b, tol):
    """The triangles two parts share: ``(ta, tb, corner)``, with ``ta`` (S,) triangles of
    ``tris_a`` (Ta, 3), ``tb`` (S,) of ``tris_b`` (Tb, 3), and ``corner`` (S, 3): corner k of
    triangle ``tb[i]`` lies on corner ``corner[i, k]`` of ``ta[i]``.  Vertices match when
    their positions (``pos_a`` (Na, 3), ``pos_b`` (Nb, 3), in one space) are within ``tol``
    (:func:`match_points`)."""
    tris_a = np.asarray(tris_a, np.int64).reshape(-1, 3)
    tris_b = np.asarray(tris_b, np.int64).reshape(-1, 3)
    empty = (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 3), np.int64))
    if len(tris_a) == 0 or len(tris_b) == 0:
        return empty
    m = match_points(pos_a, pos_b, tol)[tris_b]  # (Tb, 3) A vertices under B's corners
    full = np.flatnonzero((m >= 0).all(axis=1))
    if len(full) == 0:
        return empty
    na = int(max(tris_a.max(), m.max())) + 1
    sa, sb = np.sort(tris_a, axis=1), np.sort(m[full], axis=1)
    ka = (sa[:, 0] * na + sa[:, 1]) * na + sa[:, 2]
    kb = (sb[:, 0] * na + sb[:, 1]) * na + sb[:, 2]
    order = np.argsort(ka, kind="stable")
    pos = np.searchsorted(ka[order], kb)
    hit = (pos < len(ka)) & (ka[order][np.minimum(pos, len(ka) - 1)] == kb)
    ta = order[np.minimum(pos, len(ka) - 1)][hit]
    tb = full[hit]
    # corner k of B's triangle: the corner of A's triangle on the same vertex
    corner = np.argmax(tris_a[ta][:, None, :] == m[tb][:, :, None], axis=2)
    return ta, tb, corner


def sample_bilinear(image, uv):
    """``image`` (R, R) sampled at ``uv`` (K, 2) with bilinear interpolation between pixel
    centres (``core.raster``'s pixel order), clamped at the borders."""
    image = np.asarray(image, np.float64)
    R = image.shape[0]
    x = np.clip(np.asarray(uv, np.float64)[:, 0] * R - 0.5, 0.0, R - 1.0)
    y = np.clip(np.asarray(uv, np.float64)[:, 1] * R - 0.5, 0.0, R - 1.0)
    last = max(R - 2, 0)
    x0, y0 = np.minimum(x.astype(np.int64), last), np.minimum(y.astype(np.int64), last)
    x1, y1 = np.minimum(x0 + 1, R - 1), np.minimum(y0 + 1, R - 1)
    fx, fy = x - x0, y - y0
    top = image[y0, x0] * (1 - fx) + image[y0, x1] * fx
    bottom = image[y1, x0] * (1 - fx) + image[y1, x1] * fx
    return top * (1 - fy) + bottom * fy


def copy_heights(src_height, src_uv, dst_uv, resolution):
    """B's initial :class:`CarveState` (``resolution`` square) from A's height image
    ``src_height`` (Rs, Rs) (1 = no furrow) over the shared triangles, whose corner UVs are
    ``src_uv`` (S, 3, 2) in A and ``dst_uv`` (S, 3, 2) in B (matching corners in the same
    order).  Each of B's pixels on a shared triangle takes A's height at the same point of
    the skin (the affine map between the two triangles, bilinear in A's image)."""
    R = int(resolution)
    src_uv = np.asarray(src_uv, np.float64).reshape(-1, 3, 2)
    dst_uv = np.asarray(dst_uv, np.float64).reshape(-1, 3, 2)
    if src_uv.shape != dst_uv.shape:
        raise ValueError(f"the shared triangles' UVs differ in shape: {src_uv.shape} and {dst_uv.shape}")
    where, covered = raster.rasterize(dst_uv, src_uv, R)  # A's UV at each of B's pixels
    height = np.ones((R, R), _F)
    if covered.any():
        height[covered] = np.clip(sample_bilinear(src_height, where[covered]), 0.0, 1.0)
    labels = np.where(covered & (height < 1.0), 0, -1).astype(np.int32)
    return CarveState(height=height, occupancy=covered.copy(), labels=labels)


def copy_field(src_uv, dst_uv, src_field):
    """A's direction vectors ``src_field`` (S, 3, 2) at the corners of the shared triangles
    as B's (S, 3, 2): each turned by the linear part of the affine map from A's triangle
    ``src_uv`` (S, 3, 2) to B's ``dst_uv`` (S, 3, 2), its length kept.  Triangles with no
    area in either texture space copy nothing (zero vectors)."""
    src_uv = np.asarray(src_uv, np.float64).reshape(-1, 3, 2)
    dst_uv = np.asarray(dst_uv, np.float64).reshape(-1, 3, 2)
    f = np.asarray(src_field, np.float64).reshape(-1, 3, 2)
    es = np.stack([src_uv[:, 1] - src_uv[:, 0], src_uv[:, 2] - src_uv[:, 0]], axis=2)  # (S, 2, 2) columns
    ed = np.stack([dst_uv[:, 1] - dst_uv[:, 0], dst_uv[:, 2] - dst_uv[:, 0]], axis=2)
    det_s = np.linalg.det(es)
    det_d = np.linalg.det(ed)
    ok = (np.abs(det_s) > 1e-18) & (np.abs(det_d) > 1e-18)
    inv = np.linalg.inv(np.where(ok[:, None, None], es, np.eye(2)))
    lin = ed @ inv  # (S, 2, 2): A's UV -> B's UV
    g = np.einsum("sij,skj->ski", lin, f)
    length = np.linalg.norm(f, axis=2, keepdims=True)
    glen = np.linalg.norm(g, axis=2, keepdims=True)
    g = g * np.where(glen > 1e-300, length / np.where(glen > 1e-300, glen, 1.0), 0.0)
    return np.where(ok[:, None, None], g, 0.0)
