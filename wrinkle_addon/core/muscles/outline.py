# SPDX-License-Identifier: GPL-3.0-or-later
"""Outlines of a muscle's area of influence and wrinkling region, as line segments.

Returned as (2k, 3) arrays of segment end points in the muscle's (face-local)
space, for the viewport overlay.  A linear muscle's cone is drawn in two
perpendicular planes through its central fibre; a sheet muscle's rectangles
lie in the sheet's plane; a sphincter's outer ellipse and its wrinkling sector lie in
its plane.
"""

import numpy as np

from .muscle import LINEAR, SPHINCTER, ring_frame, sheet_frame
from .waters import region_end, region_start


def _polyline(points, closed=False):
    p = np.asarray(points, dtype=np.float64)
    if closed:
        p = np.concatenate([p, p[:1]])
    return np.repeat(p, 2, axis=0)[1:-1]


def _perpendicular(v):
    helper = np.array([0.0, 0.0, 1.0]) if abs(v[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    p = np.cross(v, helper)
    return p / np.linalg.norm(p)


def muscle_outline(m, arc_steps=16):
    """``{'aoi': segments, 'region': segments}`` for a sanitized-able :class:`Muscle`."""
    m = m.sanitized()
    if m.problem():
        return {"aoi": np.zeros((0, 3)), "region": np.zeros((0, 3))}
    if m.kind == LINEAR:
        a = m.attachment[0]
        fibre = m.insertion[0] - a
        fibre /= np.linalg.norm(fibre)
        side = _perpendicular(fibre)
        up = np.cross(fibre, side)
        ang = np.linspace(-m.spread, m.spread, arc_steps)
        tan = np.tan(min(m.spread, np.radians(80.0)))
        aoi, region = [], []
        for axis in (side, up):
            arc = a + m.length * (np.cos(ang)[:, None] * fibre + np.sin(ang)[:, None] * axis)
            aoi.append(_polyline(np.concatenate([[a], arc, [a]])))
            corners = [(m.lambda_w, -1), (1.0, -1), (1.0, 1), (m.lambda_w, 1)]
            quad = [a + m.length * (lam * fibre + s * lam * tan * axis) for lam, s in corners]
            region.append(_polyline(quad, closed=True))
        return {"aoi": np.concatenate(aoi), "region": np.concatenate(region)}
    if m.kind == SPHINCTER:
        c, a, b, _n, ra, rb = ring_frame(m)

        def arc(rho, t0, t1):
            t = np.linspace(t0, t1, 4 * arc_steps)
            return c + rho * (np.cos(t)[:, None] * ra * a + np.sin(t)[:, None] * rb * b)

        lo, th = m.lambda_w * m.length, m.spread
        sector = np.concatenate([arc(lo, -th, th), arc(m.length, th, -th)])
        return {"aoi": _polyline(arc(m.length, -np.pi, np.pi), closed=True),
                "region": _polyline(sector, closed=True)}
    origin, fibre, across, _n, _l = sheet_frame(m)
    half = 0.5 * m.spread

    def rect(l0, l1):
        return _polyline([origin + l * fibre + h * across for l, h in
                          ((l0, -half), (l1, -half), (l1, half), (l0, half))], closed=True)

    back = m.back_reach * m.length
    return {"aoi": rect(-back, m.length), "region": rect(region_start(m, m.length, -back), region_end(m))}
