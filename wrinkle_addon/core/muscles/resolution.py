# SPDX-License-Identifier: GPL-3.0-or-later
"""The resolution the muscles' wrinkles need (Zhang 2005 §3): the muscles' rule for Refine
Wrinkling Regions, which ``core.refinement`` and ``glue/refine.py`` then carry out.

**The rule.**  Every half cycle ``u`` (eq. 6) must span at least ``factor`` edges wherever a
wrinkle has amplitude: an edge is too long when it is longer than ``u / factor`` of a muscle
whose static amplitude ``H(w) At`` (with the end fade) is non-zero at one of its end points or
at its midpoint (so a long edge that crosses a region without a vertex in it counts too).
Faded ends and everything outside the regions need nothing.
"""

import numpy as np

from .. import mesh
from .fields import muscle_field


def edge_limits(rest, edges, muscles, factor=4.0, keep_out=None):
    """The longest length each edge (E,) may have: ``u / factor`` of the finest muscle whose
    wrinkle has amplitude at either end point or the midpoint, ``inf`` elsewhere.

    Where a muscle's amplitude envelope ``a`` (``MuscleField.envelope``: the attenuation and
    end fade ramps, in [0, 1]) is below 1, the limit grows by ``sqrt(1 / a)``, up to 2×:
    sampling a profile of amplitude ``a`` with edges of length ``h`` misses it by about
    ``a (pi h / 2u)² / 2``, so one absolute error everywhere needs ``h ∝ u sqrt(1 / a)``.
    ``keep_out`` (N,) weights
    the amplitude per vertex (``core.zones``: 0 on the eyelids and lips, which need nothing)."""
    rest = np.asarray(rest, dtype=np.float64).reshape(-1, 3)
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    n = len(rest)
    points = np.concatenate([rest, 0.5 * (rest[edges[:, 0]] + rest[edges[:, 1]])])
    weight = np.ones(len(points))
    if keep_out is not None:
        keep_out = np.asarray(keep_out, np.float64).ravel()
        weight = np.concatenate([keep_out, np.maximum(keep_out[edges[:, 0]], keep_out[edges[:, 1]])])
    limit = np.full(len(points), np.inf)
    factor = max(float(factor), 1e-6)
    for m in muscles:
        f = muscle_field(points, m)
        if len(f.region) and f.half_cycle > 0:
            env = np.asarray(f.envelope) * weight[f.region] * (np.asarray(f.amplitude) != 0.0)
            live = env > 0.0
            if not live.any():
                continue
            grow = np.minimum(np.sqrt(1.0 / np.maximum(env[live], 1e-300)), 2.0)
            np.minimum.at(limit, f.region[live], grow * f.half_cycle / factor)
    return np.minimum(np.minimum(limit[edges[:, 0]], limit[edges[:, 1]]), limit[n:])


def refine_edges(rest, edges, muscles, factor=4.0, keep_out=None):
    """Indices of the edges that break the rule (longer than :func:`edge_limits`)."""
    rest = np.asarray(rest, dtype=np.float64).reshape(-1, 3)
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    if len(edges) == 0:
        return np.zeros(0, np.int64)
    limits = edge_limits(rest, edges, muscles, factor, keep_out)
    return np.flatnonzero(mesh.edge_lengths(rest, edges) > limits)
