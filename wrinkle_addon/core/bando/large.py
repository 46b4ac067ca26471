# SPDX-License-Identifier: GPL-3.0-or-later
"""Large-scale wrinkles per frame (Bando, Kuratate & Nishita 2002, §6-7): the curves' static
heights (:mod:`.curves`) times the amplitude modulation ``M(s)`` (eq. 5) of the shrinkage
``s`` measured across each curve (eq. 4, :mod:`.field`), on the face's vertices.

A vertex near two curves has two shrinkages, one across each curve's direction.  The plan
therefore gives every curve its own copy of the triangles around its entries (the curve's
*patch*), with the curve's tangent as the direction at the entries, and concatenates the
patches into one mesh for one :func:`field.shrinkage_plan`; per frame
:func:`field.edge_slot_shrinkage` measures only the edges the entries use, never the
whole face.

Heights are computed on the mapped mesh (UV seams split vertices) and go back to the
face's vertices by averaging the copies of a vertex that a curve reaches.  A curve does not
reach across a UV seam: its distance is measured in one UV island (the paper's curves live
in one texture space), so draw one curve per side of a seam.
"""

from dataclasses import dataclass

import numpy as np

from . import curves as core_curves
from . import field

_F = np.float32


@dataclass(frozen=True)
class LargePlan:
    """Static data of the large-scale wrinkles of one face (see the module notes)."""

    curves: "core_curves.CurvePlan"
    footprint: np.ndarray  # (F,) sorted mesh vertex ids that get a height
    entry_slot: np.ndarray  # (E,) index into the footprint of each entry's mesh vertex
    shrink: "field.EdgeSlots"  # one row per entry: the shrinkage across its curve
    rest_height: np.ndarray  # (E,) float32 r of each entry's curve
    growth: np.ndarray  # (E,) float32 1 - r: M's slope for s >= 0
    decay: np.ndarray  # (E,) float32 1/r - 1 (0 where r = 0): M's rate for s < 0
    static: np.ndarray  # (E,) float32 S(l) taper(u) window(l)


def _patches(tris, plan):
    """Per curve, the triangles touching its entries, re-indexed into one concatenated mesh."""
    patch_tris, patch_verts, entry_patch = [], [], []
    start = 0
    for c in range(len(plan.lengths)):
        ent = plan.entries(c)
        verts = plan.verts[ent]
        touch = np.zeros(plan.n_verts, bool)
        touch[verts] = True
        t = tris[touch[tris].any(axis=1)]
        local, inverse = np.unique(t, return_inverse=True)
        patch_tris.append(inverse.reshape(-1, 3) + start)
        patch_verts.append(local)
        entry_patch.append(np.searchsorted(local, verts) + start)
        start += len(local)
    if not patch_tris:
        return np.zeros((0, 3), np.int64), np.zeros(0, np.int64), np.zeros(0, np.int64)
    return np.concatenate(patch_tris), np.concatenate(patch_verts), np.concatenate(entry_patch)


def build(mapped, rest, curves, rest_heights):
    """The :class:`LargePlan` of ``curves`` (:class:`curves.Curve` list, UV polylines) on the
    mapped mesh ``mapped`` (:class:`mapped.MappedMesh`) of a face whose rest positions are
    ``rest`` (N, 3); ``rest_heights`` (C,) the r of each curve.  Raises ValueError."""
    pos = mapped.positions(np.asarray(rest, np.float64))
    plan = core_curves.curve_plan(mapped.uv, mapped.tris, pos, curves)
    tris, patch_verts, entry_patch = _patches(mapped.tris, plan)
    direction = np.zeros((len(patch_verts), 2))
    direction[entry_patch] = plan.tangent
    patch_plan = field.shrinkage_plan(mapped.uv[patch_verts], tris, direction, pos[patch_verts])
    shrink = field.edge_slots([(patch_plan, entry_patch, mapped.vert_of[patch_verts])], mapped.n_verts)
    mesh_vert = mapped.vert_of[plan.verts]
    footprint, entry_slot = np.unique(mesh_vert, return_inverse=True)
    # a vertex near two curves sums their heights; the seam copies of one vertex near one
    # curve are averaged: each entry's share is divided by its (curve, vertex) count
    _u, pair, count = np.unique(plan.curve * (mapped.n_verts + 1) + mesh_vert, return_inverse=True,
                                return_counts=True)
    seam = count[pair.ravel()].astype(np.float64)
    r = np.clip(np.asarray(rest_heights, np.float64).reshape(-1), 0.0, 1.0)
    r = r[plan.curve] if len(plan.curve) else np.zeros(0)
    decay = np.where(r > 0, 1.0 / np.where(r > 0, r, 1.0) - 1.0, 0.0)
    return LargePlan(plan, footprint, entry_slot.ravel(), shrink, r.astype(_F), (1.0 - r).astype(_F),
                     decay.astype(_F), (plan.static / seam).astype(_F))


def heights(plan, skin, formed=False):
    """The frame's heights (F,) float32 at ``plan.footprint``: the sum over curves of
    ``S(l) taper window M(s)``, ``s`` across each curve, for the face's skin (N, 3)
    float32.  ``formed``: every wrinkle at its full height, ``M = 1`` (for a baked map), the
    skin unused."""
    if len(plan.footprint) == 0:
        return np.zeros(0, _F)
    if formed:
        m = 1.0
    else:  # eq. 5 (field.modulation) with its constants per entry precomputed, in float32
        s = np.minimum(shrinkage_at(plan, skin), np.float32(1.0))
        m = np.where(s >= 0, plan.growth * s + plan.rest_height,
                     plan.rest_height * np.exp(plan.decay * np.minimum(s, np.float32(0.0))))
    return np.bincount(plan.entry_slot, weights=plan.static * m, minlength=len(plan.footprint)).astype(_F)


def shrinkage_at(plan, skin):
    """The shrinkage across each curve at its entries (E,), for the face's skin (N, 3)."""
    return field.edge_slot_shrinkage(plan.shrink, skin)
