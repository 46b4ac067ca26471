# SPDX-License-Identifier: GPL-3.0-or-later
"""Cubic Bézier curves in Blender's layout, sampled: the wrinkle curves' furrows (Bando et al.
2002, §6) and the shedding tears' paths are drawn as Blender curves and read through it."""

import numpy as np


def bezier(points, handles_left, handles_right, n, *, cyclic=False):
    """Samples of a multi-segment cubic Bezier curve in Blender's layout: segment i runs
    through ``points[i], handles_right[i], handles_left[i + 1], points[i + 1]`` (and, if
    ``cyclic``, a last segment back to point 0).  ``n`` samples per segment at
    ``t = 0, 1/n, ...``, plus the final point: (n * segments + 1, dim) for dim 2 or 3."""
    p, hl, hr = (np.asarray(a, dtype=np.float64) for a in (points, handles_left, handles_right))
    if p.ndim != 2 or p.shape[1] not in (2, 3) or hl.shape != p.shape or hr.shape != p.shape:
        raise ValueError("Bezier control points and handles must be matching (N, 2) or (N, 3) arrays")
    if len(p) < 2:
        raise ValueError("A Bezier curve needs at least 2 control points")
    if not (np.isfinite(p).all() and np.isfinite(hl).all() and np.isfinite(hr).all()):
        raise ValueError("A Bezier control point or handle is not a finite number")
    n = int(n)
    if n < 1:
        raise ValueError("Sample a Bezier segment at least once (n >= 1)")
    nxt = np.roll(np.arange(len(p)), -1) if cyclic else np.arange(1, len(p))
    cur = np.arange(len(nxt))
    ctrl = np.stack([p[cur], hr[cur], hl[nxt], p[nxt]], axis=1)  # (S, 4, dim)
    t = np.arange(n) / n
    s = 1.0 - t
    basis = np.stack([s * s * s, 3 * t * s * s, 3 * t * t * s, t * t * t], axis=1)  # (n, 4)
    out = np.einsum("tk,skd->std", basis, ctrl).reshape(-1, p.shape[1])
    return np.concatenate([out, ctrl[-1, 3][None]])
