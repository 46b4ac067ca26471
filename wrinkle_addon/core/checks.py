# SPDX-License-Identifier: GPL-3.0-or-later
"""The checks of the core's entry points that take a user's parameters: a number (or a
count) in its range, finite arrays, and a number of samples the machine can hold.  Each
raises ValueError with a message that names the parameter; the glue turns it into a
``WrinkleError`` for the artist."""

import math

import numpy as np

MAX_SAMPLES = 1_000_000  # samples of one path or polyline: 24 MB in 3-D float64


def number(name, value, lo=-math.inf, hi=math.inf):
    """``value`` as a finite float in ``[lo, hi]``; ValueError otherwise (NaN and the
    infinities included)."""
    try:
        x = float(value)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name} must be a number, not {value!r}") from None
    if not math.isfinite(x):
        raise ValueError(f"{name} must be a finite number, not {x}")
    if not lo <= x <= hi:
        raise ValueError(f"{name} must lie between {lo:g} and {hi:g}, not {x:g}")
    return x


def whole(name, value, lo=-math.inf, hi=math.inf):
    """``value`` as an int in ``[lo, hi]``: a whole number (a float equal to one too)."""
    x = number(name, value, lo, hi)
    if x != math.floor(x):
        raise ValueError(f"{name} must be a whole number, not {x:g}")
    return int(x)


def finite(name, a, dtype=np.float64):
    """``a`` as an array of ``dtype`` with only finite values."""
    try:
        a = np.asarray(a, dtype=dtype)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{name} must hold numbers") from None
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return a


def samples(name, length, step, most=MAX_SAMPLES):
    """``length / step``, the number of steps of ``step`` that cover ``length``, when that
    is at most ``most``; ValueError otherwise, so that a tiny step (or a huge length)
    never asks for more memory than the machine has."""
    step = number(f"{name}'s spacing", step)
    if not step > 0.0:
        raise ValueError(f"{name}'s spacing must be more than 0, not {step:g}")
    with np.errstate(over="ignore"):
        ratio = float(length) / step
    if not math.isfinite(ratio) or ratio > most:
        raise ValueError(f"{name} is {float(length):g} long: a spacing of {step:g} would need more "
                         f"than {most:,} samples")
    return ratio
