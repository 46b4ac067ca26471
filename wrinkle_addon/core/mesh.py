# SPDX-License-Identifier: GPL-3.0-or-later
"""Mesh helpers on plain arrays: incidence, edge lengths, normals, fan triangulation."""

import numpy as np

_EPS = 1e-20


def fan_triangles(corner_verts, face_starts, face_sizes):
    """Triangulate polygons (n-gons included) as fans: (T, 3) int32 vertex indices.

    ``corner_verts`` lists each face's corners, face ``f`` occupying
    ``corner_verts[face_starts[f] : face_starts[f] + face_sizes[f]]``.
    Faces with fewer than 3 corners produce no triangle.
    """
    face_starts = np.asarray(face_starts, dtype=np.int64)
    face_sizes = np.asarray(face_sizes, dtype=np.int64)
    n_tri = np.maximum(face_sizes - 2, 0)
    owner = np.repeat(np.arange(len(face_sizes)), n_tri)
    if len(owner) == 0:
        return np.zeros((0, 3), dtype=np.int32)
    first = np.cumsum(n_tri) - n_tri
    k = np.arange(len(owner)) - first[owner]  # triangle number inside its face
    base = face_starts[owner]
    tris = np.stack(
        [corner_verts[base], corner_verts[base + k + 1], corner_verts[base + k + 2]], axis=1
    )
    return tris.astype(np.int32)


def edge_lengths(positions, edges):
    d = positions[edges[:, 1]] - positions[edges[:, 0]]
    return np.sqrt(np.einsum("ij,ij->i", d, d))


def vertex_incidence(edges, n_verts):
    """CSR incidence of vertices to edges: ``(offsets, edge_ids)``.

    The edges incident to vertex ``v`` are ``edge_ids[offsets[v]:offsets[v+1]]``.
    """
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    verts = edges.T.ravel()  # all first end points, then all second ones
    ids = np.tile(np.arange(len(edges)), 2)
    order = np.argsort(verts, kind="stable")
    counts = np.bincount(verts, minlength=n_verts)
    offsets = np.zeros(n_verts + 1, dtype=np.int64)
    np.cumsum(counts, out=offsets[1:])
    return offsets, ids[order]


def gather_incident(offsets, values, verts):
    """For each vertex in ``verts``, the CSR entries: ``(row, entry_index)``.

    ``row`` indexes ``verts``; ``values[entry_index]`` are the incident items.
    """
    verts = np.asarray(verts, dtype=np.int64)
    starts = offsets[verts]
    counts = offsets[verts + 1] - starts
    row = np.repeat(np.arange(len(verts)), counts)
    first = np.cumsum(counts) - counts
    entry = starts[row] + (np.arange(len(row)) - first[row])
    return row, values[entry] if len(entry) else values[:0]


def vertex_normals(positions, tris, n_verts):
    """Area-weighted vertex normals from triangles; zero where undefined."""
    out = np.zeros((n_verts, 3), dtype=positions.dtype)
    if len(tris) == 0:
        return out
    p0 = positions[tris[:, 0]]
    a = positions[tris[:, 1]] - p0
    b = positions[tris[:, 2]] - p0
    # the cross product written out: ~2x faster than np.cross on (T, 3) arrays
    fn = np.empty_like(a)
    fn[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    fn[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    fn[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    idx = tris.ravel()
    for c in range(3):
        out[:, c] = np.bincount(idx, weights=np.repeat(fn[:, c], 3), minlength=n_verts)
    length = np.sqrt(np.einsum("ij,ij->i", out, out))
    inv = np.where(length > _EPS, 1.0 / np.maximum(length, _EPS), 0.0).astype(out.dtype)
    out *= inv[:, None]
    return out
