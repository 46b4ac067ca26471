# SPDX-License-Identifier: GPL-3.0-or-later
"""The muscle record: one muscle's parameters (:class:`Muscle`), their valid ranges, the frame
each kind is placed in, and the static field every kind evaluates to (:class:`MuscleField`).

Waters' linear and sheet muscles are in ``waters.py``, the sphincter in ``sphincter.py``;
``fields.py`` chooses between them.  This module names no kind's field, so both kinds import
it and neither imports the other's choice.
"""

from dataclasses import dataclass

import numpy as np

from . import irregularity as irregular

LINEAR = 0
SHEET = 1
SPHINCTER = 2  # Waters' third type, an ellipse round an opening: sphincter.py
MAX_PULL = 0.6  # < 2/pi: no point can overshoot the attachment (waters.py)
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
    back_reach: float = 0.0  # sheet only: reach behind the attachment line, as a fraction of Ls
    region_end: float = 1.0  # sheet only: where the wrinkling region ends, as a fraction of Ls
    irregularity: float = 0.0  # natural irregularity of the furrows, 0 to 4 (0: Zhang's regular ones)
    seed: int = 0  # the irregularity's pattern: the face's, so that neighbouring muscles join

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
            kind=int(self.kind) if int(self.kind) in (SHEET, SPHINCTER) else LINEAR,
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
            back_reach=f(self.back_reach, 0.0, 10.0, 0.0),
            region_end=f(self.region_end, 0.0, 1.0, 1.0),
            irregularity=f(self.irregularity, 0.0, irregular.MAX_AMOUNT, 0.0),
            seed=_seed(self.seed),
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
        elif m.kind == SPHINCTER:
            if m.attachment.shape[0] < 1 or m.insertion.shape[0] < 2:
                return "a sphincter muscle needs a centre and the ends of its two axes"
            if ring_frame(m) is None:
                return "its two axes do not span an ellipse"
            if m.length < 1.0:
                return "its outer reach is less than 1 (inside its own ring)"
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
    coords: np.ndarray = None  # (len(region), 2) the region's points in the muscle's plane:
    # (along the fibre, across it), local units; where A(eps) is smoothed (system.build_plan)
    envelope: np.ndarray = None  # (len(region),) At * fade (* slab) in [0, 1], times the
    # irregularity's depth factor (about 1): the amplitude's envelope without the wrinkle
    # profile H(w) (refinement)


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


def ring_frame(m):
    """(centre, unit a, unit b, normal, |a|, |b|) of the sanitized sphincter ``m``, or None
    when its axes do not span an ellipse (``b`` is made perpendicular to ``a``)."""
    if m.attachment.shape[0] < 1 or m.insertion.shape[0] < 2:
        return None
    c = m.attachment[0]
    a = m.insertion[0] - c
    ra = float(np.linalg.norm(a))
    if ra < _EPS:
        return None
    a = a / ra
    b = m.insertion[1] - c
    b = b - np.dot(b, a) * a
    rb = float(np.linalg.norm(b))
    if rb < _EPS:
        return None
    b = b / rb
    return c, a, b, np.cross(a, b), ra, rb


def empty_field():
    z = np.zeros(0, dtype=np.int32)
    return MuscleField(z, np.zeros(0), np.zeros(3), np.zeros(3), z, np.zeros(0), np.zeros((0, 3)), 0.0,
                       np.zeros((0, 2)), np.zeros(0))


def _seed(seed):
    """``seed`` as an int (0 for a value that is not a finite number)."""
    try:
        return int(seed)
    except (TypeError, ValueError, OverflowError):
        return 0
