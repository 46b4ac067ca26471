# SPDX-License-Identifier: GPL-3.0-or-later
"""Fine-scale wrinkles on a face (Bando, Kuratate & Nishita 2002, §5 and §7): the two
direction fields, the carving of their height images, and the per-frame shrinkage across
each field that modulates them.

* :func:`uv_directions` turns directions given on the skin (3-D vectors at vertices, as an
  artist sets them on selected vertices) into the texture-space vectors of §5.1.
* :func:`carve_pair` carves both height images: the second field is the first rotated by
  an angle (the paper's two directions of Fig. 1), each with its own seed.
* :func:`plan` / :func:`shrinkages` measure, per frame, the shrinkage ``s`` (eq. 4) across
  each field at every mesh vertex; the shader scales each height image by ``M(s)`` (eq. 5) of its own
  field's shrinkage.  A vertex on a UV seam takes the value of one of its copies.
* :func:`vertex_slots` lays a plan out per vertex, as the face's Geometry Nodes tree reads it
  (``glue.bando.fine_tree``): Blender computes the frames' shrinkage itself, and
  :func:`slot_shrinkages` is the line-by-line NumPy transcription of that tree.
"""

import numpy as np

from .. import raster
from . import carve, field


def uv_directions(positions, uv, tris, vectors):
    """Skin directions (U, 3) at the mapped vertices to texture-space vectors (U, 2) of the
    same length measured on the skin.  Per triangle the UV -> surface map is
    ``J = [s_u T, c T + s_v B]`` (``raster.uv_jacobian``); a 3-D vector ``v`` maps to the
    UV vector solving ``J x = (v.T) T + (v.B) B`` (its part in the triangle's plane), then
    rescaled to the UV length of a skin length |v|; triangles are area-weighted at the
    vertices."""
    positions = np.asarray(positions, np.float64)
    t = np.asarray(tris, np.int64).reshape(-1, 3)
    corner_uv = np.asarray(uv, np.float64)[t].reshape(-1, 2)
    frame, tan, bit, _g, area = raster.uv_frames(positions[t].reshape(-1, 3), corner_uv)
    su, c, sv = frame.T
    ok = (su > 0) & (sv > 0)
    n = len(positions)
    out = np.zeros((n, 2))
    weight = np.zeros(n)
    v = np.asarray(vectors, np.float64)
    for k in range(3):  # the triangle's three corners
        vk = v[t[:, k]]
        a, b = np.einsum("ij,ij->i", vk, tan), np.einsum("ij,ij->i", vk, bit)
        dv = np.where(ok, b / np.where(ok, sv, 1.0), 0.0)
        du = np.where(ok, (a - c * dv) / np.where(ok, su, 1.0), 0.0)
        w = np.where(ok, area, 0.0)
        np.add.at(out, t[:, k], np.stack([du, dv], 1) * w[:, None])
        np.add.at(weight, t[:, k], w)
    out /= np.where(weight > 0, weight, 1.0)[:, None]
    # keep the skin length: the artist's magnitude m is on the skin
    uv_len = np.linalg.norm(out, axis=1)
    skin_len = np.linalg.norm(v, axis=1)
    return out * np.where(uv_len > 1e-12, skin_len / np.where(uv_len > 1e-12, uv_len, 1.0), 0.0)[:, None]


def carve_pair(uv, tris, field1, angle, resolution, seed=0, progress=None, held2=None, initial=(None, None)):
    """The two height images (R, R) float32 of §5 (1 = no furrow): ``field1`` (U, 2) and
    ``field1`` rotated by ``angle`` (radians), carved with seeds ``seed`` and ``seed + 1``.
    ``progress(i)`` is called before each.  For a part carved on from another (§5.4,
    ``core.bando.parts``): ``held2`` = (vertices (K,), vectors (K, 2)), the second field
    copied there in place of the rotated one, and ``initial`` the two images' initial
    states.  Returns ``(results, field2)``."""
    field2 = field.rotate(field1, angle)
    if held2 is not None:
        field2[held2[0]] = held2[1]
    out = []
    for i, (f, s, start) in enumerate(((field1, seed, initial[0]), (field2, seed + 1, initial[1]))):
        if progress is not None:
            progress(i)
        out.append(carve.carve(uv, tris, f, resolution, seed=s, initial=start))
    return out, field2


def plan(mapped, rest, field1, field2):
    """The per-frame shrinkage plan of both fields (U, 2) on the mapped mesh of a face at
    rest (N, 3): a :class:`field.EdgeSlots` whose rows are, per field, one copy of each mesh
    vertex (-1 for vertices in no triangle)."""
    pos = mapped.positions(np.asarray(rest, np.float64))
    rep = np.full(mapped.n_verts, -1, np.int64)
    rep[mapped.vert_of] = np.arange(len(mapped.vert_of))  # any one copy of each vertex
    parts = [(field.shrinkage_plan(mapped.uv, mapped.tris, f, pos), rep, mapped.vert_of)
             for f in (field1, field2)]
    return field.edge_slots(parts, mapped.n_verts)


def shrinkages(fine_plan, skin, out=None):
    """The frame's shrinkage across each field (2, N) float32 at the mesh's vertices, from
    the skin (N, 3) float32, into ``out`` (2, N) float32 when given; 0 at vertices in no
    triangle.  Both fields in one pass over the edges they share.  Equal to
    :func:`field.shrinkage` at each vertex's copy (tested)."""
    flat = None if out is None else out.reshape(-1)
    return field.edge_slot_shrinkage(fine_plan, skin, flat).reshape(2, -1)


class VertexSlots:
    """A :func:`plan` laid out per mesh vertex for the face's Geometry Nodes tree: for field
    ``f`` (0, 1) and slot ``j`` (0..3), ``far[f, j]`` (N,) int32 the vertex at the far end of
    the slot's edge and ``coef[f, j]`` (N,) float32 its coefficient (``a'`` or ``b'`` of
    eq. 4; slots 0, 1 are one side of the vertex, 2, 3 the other); ``share[f]`` (N,)
    float32, 1 where the vertex has a side, 0 where ``s = 0`` (no direction, or in no
    triangle)."""

    __slots__ = ("far", "coef", "share")

    def __init__(self, far, coef, share):
        self.far, self.coef, self.share = far, coef, share


def vertex_slots(fine_plan):
    """The :class:`VertexSlots` of a :func:`plan`: each slot's edge as the vertex at its far
    end, the coefficients and shares as the plan holds them (float32, so the tree computes
    exactly what :func:`shrinkages` does)."""
    n = fine_plan.n_verts
    rows = np.asarray(fine_plan.offsets)
    if len(rows) != 3 or rows[1] != n or rows[2] != 2 * n:
        raise ValueError("vertex_slots needs a fine-wrinkle plan: two fields of one row per vertex")
    edge = fine_plan.slot_edge.reshape(4, 2, n).transpose(1, 0, 2)  # (field, slot, vertex)
    a, b = fine_plan.ends[0][edge], fine_plan.ends[1][edge]
    far = np.where(a == np.arange(n), b, a).astype(np.int32)
    coef = np.ascontiguousarray(fine_plan.slot_coef.reshape(4, 2, n).transpose(1, 0, 2), np.float32)
    share = np.where(fine_plan.none, 0.0, fine_plan.share).reshape(2, n).astype(np.float32)
    return VertexSlots(np.ascontiguousarray(far), coef, share)


def slot_shrinkages(slots, skin):
    """Both fields' shrinkage (2, N) float32 from :class:`VertexSlots` and the skin (N, 3)
    float32, computed as the Geometry Nodes tree does, node by node: per slot the distance to
    the far vertex (at least 1e-30), the coefficient over it; per side the reciprocal of the
    sum of its two; ``s = (share - side 1 - side 2) * share``.  Equal to :func:`shrinkages`
    (tested): the tree is this transcription."""
    p = np.asarray(skin, np.float32)
    d = p[slots.far] - p  # (2, 4, N, 3)
    length = np.maximum(np.sqrt((d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1]) + d[..., 2] * d[..., 2]),
                        np.float32(1e-30))
    q = slots.coef / length
    side = np.float32(1.0) / (q[:, 0] + q[:, 1]), np.float32(1.0) / (q[:, 2] + q[:, 3])
    return (slots.share - (side[0] + side[1])) * slots.share
