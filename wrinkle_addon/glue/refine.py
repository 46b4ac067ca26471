# SPDX-License-Identifier: GPL-3.0-or-later
"""Adaptive refinement of the wrinkling regions (Zhang 2005 §3, Fig. 11), for every method.

Zhang refines where the wrinkles need resolution.  Each wrinkle source says which edges
are too long for its wrinkles (``WrinkleSource.refine_need``: the muscles' half cycles, the
wrinkle curves' furrows, the pattern layers' half cycles); ``core.refinement`` closes that
choice over the triangles and computes where the new points go; this module does each pass
in Blender:

1. read the mesh and every shape key, and the vertex normals of each;
2. bisect the chosen edges with bmesh (one cut each; a quad with all four edges split gets a
   2×2 grid, two adjacent ones a straight cut, one a pentagon), which interpolates UVs,
   shape keys, vertex groups and every other attribute, and keeps material indices; a
   triangle with a single split edge is then split from the new point to the opposite
   corner;
3. move the new points off the flat facets onto the smooth surface through the old
   vertices (Hermite midpoints, Coons centres), the mesh from its own positions and
   normals and each shape key from its own.

Passes repeat until the rule holds; each pass halves the edges that still break it.
"""

from dataclasses import dataclass

import bmesh
import numpy as np
from mathutils.kdtree import KDTree

from ..core import refinement
from . import meshio

MAX_PASSES = refinement.MAX_PASSES


@dataclass
class Result:
    passes: int
    message: str = ""


def _key_blocks(me):
    keys = me.shape_keys
    return list(keys.key_blocks) if keys is not None else []


def _read_shapes(me):
    """(K, N, 3) float64: the mesh positions, then every shape key's points."""
    n = len(me.vertices)
    out = [meshio.read_vectors(me, "position").astype(np.float64)]
    buf = np.empty(n * 3, np.float32)
    for kb in _key_blocks(me):
        kb.points.foreach_get("co", buf)
        out.append(buf.reshape(n, 3).astype(np.float64))
    return np.stack(out)


def _write_shapes(me, shapes):
    meshio.write_vectors(me, "position", shapes[0])
    for kb, co in zip(_key_blocks(me), shapes[1:]):
        kb.points.foreach_set("co", np.ascontiguousarray(co, dtype=np.float32).ravel())


def _close_single_splits(bm, n_old):
    """Split every triangle that kept one new point on a side (bmesh leaves it a 4-gon)
    from that point to the opposite corner."""
    bm.verts.index_update()
    bm.verts.ensure_lookup_table()
    todo = {}
    for v in bm.verts[n_old:]:
        for f in v.link_faces:
            if len(f.verts) == 4 and sum(w.index >= n_old for w in f.verts) == 1:
                todo[f] = v
    for f, v in todo.items():
        loop = next(lp for lp in f.loops if lp.vert is v)
        bmesh.utils.face_split(f, v, loop.link_loop_next.link_loop_next.vert)


def _merge_coincident(bm, n_old, split_pairs, rest):
    """Merge a new point that lands on an existing one.  A quad with one split edge stays a
    pentagon with a straight corner at the new point; when a later pass splits both halves
    of that edge, bmesh cuts the corner off as a triangle of no area, and the pass after
    puts a point a micrometre from another: a dark dot in renders.  After the points are
    placed, a new one within a hundredth of the split edges' median length of another is
    welded to it (their faces of no area go).  Returns whether any was."""
    if len(split_pairs) == 0:
        return False
    d = rest[split_pairs[:, 1]] - rest[split_pairs[:, 0]]
    tol = 1e-2 * float(np.median(np.sqrt(np.einsum("ij,ij->i", d, d))))
    bm.verts.ensure_lookup_table()
    tree = KDTree(len(bm.verts))
    for v in bm.verts:  # one insert a vertex: a pass's mesh, not a frame's
        tree.insert(v.co, v.index)
    tree.balance()
    weld = {}
    for v in bm.verts[n_old:]:
        for _co, j, dist in tree.find_range(v.co, tol):
            w = bm.verts[j]
            if w is not v and dist < tol and w not in weld and v not in weld.values():
                weld[v] = w
                break
    if weld:
        bmesh.ops.weld_verts(bm, targetmap=weld)
    return bool(weld)


def _bisect_pass(me, split_pairs, split_index):
    """One bisection pass over the edges ``split_index`` (``split_pairs`` their vertex pairs,
    from ``core.refinement.split_edges``); the new points placed smoothly."""
    n_old = len(me.vertices)
    corner, starts, sizes = meshio.read_polygons(me)
    shapes = _read_shapes(me)
    normals = refinement.vertex_normals(shapes, corner, starts, sizes)
    bm = bmesh.new()
    try:
        bm.from_mesh(me)
        bm.edges.ensure_lookup_table()
        chosen = [bm.edges[int(i)] for i in split_index]
        bmesh.ops.subdivide_edges(bm, edges=chosen, cuts=1, use_grid_fill=True,
                                  quad_corner_type="STRAIGHT_CUT")
        _close_single_splits(bm, n_old)
        bm.to_mesh(me)
    finally:
        bm.free()
    offsets = refinement.smooth_offsets(shapes, normals, n_old, meshio.read_edges(me), split_pairs)
    new = _read_shapes(me)
    new[:, n_old:] += offsets
    _write_shapes(me, new)
    me.update()
    bm = bmesh.new()
    try:
        bm.from_mesh(me)
        if _merge_coincident(bm, n_old, split_pairs, shapes[0]):
            bm.to_mesh(me)
            me.update()
    finally:
        bm.free()


def refine(face, need, max_vertices=1_000_000, progress=None):
    """Refine ``face`` until no edge is left that ``need(rest, edges)`` names (the union of
    the sources' rules, re-asked on the refined mesh after each pass).

    Returns a :class:`Result` whose message is set only when the rule is still broken
    (the vertex limit or the pass limit stopped it)."""
    me = face.data
    for i in range(MAX_PASSES + 1):
        rest = meshio.read_vectors(me, "position").astype(np.float64)
        edges = meshio.read_edges(me)
        split_needed = need(rest, edges)
        if len(split_needed) == 0:
            return Result(i)
        if i == MAX_PASSES:
            break
        if progress:
            progress(i)
        corner, starts, sizes = meshio.read_polygons(me)
        split, grid_quads = refinement.split_edges(rest, edges, corner, starts, sizes, split_needed)
        if len(rest) + len(split) + grid_quads > max_vertices:
            return Result(i, f"Stopped: refining further would exceed {max_vertices} vertices")
        _bisect_pass(me, edges[split], split)
    return Result(MAX_PASSES, f"Stopped after {MAX_PASSES} passes: {len(split_needed)} edges are still "
                              "longer than the wrinkles need")
