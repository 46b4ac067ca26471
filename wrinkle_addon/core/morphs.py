# SPDX-License-Identifier: GPL-3.0-or-later
"""Wrinkle morph targets: a frame range's wrinkle offsets as a few targets and their weights.

An engine plays morph targets (blend shapes) with animated weights, not a point cache.
The offsets of F frames, ``D`` (F, V, 3), are approximated as ``D ≈ W T``: K targets ``T``
(K, V, 3) and their weights per frame ``W`` (F, K), ``d_f ≈ Σ_k w_fk t_k``.

The truncated singular value decomposition of ``D`` flattened to (F, 3V) is the best
rank-K approximation in the least-squares sense (Eckart & Young 1936), so it needs the
fewest targets for a given error.  K is the smallest number whose reconstruction keeps
every vertex of every frame within ``tolerance`` (the length of the error vector), up to
``max_targets``; or the number asked for.

Engines and Blender's own importer clamp morph weights to [0, 1] (Blender's shape-key
sliders start at 0), so the weights are made to lie in [0, 1], exactly: with the singular
weights ``w_fk`` ranging over ``[lo_k, hi_k]`` (each component's sign chosen so that its
largest weight is positive, and ``lo_k`` taken as 0 when none is negative),

    d_f = Σ_k w_fk t_k = C + Σ_k u_fk T_k,   u_fk = (w_fk - lo_k) / (hi_k - lo_k) ∈ [0, 1],
    T_k = (hi_k - lo_k) t_k,   C = Σ_k lo_k t_k,

and the constant ``C``, when it is not zero, is one more target (the last) whose weight
is 1 on every frame of the range.  It takes one of the ``max_targets``.

Only the vertices that some frame moves take part (the wrinkles' footprint), which keeps
the decomposition small on a whole head; the others are 0 in every target.
"""

from dataclasses import dataclass

import numpy as np

from . import checks


@dataclass
class MorphTargets:
    weights: np.ndarray  # (F, K) float32
    targets: np.ndarray  # (K, V, 3) float32
    max_error: float  # the largest error vector's length over every frame and vertex
    mean_error: float  # its mean over the frames and the vertices the wrinkles move
    frame_max_error: np.ndarray  # (F,) the largest error on each frame
    within_tolerance: bool  # False when max_targets were not enough
    constant: bool = False  # the last target is the constant C, weight 1 throughout

    @property
    def count(self):
        """The number of targets, the constant included."""
        return len(self.targets)

    @property
    def components(self):
        """The number of singular components (the targets but the constant)."""
        return self.count - int(self.constant)


def _residual_norms(residual):
    """Per-frame, per-vertex error lengths (F, n) of a residual (F, 3n)."""
    f = residual.shape[0]
    return np.sqrt(np.sum(residual.reshape(f, -1, 3) ** 2, axis=2))


def fit(offsets, tolerance, max_targets=16, count=0):
    """Morph targets of ``offsets`` (F, V, 3): see the module docstring.

    ``tolerance`` in the offsets' units; ``count`` > 0 asks for exactly that many
    singular components (at most F and the moved vertices' 3n; the constant target
    comes on top), 0 for the fewest within the tolerance, with at most ``max_targets``
    targets in all.
    """
    d = checks.finite("offsets", offsets)
    if d.ndim != 3 or d.shape[2] != 3:
        raise ValueError(f"offsets must be (frames, vertices, 3), not {d.shape}")
    tolerance = checks.number("tolerance", tolerance, lo=0.0)
    max_targets = checks.whole("max_targets", max_targets, lo=1, hi=1024)
    count = checks.whole("count", count, lo=0, hi=1024)
    f, v = d.shape[:2]
    moved = np.flatnonzero(np.any(d != 0.0, axis=(0, 2)))
    flat = d[:, moved].reshape(f, -1)
    rank_cap = min(f, flat.shape[1])
    if rank_cap:
        u, s, vt = np.linalg.svd(flat, full_matrices=False)
    else:
        u, s, vt = np.zeros((f, 0)), np.zeros(0), np.zeros((0, 0))
    limit = min(count if count else max_targets, rank_cap)
    k, norms = _rank(flat, u, s, vt, tolerance, limit, exact=bool(count))
    weights, basis, constant = _unit_weights(u[:, :k] * s[:k], vt[:k])
    if constant and not count and k + 1 > max_targets:  # the constant needs a slot of its own
        k, norms = _rank(flat, u, s, vt, tolerance, max_targets - 1, exact=False)
        weights, basis, constant = _unit_weights(u[:, :k] * s[:k], vt[:k])
    targets = np.zeros((len(basis), v, 3), np.float32)
    targets[:, moved] = basis.reshape(len(basis), len(moved), 3)
    max_error = float(norms.max(initial=0.0))
    return MorphTargets(
        weights=weights.astype(np.float32),
        targets=targets,
        max_error=max_error,
        mean_error=float(norms.mean()) if norms.size else 0.0,
        frame_max_error=norms.max(axis=1, initial=0.0).astype(np.float32),
        within_tolerance=max_error <= tolerance,
        constant=constant,
    )


def _rank(flat, u, s, vt, tolerance, limit, exact):
    """The number of singular components (``limit`` if ``exact``, else the fewest up to
    ``limit`` within ``tolerance``) and the error lengths (F, n) they leave."""
    residual = flat.copy()
    norms = _residual_norms(residual)
    k = 0
    while k < limit and (exact or norms.max(initial=0.0) > tolerance):
        residual -= np.outer(u[:, k] * s[k], vt[k])
        norms = _residual_norms(residual)
        k += 1
    return k, norms


def _unit_weights(w, basis):
    """Weights (F, K) and basis (K, 3n) -> weights in [0, 1] and targets with the same
    product, plus a constant target when a weight was negative (module docstring)."""
    if not w.shape[1]:
        return w, basis, False
    peak = w[np.argmax(np.abs(w), axis=0), np.arange(w.shape[1])]
    sign = np.where(peak < 0.0, -1.0, 1.0)
    w, basis = w * sign, basis * sign[:, None]
    lo = np.minimum(w.min(axis=0), 0.0)
    span = w.max(axis=0) - lo
    span = np.where(span > 0.0, span, 1.0)
    unit = (w - lo) / span
    targets = basis * span[:, None]
    if not np.any(lo < 0.0):
        return unit, targets, False
    c = lo @ basis
    return (np.concatenate([unit, np.ones((len(w), 1))], axis=1),
            np.concatenate([targets, c[None]], axis=0), True)


def reconstruct(weights, targets):
    """The offsets (F, V, 3) that ``weights`` (F, K) of ``targets`` (K, V, 3) give."""
    w = np.asarray(weights, np.float64)
    t = np.asarray(targets, np.float64)
    return np.tensordot(w, t, axes=(1, 0)).astype(np.float32)


def fit_normals(weights, missing):
    """The morph-target normal deltas (K, N, 3) that best give ``missing`` (F, N, 3), what
    an engine's normal lacks on each frame, as ``Σ_k w_fk dN_k`` with the targets' weights
    (F, K): the least-squares solution, for every vertex at once (one F x K system with N x 3
    right-hand sides)."""
    w = checks.finite("weights", weights)
    r = checks.finite("missing normals", missing)
    if w.ndim != 2 or r.ndim != 3 or len(w) != len(r):
        raise ValueError(f"weights {w.shape} and missing normals {r.shape} do not match")
    if not w.shape[1]:
        return np.zeros((0,) + r.shape[1:], np.float32)
    solution = np.linalg.lstsq(w, r.reshape(len(r), -1), rcond=None)[0]
    return solution.reshape((w.shape[1],) + r.shape[1:]).astype(np.float32)
