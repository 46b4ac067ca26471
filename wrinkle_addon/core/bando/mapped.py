# SPDX-License-Identifier: GPL-3.0-or-later
"""The body-part mesh mapped to texture space (Bando, Kuratate & Nishita 2002, §4).

The paper works on a mesh whose every vertex has one texture coordinate.  A Blender mesh
keeps its UVs per corner, so a vertex on a UV seam has several.  :func:`mapped_mesh` splits
such vertices: each distinct (vertex, UV) pair becomes one *mapped vertex*, and the
triangles index those.  UV islands are then disconnected, as the paper's body parts are
(§5.4).  Values computed on the mapped mesh go back to the mesh's vertices by averaging
the copies of a vertex (:meth:`MappedMesh.to_vertices`).
"""

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class MappedMesh:
    """``uv`` (U, 2) float64, ``tris`` (T, 3) int64 into ``uv``, ``vert_of`` (U,) int64: the
    mesh vertex of each mapped vertex, and ``n_verts`` the mesh's vertex count."""

    uv: np.ndarray
    tris: np.ndarray
    vert_of: np.ndarray
    n_verts: int

    def positions(self, positions):
        """The (U, 3) positions of the mapped vertices from the mesh's (N, 3)."""
        return np.asarray(positions)[self.vert_of]

    def to_vertices(self, values, verts=None):
        """Per mapped vertex values (U,) or (U, k) to the mesh's vertices, averaging the
        copies of a seam vertex; with ``verts`` (sorted mesh vertex ids), only those rows
        (every one must have a copy).  Vertices without a copy get 0."""
        values = np.asarray(values, dtype=np.float64)
        flat = values.reshape(len(values), -1)
        count = np.bincount(self.vert_of, minlength=self.n_verts).astype(np.float64)
        sums = np.stack([np.bincount(self.vert_of, weights=flat[:, k], minlength=self.n_verts)
                         for k in range(flat.shape[1])], axis=1)
        out = sums / np.maximum(count, 1.0)[:, None]
        if verts is not None:
            out = out[verts]
        return out.reshape((len(out),) + values.shape[1:])


def mapped_mesh(tris, corner_uv, n_verts):
    """The mapped mesh of triangles ``tris`` (T, 3) of mesh vertices whose corners have the
    UVs ``corner_uv`` (T, 3, 2).  A (vertex, UV) pair is one mapped vertex when its UV is
    equal bit for bit, as Blender stores a vertex's UV on both sides of an unseamed edge."""
    tris = np.asarray(tris, dtype=np.int64).reshape(-1, 3)
    uv = np.ascontiguousarray(corner_uv, dtype=np.float32).reshape(-1, 2)
    if len(uv) != tris.size:
        raise ValueError(f"{len(uv)} corner UVs for {len(tris)} triangles (need {tris.size})")
    keys = np.stack([tris.ravel(), uv.view(np.int64).ravel()], axis=1)  # (vertex, UV bits)
    unique, inverse = np.unique(keys, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    corner = np.zeros(len(unique), np.int64)
    corner[inverse] = np.arange(len(inverse))  # any corner of each: their UVs are equal
    return MappedMesh(uv=uv[corner].astype(np.float64), tris=inverse.reshape(-1, 3),
                      vert_of=unique[:, 0].copy(), n_verts=int(n_verts))


def degenerate_uv(corner_uv):
    """(T,) bool: the triangles whose corners' UVs ``corner_uv`` (T, 3, 2) span no area (at
    one point or on a line, to a relative 1e-12 of their squared UV edge lengths, the
    test :func:`field.shrinkage_plan` skips a corner by).  A new UV map that was never
    unwrapped, or one scaled to a point, has only such triangles: no texel of the fine
    wrinkles' images and no direction across a wrinkle curve lies on them."""
    uv = np.asarray(corner_uv, np.float64).reshape(-1, 3, 2)
    a, b = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    det = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    scale = np.einsum("ij,ij->i", a, a) + np.einsum("ij,ij->i", b, b)
    return ~(np.abs(det) > 1e-12 * scale)  # NaN UVs count as degenerate too


def bowtie_vertices(tris, n_verts):
    """The vertices (K,) sorted where two or more fans of triangles ``tris`` (T, 3) meet
    without sharing an edge there (a "bow-tie": non-manifold at the vertex).

    A vertex with ``k`` triangle corners around it, forming ``c`` open fans (each a run of
    triangles joined by shared edges), has ``k + c`` distinct edges; a closed fan (the
    vertex inside the surface) has as many edges as corners.  So ``edges - corners`` is
    the number of open fans, and 2 or more is a bow-tie.  (Two closed fans touching at a
    vertex, two cones apex to apex, are not found: no face is made that way.)  Triangles
    with a repeated vertex are left out."""
    t = np.asarray(tris, np.int64).reshape(-1, 3)
    n = int(n_verts)
    t = t[(t[:, 0] != t[:, 1]) & (t[:, 1] != t[:, 2]) & (t[:, 2] != t[:, 0])]
    if len(t) == 0 or n == 0:
        return np.zeros(0, np.int64)
    a = np.concatenate([t[:, 0], t[:, 1], t[:, 2]])
    b = np.concatenate([t[:, 1], t[:, 2], t[:, 0]])
    edges = np.unique(np.minimum(a, b) * n + np.maximum(a, b))
    n_edges = np.bincount(np.concatenate([edges // n, edges % n]), minlength=n)
    n_corners = np.bincount(t.ravel(), minlength=n)
    return np.flatnonzero(n_edges - n_corners >= 2)
