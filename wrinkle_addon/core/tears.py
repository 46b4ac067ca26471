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
