# SPDX-License-Identifier: GPL-3.0-or-later
"""The per-frame muscle-wrinkle evaluation: a static :class:`Plan`, then :func:`evaluate`.

Per frame (DESIGN.md, "Per-frame evaluation")::

    skin      the deformed skin before any wrinkle (shape keys, armature, ...)
    pulled    skin + Waters pull of every contracting muscle
    tau       eq. 9 on the edges around the wrinkling regions, rest vs pulled
    eps       eq. 10, per (muscle, region vertex), weights |cos theta| normalised
    W         eq. 4: H(w) At (static, cached) * A(eps)
    offset    pull + (sum of W over muscles) * skin normal

Everything static - regions, (lambda, gamma, w), H(w) At, edge weights, rest
lengths, the triangles around the regions - lives in the plan and is rebuilt
only when the rest mesh, topology or a muscle's geometry or parameters change.
The per-frame cost is proportional to the size of the regions, not the mesh.

The contraction direction for eq. 10's ``theta_ij`` is taken at rest: the
angle between an edge and ``x_i -> m_A`` barely changes while the skin
deforms, and caching it removes half of the per-frame work.
"""

from dataclasses import dataclass, field

import numpy as np

from . import mesh, zhang
from .muscles import LINEAR, muscle_field

_F = np.float32


@dataclass
class Plan:
    n_verts: int
    verts: np.ndarray  # (U,) global index of each local vertex
    # Waters pull rows
    pull_vert: np.ndarray  # linear-muscle rows first, then sheet rows
    pull_muscle: np.ndarray
    pull_weight: np.ndarray
    n_linear: int  # how many of the pull rows belong to linear muscles
    pull_target: np.ndarray  # (n_linear, 3) attachment point of each linear row
    pull_dir: np.ndarray  # (P - n_linear, 3) fixed direction of each sheet row
    muscle_pull: np.ndarray  # (M,) pull factor, 0 for wrinkles-only muscles
    # compression
    edges: np.ndarray  # (E', 2) local
    rest_length: np.ndarray
    pair_row: np.ndarray
    pair_edge: np.ndarray
    pair_weight: np.ndarray
    row_vert: np.ndarray  # local vertex of each (muscle, region vertex) row
    row_muscle: np.ndarray
    row_amp: np.ndarray  # H(w) At (fade)
    tris: np.ndarray  # (T, 3) local
    half_cycles: np.ndarray  # (M,) u per muscle
    region_sizes: np.ndarray  # (M,) vertices in each wrinkling region
    problems: list = field(default_factory=list)  # (muscle index, message)


def build_plan(rest, edges, tris, muscles):
    """Precompute everything static.  ``rest`` (N, 3), ``edges`` (E, 2), ``tris`` (T, 3)."""
    rest = np.asarray(rest, dtype=np.float64).reshape(-1, 3)
    n = len(rest)
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    tris = np.asarray(tris, dtype=np.int64).reshape(-1, 3)
    fields, problems = [], []
    for i, m in enumerate(muscles):
        why = m.problem()
        if why:
            problems.append((i, why))
        fields.append(muscle_field(rest, m))
    n_m = len(muscles)

    # Waters pull rows, all muscles concatenated
    pull_vert = np.concatenate([f.aoi for f in fields] + [np.zeros(0, np.int32)])
    pull_muscle = np.repeat(np.arange(n_m), [len(f.aoi) for f in fields])
    pull_weight = np.concatenate([f.pull_weight for f in fields] + [np.zeros(0)])
    linear = np.array([m.sanitized().kind == LINEAR for m in muscles], bool)[pull_muscle]
    order = np.argsort(~linear, kind="stable")  # linear rows first
    pull_vert, pull_muscle, pull_weight = pull_vert[order], pull_muscle[order], pull_weight[order]
    n_linear = int(linear.sum())
    pull_target = np.array([f.target for f in fields]).reshape(-1, 3)[pull_muscle[:n_linear]]
    pull_dir = np.array([f.pull_dir for f in fields]).reshape(-1, 3)[pull_muscle[n_linear:]]
    muscle_pull = np.array([0.0 if m.sanitized().wrinkles_only else m.sanitized().pull for m in muscles])

    # (muscle, region vertex) rows and their incident edges, eq. 10 weights
    row_vert = np.concatenate([f.region for f in fields] + [np.zeros(0, np.int32)]).astype(np.int64)
    row_muscle = np.repeat(np.arange(n_m), [len(f.region) for f in fields])
    row_amp = np.concatenate([f.amplitude for f in fields] + [np.zeros(0)])
    row_cdir = np.concatenate([f.contraction_dir for f in fields] + [np.zeros((0, 3))])
    keep = row_amp != 0.0
    row_vert, row_muscle, row_amp, row_cdir = row_vert[keep], row_muscle[keep], row_amp[keep], row_cdir[keep]

    offsets, inc_edge = mesh.vertex_incidence(edges, n)
    pair_row, pair_edge = mesh.gather_incident(offsets, inc_edge, row_vert)
    rest_len = mesh.edge_lengths(rest, edges)
    # Rest lengths exactly as the per-frame path computes lengths (float32), so that the
    # rest pose gives tau == 0 to the bit and no wrinkle at all.
    rest_len32 = mesh.edge_lengths(rest.astype(_F), edges)
    e = edges[pair_edge]
    d = rest[e[:, 1]] - rest[e[:, 0]]
    length = rest_len[pair_edge]
    ok = length > 1e-12
    cos = np.abs(np.einsum("ij,ij->i", d, row_cdir[pair_row])) / np.where(ok, length, 1.0)
    cos = np.where(ok, cos, 0.0)
    total = np.bincount(pair_row, weights=cos, minlength=len(row_vert))
    pair_weight = np.where(total[pair_row] > 0, cos / np.where(total[pair_row] > 0, total[pair_row], 1), 0)

    # triangles around the wrinkling regions, for the skin normal
    in_region = np.zeros(n, bool)
    in_region[row_vert] = True
    tri_keep = in_region[tris].any(axis=1) if len(tris) else np.zeros(0, bool)
    tris = tris[tri_keep]

    used_edges, pair_edge_local = np.unique(pair_edge, return_inverse=True)
    verts = np.unique(np.concatenate([pull_vert, row_vert, edges[used_edges].ravel(), tris.ravel()]))
    local = np.full(n, -1, dtype=np.int64)
    local[verts] = np.arange(len(verts))
    return Plan(
        n_verts=n,
        verts=verts.astype(np.int64),
        pull_vert=local[pull_vert],
        pull_muscle=pull_muscle,
        pull_weight=pull_weight.astype(_F),
        n_linear=n_linear,
        pull_target=pull_target.astype(_F),
        pull_dir=pull_dir.astype(_F),
        muscle_pull=muscle_pull,
        edges=local[edges[used_edges]].reshape(-1, 2),
        rest_length=rest_len32[used_edges],
        pair_row=pair_row,
        pair_edge=pair_edge_local.ravel(),
        pair_weight=pair_weight.astype(_F),
        row_vert=local[row_vert],
        row_muscle=row_muscle,
        row_amp=row_amp.astype(_F),
        tris=local[tris].reshape(-1, 3),
        half_cycles=np.array([f.half_cycle for f in fields]),
        region_sizes=np.array([len(f.region) for f in fields]),
        problems=problems,
    )


def waters_pull(plan, skin_local, contraction):
    """The summed Waters pull at the plan's local vertices, (U, 3) float32."""
    u = len(plan.verts)
    out = np.zeros((u, 3), dtype=_F)
    gain = (np.nan_to_num(np.asarray(contraction, dtype=np.float64)) * plan.muscle_pull).astype(_F)
    if len(plan.pull_vert) == 0 or not gain.any():
        return out
    k = gain[plan.pull_muscle] * plan.pull_weight
    n = plan.n_linear
    disp = np.empty((len(k), 3), dtype=_F)
    # linear muscles: toward the attachment from where the skin is now, never past it
    to = plan.pull_target - skin_local[plan.pull_vert[:n]]
    dist = np.sqrt(np.einsum("ij,ij->i", to, to))
    scale = np.minimum(k[:n], 0.95 * dist) / np.maximum(dist, _F(1e-12))
    np.multiply(to, scale[:, None], out=disp[:n])
    # sheet muscles: parallel to the central fibre
    np.multiply(plan.pull_dir, k[n:, None], out=disp[n:])
    for c in range(3):
        out[:, c] = np.bincount(plan.pull_vert, weights=disp[:, c], minlength=u)
    return out


def compression(plan, pulled_local):
    """Eq. 10 per (muscle, region vertex) row."""
    e = plan.edges
    if len(e) == 0:
        return np.zeros(len(plan.row_vert), dtype=_F)
    d = pulled_local[e[:, 1]] - pulled_local[e[:, 0]]
    tau = zhang.edge_shrinkage(plan.rest_length, np.sqrt(np.einsum("ij,ij->i", d, d)))
    return np.bincount(plan.pair_row, weights=plan.pair_weight * tau[plan.pair_edge],
                       minlength=len(plan.row_vert))


def evaluate(plan, skin, contraction, strength=1.0, out=None):
    """Offsets (N, 3) float32 for the skin positions ``skin`` (N, 3).

    ``contraction`` holds one value per muscle.  ``out`` may be a preallocated
    (N, 3) float32 array; only the plan's vertices are written, so keep it zero
    elsewhere.  Non-finite input never produces non-finite output.
    """
    if out is None:
        out = np.zeros((plan.n_verts, 3), dtype=_F)
    if len(plan.verts) == 0:
        return out
    s = np.asarray(skin, dtype=_F)[plan.verts]
    bad = None
    if not np.isfinite(s.sum()):  # fast path: one reduction when all is finite
        bad = ~np.isfinite(s).all(axis=1)
        s[bad] = 0.0
    pull = waters_pull(plan, s, contraction)
    pulled = s + pull
    eps = compression(plan, pulled)
    w = plan.row_amp * zhang.anisotropic(eps).astype(_F)
    height = np.bincount(plan.row_vert, weights=w, minlength=len(plan.verts)).astype(_F)
    height *= _F(np.nan_to_num(strength))
    normal = mesh.vertex_normals(pulled, plan.tris, len(plan.verts))
    offset = pull + height[:, None] * normal
    if bad is not None:
        offset[bad] = 0.0
    if not np.isfinite(offset.sum()):
        offset[~np.isfinite(offset)] = 0.0
    out[plan.verts] = offset
    return out


def refine_edges(rest, edges, muscles, factor=4.0):
    """Edges to split so every half cycle ``u`` spans at least ``factor`` edges.

    Returns the indices of edges touching a wrinkling region whose rest length
    exceeds ``u / factor`` for that region's muscle (Zhang §3 refines where the
    wrinkles need resolution).
    """
    rest = np.asarray(rest, dtype=np.float64).reshape(-1, 3)
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    limit = np.full(len(rest), np.inf)
    for m in muscles:
        f = muscle_field(rest, m)
        if len(f.region) and f.half_cycle > 0:
            np.minimum.at(limit, f.region, f.half_cycle / factor)
    lim_e = np.minimum(limit[edges[:, 0]], limit[edges[:, 1]])
    return np.flatnonzero(mesh.edge_lengths(rest, edges) > lim_e)
