# SPDX-License-Identifier: GPL-3.0-or-later
"""Fine-scale wrinkles on a face (Bando, Kuratate & Nishita 2002, §5 and §7): the two
direction fields, the carving of their height images, and the per-frame shrinkage across
each field that modulates them.

* :func:`uv_directions` turns directions given on the skin (3-D vectors at vertices, as an
  artist sets them on selected vertices) into the texture-space vectors of §5.1.
* :func:`carve_pair` carves both height images: the second field is the first rotated by
  an angle (the paper's two directions of Fig. 1), each with its own seed.
* :class:`FinePlan` measures, per frame, the shrinkage ``s`` (eq. 4) across each field at
  every mesh vertex; the shader scales each height image by ``M(s)`` (eq. 5) of its own
  field's shrinkage.  A vertex on a UV seam takes the value of one of its copies.
"""

from dataclasses import dataclass

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


def carve_pair(uv, tris, field1, angle, resolution, seed=0, progress=None):
    """The two height images (R, R) float32 of §5 (1 = no furrow): ``field1`` (U, 2) and
    ``field1`` rotated by ``angle`` (radians), carved with seeds ``seed`` and ``seed + 1``.
    ``progress(i)`` is called before each.  Returns ``(results, field2)``."""
    field2 = field.rotate(field1, angle)
    out = []
    for i, (f, s) in enumerate(((field1, seed), (field2, seed + 1))):
        if progress is not None:
            progress(i)
        out.append(carve.carve(uv, tris, f, resolution, seed=s))
    return out, field2


@dataclass(frozen=True)
class FinePlan:
    """Static data of the per-frame shrinkage of both fields at the mesh's vertices.

    :func:`field.shrinkage` per field would gather four edge ends per mapped vertex and
    field; here the edges the two plans use are listed once (``ends`` (E, 2) mesh
    vertices), so a frame measures each edge once and both fields gather their lengths.
    ``slot_edge`` (2, 4, N): per field and slot (two edges per side) the edge of each mesh
    vertex's representative copy, ``slot_coef`` (2, 4, N) its coefficient, ``share``
    (2, N) and ``none`` as in :class:`field.ShrinkagePlan`."""

    ends: tuple  # two (E,) contiguous intp arrays: fancy row indexing is 3.6x slower than take
    slot_edge: np.ndarray
    slot_coef: np.ndarray
    share: np.ndarray
    none: np.ndarray  # (2, N) bool: no corner (s = 0), or no copy at all


def plan(mapped, rest, field1, field2):
    """The :class:`FinePlan` of the fields (U, 2) on the mapped mesh of a face at rest (N, 3)."""
    pos = mapped.positions(np.asarray(rest, np.float64))
    n = mapped.n_verts
    rep = np.full(n, -1, np.int64)
    rep[mapped.vert_of] = np.arange(len(mapped.vert_of))  # any one copy of each vertex
    has = rep >= 0
    rep = np.where(has, rep, 0)
    here = mapped.vert_of[rep]  # (N,) the vertex itself, or 0 for vertices in no triangle
    keys, coefs, shares, nones = [], [], [], []
    for f in (field1, field2):
        sp = field.shrinkage_plan(mapped.uv, mapped.tris, f, pos)
        far = mapped.vert_of[sp.slot_ends[:, rep]]  # (4, N) mesh vertices
        lo, hi = np.minimum(here, far), np.maximum(here, far)
        keys.append(lo * n + hi)
        coefs.append(sp.slot_coef[:, rep])
        none = np.zeros(len(mapped.uv), bool)
        none[sp.none] = True
        shares.append(np.where(has, sp.share[rep], 0.0))
        nones.append(none[rep] | ~has)
    keys = np.stack(keys)  # (2, 4, N)
    unique, slot_edge = np.unique(keys, return_inverse=True)
    ends = ((unique // n).astype(np.intp), (unique % n).astype(np.intp))
    return FinePlan(ends, slot_edge.reshape(keys.shape).astype(np.intp), np.stack(coefs).astype(np.float32),
                    np.stack(shares).astype(np.float32), np.stack(nones))


def shrinkages(fine_plan, skin):
    """The frame's shrinkage across each field (2, N) float32 at the mesh's vertices, from
    the skin (N, 3) float32; 0 at vertices in no triangle.  Equal to
    :func:`field.shrinkage` at each vertex's representative copy."""
    p = np.asarray(skin, np.float32)
    d = np.take(p, fine_plan.ends[1], axis=0)
    d -= np.take(p, fine_plan.ends[0], axis=0)
    length = np.sqrt(np.einsum("ij,ij->i", d, d))
    np.maximum(length, np.float32(1e-30), out=length)
    q = fine_plan.slot_coef / np.take(length, fine_plan.slot_edge)  # (2, 4, N): a'/l2, b'/l3 per side
    den = q[:, 0::2] + q[:, 1::2]  # (2, 2, N)
    s = fine_plan.share - (1.0 / den).sum(axis=1)
    s[fine_plan.none] = 0.0
    return s
