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

import math

import numpy as np

from .. import checks

T0 = 1.2  # t at the drop's birth: t + cos(u) >= 0.2 > 0
OUTLINE_TIP = 0.2  # a shedding tear's tip keeps this fraction of its width


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


BEAD = 1.5  # how much a running tear's head swells over its trail (bead_profile)


def bead_profile(arc, length, head, bead=BEAD):
    """A running tear's thickness factor along its path (arc length ``arc``, (n,)) when it
    has run ``length``: 1 behind its head; over the ``head`` (``x`` from 0 to 1 at the front)
    the water gathered there, ``(1 + bead sin^2(pi x)) sqrt(1 - x^2)``: it swells into a bead
    (``bead`` = 1.5: up to 2.2 times as thick, C¹ where it leaves the trail) and ends in a
    round front that meets the skin steeply, as water does (a contact angle near 90
    degrees); 0 ahead of it.  Its curved back and front are what catch the lights."""
    a = np.asarray(arc, np.float64)
    head = max(float(head), 1e-12)
    x = np.clip((a - (float(length) - head)) / head, 0.0, 1.0)
    return (1.0 + float(bead) * np.sin(np.pi * x) ** 2) * np.sqrt(np.maximum(1.0 - x * x, 0.0))


MAX_ROUGHNESS = 1e100  # beyond it the MLS sums of the bumps overflow


def rise_noise(coords, fraction, amplitude, seed, eps, degree=1):
    """The paper's roughness of the tear's top surface (step four): at a seeded random
    ``fraction`` of the points ``coords`` (n, 2) (the top surface's parameters, in scene
    units) a bump of height up to ``amplitude`` is raised, the rest stay 0, and the moving
    least squares fit (:func:`..mls.fit`, weight ``1 / (r^2 + eps^2)``) smooths them.  The
    noise only rises (clipped at 0): the tear never sinks into the skin."""
    from . import mls

    c = checks.finite("The roughness' coordinates", coords).reshape(-1, 2)
    fraction = checks.number("The roughness' fraction of bumps", fraction)
    amplitude = checks.number("The roughness' height", amplitude, hi=MAX_ROUGHNESS)
    seed = checks.whole("The roughness' seed", seed, 0)
    rng = np.random.default_rng(seed)
    bumps = np.zeros(len(c))
    k = int(round(min(max(fraction, 0.0), 1.0) * len(c)))
    if k == 0 or amplitude <= 0 or len(c) < 3:
        return bumps
    pick = rng.permutation(len(c))[:k]
    bumps[pick] = rng.uniform(0.0, amplitude, k)
    return np.maximum(mls.fit(c, bumps, c, degree=degree, eps=eps), 0.0)


def outline(arc, length, head, tip=OUTLINE_TIP):
    """The tear's half width along its path, as a fraction (``arc`` (n,), ``length`` long):
    1 in the middle, a quarter circle over ``head`` at its start and at its end (never below
    ``tip``, so the last row keeps a small round tip), as the paper's smoothed head."""
    a = np.asarray(arc, np.float64)
    head = max(float(head), 1e-12)
    x0 = np.clip((head - a) / head, 0.0, 1.0)
    x1 = np.clip((a - (float(length) - head)) / head, 0.0, 1.0)
    return np.sqrt(np.maximum((1.0 - x0 * x0) * (1.0 - x1 * x1), tip * tip))


def strip(path, normals, half_width, n_across, head=None):
    """A shedding tear's base surface (step one): a band ``2 half_width`` wide along a path
    on the skin, ``path`` (k, 3) samples with the skin's unit ``normals`` (k, 3) there, the
    band across in the skin's tangent plane (normal x tangent); with ``head``, its ends
    rounded over that length (:func:`outline`).  Returns ``(positions (k n, 3), arc (k n,),
    across (k n,) in [-1, 1])``, row by row along the path.  The caller snaps the positions
    back onto a curved skin."""
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
    hw = float(half_width) * (np.ones(len(p)) if head is None else outline(arc, arc[-1], head))
    pos = p[:, None, :] + (hw[:, None] * w[None, :])[..., None] * side[:, None, :]
    return pos.reshape(-1, 3), np.repeat(arc, len(w)), np.tile(w, len(p))


def shell(base, normals, across, k, thickness, gap, rise=None, factor=None):
    """The closed tear (step two): a bottom sheet ``gap`` above the base surface ``base``
    (k rows of n points, :func:`strip`) along the skin's ``normals`` (k n, 3), and a top
    ``(thickness factor + rise) sqrt(1 - w^2)`` above it (a lens across the tear, meeting the
    bottom at both sides; ``factor`` (k n,) the reveal and end taper in [0, 1], ``rise``
    (k n,) >= 0 the roughness).  Where the top meets the bottom (the sides, and every
    point of zero thickness) the two share one vertex, so the surface is closed and has no
    zero-thickness sliver.  Returns ``(positions (V, 3), quads (F, 4), partner (V,))``, the
    bottom's faces turned toward the skin, the top's away from it; ``partner`` is the bottom
    vertex under each vertex (itself on the bottom), which the reveal lowers the top onto."""
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
    partner = np.concatenate([np.arange(len(base)), np.flatnonzero(~shared)])
    return positions, np.concatenate([down[keep], up[keep]]), partner


def resample(path, step):
    """The polyline ``path`` (k, 3) resampled at equal arc-length steps of at most ``step``
    (the linear subdivision of step one), its ends kept; repeated points dropped first.
    Raises ValueError for a path of fewer than two distinct points, or a step that would
    need more than ``checks.MAX_SAMPLES`` samples."""
    p = checks.finite("A tear's path", path).reshape(-1, 3)
    with np.errstate(over="ignore"):  # a path beyond the float range is refused below
        seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
    if len(p) > 1:
        keep = np.concatenate([[True], seg > 1e-12])
        p, seg = p[keep], seg[keep[1:]]
    if len(p) < 2:
        raise ValueError("a tear's path needs at least two distinct points")
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    n = max(2, math.ceil(checks.samples("A tear's path", arc[-1], step)) + 1)
    s = np.linspace(0.0, arc[-1], n)
    return np.stack([np.interp(s, arc, p[:, i]) for i in range(3)], 1)


def spine(points, step):
    """The middle line of a patch (the vertices of the selected faces, ``points`` (n, 3)),
    for a tear that runs along it: the points ordered along the patch's main axis, averaged
    in bins ``step`` long.  Returns ``(path (k, 3), half_width)``, the half width the median
    over the bins of half their spread across (the patch's second axis).  A patch that
    doubles back along its main axis is not followed (draw a curve for that).  Raises
    ValueError for a patch with no length."""
    p = np.asarray(points, np.float64).reshape(-1, 3)
    if len(p) < 2:
        raise ValueError("a tear's path needs at least two points")
    centre = p.mean(axis=0)
    _u, _s, vt = np.linalg.svd(p - centre, full_matrices=False)
    along, side = (p - centre) @ vt[0], (p - centre) @ vt[1]
    length = float(np.ptp(along))
    if length <= 1e-12:
        raise ValueError("a tear's path has no length")
    bins = np.minimum(((along - along.min()) / max(float(step), 1e-12)).astype(np.int64),
                      max(1, int(length / max(float(step), 1e-12))))
    used, inverse, counts = np.unique(bins, return_inverse=True, return_counts=True)
    path = np.stack([np.bincount(inverse, p[:, i]) / counts for i in range(3)], 1)
    lo = np.full(len(used), np.inf)
    hi = np.full(len(used), -np.inf)
    np.minimum.at(lo, inverse, side)
    np.maximum.at(hi, inverse, side)
    if len(path) < 2:
        raise ValueError("a tear's path needs at least two points")
    return path, 0.5 * float(np.median(hi - lo))


def taper(arc, length, head):
    """The finished tear's thickness factor along its path (``arc`` (n,), ``length`` long):
    rounded over ``head`` at its start and at its head (C¹ both)."""
    a = np.asarray(arc, np.float64)
    return reveal_profile(a, length, head) * (1.0 - reveal_profile(a, head, head))


def bind(points, a, b, c):
    """Bind ``points`` (k, 3) to the triangles ``(a, b, c)`` (k, 3 each), one per point: the
    barycentric ``weights`` (k, 3) of each point's projection on its triangle's plane and its
    ``lift`` (k,) along the triangle's unit normal ``(b - a) x (c - a)``, so that
    ``weights . (a, b, c) + lift * normal`` gives the point back, and follows the triangle
    as it moves (the weights are not clipped: a point beyond an edge stays where it is)."""
    p, a, b, c = (np.asarray(v, np.float64).reshape(-1, 3) for v in (points, a, b, c))
    n = np.cross(b - a, c - a)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    lift = np.einsum("ij,ij->i", p - a, n)
    q = p - lift[:, None] * n
    v0, v1, v2 = b - a, c - a, q - a
    d00, d01, d11 = (np.einsum("ij,ij->i", x, y) for x, y in ((v0, v0), (v0, v1), (v1, v1)))
    d20, d21 = np.einsum("ij,ij->i", v2, v0), np.einsum("ij,ij->i", v2, v1)
    den = d00 * d11 - d01 * d01
    den = np.where(np.abs(den) > 1e-300, den, 1.0)
    v = (d11 * d20 - d01 * d21) / den
    w = (d00 * d21 - d01 * d20) / den
    return np.stack([1.0 - v - w, v, w], 1), lift


def bound(weights, lift, a, b, c):
    """The points bound by :func:`bind` on the triangles ``(a, b, c)`` as they are now."""
    n = np.cross(b - a, c - a)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    return weights[:, :1] * a + weights[:, 1:2] * b + weights[:, 2:] * c + lift[:, None] * n


class Tear:
    """A shedding tear's mesh (steps one to four) on its base (:func:`strip`, ``k`` rows,
    ``half_width``): ``positions`` (V, 3), ``quads`` (F, 4), ``arc`` (V,) the arc length
    along the path under each vertex, ``across`` (V,) where across the tear it lies (-1 to
    1), ``partner`` (V,) the bottom vertex under each
    (itself on the bottom), and ``centre`` (V,) the vertex at the middle of each vertex's row
    on its own sheet.  ``thickness`` and ``gap`` as in :func:`shell`; the top's
    roughness rises up to ``roughness x thickness`` at a ``bumps`` fraction of its points
    (:func:`rise_noise`, smoothed over the half width); the start and the ``head`` (default:
    the width) are rounded (:func:`taper`)."""

    def __init__(self, base, normals, across, arc, k, half_width, thickness, gap, roughness=0.0,
                 bumps=0.15, seed=0, head=None):
        across = np.asarray(across, np.float64)
        arc = np.asarray(arc, np.float64)
        half_width = float(half_width)
        head = 2.0 * half_width if head is None else float(head)
        factor = taper(arc, float(arc.max()), min(head, 0.5 * float(arc.max())))
        rise = rise_noise(np.stack([arc, across * half_width], 1), bumps, float(roughness) * float(thickness),
                          seed, eps=half_width)
        self.positions, self.quads, self.partner = shell(base, normals, across, k, thickness, gap,
                                                         rise=rise, factor=factor)
        self.arc = arc[self.partner]
        self.across = across[self.partner]
        self.half_width = half_width
        self.length = float(arc.max())
        nb, n = len(arc), len(arc) // int(k)
        top = np.arange(nb)  # each base point's top vertex (itself where the two meet)
        top[self.partner[nb:]] = np.arange(nb, len(self.positions))
        middle = (self.partner // n) * n + n // 2  # the bottom at the middle of each row
        self.centre = np.where(np.arange(len(self.positions)) < nb, middle, top[middle])
