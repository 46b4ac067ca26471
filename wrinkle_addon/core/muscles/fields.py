# SPDX-License-Identifier: GPL-3.0-or-later
"""The choice of kind: a muscle's static field from the kind's own module (Waters' linear and
sheet muscles, ``waters.py``; the sphincter, ``sphincter.py``)."""

import numpy as np

from . import sphincter, waters
from .muscle import LINEAR, SPHINCTER, empty_field


def muscle_field(rest, muscle):
    """Evaluate one muscle's static field over the rest positions ``rest`` (N, 3)."""
    m = muscle.sanitized()
    if m.problem() is not None or len(rest) == 0:
        return empty_field()
    rest = np.asarray(rest, dtype=np.float64)
    if m.kind == LINEAR:
        return waters.linear_field(rest, m)
    if m.kind == SPHINCTER:
        return sphincter.field(rest, m)
    return waters.sheet_field(rest, m)
