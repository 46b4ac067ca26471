# SPDX-License-Identifier: GPL-3.0-or-later
"""Dripping tears ("Pattern functions and tears", §4.1): the teardrop surface.

The text was extracted from a PDF; the formula reads::

    x = a sin(u) cos(v) / (t ? cos(u))    y = a sin(u) sin(v) / (t ? cos(u))
    z = b t cos(u) + l t

with ``?`` printed as ``x``.  Read as a product (``t x cos u``) the surface is two open
funnels, not a drop.  Read as ``t + cos(u)`` it is a closed drop for ``t > 1``: with
``u`` in [0, pi] from its top to its bottom and ``v`` around it, the radius
``a sin(u) / (t + cos(u))`` is pointed at the top (u = 0: ``a u / (t + 1)``) and round at
the bottom (u = pi: ``a (pi - u) / (t - 1)``); as ``t`` grows the drop grows longer (its
height is ``2 b t``), thinner (its width ``~ 2 a / t``) and rounder, which is the paper's
"the teardrop continually changes shape as it falls".  We take that reading, and for the
fall: ``t = t0 + tau`` with ``tau`` the drop's age in seconds and ``t0`` = 1.2 (the
printed ``t`` starts where the denominator is not near 0), ``z`` measured downward from
the drop's top at birth, so the drop hangs from where it forms and falls at speed ``l``::

    z = b t cos(u) - b t0 - l tau           (the frame's z up; the top starts at 0)

``a``, ``b`` (scene units) are the drop's sizes, ``l`` (scene units per second) its speed.
"""

import numpy as np

T0 = 1.2  # t at the drop's birth: t + cos(u) >= 0.2 > 0


def teardrop(u, v, tau, alpha, beta, lam, t0=T0):
    """The teardrop's points (..., 3) at the parameters ``u`` in [0, pi] (top to bottom) and
    ``v`` in [0, 2 pi] (around), ``tau`` seconds after it formed."""
    u = np.asarray(u, np.float64)
    v = np.asarray(v, np.float64)
    t = float(t0) + max(float(tau), 0.0)
    r = alpha * np.sin(u) / (t + np.cos(u))
    z = beta * t * np.cos(u) - beta * t0 - lam * max(float(tau), 0.0)
    return np.stack([r * np.cos(v), r * np.sin(v), z], axis=-1)


def age(seconds, start, period, lifetime):
    """The drop's age in seconds at scene time ``seconds`` for drops born every ``period``
    seconds from ``start`` on, or None when no drop shows (before ``start``, or past
    ``lifetime`` in its cycle)."""
    if seconds < start or period <= 0:
        return None
    tau = (seconds - start) % period
    return tau if tau < lifetime else None


# --------------------------------------------------------------------------- shedding tears
def revealed(tau, start, speed):
    """How far along its path a shedding tear has run ``tau`` seconds after it started: the
    paper's ``h = s + c t`` (step five) with ``s`` = ``start`` (the length shown at once) and
    ``c`` = ``speed``; never below 0.  Monotone in ``tau`` for ``speed >= 0``."""
    return np.maximum(float(start) + float(speed) * np.asarray(tau, np.float64), 0.0)


def reveal_profile(arc, length, head):
    """The tear's thickness factor along its path (arc length ``arc``, (n,)) when it has run
    ``length``: 1 behind its head, falling to 0 at the front over the rounded ``head`` (C¹,
    ``1 - smoothstep``), 0 ahead of it."""
    a = np.asarray(arc, np.float64)
    head = max(float(head), 1e-12)
    x = np.clip((a - (float(length) - head)) / head, 0.0, 1.0)
    return 1.0 - x * x * (3.0 - 2.0 * x)


def rise_noise(coords, fraction, amplitude, seed, eps, degree=1):
    """The paper's roughness of the tear's top surface (step four): at a seeded random
    ``fraction`` of the points ``coords`` (n, 2) (the top surface's parameters, in scene
    units) a bump of height up to ``amplitude`` is raised, the rest stay 0, and the moving
    least squares fit (:func:`..mls.fit`, weight ``1 / (r^2 + eps^2)``) smooths them.  The
    noise only rises (clipped at 0): the tear never sinks into the skin."""
    from . import mls

    c = np.asarray(coords, np.float64).reshape(-1, 2)
    rng = np.random.default_rng(int(seed))
    bumps = np.zeros(len(c))
    k = int(round(np.clip(fraction, 0.0, 1.0) * len(c)))
    if k == 0 or amplitude <= 0 or len(c) < 3:
        return bumps
    pick = rng.permutation(len(c))[:k]
    bumps[pick] = rng.uniform(0.0, float(amplitude), k)
    return np.maximum(mls.fit(c, bumps, c, degree=degree, eps=eps), 0.0)


def strip(path, normals, half_width, n_across):
    """A shedding tear's base surface (step one): a band ``2 half_width`` wide along a path
    on the skin, ``path`` (k, 3) samples with the skin's unit ``normals`` (k, 3) there, the
    band across in the skin's tangent plane (normal x tangent).  Returns ``(positions
    (k n, 3), arc (k n,), across (k n,) in [-1, 1])``, row by row along the path.  The
    caller snaps the positions back onto a curved skin."""
    p = np.asarray(path, np.float64).reshape(-1, 3)
    n = np.asarray(normals, np.float64).reshape(-1, 3)
    if len(p) < 2:
        raise ValueError("a tear's path needs at least two points")
    seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
    if not (seg > 0).all():
        raise ValueError("a tear's path has repeated points")
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    tangent = np.gradient(p, arc, axis=0)
    side = np.cross(n, tangent)
    side /= np.maximum(np.linalg.norm(side, axis=1, keepdims=True), 1e-300)
    w = np.linspace(-1.0, 1.0, int(n_across))
    pos = p[:, None, :] + (half_width * w)[None, :, None] * side[:, None, :]
    return pos.reshape(-1, 3), np.repeat(arc, len(w)), np.tile(w, len(p))


def shell(base, normals, across, k, thickness, gap, rise=None, factor=None):
    """The closed tear (step two): a bottom sheet ``gap`` above the base surface ``base``
    (k rows of n points, :func:`strip`) along the skin's ``normals`` (k n, 3), and a top
    ``(thickness factor + rise) sqrt(1 - w^2)`` above it (a lens across the tear, meeting the
    bottom at both sides; ``factor`` (k n,) the reveal and end taper in [0, 1], ``rise``
    (k n,) >= 0 the roughness).  Where the top meets the bottom (the sides, and every
    point of zero thickness) the two share one vertex, so the surface is closed and has no
    zero-thickness sliver.  Returns ``(positions (V, 3), quads (F, 4))``, the bottom's
    faces turned toward the skin, the top's away from it."""
    base = np.asarray(base, np.float64).reshape(-1, 3)
    nrm = np.asarray(normals, np.float64).reshape(-1, 3)
    w = np.asarray(across, np.float64).reshape(-1)
    k = int(k)
    n = len(base) // k
    f = np.ones(len(base)) if factor is None else np.clip(np.asarray(factor, np.float64), 0.0, 1.0)
    r = np.zeros(len(base)) if rise is None else np.maximum(np.asarray(rise, np.float64), 0.0)
    lens = np.sqrt(np.clip(1.0 - w * w, 0.0, 1.0))  # 0 at both sides: the top meets the bottom
    height = (float(thickness) * f + r * (f > 0)) * lens
    bottom = base + float(gap) * nrm
    top = bottom + height[:, None] * nrm
    shared = height <= 0.0
    top_index = np.where(shared, np.arange(len(base)), len(base) + np.cumsum(~shared) - 1)
    positions = np.concatenate([bottom, top[~shared]])
    g = np.arange(len(base)).reshape(k, n)
    a, b, c, d = g[:-1, :-1].ravel(), g[:-1, 1:].ravel(), g[1:, 1:].ravel(), g[1:, :-1].ravel()
    down = np.stack([a, d, c, b], 1)  # toward the skin
    up = top_index[np.stack([a, b, c, d], 1)]
    keep = ~(up == down[:, [0, 3, 2, 1]]).all(axis=1)  # a top face flat on the bottom: none
    return positions, np.concatenate([down[keep], up[keep]])
