# SPDX-License-Identifier: GPL-3.0-or-later
"""Adaptive refinement of the wrinkling regions (Zhang 2005 §3): which edges a pass splits
besides the ones asked for, and where the new points go.  Pure NumPy; ``glue/refine.py``
does the splitting.  Which edges are too long is each method's rule: the muscles' half
cycles (``core.muscles.resolution``), the wrinkle curves' furrows
(``core.bando.curves.edge_limits``), the pattern layers' half cycles
(``core.patterns.functions.half_cycle``).

**Only as much as needed.**  A refinement pass bisects the edges that break the rule and
nothing else, closed only over the triangles' longest edges (:func:`split_edges`); the
passes repeat until the rule holds, so an edge of ``k`` limits ends in about ``k`` to ``2k``
pieces, and each split adds one vertex (no whole faces).  bmesh splits the faces around
them by its patterns: a triangle in two (the new point joined to the opposite corner), into
a triangle and a quad, or into four; a quad with one split edge stays a pentagon (a fan
from the new point would add diagonals longer than the edge it split), with two opposite
ones it becomes two quads, with two adjacent ones a straight cut between the new points,
with all four a 2×2 grid.

**Smooth placement.**  A new point on the edge ``(p0, p1)`` goes on the cubic Hermite curve
between the end points whose tangents are the edge vector projected on each end's tangent
plane, ``t_i = d − (d·n_i) n_i`` with ``d = p1 − p0`` and ``n_i`` the vertex normals; at the
midpoint that is ``(p0 + p1)/2 + (t0 − t1)/8`` (:func:`hermite_offsets`).  These are the
boundary curves of Vlachos et al.'s curved PN triangles, so the points lie on one smooth
surface through the old vertices instead of on the flat facets; on a sphere of radius R the
error of a midpoint is O(|d|⁴/R³), against the facet's |d|²/(8R), and a plane stays exactly
planar.  The centre of a quad split into a grid goes where the bilinear Coons patch of its
four boundary curves puts it: the facet's centre plus twice the mean offset of its four edge
midpoints (:func:`centre_offsets`).  Shape keys get the same placement from their own
positions and normals.
"""

import numpy as np

from . import mesh

MAX_PASSES = 20  # bisection passes: each halves the edges that still break the rule


def corner_edges(corner_verts, face_starts, face_sizes, edges, n_verts):
    """The edge (index into ``edges``) from each corner to the next corner of its face, or -1."""
    corner_verts = np.asarray(corner_verts, dtype=np.int64)
    starts = np.asarray(face_starts, dtype=np.int64)
    sizes = np.asarray(face_sizes, dtype=np.int64)
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    owner = np.repeat(np.arange(len(sizes)), sizes)
    k = np.arange(len(corner_verts)) - starts[owner]
    nxt = corner_verts[starts[owner] + (k + 1) % np.maximum(sizes[owner], 1)]
    n = max(int(n_verts), 1)
    key = np.minimum(corner_verts, nxt) * n + np.maximum(corner_verts, nxt)
    ekey = np.minimum(edges[:, 0], edges[:, 1]) * n + np.maximum(edges[:, 0], edges[:, 1])
    order = np.argsort(ekey)
    pos = np.searchsorted(ekey[order], key)
    pos = np.minimum(pos, max(len(ekey) - 1, 0))
    if len(ekey) == 0:
        return np.full(len(key), -1, np.int64)
    return np.where(ekey[order][pos] == key, order[pos], -1)


def split_edges(rest, edges, corner_verts, face_starts, face_sizes, need):
    """The edges to bisect in a pass, sorted, and how many quads get all four edges split
    (each adds a centre vertex), for the vertex budget.

    ``need`` plus Rivara's closure over the triangles: a triangle with a split edge gets its
    longest edge split too (longest-edge bisection keeps the angles bounded), unless that
    edge borders a quad or an n-gon; over quads the closure would cross into the next quad
    every pass and never settle.  A median from a bisected edge to the opposite corner is
    never longer than the triangle's longest other edge, so no pass adds an edge longer than
    those it split."""
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    mark = np.zeros(len(edges), bool)
    mark[np.asarray(need, dtype=np.int64)] = True
    sizes = np.asarray(face_sizes, dtype=np.int64)
    starts = np.asarray(face_starts, dtype=np.int64)
    ce = corner_edges(corner_verts, starts, sizes, edges, len(np.asarray(rest).reshape(-1, 3)))
    # Rivara's closure, over the triangles only: a triangle with a split edge gets its longest
    # split too, unless that edge borders another kind of face
    owner = np.repeat(np.arange(len(sizes)), sizes)
    other = np.zeros(len(edges), bool)
    other[ce[(sizes[owner] != 3) & (ce >= 0)]] = True
    tri = np.flatnonzero(sizes == 3)
    t_edges = ce[starts[tri][:, None] + np.arange(3)]
    t_edges = t_edges[(t_edges >= 0).all(axis=1)]
    if len(t_edges) and mark.any():
        length = mesh.edge_lengths(np.asarray(rest, dtype=np.float64).reshape(-1, 3), edges)[t_edges]
        rows = np.arange(len(t_edges))
        longest = t_edges[rows, np.argmax(length, axis=1)]
        while True:  # over propagation steps along the longest-edge paths, a handful
            grow = longest[mark[t_edges].any(axis=1) & ~mark[longest] & ~other[longest]]
            if not len(grow):
                break
            mark[grow] = True
    quad = np.flatnonzero(sizes == 4)
    q_edges = ce[starts[quad][:, None] + np.arange(4)]
    grid_quads = int(((q_edges >= 0) & mark[np.maximum(q_edges, 0)]).all(axis=1).sum())
    return np.flatnonzero(mark), grid_quads


def hermite_offsets(positions, normals, pairs):
    """Offset of the Hermite midpoint of each edge ``pairs`` (M, 2) from the straight
    midpoint: ``(t0 − t1)/8`` with ``t_i = d − (d·n_i) n_i``, ``d = p1 − p0``.

    ``positions`` and ``normals`` are (N, 3) or a stack (K, N, 3) (one per shape key); the
    result is (M, 3) or (K, M, 3).  Unit normals are expected; a zero normal leaves the
    tangent as the edge itself (no bend from that end).
    """
    pairs = np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
    p = np.asarray(positions, dtype=np.float64)
    n = np.asarray(normals, dtype=np.float64)
    a, b = pairs[:, 0], pairs[:, 1]
    d = p[..., b, :] - p[..., a, :]
    n0, n1 = n[..., a, :], n[..., b, :]
    # t0 - t1 = (d·n1) n1 - (d·n0) n0
    return ((d * n1).sum(-1)[..., None] * n1 - (d * n0).sum(-1)[..., None] * n0) / 8.0


def centre_offsets(edge_offsets, members, owner, n_centres):
    """Offsets (.., C, 3) of grid-quad centres: twice the mean of the offsets of the edge
    midpoints around each (the bilinear Coons patch of the four boundary curves at its
    centre).  ``members`` index ``edge_offsets``'s rows (axis -2) and ``owner`` says which
    centre each belongs to."""
    members = np.asarray(members, dtype=np.int64)
    owner = np.asarray(owner, dtype=np.int64)
    rows = np.moveaxis(np.asarray(edge_offsets, dtype=np.float64)[..., members, :], -2, 0)
    total = np.zeros((n_centres,) + rows.shape[1:])
    np.add.at(total, owner, rows)
    count = np.bincount(owner, minlength=n_centres).astype(np.float64)
    total = np.moveaxis(total, 0, -2)
    return 2.0 * total / np.maximum(count, 1.0)[:, None]


def new_vertex_parents(n_old, edges_after, split):
    """Match every new vertex (index >= ``n_old``) of the mesh after a pass to what made it.

    ``edges_after`` (E', 2) are the refined mesh's edges, ``split`` (M, 2) the end points of
    the edges that were bisected.  Returns ``(parent, centre, members, owner)``: ``parent``
    (V,) the row of ``split`` whose midpoint each new vertex is, or -1; ``centre`` the new
    vertices that are no midpoint (grid-quad centres), and for those, the pairs
    ``members``/``owner`` of (index of a neighbouring midpoint in ``split``, row in
    ``centre``).  A midpoint is the new vertex joined by edges to both ends of its edge."""
    e = np.asarray(edges_after, dtype=np.int64).reshape(-1, 2)
    split = np.asarray(split, dtype=np.int64).reshape(-1, 2)
    n_new = int(e.max(initial=n_old - 1)) + 1 - n_old
    parent = np.full(max(n_new, 0), -1, np.int64)
    empty = np.zeros(0, np.int64)
    if n_new <= 0:
        return parent, empty, empty, empty
    old = e < n_old
    mixed = old[:, 0] ^ old[:, 1]
    o = np.where(old[:, 0], e[:, 0], e[:, 1])[mixed]
    v = np.where(old[:, 0], e[:, 1], e[:, 0])[mixed] - n_old
    # candidate parents: every pair of old neighbours of the same new vertex
    order = np.argsort(v, kind="stable")
    v, o = v[order], o[order]
    first = np.searchsorted(v, v)
    rank = np.arange(len(v)) - first
    degree = np.bincount(v, minlength=n_new)
    width = int(degree.max(initial=0))
    table = np.full((n_new, max(width, 1)), -1, np.int64)
    table[v, rank] = o
    n = max(int(n_old), 1)
    skey = np.minimum(split[:, 0], split[:, 1]) * n + np.maximum(split[:, 0], split[:, 1])
    sorder = np.argsort(skey)
    for i in range(width):  # over neighbour slots (a handful), not vertices
        for j in range(i + 1, width):
            a, b = table[:, i], table[:, j]
            ok = (a >= 0) & (b >= 0) & (parent < 0)
            key = np.minimum(a, b) * n + np.maximum(a, b)
            pos = np.minimum(np.searchsorted(skey[sorder], key), max(len(skey) - 1, 0))
            if len(skey):
                hit = ok & (skey[sorder][pos] == key)
                parent[hit] = sorder[pos][hit]
    centre = np.flatnonzero(parent < 0)
    # the centres' neighbouring midpoints
    both_new = ~old[:, 0] & ~old[:, 1]
    x, y = e[both_new, 0] - n_old, e[both_new, 1] - n_old
    slot = np.full(n_new, -1, np.int64)
    slot[centre] = np.arange(len(centre))
    xs, ys = np.concatenate([x, y]), np.concatenate([y, x])
    keep = (slot[xs] >= 0) & (parent[ys] >= 0)
    return parent, centre, parent[ys[keep]], slot[xs[keep]]


def smooth_offsets(positions, normals, n_old, edges_after, split):
    """Offsets (.., V, 3) that move the V new vertices of a pass from where a straight split
    puts them onto the smooth surface through the old vertices: Hermite midpoints on the
    bisected edges, Coons centres in grid quads (module doc).  ``positions``/``normals`` are
    the old vertices' (N, 3), or stacks (K, N, 3) for shape keys."""
    split = np.asarray(split, dtype=np.int64).reshape(-1, 2)
    parent, centre, members, owner = new_vertex_parents(n_old, edges_after, split)
    mids = hermite_offsets(positions, normals, split)
    out = np.zeros(mids.shape[:-2] + (len(parent), 3))
    hit = parent >= 0
    out[..., hit, :] = mids[..., parent[hit], :]
    if len(centre):
        out[..., centre, :] = centre_offsets(mids, members, owner, len(centre))
    return out


def vertex_normals(positions, corner_verts, face_starts, face_sizes):
    """Unit vertex normals (N, 3), or (K, N, 3) for a stack of positions (shape keys)."""
    p = np.asarray(positions, dtype=np.float64)
    tris = mesh.fan_triangles(np.asarray(corner_verts), face_starts, face_sizes)
    if p.ndim == 3:
        return np.stack([mesh.vertex_normals(k, tris, k.shape[0]) for k in p])
    return mesh.vertex_normals(p, tris, len(p))
