# SPDX-License-Identifier: GPL-3.0-or-later
"""Skin Age: one face-level setting from young (0) to old (1) that scales the three things
age changes in real skin together.

- **Fine wrinkles at rest.** Bando 2002's fine furrows show at rest with the height
  ``r`` of eq. 5 (0.5 in the paper, an adult's skin). Young skin shows none until it
  shrinks: the effective rest height is ``r * rest_factor(age)``, ``rest_factor = 2 age``
  (0 at 0, 1 at 0.5, 2 at 1), clamped to 1. With ``r = 0`` eq. 5 is ``M(s) = s`` for
  ``s >= 0``, so a young face still folds finely where its skin compresses.
- **Furrow depth.** Expression lines deepen with age as the skin loses elasticity: every
  muscle's wrinkle amplitude ``k0`` and the fine furrows' depth are multiplied by
  ``depth_factor = 0.6 + 0.8 age`` (0.6 young, 1 at 0.5, 1.4 old).
- **Irregularity.** Old skin's furrows break, branch and wander more: the face's
  Irregularity is multiplied by ``irregularity_factor = 0.5 + age`` (0.5 … 1.5).

Every factor is exactly 1 at 0.5 (:data:`NEUTRAL`), so a face that had no Skin Age
(a file saved before it existed) looks as it did. A non-finite age is :data:`NEUTRAL`.
Pure Python on scalars; no Blender.
"""

import math

__all__ = ["NEUTRAL", "YOUNG", "clamp", "rest_factor", "rest_height", "depth_factor",
           "irregularity_factor"]

NEUTRAL = 0.5  # every factor 1: the methods as published
YOUNG = 0.25  # a young adult: the sample head's default (no fine crackle at rest's full r)


def clamp(age):
    """``age`` in [0, 1]; NaN and infinities give :data:`NEUTRAL`."""
    age = float(age)
    return min(max(age, 0.0), 1.0) if math.isfinite(age) else NEUTRAL


def rest_factor(age):
    """Factor on Bando's rest height ``r``: ``2 age``."""
    return 2.0 * clamp(age)


def rest_height(r, age):
    """The effective rest height: ``r * rest_factor(age)`` in [0, 1] (NaN ``r`` is 0)."""
    r = float(r)
    r = min(max(r, 0.0), 1.0) if math.isfinite(r) else 0.0
    return min(r * rest_factor(age), 1.0)


def depth_factor(age):
    """Factor on the furrows' depth (the muscles' ``k0``, the fine furrows' depth):
    ``0.6 + 0.8 age``."""
    return 0.6 + 0.8 * clamp(age)


def irregularity_factor(age):
    """Factor on the face's Irregularity: ``0.5 + age``."""
    return 0.5 + clamp(age)
