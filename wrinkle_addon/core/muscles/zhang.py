# SPDX-License-Identifier: GPL-3.0-or-later
"""Zhang, Sim & Tan 2005, "Simulating Wrinkles in Facial Expressions on an
Anatomy-Based Face": the scalar wrinkle functions, equations 5-12 and 15.

Everything here is element-wise NumPy; arrays in, arrays out.

Reading of the garbled equation 5 (the PDF extraction lost the fraction bars)::

    t    = (w - u) / u                       in [-1, 1] over one cycle [0, 2u]
    H(w) =  k0 (1 + t^2)^alpha t + d          0 <= w <= u    (t <= 0)
    H(w) = -k0 (1 + t^2)^alpha t + d          u <  w <= 2u   (t >  0)
         = d - k0 |t| (1 + t^2)^alpha

The sign flip between the two branches only makes sense for an odd factor
``t``, so the extraction kept the structure intact.  The furrows sit at the
cycle ends (w = 0, 2u) where the slope jumps by ``2 k0 2^alpha (1 + alpha) / u``:
they are sharp.  The bulge sits mid-cycle (w = u) where the slope jump is only
``2 k0 / u``; with the default alpha = 1 the furrow is four times sharper than
the bulge, which is the paper's "the furrow is sharp and the bulge is round".

Equation 8 (zero mean, skin incompressibility) fixes ``d`` in closed form::

    integral_0^{2u} H dw = 2u d - 2 k0 u integral_0^1 t (1+t^2)^alpha dt = 0
    d = k0 (2^(alpha+1) - 1) / (2 (alpha + 1))      (alpha != -1)
    d = k0 ln(2) / 2                                (alpha == -1)

Departure: a fold is never a cut.  With the default ``alpha = 1`` the furrow (where H < 0)
is ``0.82 u`` wide and ``1.25 k0`` deep, so at ``k0 = 0.25 u`` it is only 2.6 times as wide
as it is deep: a thin dark slit where the skin is compressed most.  :func:`soft_fold`
limits the depth to a :data:`FOLD_RATIO`-th of the furrow's width (:func:`furrow_width`),
leaving shallower furrows as they are (docs/model.md, "Soft folds").
"""

import numpy as np

from ..mesh import (
    edge_shrinkage,  # noqa: F401  (eq. 9, shared with the other methods)
    smoothstep,
)

_EPS = 1e-12
FOLD_RATIO = 4.0  # a furrow's width over the greatest depth soft_fold lets it reach
FOLD_KNEE = 0.7  # the share of that depth below which soft_fold changes nothing


def bulge_height(k0, alpha):
    """Eq. 8 solved for the bulge height parameter ``d`` (closed form, see module doc)."""
    k0 = np.asarray(k0, dtype=np.float64)
    alpha = np.asarray(alpha, dtype=np.float64)
    a1 = alpha + 1.0
    near = np.abs(a1) < 1e-9
    safe = np.where(near, 1.0, a1)
    d = np.where(near, 0.5 * np.log(2.0), (np.power(2.0, a1) - 1.0) / (2.0 * safe))
    return k0 * d


def half_cycle(length, lambda_w, n_wrinkles):
    """Eq. 6: the half cycle length ``u = (1 - lambda_w) R / (2 n_w)``.

    ``length`` is R for a linear muscle and Ls for a sheet muscle.  ``n_wrinkles``
    is clamped to at least 1e-6 so that ``n_w = 0`` cannot divide by zero.
    """
    return (1.0 - lambda_w) * length / (2.0 * np.maximum(n_wrinkles, 1e-6))


def cycle_position(l, lambda_w, length, u):
    """Eq. 7: map the longitudinal distance ``l`` periodically into ``[0, 2u)``.

    ``w = l - lambda_w R - int((l - lambda_w R) / 2u) 2u``; for the region
    ``l >= lambda_w R`` this is the non-negative remainder.
    """
    period = np.maximum(2.0 * u, _EPS)
    return np.mod(np.asarray(l) - lambda_w * length, period)


def shape_function(w, u, k0, alpha):
    """Eq. 5: wrinkle cross-section ``H(w)`` (see the module doc for the reading)."""
    u = np.maximum(u, _EPS)
    t = (np.asarray(w) - u) / u
    t = np.clip(t, -1.0, 1.0)
    return bulge_height(k0, alpha) - k0 * np.abs(t) * np.power(1.0 + t * t, alpha)


def anisotropic(eps):
    """Eq. 11: ``A(eps) = cos(pi/2 (1 - eps))`` for ``0 <= eps <= 1``, 0 for stretch.

    Compression above 1 cannot occur (edges cannot shrink by more than their
    length) and is clamped to 1.
    """
    e = np.clip(eps, 0.0, 1.0)
    return np.where(np.asarray(eps) > 0.0, np.cos(0.5 * np.pi * (1.0 - e)), 0.0)


def attenuation_paper(x, x_c, x_max):
    """Eqs. 12 and 15 as printed: ``At = 1`` up to ``x_c``, then ``-1/2 (1 + s^2) s + 1``
    with ``s = (x - x_c) / (x_max - x_c)``, reaching exactly 0 at ``x_max`` and 0 beyond.
    It reaches 0 with slope -2 (per unit s): the furrows end in a crease at the region's
    side, and two regions side by side sum to a bump (1.375 where both are at s = 1/2).
    Kept for reference; :func:`attenuation` is what the model uses."""
    x = np.asarray(x, dtype=np.float64)
    span = np.maximum(x_max - x_c, _EPS)
    s = np.clip((x - x_c) / span, 0.0, 1.0)
    return np.where(x > x_max, 0.0, 1.0 - 0.5 * (1.0 + s * s) * s)


def attenuation(x, x_c, x_max):
    """Eqs. 12 and 15's attenuation, C¹: ``At = 1`` up to ``x_c``, then ``1 - smoothstep(s)``
    with ``s = (x - x_c) / (x_max - x_c)``, reaching 0 at ``x_max`` with zero slope, and 0
    beyond.  Departure from the paper's cubic (:func:`attenuation_paper`), which ends with
    a slope: this one ends smoothly, and it is a partition of unity, so the furrows of two
    sheets whose ramps overlap (the Frontalis preset) keep one depth across the border.

    Eq. 12 uses the angle phi with (phi_c, Phi); eq. 15 uses the distance h from
    the central fibre with (h_c, Ws/2).
    """
    x = np.asarray(x, dtype=np.float64)
    span = np.maximum(x_max - x_c, _EPS)
    return np.where(x > x_max, 0.0, 1.0 - smoothstep((x - x_c) / span))


def edge_fade(l, start, end, u):
    """Fade over the first and last half cycle of the wrinkling region.

    Not in the paper: at both ends of the region (lambda = lambda_w and
    lambda = 1) eq. 7 puts w = 0, where H is a furrow of depth
    ``k0 2^alpha - d``.  Cutting it off there leaves a cliff in the skin, so the
    amplitude is ramped with the same profile as eq. 12 over one half cycle ``u``
    at each end (C¹: zero slope where it reaches 0 and 1).  Switch it off per muscle for the
    paper's model.
    """
    u = np.maximum(u, _EPS)
    a = np.clip((np.asarray(l) - start) / u, 0.0, 1.0)
    b = np.clip((end - np.asarray(l)) / u, 0.0, 1.0)
    return attenuation(1.0 - a, 0.0, 1.0) * attenuation(1.0 - b, 0.0, 1.0)


def furrow_width(alpha):
    """The furrow's width where ``H < 0`` (eq. 5 with eq. 8's ``d``), in half cycles ``u``:
    the same for every ``k0``.  Measured on 4001 samples of a half cycle (any ``alpha``)."""
    t = np.linspace(0.0, 1.0, 4001)
    below = shape_function(t + 1.0, 1.0, 1.0, float(alpha)) < 0.0
    return 2.0 * float(below.mean())


def fold_cap(u, alpha):
    """The greatest depth :func:`soft_fold` lets a furrow of half cycle ``u`` and shape
    ``alpha`` reach: ``furrow_width(alpha) u / FOLD_RATIO``."""
    return furrow_width(alpha) * max(float(u), 0.0) / FOLD_RATIO


def soft_fold(h, cap):
    """Heights ``h`` with their depth (``-h`` where ``h < 0``) limited to ``cap`` (a scalar or
    one per height; 0 or less: no limit): unchanged down to ``knee = FOLD_KNEE cap``, then
    ``knee + (cap - knee) tanh((depth - knee) / (cap - knee))`` (C¹: slope 1 at the knee), so
    a furrow's deepest part rounds off before it is a cut.  Heights are summed and blended
    first, so the limit holds where the furrows of neighbouring muscles meet."""
    h = np.asarray(h)
    cap = np.asarray(cap, dtype=h.dtype if h.dtype.kind == "f" else np.float64)
    knee = FOLD_KNEE * cap
    span = np.maximum(cap - knee, _EPS)
    deep = -h - knee
    limit = (cap > 0.0) & (deep > 0.0)
    if not np.any(limit):
        return h
    return np.where(limit, -(knee + span * np.tanh(np.maximum(deep, 0.0) / span)), h).astype(h.dtype)
