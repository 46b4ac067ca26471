# SPDX-License-Identifier: GPL-3.0-or-later
"""Muscle geometry: Zhang 2005 eqs. 1-3 and 13-14, and Waters' 1987 skin pull.

A muscle is described by ``muscle.Muscle`` in the face's local coordinates.  For a
linear or a sheet muscle, :func:`linear_field` and :func:`sheet_field` (chosen by
``fields.muscle_field``) evaluate, for every rest vertex, the static quantities the
per-frame evaluation needs (a ``muscle.MuscleField``):

* the Waters area of influence and its pull weight ``a * r`` (Waters' angular
  and radial fall-off),
* the Zhang wrinkling region ``S_w`` and the static part of the wrinkle
  amplitude ``H(w) At`` (eqs. 4-7, 12, 15),
* the unit direction of contraction used to weight edges in eq. 10.

Waters, linear muscle (docs/model.md, "Muscles (Waters)")::

    p' = p + k a r (v1 - p) / D,   D = |p - v1|
    a  = cos(pi/2 * angle / Omega)                 (0 beyond Omega)
    r  = cos((1 - D/Rs) pi/2)        D <= Rs
         cos((D - Rs)/(Rf - Rs) pi/2) Rs < D <= Rf  (0 beyond Rf)

Choices, with reasons:

* ``a = cos(pi/2 * angle/Omega)`` instead of Waters' ``cos(angle)`` cut off at
  Omega: Waters' own notes allow it, and it removes the step where the pull would jump
  from ``cos(Omega)`` to 0 at the cone's side and tear the skin.  A sheet's
  pull across its width uses eq. 15's profile (flat to h_c, then to 0 at Ws/2).
* ``Rf`` is Zhang's ``R`` (``Ls`` for a sheet): both papers mean the end of the
  area of influence.  ``Rs`` is the distance from the attachment to the
  insertion, so the pull is strongest at the insertion, where the muscle
  meets the skin.  Skin between attachment and insertion is compressed, skin
  beyond it is stretched; the wrinkles appear only where A(eps) sees compression.
* ``k = contraction * pull * Rs`` with ``pull < 2/pi``: since
  ``r <= pi/2 D/Rs``, no point can overshoot the attachment (``k a r < D``).
* The sheet muscle measures ``l`` along the central fibre and ``h`` across it
  in the sheet's plane, and ignores points further than ``depth`` from that
  plane, so a forehead sheet cannot reach the back of the skull.
"""

import numpy as np

from ..mesh import smoothstep
from . import irregularity, zhang
from .muscle import MuscleField, sheet_frame

_EPS = 1e-9


def radial_falloff(dist, r_s, r_f, squared=False):
    """Waters' radial fall-off ``r`` (see module doc).  ``r_s`` is clamped to ``r_f``.

    Inside ``r_s`` it is Waters' ``sin(pi/2 D/Rs)``, or with ``squared`` its square, which
    starts with zero slope: the skin at the attachment (a cone's apex, a one-sided sheet's
    attachment line, both borders of the area of influence) then has no strain step.
    Beyond ``r_s`` it is ``1 - smoothstep`` down to 0 at ``r_f``, which reaches 0 with zero
    slope (Waters' cosine ends with a kink, and the skin shows a crease along the border of
    the area of influence)."""
    r_s = max(min(r_s, r_f), _EPS)
    inner = np.sin(0.5 * np.pi * np.clip(dist / r_s, 0.0, 1.0))
    if squared:
        inner = inner * inner
    span = max(r_f - r_s, _EPS)
    outer = 1.0 - smoothstep((dist - r_s) / span)
    return np.where(dist <= r_s, inner, np.where(dist <= r_f, outer, 0.0))


def angular_falloff(gamma):
    """A linear muscle's pull across its cone, ``cos²(pi/2 gamma)`` for ``gamma = phi/Phi``:
    1 with zero slope on the central fibre, 0 with zero slope on the cone's side (C¹)."""
    c = np.cos(0.5 * np.pi * np.clip(gamma, 0.0, 1.0))
    return c * c


def across_falloff(h, h_c, half_width):
    """Sheet pull across the fibres: 1 up to ``h_c``, then ``1 - smoothstep`` to 0 at Ws/2.

    Waters' cosine across the whole width pulls each sheet's centre hardest, so
    side-by-side sheets (the three Frontalis) scallop the brows and bend the
    furrows into arcs.  A smoothstep ramp is a partition of unity: two sheets
    whose ramps overlap exactly pull the skin between them as much as their cores.
    """
    span = max(half_width - h_c, _EPS)
    return 1.0 - smoothstep((np.asarray(h) - h_c) / span)


def depth_falloff(depth, half_thickness):
    """A sheet's weight by distance from its plane: 1 up to half of ``depth``, then
    ``1 - smoothstep`` to 0 at ``depth`` (a hard cut shears the skin along the cut)."""
    half = 0.5 * half_thickness
    return 1.0 - smoothstep((np.asarray(depth) - half) / max(half, _EPS))


def region_start(m, length, lo=0.0):
    """Where the wrinkling region starts along ``l`` (eqs. 3, 14) for a muscle whose extent
    along ``l`` is ``[lo, length]``: ``lambda_w`` of the way."""
    return lo + m.lambda_w * (length - lo)


def region_end(m):
    """Where a sheet's wrinkling region ends along ``l``: ``region_end`` of its length Ls
    (1: Zhang's eq. 14, the sheet's end).  The pull still reaches Ls, and eq. 6's half cycle
    is still measured over the whole sheet, so a shorter region keeps the furrows where they
    are and only leaves out those past its end (the Frontalis draws the brows' skin down to
    below the brows, but its lines are the forehead's)."""
    return m.region_end * m.length


def _wrinkle_amplitude(l, across, across_c, across_max, m, length, lo=0.0, points=None, end=None):
    """``H(w) At`` (eqs. 5-7, with a C¹ attenuation in place of eqs. 12/15) plus the optional
    end fade, for a muscle whose extent along ``l`` is ``[lo, length]`` (``lo`` is 0 but for a
    sheet that reaches behind its attachment line) and whose region ends at ``end``
    (``length`` unless given).  With ``points`` (the region's rest
    positions) and an irregularity, the phase ``l`` is warped and the envelope multiplied by
    the depth factor of :func:`irregularity.apply`; the region's ends and the end fade stay
    on the unwarped ``l``."""
    span = length - lo  # the muscle's whole extent along l (R, Ls, or (1 + b) Ls)
    u = zhang.half_cycle(span, m.lambda_w, m.n_wrinkles)
    if m.n_wrinkles < 0.5:  # n_w = 0: no wrinkles, the muscle still pulls
        return np.zeros_like(l), float(u), np.zeros_like(l)
    phase, depth = np.asarray(l), None
    if points is not None and m.irregularity > 0.0:
        phase, depth = irregularity.apply(points, phase, u, m.seed, m.irregularity)
    w = zhang.cycle_position(phase - lo, m.lambda_w, span, u)
    env = zhang.attenuation(across, across_c, across_max)
    if m.fade_ends:
        env = env * zhang.edge_fade(l, region_start(m, length, lo), length if end is None else end, u)
    if depth is not None:
        env = env * depth
    return zhang.shape_function(w, u, m.k0, m.alpha) * env, float(u), env


def linear_field(rest, m):
    m_a, m_i = m.attachment[0], m.insertion[0]
    fibre = m_i - m_a
    r_s = np.linalg.norm(fibre)
    fibre = fibre / r_s
    rel = rest - m_a
    dist = np.sqrt(np.einsum("ij,ij->i", rel, rel))
    cos_phi = np.clip((rel @ fibre) / np.maximum(dist, _EPS), -1.0, 1.0)
    phi = np.arccos(cos_phi)  # eq. 1-2: angle to the central fibre
    l = dist * cos_phi  # eq. 1
    lam = l / m.length  # eq. 2
    gamma = phi / m.spread

    aoi = np.flatnonzero((dist <= m.length) & (gamma <= 1.0) & (dist > _EPS))
    pull_weight = r_s * angular_falloff(gamma[aoi]) * radial_falloff(dist[aoi], r_s, m.length, squared=True)

    region = np.flatnonzero((lam >= m.lambda_w) & (lam <= 1.0) & (gamma <= 1.0))  # eq. 3
    amp, u, env = _wrinkle_amplitude(l[region], phi[region], m.spread_c, m.spread, m, m.length,
                                     points=rest[region])
    cdir = -rel[region] / np.maximum(dist[region], _EPS)[:, None]  # x_i -> m_A
    return MuscleField(
        aoi.astype(np.int32), pull_weight, np.zeros(3), m_a.copy(),
        region.astype(np.int32), amp, cdir, u, _plane_coords(rel[region], fibre), env,
    )


def _plane_coords(rel, fibre):
    """(along ``fibre``, across it) of the points ``rel`` (K, 3): the across axis lies in the
    points' best-fit plane (their smallest principal axis is its normal)."""
    if len(rel) < 3:
        return np.stack([rel @ fibre, np.zeros(len(rel))], axis=1)
    centred = rel - rel.mean(axis=0)
    _w, vecs = np.linalg.eigh(centred.T @ centred)
    side = np.cross(fibre, vecs[:, 0])
    n = np.linalg.norm(side)
    if n < 1e-6:  # the fibre is the plane's normal: any perpendicular will do
        side = np.cross(fibre, vecs[:, 1])
        n = np.linalg.norm(side)
    return np.stack([rel @ fibre, rel @ (side / n)], axis=1)


def sheet_field(rest, m):
    """A sheet, and with ``back_reach`` b > 0 the skin behind its attachment line too: that
    skin (up to B = b Ls behind the line) is pulled toward the line with Waters' profile
    over (B/2, B), so the skin converges on the attachment line from both sides, as the
    forehead does on the Frontalis' line of convergence (docs/model.md).  Each side's
    weight is its own Rs times ``sin(pi/2 D/Rs)``, so both start with the slope pi/2 at
    the line and the field is C¹ there (a one-sided sheet uses the squared profile
    instead, see :func:`radial_falloff`).  The wrinkling region then runs over the whole
    extent ``[-B, Ls]``, with Zhang's lambda measured over it, up to :func:`region_end`."""
    origin, fibre, across, normal, r_s = sheet_frame(m)
    rel = rest - origin
    l = rel @ fibre  # distance from the attachment line, along the fibres
    h = np.abs(rel @ across)  # distance from the central fibre
    depth = np.abs(rel @ normal)
    back = m.back_reach * m.length
    inside = (2.0 * h <= m.spread) & (depth <= m.depth)
    slab = depth_falloff(depth, m.depth)

    half_w = 0.5 * m.spread
    h_c = min(m.spread_c, half_w)
    aoi = np.flatnonzero(inside & (l != 0.0) & (l <= m.length) & (l >= -back))
    la = l[aoi]
    front = la > 0.0
    if back > 0.0:
        r = np.where(front, r_s * radial_falloff(la, r_s, m.length),
                     -0.5 * back * radial_falloff(-la, 0.5 * back, back))
    else:
        r = r_s * radial_falloff(la, r_s, m.length, squared=True)
    pull_weight = across_falloff(h[aoi], h_c, half_w) * slab[aoi] * r

    start = region_start(m, m.length, -back)
    end = region_end(m)
    region = np.flatnonzero(inside & (l >= start) & (l <= end))  # eq. 14
    amp, u, env = _wrinkle_amplitude(l[region], h[region], h_c, half_w, m, m.length, -back,
                                     points=rest[region], end=end)
    amp, env = amp * slab[region], env * slab[region]
    cdir = np.broadcast_to(-fibre, (len(region), 3)).copy()
    coords = np.stack([l[region], rel[region] @ across], axis=1)
    return MuscleField(
        aoi.astype(np.int32), pull_weight, -fibre, np.zeros(3),
        region.astype(np.int32), amp, cdir, u, coords, env,
    )
