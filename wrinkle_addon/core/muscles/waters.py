# SPDX-License-Identifier: GPL-3.0-or-later
"""Muscle geometry: Zhang 2005 eqs. 1-3 and 13-14, and Waters' 1987 skin pull.

A muscle is described by :class:`Muscle` in the face's local coordinates.  For
each muscle, :func:`muscle_field` evaluates, for every rest vertex, the static
quantities the per-frame evaluation needs:

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

from dataclasses import dataclass

import numpy as np

from . import zhang

LINEAR = 0
SHEET = 1
MAX_PULL = 0.6  # < 2/pi, see module doc
_EPS = 1e-9


@dataclass(frozen=True)
class Muscle:
    """One muscle in the face's local space.  Lengths are local units.

    ``attachment``/``insertion`` are (1, 3) points for a linear muscle and
    (2, 3) line end points for a sheet muscle.
    """

    kind: int
    attachment: np.ndarray
    insertion: np.ndarray
    length: float  # R (linear) or Ls (sheet): the extent of the area of influence
    spread: float  # Phi in radians (linear) or Ws (sheet)
    spread_c: float  # phi_c in radians (linear) or h_c (sheet): where attenuation starts
    lambda_w: float = 0.4
    n_wrinkles: float = 4.0
    k0: float = 0.001
    alpha: float = 1.0
    pull: float = 0.3
    depth: float = 0.05  # sheet only: half thickness of the slab around the sheet plane
    wrinkles_only: bool = False
    fade_ends: bool = True

    def sanitized(self):
        """A copy with NaN/inf replaced and every parameter clamped to its valid range."""

        def f(x, lo, hi, default):
            x = float(x)
            if not np.isfinite(x):
                x = default
            return min(max(x, lo), hi)

        def pts(p):
            p = np.asarray(p, dtype=np.float64).reshape(-1, 3)
            return np.nan_to_num(p, nan=0.0, posinf=0.0, neginf=0.0)

        return Muscle(
            kind=SHEET if int(self.kind) == SHEET else LINEAR,
            attachment=pts(self.attachment),
            insertion=pts(self.insertion),
            length=f(self.length, 0.0, 1e9, 0.0),
            spread=f(self.spread, 0.0, 1e9 if self.kind == SHEET else np.pi, 0.0),
            spread_c=f(self.spread_c, 0.0, 1e9, 0.0),
            lambda_w=f(self.lambda_w, 0.0, 0.999, 0.4),
            n_wrinkles=f(self.n_wrinkles, 0.0, 1e4, 0.0),
            k0=f(self.k0, -1e9, 1e9, 0.0),
            alpha=f(self.alpha, -10.0, 10.0, 1.0),
            pull=f(self.pull, 0.0, MAX_PULL, 0.0),
            depth=f(self.depth, 0.0, 1e9, 0.0),
            wrinkles_only=bool(self.wrinkles_only),
            fade_ends=bool(self.fade_ends),
        )

    def problem(self):
        """A human-readable reason why this muscle has no effect, or ``None``."""
        m = self.sanitized()
        if m.kind == LINEAR:
            if np.linalg.norm(m.insertion[0] - m.attachment[0]) < _EPS:
                return "its attachment equals its insertion"
            if m.length <= _EPS:
                return "its radius R is 0"
            if m.spread <= _EPS:
                return "its angle is 0"
        else:
            if m.attachment.shape[0] < 2 or m.insertion.shape[0] < 2:
                return "a sheet muscle needs two attachment and two insertion points"
            frame = sheet_frame(m)
            if frame is None:
                return "its attachment line and insertion line do not span a sheet"
            if m.length <= _EPS:
                return "its length Ls is 0"
            if m.spread <= _EPS:
                return "its width Ws is 0"
        return None


@dataclass
class MuscleField:
    """Static per-vertex quantities of one muscle (indices into the rest mesh)."""

    aoi: np.ndarray  # int32 vertex indices in the Waters area of influence
    pull_weight: np.ndarray  # Rs * a * r at those vertices (multiply by contraction * pull)
    pull_dir: np.ndarray  # (3,) fixed pull direction for sheets; zeros for linear muscles
    target: np.ndarray  # (3,) attachment point mA (linear) - pull goes toward it
    region: np.ndarray  # int32 vertex indices in the wrinkling region S_w (eq. 3 / 14)
    amplitude: np.ndarray  # H(w) * At * fade at region vertices (eq. 4 without A(eps))
    contraction_dir: np.ndarray  # (len(region), 3) unit direction of contraction (eq. 10)
    half_cycle: float  # u (eq. 6)


def sheet_frame(m):
    """Orthonormal frame of a sheet muscle: origin mAc, fibre f, across a, normal n.

    Returns ``None`` when the attachment and insertion lines are degenerate.
    """
    a_c = m.attachment[:2].mean(axis=0)
    i_c = m.insertion[:2].mean(axis=0)
    fibre = i_c - a_c
    fl = np.linalg.norm(fibre)
    if fl < _EPS:
        return None
    fibre = fibre / fl
    across = (m.attachment[1] - m.attachment[0]) + (m.insertion[1] - m.insertion[0])
    across = across - np.dot(across, fibre) * fibre
    al = np.linalg.norm(across)
    if al < _EPS:
        return None
    across = across / al
    return a_c, fibre, across, np.cross(fibre, across), fl


def radial_falloff(dist, r_s, r_f):
    """Waters' radial fall-off ``r`` (see module doc).  ``r_s`` is clamped to ``r_f``."""
    r_s = max(min(r_s, r_f), _EPS)
    inner = np.sin(0.5 * np.pi * np.clip(dist / r_s, 0.0, 1.0))
    span = max(r_f - r_s, _EPS)
    outer = np.cos(0.5 * np.pi * np.clip((dist - r_s) / span, 0.0, 1.0))
    return np.where(dist <= r_s, inner, np.where(dist <= r_f, outer, 0.0))


def across_falloff(h, h_c, half_width):
    """Sheet pull across the fibres: 1 up to ``h_c``, then ``1 - smoothstep`` to 0 at Ws/2.

    Waters' cosine across the whole width pulls each sheet's centre hardest, so
    side-by-side sheets (the three Frontalis) scallop the brows and bend the
    furrows into arcs.  A smoothstep ramp is a partition of unity: two sheets
    whose ramps overlap exactly pull the skin between them as much as their cores.
    """
    span = max(half_width - h_c, _EPS)
    s = np.clip((np.asarray(h) - h_c) / span, 0.0, 1.0)
    return 1.0 - s * s * (3.0 - 2.0 * s)


def _empty_field():
    z = np.zeros(0, dtype=np.int32)
    return MuscleField(z, np.zeros(0), np.zeros(3), np.zeros(3), z, np.zeros(0), np.zeros((0, 3)), 0.0)


def muscle_field(rest, muscle):
    """Evaluate one muscle's static field over the rest positions ``rest`` (N, 3)."""
    m = muscle.sanitized()
    if m.problem() is not None or len(rest) == 0:
        return _empty_field()
    rest = np.asarray(rest, dtype=np.float64)
    if m.kind == LINEAR:
        return _linear_field(rest, m)
    return _sheet_field(rest, m)


def _wrinkle_amplitude(l, across, across_c, across_max, m, length):
    """``H(w) At`` (eqs. 5-7, 12/15) plus the optional end fade."""
    u = zhang.half_cycle(length, m.lambda_w, m.n_wrinkles)
    if m.n_wrinkles < 0.5:  # n_w = 0: no wrinkles, the muscle still pulls
        return np.zeros_like(l), float(u)
    w = zhang.cycle_position(l, m.lambda_w, length, u)
    amp = zhang.shape_function(w, u, m.k0, m.alpha) * zhang.attenuation(across, across_c, across_max)
    if m.fade_ends:
        amp = amp * zhang.edge_fade(l, m.lambda_w * length, length, u)
    return amp, float(u)


def _linear_field(rest, m):
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
    ang = np.cos(0.5 * np.pi * gamma[aoi])
    pull_weight = r_s * ang * radial_falloff(dist[aoi], r_s, m.length)

    region = np.flatnonzero((lam >= m.lambda_w) & (lam <= 1.0) & (gamma <= 1.0))  # eq. 3
    amp, u = _wrinkle_amplitude(l[region], phi[region], m.spread_c, m.spread, m, m.length)
    cdir = -rel[region] / np.maximum(dist[region], _EPS)[:, None]  # x_i -> m_A
    return MuscleField(
        aoi.astype(np.int32), pull_weight, np.zeros(3), m_a.copy(),
        region.astype(np.int32), amp, cdir, u,
    )


def _sheet_field(rest, m):
    origin, fibre, across, normal, r_s = sheet_frame(m)
    rel = rest - origin
    l = rel @ fibre  # distance from the attachment line, along the fibres
    h = np.abs(rel @ across)  # distance from the central fibre
    depth = np.abs(rel @ normal)
    lam = l / m.length  # eq. 13
    gamma = 2.0 * h / m.spread
    inside = (gamma <= 1.0) & (depth <= m.depth)

    half_w = 0.5 * m.spread
    aoi = np.flatnonzero(inside & (l > 0.0) & (lam <= 1.0))
    ang = across_falloff(h[aoi], min(m.spread_c, half_w), half_w)
    pull_weight = r_s * ang * radial_falloff(l[aoi], r_s, m.length)

    region = np.flatnonzero(inside & (lam >= m.lambda_w) & (lam <= 1.0))  # eq. 14
    amp, u = _wrinkle_amplitude(l[region], h[region], min(m.spread_c, half_w), half_w, m, m.length)
    cdir = np.broadcast_to(-fibre, (len(region), 3)).copy()
    return MuscleField(
        aoi.astype(np.int32), pull_weight, -fibre, np.zeros(3),
        region.astype(np.int32), amp, cdir, u,
    )
