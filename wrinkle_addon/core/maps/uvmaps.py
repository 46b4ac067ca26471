# SPDX-License-Identifier: GPL-3.0-or-later
"""The wrinkle map and the zone masks in UV space (Jimenez et al. 2011, §1.1 and §1.2):
the shared rasterisation of ``core.raster`` with this method's encodings."""

import numpy as np

from ..raster import CHUNK_PIXELS, pad, rasterize, slopes
from . import jimenez

_F = np.float32


def pd_map(uv, positions, heights, resolution, *, smooth=False, verts=None, islands=None, padding=8,
           chunk_pixels=CHUNK_PIXELS, weights=None):
    """A partial-derivative wrinkle map (R, R, 4) float32 of a height field (§1.2).

    RG = ``jimenez.encode(clip(n', -1, 1))`` with ``n' = (-dh/ds_u, -dh/ds_v)`` from
    :func:`slopes` (see there for the formula), B = 0, A = 1.  The clip is the PD
    encoding's 45 degree cone (``jimenez.encode``): steeper slopes are stored as +-1.
    Pixels outside the UV islands (beyond the padding) hold the flat value 0.5.
    """
    s, _covered = slopes(uv, positions, heights, resolution, smooth=smooth, verts=verts, islands=islands,
                         padding=padding, chunk_pixels=chunk_pixels, weights=weights)
    R = s.shape[0]
    out = np.empty((R, R, 4), _F)
    np.clip(s, -1.0, 1.0, out=s)
    out[..., :2] = jimenez.encode(s)
    out[..., 2] = 0.0
    out[..., 3] = 1.0
    return out


def mask_images(uv, corner_memberships, resolution, *, padding=4, chunk_pixels=CHUNK_PIXELS):
    """The two RGBA zone masks (R, R, 4) float32 each: mask A = zones 1-4 (0-3) in R, G,
    B, A; mask B = zones 5-8.  ``corner_memberships`` (T, 3, 8) soft memberships at the
    triangle corners (see ``core.raster.soften``).  Interpolation and padding are convex
    combinations, so the sum of the 8 masks stays <= 1; it is renormalised once more
    against rounding."""
    m = np.asarray(corner_memberships, np.float32).reshape(-1, 3, jimenez.N_ZONES)
    img, covered = rasterize(uv, m, resolution, chunk_pixels=chunk_pixels)
    if padding:
        img, _cov = pad(img, covered, padding)
    np.clip(img, 0.0, 1.0, out=img)
    total = img.sum(axis=-1, keepdims=True)
    over = total[..., 0] > 1.0
    img[over] /= total[over]
    return np.ascontiguousarray(img[..., :4]), np.ascontiguousarray(img[..., 4:])
