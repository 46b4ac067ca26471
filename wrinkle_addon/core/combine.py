# SPDX-License-Identifier: GPL-3.0-or-later
"""The one output stage's arithmetic: every wrinkle source's share of a frame, summed.

A source declares once, with its static data, where it writes (a :class:`Footprint`:
the vertices it moves tangentially and the vertices it raises along the normal).  Each
frame it returns a :class:`Contribution`: the tangential offset (3, P), such as Waters' pull,
and the height (H,) along the skin normal, such as Zhang's wrinkle height W.  Then::

    offset = sum of the tangential offsets
    normal = the area-weighted normal of (skin + offset), at the raised vertices
    out    = offset + (sum of the heights) * normal

so the heights of all sources add up along one normal, and a wrinkle never feeds the
compression it came from (the sources read the skin before any height; a source after one
that pulls the skin tangentially reads it pulled, ``glue/pipeline.py``).  All static
indexing is precomputed in :func:`build`; :func:`combine` is gathers and sums over the
footprints' union only, never the whole mesh.
"""

from dataclasses import dataclass, field

import numpy as np

from . import mesh

_F = np.float32
_EMPTY = np.zeros(0, np.int64)


@dataclass(frozen=True)
class Footprint:
    """Where a source writes, fixed by its static data: sorted unique vertex indices."""

    offset_verts: np.ndarray = field(default_factory=lambda: _EMPTY)
    height_verts: np.ndarray = field(default_factory=lambda: _EMPTY)


@dataclass
class Contribution:
    """A source's share of one frame: ``offset`` (3, P) float32 at its footprint's
    ``offset_verts`` and ``height`` (H,) float32 at its ``height_verts``; either may be
    None (nothing of that kind this frame).  Values for the shaders: ``shading``, by name,
    handed back to the source to write (such as the 8 zone weights of the wrinkle maps),
    and ``attributes``, per-vertex (N,) arrays that the stage writes as point attributes
    of the mesh (such as a skin shrinkage a shader reads)."""

    offset: np.ndarray = None
    height: np.ndarray = None
    shading: dict = field(default_factory=dict)
    attributes: dict = field(default_factory=dict)


@dataclass
class Plan:
    n_verts: int
    verts: np.ndarray  # (U,) the union of the footprints and the triangles around raised vertices
    flat: np.ndarray  # (3, U) flat indices of those vertices' x, y, z in an (N, 3) array
    offset_index: list  # per footprint: (P_i,) local indices
    height_index: list  # per footprint: (H_i,) indices into ``height_keys``
    height_keys: np.ndarray  # (H,) local indices of every raised vertex
    tris: np.ndarray  # (3, T) local corners of the triangles around the raised vertices
    normal_sum: "mesh.Bins"  # corners -> height_keys


def _unique(a):
    return np.unique(np.asarray(a, np.int64).ravel())


def build(n_verts, tris, footprints):
    """The static plan for ``footprints`` on a mesh of ``n_verts`` vertices whose
    triangles are ``tris`` (T, 3); any superset of the triangles around the raised
    vertices will do."""
    tris = np.asarray(tris, np.int64).reshape(-1, 3)
    raised = _unique(np.concatenate([f.height_verts for f in footprints] + [_EMPTY]))
    flag = np.zeros(n_verts, bool)
    flag[raised] = True
    tris = tris[flag[tris].any(axis=1)] if len(raised) else tris[:0]
    verts = _unique(np.concatenate([f.offset_verts for f in footprints] + [raised, tris.ravel()]))
    local = np.full(n_verts, -1, np.int64)
    local[verts] = np.arange(len(verts))
    height_keys = local[raised]
    tris_local = np.ascontiguousarray(local[tris].T)
    return Plan(
        n_verts=n_verts,
        verts=verts,
        flat=verts[None, :] * 3 + np.arange(3)[:, None],
        offset_index=[local[np.asarray(f.offset_verts, np.int64)] for f in footprints],
        height_index=[np.searchsorted(raised, np.asarray(f.height_verts, np.int64)) for f in footprints],
        height_keys=height_keys,
        tris=tris_local,
        normal_sum=mesh.Bins.of(tris_local, domain=height_keys),
    )


def local_skin(flat, skin):
    """The skin (3, U) float32 at the flat indices ``flat`` (one 1-D gather), with
    non-finite vertices set to 0, and the mask of those vertices (or None)."""
    s = np.take(np.asarray(skin, dtype=_F).reshape(-1), flat)
    bad = None
    if not np.isfinite(s.sum()):  # one reduction when all is finite
        bad = ~np.isfinite(s).all(axis=0)
        s[:, bad] = 0.0
    return s, bad


def combine(plan, skin, parts, out=None):
    """Sum ``parts`` (one :class:`Contribution` per footprint, in :func:`build`'s order) into the
    offsets (N, 3) float32 of the skin ``skin`` (N, 3).

    ``out`` may be a preallocated C-contiguous (N, 3) float32 array; only the plan's
    vertices are written, so keep it zero elsewhere.  Non-finite input never gives
    non-finite output: a vertex whose skin or share is not finite gets no offset.

    The normals are computed here, over the raised vertices' triangles only: Blender's own
    vertex normals of the evaluated mesh cost 1.4 ms at 50k vertices when first read
    (measured, bpy 4.5), more than these on a face's wrinkling regions."""
    if out is None:
        out = np.zeros((plan.n_verts, 3), dtype=_F)
    if len(plan.verts) == 0:
        return out
    s, bad = local_skin(plan.flat, skin)
    offset = np.zeros_like(s)
    height = np.zeros(len(plan.height_keys), _F)
    for idx, hidx, part in zip(plan.offset_index, plan.height_index, parts):
        if part is None:
            continue
        if part.offset is not None and len(idx):
            offset[:, idx] += part.offset
        if part.height is not None and len(hidx):
            height[hidx] += part.height
    if len(height) and height.any():
        normal = mesh.normals_at(s + offset, plan.tris, plan.normal_sum)
        keys = plan.height_keys
        for c in range(3):
            offset[c][keys] += height * normal[c]
    if bad is not None:
        offset[:, bad] = 0.0
    if not np.isfinite(offset.sum()):
        offset[~np.isfinite(offset)] = 0.0
    np.put(out.reshape(-1), plan.flat, offset)
    return out
