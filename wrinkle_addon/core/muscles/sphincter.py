# SPDX-License-Identifier: GPL-3.0-or-later
"""The sphincter muscle: Waters' third muscle type, and the wrinkle model for it that Zhang,
Sim & Tan name as future work ("develop the wrinkle model corresponding to the sphincter
muscles that surround the eyes and mouth").  docs/model.md, "Sphincter muscles", gives the
equations and says which part is whose.

A sphincter is an ellipse round an opening (the eye, the mouth) in the face's local space::

    c          its centre (``Muscle.attachment[0]``)
    a, b       its semi-axes (``Muscle.insertion[0] - c``, ``Muscle.insertion[1] - c``): the
               ring of fibres; ``a`` points at the middle of the wrinkling sector
    rho        the normalised elliptical radius of a point, 1 on the ring
    theta      its angle round the centre, 0 on ``a``

Its fibres run round the opening.  Contracted, it draws the skin toward the centre
(Waters), which shortens the skin *along* the fibres, round the opening; the skin then folds
*across* them, so its wrinkles are radial lines: crow's feet at the outer eye corner, the
vertical lines above the upper lip.

Pull (Waters' sphincter, with C¹ profiles as every fall-off here)::

    x' = x + c_k pull s(rho) (c - x)
    s  = 1                                     rho <= 1
         1 - smoothstep((rho - 1)/(R - 1))     1 < rho <= R    (R: ``Muscle.length``)

Wrinkles (Zhang's eqs. 4-11 carried over, with the fibre's direction round the ring)::

    l   = theta |b|                       along the fibre: arc length on the ring at theta = 0
    u   = Theta |b| / n_w                 eq. 6 over the sector's length 2 Theta |b|
    w   = (l + Theta |b|) mod 2u          eq. 7: a furrow on each cycle end, radial
    At  = 1 - smoothstep((|theta| - theta_c)/(Theta - theta_c))    eq. 12 in the angle
    Ar  = the radial band rho_w <= rho <= R, faded in and out over RAMP of its width
    W   = H(w) At Ar A(eps)               eps along the fibre's tangent (eq. 10)

With an irregularity, ``l`` and the envelope go through ``irregularity.apply`` as for the
other muscles (``l`` is a distance round the ring, so the furrows never cross).

``rho_w = lambda_w R``.  Points further than ``depth`` from the ellipse's plane are ignored
(the slab of a sheet muscle), so an eye's sphincter cannot reach the temple's far side.
"""

import numpy as np

from ..mesh import smoothstep
from . import irregularity, zhang
from .muscle import MuscleField, ring_frame
from .waters import depth_falloff

RAMP = 0.3  # the radial fade at each end of the wrinkling band, as a fraction of its width
_EPS = 1e-9


def half_cycle(a, b, sector, n_wrinkles):
    """Eq. 6 for a sphincter with semi-axes ``a``, ``b`` (3,): ``u = Theta |b| / n_w``, the
    sector's arc ``2 Theta |b|`` on the ring over ``2 n_w`` (``b`` taken perpendicular to
    ``a``, as :func:`frame` does)."""
    a = np.asarray(a, np.float64)
    b = np.asarray(b, np.float64)
    na = np.linalg.norm(a)
    if na > _EPS:
        b = b - np.dot(b, a) / (na * na) * a
    return float(sector * np.linalg.norm(b) / max(n_wrinkles, 1e-6))


def coordinates(rest, fr):
    """(rho, theta, distance from the plane, unit fibre tangent (N, 3)) of ``rest`` (N, 3)."""
    c, a, b, n, ra, rb = fr
    rel = rest - c
    pa, pb = (rel @ a) / ra, (rel @ b) / rb
    rho = np.sqrt(pa * pa + pb * pb)
    theta = np.arctan2(pb, pa)
    # the ellipse through the point, rho (ra cos t a + rb sin t b): its tangent at theta
    tangent = np.outer(-np.sin(theta) * ra, a) + np.outer(np.cos(theta) * rb, b)
    tangent /= np.maximum(np.linalg.norm(tangent, axis=1), _EPS)[:, None]
    return rho, theta, np.abs(rel @ n), tangent


def pull_profile(rho, reach):
    """``s(rho)``: 1 inside the ring, ``1 - smoothstep`` to 0 at ``reach`` (C¹)."""
    span = max(reach - 1.0, _EPS)
    return np.where(rho <= 1.0, 1.0, 1.0 - smoothstep((rho - 1.0) / span))


def band(rho, start, end, fade=True):
    """The radial wrinkling band ``start <= rho <= end``, faded in and out over ``RAMP`` of
    its width with the C¹ ramp of eq. 12 (the furrows taper at both ends); without
    ``fade``, 1 inside it."""
    inside = (rho >= start) & (rho <= end)
    if not fade:
        return inside.astype(np.float64)
    t = max(RAMP * (end - start), _EPS)
    return np.where(inside, smoothstep((rho - start) / t) * smoothstep((end - rho) / t), 0.0)


def field(rest, m):
    """The static field (``muscle.MuscleField``) of the sanitized sphincter ``m`` over the
    rest positions ``rest`` (N, 3)."""
    fr = ring_frame(m)
    c, _a, _b, _n, _ra, rb = fr
    rho, theta, depth, tangent = coordinates(rest, fr)
    reach = m.length
    inside = depth <= m.depth
    slab = depth_falloff(depth, m.depth)
    dist = np.linalg.norm(rest - c, axis=1)

    aoi = np.flatnonzero(inside & (rho <= reach) & (dist > _EPS))
    pull_weight = dist[aoi] * pull_profile(rho[aoi], reach) * slab[aoi]

    sector = m.spread
    start = m.lambda_w * reach
    region = np.flatnonzero(inside & (rho >= start) & (rho <= reach) & (np.abs(theta) <= sector))
    th, r = theta[region], rho[region]
    l = th * rb
    u = half_cycle(m.insertion[0] - c, m.insertion[1] - c, sector, m.n_wrinkles)
    env = zhang.attenuation(np.abs(th), min(m.spread_c, sector), sector)
    env = env * band(r, start, reach, m.fade_ends) * slab[region]
    phase = l + sector * rb
    if m.irregularity > 0.0:  # the furrows' spacing, course and depth vary (docs/model.md)
        phase, depth_factor = irregularity.apply(rest[region], phase, u, m.seed, m.irregularity)
        env = env * depth_factor
    if m.n_wrinkles < 0.5:
        amp = np.zeros(len(region))
    else:
        w = zhang.cycle_position(phase, 0.0, 0.0, u)
        amp = zhang.shape_function(w, u, m.k0, m.alpha) * env
    return MuscleField(
        aoi.astype(np.int32), pull_weight, np.zeros(3), c.copy(),
        region.astype(np.int32), amp, tangent[region], u, np.stack([l, r * rb], axis=1), env,
    )
