# SPDX-License-Identifier: GPL-3.0-or-later
"""The per-frame muscle-wrinkle evaluation: a static :class:`Plan`, then :func:`evaluate`.

Per frame (docs/architecture.md, "The frame stage")::

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

from dataclasses import dataclass, field, replace

import numpy as np

from .. import combine, mesh
from . import zhang
from .fields import muscle_field
from .muscle import LINEAR, SPHINCTER

_F = np.float32


@dataclass
class Plan:
    """Static data of one face and its muscles; sums over rows are segment sums.

    Every per-frame sum (Waters pull per vertex, eq. 10 per row, heights and
    normals per vertex) goes through a :class:`mesh.Bins` built here.
    """

    n_verts: int
    verts: np.ndarray  # (U,) global index of each local vertex
    flat: np.ndarray  # (3, U) index of each local vertex's x, y, z in a flattened (N, 3) array
    # Waters pull rows
    pull_vert: np.ndarray  # (P,) sorted by vertex
    pull_muscle: np.ndarray
    pull_weight: np.ndarray
    pull_linear: np.ndarray  # (P,) float32: 1 for a linear muscle's row, 0 for a sheet's
    pull_target: np.ndarray  # (3, P) attachment point of a linear row (0 for sheet rows)
    pull_dir: np.ndarray  # (3, P) fixed direction of a sheet row (0 for linear rows)
    muscle_pull: np.ndarray  # (M,) pull factor, 0 for wrinkles-only muscles
    pull_sum: "mesh.Bins"  # pull rows -> local vertices
    # compression
    edges: np.ndarray  # (2, E') local end points
    rest_length: np.ndarray
    pair_edge: np.ndarray  # (row, incident edge) pairs
    pair_weight: np.ndarray
    pair_sum: "mesh.Bins"  # pairs -> rows
    row_vert: np.ndarray  # local vertex of each (muscle, region vertex) row
    row_muscle: np.ndarray
    row_amp: np.ndarray  # H(w) At (fade)
    height_sum: "mesh.Bins"  # rows -> local vertices with a wrinkle (``keys``)
    fold_weight: np.ndarray  # (R,) float32: each row's share of its vertex's fold cap (_fold_weights)
    footprint: "combine.Footprint"  # where the muscles write: pulled and raised vertices
    output: "combine.Plan"  # the output stage for this plan alone (:func:`evaluate`)
    half_cycles: np.ndarray  # (M,) u per muscle
    region_sizes: np.ndarray  # (M,) vertices in each wrinkling region
    problems: list = field(default_factory=list)  # (muscle index, message)
    limits: list = field(default_factory=list)  # (muscle index, n_w asked, n_w built): see wrinkle_limit
    smooth_cells: np.ndarray = None  # (R, 4) cells of each row's A(eps) smoothing, or None
    smooth_weights: np.ndarray = None  # (R, 4) float32 bilinear weights
    smooth_norm: np.ndarray = None  # (cells,) 1 / total weight per cell (0 where empty)
    smooth_size: int = 0
    # folds that meet (``families``): at the vertices where two families of folds overlap,
    # each (vertex, family) pair's strength and height are summed and blended
    blend_rows: np.ndarray = None  # (B,) the rows at those vertices
    blend_pair: np.ndarray = None  # (B,) their (vertex, family) pair
    blend_env: np.ndarray = None  # (B,) float32: each row's envelope At (keep-out included)
    blend_pair_vert: np.ndarray = None  # (Q,) index into ``height_sum.keys`` of each pair
    blend_verts: np.ndarray = None  # (V,) indices into ``height_sum.keys`` that are blended
    # sphincters' rings (``ring_gate``): their rows, each row's group (ring and half of its
    # sector) and envelope weight, and each group's total weight
    ring_rows: np.ndarray = None  # (G,)
    ring_of: np.ndarray = None  # (G,) 2 k + h: the k-th ring, the half h of its sector
    ring_weight: np.ndarray = None  # (G,) float32
    ring_total: np.ndarray = None  # (2 K,)


# A(eps) smoothing cells, in half cycles u: (along the fibre, across it).  A row's splat and
# read back together span two cells each way: +-u along the fibre, across the furrows, so
# the sequence of furrows keeps its shape; +-2u across the fibre, along each furrow, whose
# fold is long and whose depth changes slowly along it (a scan's irregular edges made lumps)
CELL = (0.5, 1.0)
_MAX_CELL = float(2**40)


def _smoothing(fields, keep):
    """The grid on which each muscle's amplitude A(eps) is smoothed: cells of ``CELL`` half
    cycles u in the muscle's plane (``MuscleField.coords``); each kept row splats into and
    reads back from its 4 surrounding cells with bilinear weights.  Returns (cells (R, 4),
    weights (R, 4) float32, number of cells, per-cell weight totals).

    Only the cells that some row touches are numbered, so the grid has at most 4 cells a
    row whatever the half cycle: a grid over the region's whole bounding box grows as
    ``(n_w / (1 - lambda_w))²`` and took 15 GB for 1000 wrinkles (measured)."""
    keys, weights = [], []
    corner = [(0, 0), (1, 0), (0, 1), (1, 1)]
    for k, f in enumerate(fields):
        c = np.asarray(f.coords, np.float64).reshape(-1, 2)
        if len(c) == 0:
            continue
        g = (c - c.min(axis=0)) / (np.array(CELL) * max(f.half_cycle, 1e-12))
        g = np.minimum(g, _MAX_CELL)  # a finite cell index even for an absurdly small u
        i = np.floor(g).astype(np.int64)
        t = g - i
        keys.append(np.stack([np.stack([np.full(len(c), k), i[:, 0] + a, i[:, 1] + b], axis=1)
                              for a, b in corner], axis=1))
        weights.append(np.stack([np.where(a, t[:, 0], 1 - t[:, 0]) * np.where(b, t[:, 1], 1 - t[:, 1])
                                 for a, b in corner], axis=1))
    if not keys:
        return np.zeros((0, 4), np.int64), np.zeros((0, 4), _F), 0, np.zeros(0)
    keys = np.concatenate(keys)[keep].reshape(-1, 3)
    weights = np.concatenate(weights)[keep]
    used, cells = np.unique(keys, axis=0, return_inverse=True)
    cells = cells.reshape(-1, 4)
    total = np.bincount(cells.ravel(), weights=weights.ravel(), minlength=len(used))
    return cells, weights.astype(_F), len(used), total


def smooth_rows(plan, values):
    """``values`` (R,) per row, smoothed over each muscle's half-cycle grid (see
    :func:`_smoothing`): a bilinear splat, normalised, and a bilinear read back."""
    if plan.smooth_cells is None or len(values) == 0:
        return values
    num = np.bincount(plan.smooth_cells.ravel(), weights=(plan.smooth_weights * values[:, None]).ravel(),
                      minlength=plan.smooth_size)
    grid = (num * plan.smooth_norm).astype(_F)
    return np.einsum("ij,ij->i", plan.smooth_weights, grid[plan.smooth_cells])


# How sharply the stronger family of folds takes over where two meet (the weight is the
# family's strength to this power, normalised): at twice the other's strength it has 94 %
BLEND_POWER = 4.0
_SAME_FOLD = 0.9  # the correlation of two muscles' profiles H(w) above which they are one family


def families(fields):
    """One family index per muscle: muscles whose folds are one set of folds where their
    regions overlap (their profiles H(w) correlate above ``_SAME_FOLD`` and their directions
    of contraction agree there) are one family, as the Frontalis sheets that share one phase.
    Muscles whose regions do not overlap are each their own.  A loop over pairs of muscles
    (a face has a few dozen), vectorised over their shared vertices."""
    parent = list(range(len(fields)))

    def root(i):
        while parent[i] != i:
            i = parent[i]
        return i

    # per muscle: its region vertices where the envelope is not ~0, their profile H(w) and
    # their direction of contraction
    kept = []
    for f in fields:
        ok = np.abs(f.envelope) > 1e-3 if f.envelope is not None and len(f.region) else np.zeros(0, bool)
        kept.append((f.region[ok], f.amplitude[ok] / f.envelope[ok], f.contraction_dir[ok]))
    for i in range(len(fields)):
        for j in range(i + 1, len(fields)):
            _v, ia, ib = np.intersect1d(kept[i][0], kept[j][0], assume_unique=True, return_indices=True)
            if len(ia) < 8:
                continue
            a, b = kept[i][1][ia], kept[j][1][ib]
            if a.std() < 1e-12 or b.std() < 1e-12 or np.corrcoef(a, b)[0, 1] < _SAME_FOLD:
                continue
            if np.mean(np.abs(np.einsum("ij,ij->i", kept[i][2][ia], kept[j][2][ib]))) < _SAME_FOLD:
                continue
            parent[root(j)] = root(i)
    roots = [root(i) for i in range(len(fields))]
    _u, fam = np.unique(roots, return_inverse=True)
    return fam.astype(np.int64)


def _blend_plan(row_vert, row_family, row_env, keys):
    """The static part of the blend of folds (see :func:`blend`): only the wrinkled local
    vertices where rows of two or more families meet."""
    pairs, row_pair = np.unique(np.stack([row_vert, row_family], axis=1), axis=0, return_inverse=True)
    row_pair = row_pair.ravel()
    count = np.bincount(pairs[:, 0], minlength=int(keys.max()) + 1 if len(keys) else 0)
    mixed = count[row_vert] > 1
    if not mixed.any():
        return None
    rows = np.flatnonzero(mixed)
    used, pair = np.unique(row_pair[rows], return_inverse=True)
    key_of = np.full(int(keys.max()) + 1, -1, np.int64)
    key_of[keys] = np.arange(len(keys))
    pair_vert = key_of[pairs[used, 0]]
    return rows, pair.ravel(), row_env[rows].astype(_F), pair_vert, np.unique(pair_vert)


def blend(plan, a, w, height):
    """Where folds of two families meet, blend them instead of summing: each (vertex,
    family) pair's strength ``E = sum of At A(eps)`` and height ``S = sum of W``; the vertex's
    height is ``sum_f E_f^p S_f / sum_f E_f^p`` (p = ``BLEND_POWER``).  Summed, two sets of
    folds that cross pile into a slit beside a bump (Zhang et al. name "prevent neighbouring
    folds from intersecting" as future work); blended, the folds of the stronger compression
    run through and the other's fade out, smoothly.  ``a`` (R,) is each row's smoothed A(eps),
    ``w`` (R,) its height W, ``height`` the summed heights at ``height_sum.keys`` (changed in
    place at the blended vertices only: elsewhere one family's folds are exactly the sum)."""
    if plan.blend_rows is None:
        return height
    rows, pair = plan.blend_rows, plan.blend_pair
    q = len(plan.blend_pair_vert)
    strength = np.bincount(pair, weights=plan.blend_env * a[rows], minlength=q) ** BLEND_POWER
    folds = np.bincount(pair, weights=w[rows], minlength=q)
    n = len(height)
    total = np.bincount(plan.blend_pair_vert, weights=strength, minlength=n)
    mixed = np.bincount(plan.blend_pair_vert, weights=strength * folds, minlength=n)
    v = plan.blend_verts
    out = np.asarray(height).copy()
    some = total[v] > 0.0
    out[v[some]] = (mixed[v[some]] / total[v[some]]).astype(out.dtype)
    return out


# A sphincter folds as its ring shortens all round: its wrinkles' A(eps) is scaled by the
# smoothstep, from RING_GATE[0] to RING_GATE[1], of the lesser of the mean compressions along
# its fibres (eq. 10, weighted by the envelope) over the two halves of its wrinkling sector
# (either side of its axis a).  When only the brows come down, the skin beside the eye is
# squeezed from above: the sector's lower half shortens and its upper half does not (its mean
# stays under 0.001 on the sample head and a variant of it); when the eyes squint or the
# cheeks rise, both halves shorten (0.013 to 0.07): crow's feet come with those, not with a
# frown.  A sheet or a linear muscle has no ring and no gate.
RING_GATE = (0.003, 0.015)


def _ring_plan(muscles, row_muscle, row_env, row_along):
    """The static part of :func:`ring_gate`: the sphincters' rows, each row's half of its
    ring's sector (group ``2 k + (along >= 0)`` for the k-th ring), its envelope weight and
    each group's total weight; or None without a sphincter."""
    ring = np.array([m.sanitized().kind == SPHINCTER for m in muscles], bool)
    if not ring.any() or len(row_muscle) == 0:
        return None
    rows = np.flatnonzero(ring[row_muscle])
    if len(rows) == 0:
        return None
    _u, of = np.unique(row_muscle[rows], return_inverse=True)
    group = 2 * of.ravel() + (np.asarray(row_along)[rows] >= 0.0)
    weight = np.asarray(row_env, np.float64)[rows]
    total = np.bincount(group, weights=weight, minlength=2 * (int(of.max()) + 1))
    return rows, group, weight.astype(_F), total


def ring_gate(plan, eps, a):
    """``a`` (R,), each row's A(eps), with every sphincter's rows scaled in place by its
    ring's gate (see ``RING_GATE``) for the compressions ``eps`` (R,) of eq. 10."""
    if plan.ring_rows is None:
        return a
    rows, group = plan.ring_rows, plan.ring_of
    mean = np.bincount(group, weights=plan.ring_weight * eps[rows], minlength=len(plan.ring_total))
    # a half with no rows (kept out) leaves the ring to the other half
    mean = np.where(plan.ring_total > 0, mean / np.where(plan.ring_total > 0, plan.ring_total, 1.0), np.inf)
    least = np.minimum(mean[0::2], mean[1::2])
    least = np.where(np.isfinite(least), least, 0.0)
    gate = mesh.smoothstep((least - RING_GATE[0]) / (RING_GATE[1] - RING_GATE[0])).astype(_F)
    a[rows] *= gate[group // 2]
    return a


def wrinkle_limit(rest, edges, muscle, f):
    """The most wrinkles the mesh can show in the wrinkling region of ``f`` (the
    :class:`MuscleField` of ``muscle``), or None when its ``n_w`` is within that.

    A wrinkle is one cycle ``2u`` of eq. 5's profile; sampled by edges longer than ``u`` it
    aliases into noise.  So a region carries at most one wrinkle per two edge lengths
    (the median rest length of the edges inside it) along the muscle: ``u >= h``, and
    since ``u`` is inversely proportional to ``n_w`` (eq. 6), ``n_w <= n_w u / h``.  At
    least one wrinkle is kept.  A region with no edge inside is left as it is."""
    n_w = muscle.sanitized().n_wrinkles
    if n_w < 0.5 or len(f.region) < 2 or len(edges) == 0:
        return None
    inside = np.zeros(len(rest), bool)
    inside[f.region] = True
    e = edges[inside[edges].all(axis=1)]
    if len(e) == 0:
        return None
    h = float(np.median(mesh.edge_lengths(rest, e)))
    if not h > 0.0 or f.half_cycle >= h:
        return None
    return max(int(np.floor(n_w * f.half_cycle / h)), 1)


def build_plan(rest, edges, tris, muscles, keep_out=None, smooth=True):
    """Precompute everything static.  ``rest`` (N, 3), ``edges`` (E, 2), ``tris`` (T, 3).

    ``keep_out`` (N,) in [0, 1], or None: a weight on every muscle's pull and wrinkles
    (``core.zones.keep_out``: 0 on the eyelids and the lips).  ``smooth``: smooth the
    amplitude A(eps) over half a wrinkle cycle (docs/model.md, "Coherent furrows")."""
    rest = np.asarray(rest, dtype=np.float64).reshape(-1, 3)
    n = len(rest)
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    tris = np.asarray(tris, dtype=np.int64).reshape(-1, 3)
    fields, problems, limits = [], [], []
    for i, m in enumerate(muscles):
        why = m.problem()
        if why:
            problems.append((i, why))
        f = muscle_field(rest, m)
        most = wrinkle_limit(rest, edges, m, f)
        if most is not None:
            asked = float(m.n_wrinkles) if np.isfinite(m.n_wrinkles) else m.sanitized().n_wrinkles
            limits.append((i, asked, most))
            f = muscle_field(rest, replace(m.sanitized(), n_wrinkles=most))
        fields.append(f)
    n_m = len(muscles)

    # Waters pull rows, all muscles concatenated
    pull_vert = np.concatenate([f.aoi for f in fields] + [np.zeros(0, np.int32)])
    pull_muscle = np.repeat(np.arange(n_m), [len(f.aoi) for f in fields])
    pull_weight = np.concatenate([f.pull_weight for f in fields] + [np.zeros(0)])
    if keep_out is not None:
        keep_out = np.clip(np.nan_to_num(np.asarray(keep_out, np.float64).ravel()), 0.0, 1.0)
        pull_weight = pull_weight * keep_out[pull_vert]
    # a linear muscle and a sphincter pull toward a point (the attachment, the centre)
    linear = np.array([m.sanitized().kind in (LINEAR, SPHINCTER) for m in muscles], bool)[pull_muscle]
    pull_target = np.array([f.target for f in fields]).reshape(-1, 3)[pull_muscle] * linear[:, None]
    pull_dir = np.array([f.pull_dir for f in fields]).reshape(-1, 3)[pull_muscle] * ~linear[:, None]
    muscle_pull = np.array([0.0 if m.sanitized().wrinkles_only else m.sanitized().pull for m in muscles])

    # (muscle, region vertex) rows and their incident edges, eq. 10 weights
    row_vert = np.concatenate([f.region for f in fields] + [np.zeros(0, np.int32)]).astype(np.int64)
    row_muscle = np.repeat(np.arange(n_m), [len(f.region) for f in fields])
    row_amp = np.concatenate([f.amplitude for f in fields] + [np.zeros(0)])
    if keep_out is not None:
        row_amp = row_amp * keep_out[row_vert]
    row_cdir = np.concatenate([f.contraction_dir for f in fields] + [np.zeros((0, 3))])
    row_env = np.concatenate([f.envelope if f.envelope is not None else np.ones(len(f.region))
                              for f in fields] + [np.zeros(0)])
    if keep_out is not None:
        row_env = row_env * keep_out[row_vert]
    row_family = families(fields)[row_muscle] if n_m else np.zeros(0, np.int64)
    row_along = np.concatenate([np.asarray(f.coords, np.float64).reshape(-1, 2)[:, 0]
                                if f.coords is not None else np.zeros(len(f.region)) for f in fields]
                               + [np.zeros(0)])
    keep = row_amp != 0.0
    cells, cell_w, n_cells, cell_total = _smoothing(fields, keep)
    row_vert, row_muscle, row_amp, row_cdir = row_vert[keep], row_muscle[keep], row_amp[keep], row_cdir[keep]
    row_env, row_family, row_along = row_env[keep], row_family[keep], row_along[keep]

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

    # triangles around the vertices that get a wrinkle height, for the skin normal there
    wrinkled = np.unique(row_vert)
    in_region = np.zeros(n, bool)
    in_region[wrinkled] = True
    tri_keep = in_region[tris].any(axis=1) if len(tris) else np.zeros(0, bool)
    tris = tris[tri_keep]

    used_edges, pair_edge_local = np.unique(pair_edge, return_inverse=True)
    verts = np.unique(np.concatenate([pull_vert, row_vert, edges[used_edges].ravel(), tris.ravel()]))
    local = np.full(n, -1, dtype=np.int64)
    local[verts] = np.arange(len(verts))
    wrinkled_local = np.unique(local[row_vert])
    pulls = bool(len(pull_vert)) and bool(np.any(muscle_pull > 0))
    folds = _blend_plan(local[row_vert], row_family, row_env, wrinkled_local) if len(row_vert) else None
    rings = _ring_plan(muscles, row_muscle, row_env, row_along)
    height_sum = mesh.Bins.of(local[row_vert], domain=wrinkled_local)
    footprint = combine.Footprint(offset_verts=verts.astype(np.int64) if pulls else np.zeros(0, np.int64),
                                  height_verts=verts[wrinkled_local].astype(np.int64))
    return Plan(
        n_verts=n,
        verts=verts.astype(np.int64),
        flat=verts[None, :].astype(np.int64) * 3 + np.arange(3)[:, None],
        pull_vert=local[pull_vert],
        pull_muscle=pull_muscle,
        pull_weight=pull_weight.astype(_F),
        pull_linear=linear.astype(_F),
        pull_target=np.ascontiguousarray(pull_target.T, dtype=_F),
        pull_dir=np.ascontiguousarray(pull_dir.T, dtype=_F),
        muscle_pull=muscle_pull,
        pull_sum=mesh.Bins.of(local[pull_vert]),
        edges=np.ascontiguousarray(local[edges[used_edges]].reshape(-1, 2).T),
        rest_length=rest_len32[used_edges],
        pair_edge=pair_edge_local.ravel(),
        pair_weight=pair_weight.astype(_F),
        pair_sum=mesh.Bins.of(pair_row, domain=np.arange(len(row_vert))),
        row_vert=local[row_vert],
        row_muscle=row_muscle,
        row_amp=row_amp.astype(_F),
        height_sum=height_sum,
        fold_weight=_fold_weights(muscles, fields, row_muscle, row_amp, height_sum),
        footprint=footprint,
        output=combine.build(n, tris, [footprint]),
        half_cycles=np.array([f.half_cycle for f in fields]),
        region_sizes=np.array([len(f.region) for f in fields]),
        problems=problems,
        limits=limits,
        smooth_cells=cells if smooth else None,
        smooth_weights=cell_w,
        smooth_norm=np.where(cell_total > 0, 1.0 / np.where(cell_total > 0, cell_total, 1.0), 0.0),
        smooth_size=n_cells,
        **(dict(zip(("blend_rows", "blend_pair", "blend_env", "blend_pair_vert", "blend_verts"), folds))
           if folds is not None else {}),
        **(dict(zip(("ring_rows", "ring_of", "ring_weight", "ring_total"), rings))
           if rings is not None else {}),
    )


def _fold_weights(muscles, fields, row_muscle, row_amp, height_sum):
    """Per row (float32), its share of the deepest fold at its vertex at rest: each muscle's
    :func:`zhang.fold_cap` (from its half cycle and shape) times the row's amplitude over
    the vertex's total, so ``height_sum.sum`` of them averages the caps of the muscles that
    wrinkle there (:func:`fold_caps` scales them by the frame's compression)."""
    caps = np.array([zhang.fold_cap(f.half_cycle, m.sanitized().alpha) for m, f in zip(muscles, fields)]
                    + [0.0])[row_muscle]
    weight = np.abs(row_amp)
    total = height_sum.sum(weight)
    total = np.append(np.where(total > 0.0, total, 1.0), 1.0)  # the last: rows in no bin
    share = weight / total[height_sum.index]
    return (share * caps).astype(_F)


def fold_caps(plan, eps):
    """The deepest each wrinkled vertex's fold gets this frame (``height_sum.keys``): the
    muscles' caps at rest (:func:`_fold_weights`) times ``1 - eps``, the rows' compression
    (eq. 10, clamped to [0, 1]): the skin that compresses narrows its furrows with it, the
    furrow's width over the shortened skin is ``(1 - eps)`` of its width at rest, and so is
    the depth a fold may reach without being a cut (:func:`zhang.soft_fold`)."""
    return plan.height_sum.sum(plan.fold_weight * (1.0 - np.clip(eps, 0.0, 1.0)))


def waters_pull(plan, skin, contraction):
    """The summed Waters pull (3, U) float32 at the plan's local vertices ``skin`` (3, U),
    or None when no muscle pulls.

    Every per-frame array here is one component per row, (3, K): 1-D gathers
    and sums are several times faster in NumPy than on interleaved (K, 3).
    """
    gain = (np.nan_to_num(np.asarray(contraction, dtype=np.float64)) * plan.muscle_pull).astype(_F)
    if len(plan.pull_vert) == 0 or not gain.any():
        return None
    out = np.zeros((3, len(plan.verts)), dtype=_F)
    k = gain[plan.pull_muscle] * plan.pull_weight
    rows = plan.pull_vert
    # linear muscles: toward the attachment from where the skin is now, never past it;
    # sheet muscles: parallel to the central fibre.  Both in one pass, masked per row.
    to = [plan.pull_target[c] - skin[c][rows] for c in range(3)]
    dist = np.sqrt(to[0] * to[0] + to[1] * to[1] + to[2] * to[2])
    scale = plan.pull_linear * np.minimum(k, _F(0.95) * dist) / np.maximum(dist, _F(1e-12))
    keys = plan.pull_sum.keys
    for c in range(3):
        out[c][keys] = plan.pull_sum.sum(to[c] * scale + plan.pull_dir[c] * k)
    return out


def compression(plan, pulled):
    """Eq. 10 per (muscle, region vertex) row; ``pulled`` is (3, U)."""
    if plan.edges.shape[1] == 0:
        return np.zeros(len(plan.row_vert), dtype=_F)
    e0, e1 = plan.edges
    length = np.sqrt(sum((c[e1] - c[e0]) ** 2 for c in pulled))
    tau = zhang.edge_shrinkage(plan.rest_length, length)
    return plan.pair_sum.sum(plan.pair_weight * tau[plan.pair_edge])


def _local_skin(plan, skin):
    """The plan's local skin (3, U) float32 and the mask of non-finite vertices (or None)."""
    return combine.local_skin(plan.flat, skin)


def _pull_and_heights(plan, s, contraction, strength):
    """Waters pull (3, U, or None when no muscle pulls), the pulled skin (3, U) and eq. 4's
    summed height W at the wrinkled local vertices ``plan.height_sum.keys``."""
    offset = waters_pull(plan, s, contraction)
    pulled = s if offset is None else s + offset
    eps = compression(plan, pulled)
    a = ring_gate(plan, eps, smooth_rows(plan, zhang.anisotropic(eps)))
    w = plan.row_amp * a
    height = zhang.soft_fold(blend(plan, a, w, plan.height_sum.sum(w)), fold_caps(plan, eps))
    return offset, pulled, height * _F(np.nan_to_num(strength))


def part(plan, skin, contraction, strength=1.0):
    """The muscles' share of a frame for the output stage (``core.combine``): the Waters
    pull (3, U) at ``plan.footprint.offset_verts`` (None when no muscle pulls) and eq. 4's
    height W at ``plan.footprint.height_verts``, for the skin ``skin`` (N, 3)."""
    if len(plan.verts) == 0:
        return combine.Contribution()
    s, _bad = _local_skin(plan, skin)
    offset, _pulled, height = _pull_and_heights(plan, s, contraction, strength)
    return combine.Contribution(offset=offset if len(plan.footprint.offset_verts) else None, height=height)


def evaluate(plan, skin, contraction, strength=1.0, out=None):
    """Offsets (N, 3) float32 for the skin positions ``skin`` (N, 3): the pull plus W along
    the normal of the pulled skin, through the same output stage as the add-on's frames.

    ``contraction`` holds one value per muscle.  ``out`` may be a preallocated
    (N, 3) float32 array; only the plan's vertices are written, so keep it zero
    elsewhere.  Non-finite input never produces non-finite output.
    """
    return combine.combine(plan.output, skin, [part(plan, skin, contraction, strength)], out)


def heights(plan, skin, contraction, strength=1.0):
    """Eq. 4's wrinkle height W (N,) float32 along the skin normal, per vertex (0 outside
    the wrinkling regions): the scalar field that :func:`evaluate` displaces along the
    normal, e.g. for baking it into a wrinkle map in UV space."""
    out = np.zeros(plan.n_verts, dtype=_F)
    if len(plan.verts) == 0:
        return out
    s, bad = _local_skin(plan, skin)
    _offset, _pulled, height = _pull_and_heights(plan, s, contraction, strength)
    local = np.zeros(len(plan.verts), dtype=_F)
    local[plan.height_sum.keys] = height
    if bad is not None:
        local[bad] = 0.0
    out[plan.verts] = np.nan_to_num(local, nan=0.0, posinf=0.0, neginf=0.0)
    return out


def formed_together(plan, muscles, strength=1.0):
    """The fully formed wrinkles of the muscles ``muscles`` (indices) together, each with
    ``A(eps) = 1`` and the others at 0, per vertex (N,) float32: summed where the folds are
    one family's, blended where folds of two families meet (:func:`blend`), exactly as
    :func:`heights` joins them on the face.  A sum of :func:`formed_heights` piles crossing
    folds into knots (the Corrugator's, the Procerus' and the Nasalis' at the root of the
    nose) that the geometric wrinkles never show.  The fold limit (:func:`fold_caps`) is
    left out: it depends on the frame's compression, for which a map's zone weight stands."""
    out = np.zeros(plan.n_verts, dtype=_F)
    if len(plan.verts) == 0:
        return out
    a = np.isin(plan.row_muscle, np.asarray(muscles, np.int64)).astype(_F)
    w = plan.row_amp * a
    local = np.zeros(len(plan.verts), dtype=_F)
    local[plan.height_sum.keys] = blend(plan, a, w, plan.height_sum.sum(w))
    out[plan.verts] = np.nan_to_num(local, nan=0.0, posinf=0.0, neginf=0.0) * _F(np.nan_to_num(strength))
    return out


def formed_heights(plan, muscle, strength=1.0):
    """The fully formed wrinkle of one muscle, ``H(w) At`` of eq. 4 with ``A(eps) = 1``,
    per vertex (N,) float32: its wrinkles as they are once the skin is compressed enough,
    whatever compresses it.  A wrinkle map holds this; the map's animated zone weight then
    plays the part of ``A(eps)`` (Jimenez et al. 2011, §1.2)."""
    out = np.zeros(plan.n_verts, dtype=_F)
    rows = plan.row_muscle == muscle
    if rows.any():
        local = np.bincount(plan.row_vert[rows], weights=plan.row_amp[rows], minlength=len(plan.verts))
        out[plan.verts] = local.astype(_F) * _F(np.nan_to_num(strength))
    return out

