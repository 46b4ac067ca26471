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
