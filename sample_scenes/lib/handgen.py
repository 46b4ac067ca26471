"""Procedural forearm, wrist and back of the hand, for the fine-wrinkle demo (Bando,
Kuratate & Nishita 2002, Fig. 15). Pure NumPy, no bpy.

Conventions: metres; the arm lies along +Y (the elbow toward -Y, the knuckles toward +Y),
palm down: the back of the hand and of the wrist face +Z, the thumb (radial) side is +X.
The wrist's middle is at y = 0 (``BEND_CENTRE``); the tube runs from ``Y_MIN`` (the distal
forearm) to ``Y_MAX`` (just short of the knuckles) and is open at both ends.

How it is built
---------------
* Rings of constant y.  Each ring is a superellipse ``|x/a|^p + |z/b|^p = 1`` with its own
  half-width ``a``, half-heights ``b`` above (the back) and below (the palm side) and
  exponent ``p``: a rounded forearm that narrows and flattens into the wrist and widens
  into the flat, boxy hand.  Every ring has the same number of vertices, spaced evenly in
  arc length from the palm-side midline (the UV seam) round the thumb side, over the back
  (whose midline is the middle vertex) and back; so columns run straight along the arm.
* Relief on top of the rings: the four extensor tendons fanning from the wrist to the
  knuckles on the back of the hand, and the bump of the ulnar head on the little-finger
  side of the wrist.  Both move points within their ring (x, z), so y stays the ring's.
* UVs: a cylindrical unwrap with one seam along the palm-side midline: ``u`` is the arc
  length from the back's midline (growing toward the little finger, so a face turns the
  same way in UV as on the skin seen from outside), ``v`` the distance along the arm, both divided by the
  same length (isometric around and nearly so along), centred in the 0-1 square; the
  island is narrower at the wrist than at the hand and forearm, and never overlaps.
* Shape keys from a bend of the wrist (:func:`bend`): the centre line bends in the Y-Z
  plane over the joint, and every point keeps its distance from it along the bent
  normal, so the skin on the inside of the bend shrinks along the arm and the skin on the
  outside stretches, by the distance from the centre line times the curvature.
  ``Extend`` lifts the hand (the back of the wrist shrinks, the palm side stretches),
  ``Flex`` drops it (the back of the wrist stretches).

All faces are quads, wound counter-clockwise seen from outside.
"""

import numpy as np

Y_MIN, Y_MAX = -0.110, 0.085  # distal forearm .. just short of the knuckles
BEND_CENTRE = 0.004  # the wrist joint (the capitate), a little distal of the crease
BEND_HALF = 0.035  # the bend is spread over +-3.5 cm around it
EXTEND_ANGLE = np.radians(55.0)  # the Extend key lifts the hand by this
FLEX_ANGLE = np.radians(-55.0)  # the Flex key drops it
UV_MARGIN = 0.015  # free border of the UV square

# (y, half-width a, half-height of the back, half-height of the palm side, exponent p)
PROFILE = np.array([
    (-0.110, 0.0305, 0.0210, 0.0225, 2.25),  # distal forearm
    (-0.060, 0.0290, 0.0185, 0.0205, 2.35),
    (-0.015, 0.0272, 0.0165, 0.0190, 2.60),  # wrist
    (0.010, 0.0290, 0.0150, 0.0185, 2.80),
    (0.040, 0.0390, 0.0135, 0.0175, 3.20),  # base of the hand
    (0.085, 0.0425, 0.0128, 0.0165, 3.40),  # near the knuckles
])


def _smooth_profile(y):
    """The ring parameters at ``y`` (K,): a C1 cubic Hermite through ``PROFILE`` with
    centred slopes (zero at the ends)."""
    ys, vals = PROFILE[:, 0], PROFILE[:, 1:]
    y = np.clip(np.asarray(y, np.float64), ys[0], ys[-1])
    slope = np.zeros_like(vals)
    slope[1:-1] = (vals[2:] - vals[:-2]) / (ys[2:] - ys[:-2])[:, None]
    i = np.clip(np.searchsorted(ys, y, side="right") - 1, 0, len(ys) - 2)
    h = ys[i + 1] - ys[i]
    t = ((y - ys[i]) / h)[:, None]
    h = h[:, None]
    h00, h10 = 2 * t**3 - 3 * t**2 + 1, t**3 - 2 * t**2 + t
    h01, h11 = -2 * t**3 + 3 * t**2, t**3 - t**2
    return h00 * vals[i] + h10 * h * slope[i] + h01 * vals[i + 1] + h11 * h * slope[i + 1]


def _contours(params, samples=4096):
    """Dense closed contours (K, S, 2) of (x, z) from the palm-side midline round the
    thumb side (+X), over the back and back again (the first point not repeated)."""
    a, b_top, b_bot, p = (params[:, k : k + 1] for k in range(4))
    t = np.linspace(0.0, 2.0 * np.pi, samples, endpoint=False)[None, :]
    s, c = np.sin(t), -np.cos(t)  # t = 0: palm side (z < 0); t = pi: the back
    e = 2.0 / p
    x = a * np.sign(s) * np.abs(s) ** e
    z = np.where(c > 0, b_top, b_bot) * np.sign(c) * np.abs(c) ** e
    return np.stack([x, z], -1)


def _resample(contours, m):
    """``m`` points per contour evenly spaced in arc length from its first point, and
    each contour's length (K,)."""
    closed = np.concatenate([contours, contours[:, :1]], axis=1)
    seg = np.linalg.norm(np.diff(closed, axis=1), axis=2)
    cum = np.concatenate([np.zeros((len(seg), 1)), np.cumsum(seg, axis=1)], axis=1)
    length = cum[:, -1]
    out = np.empty((len(contours), m, 2))
    targets = np.arange(m) / m
    for k in range(len(contours)):  # rings (a few hundred), each vectorised
        s = targets * length[k]
        out[k, :, 0] = np.interp(s, cum[k], closed[k, :, 0])
        out[k, :, 1] = np.interp(s, cum[k], closed[k, :, 1])
    return out, length


def _relief(x, y, z, params):
    """Outward displacement (N,) in the ring's plane: the extensor tendons on the back of
    the hand and the ulnar head at the wrist."""
    a, b_top = params[:, 0], params[:, 1]
    back = np.clip(z / b_top, 0.0, 1.0) ** 2  # only on the back, fading toward the sides
    # four tendons from near the middle of the wrist fanning to the knuckles
    out = np.zeros_like(x)
    along = np.clip((y - 0.005) / (Y_MAX - 0.005), 0.0, 1.0)
    rise = along * along * (3.0 - 2.0 * along)  # they stand out toward the knuckles
    for start, end in ((-0.010, -0.030), (-0.003, -0.010), (0.004, 0.010), (0.011, 0.029)):
        centre = start + (end - start) * along
        out += 0.00055 * rise * np.exp(-0.5 * ((x - centre) / 0.0028) ** 2)
    out *= back
    # the ulnar head: a round bump on the little-finger side (-X) of the back of the wrist
    d2 = ((x + 0.72 * a) / 0.007) ** 2 + ((y + 0.012) / 0.008) ** 2
    out += 0.0022 * np.exp(-0.5 * d2) * (z > -0.3 * b_top)
    return out


def bend(rest, angle, centre=BEND_CENTRE, half=BEND_HALF, samples=4001):
    """The rest points (N, 3) with the wrist bent by ``angle`` radians (positive lifts the
    hand toward +Z).  The centre line (the Y axis) turns by ``angle * G(y)``, G rising
    smoothly from 0 at ``centre - half`` to 1 at ``centre + half`` (its slope, the
    curvature, a raised cosine); a point keeps its height above the centre line along the
    turned normal.  Along the arm, the skin at height ``z`` is scaled by ``1 - z angle G'(y)``:
    it shrinks on the inside of the bend and stretches on the outside."""
    rest = np.asarray(rest, np.float64)
    lo, hi = min(Y_MIN, centre - half) - 0.01, max(Y_MAX, centre + half) + 0.01
    ys = np.linspace(lo, hi, samples)
    g = np.clip((ys - (centre - half)) / (2.0 * half), 0.0, 1.0)
    phi = angle * 0.5 * (1.0 - np.cos(np.pi * g))
    # the centre line, integrated from y = lo where it is still straight
    dy = np.diff(ys)
    cy = lo + np.concatenate([[0.0], np.cumsum(0.5 * (np.cos(phi[1:]) + np.cos(phi[:-1])) * dy)])
    cz = np.concatenate([[0.0], np.cumsum(0.5 * (np.sin(phi[1:]) + np.sin(phi[:-1])) * dy)])
    y = rest[:, 1]
    f, py, pz = np.interp(y, ys, phi), np.interp(y, ys, cy), np.interp(y, ys, cz)
    out = rest.copy()
    out[:, 1] = py - rest[:, 2] * np.sin(f)
    out[:, 2] = pz + rest[:, 2] * np.cos(f)
    return out


def make_arm(rings=190, around=240):
    """The forearm, wrist and hand: a dict with ``positions`` (N, 3) float32, ``quads``
    (F, 4) int32, ``corner_uvs`` (F, 4, 2) float32, ``shape_keys`` {"Extend", "Flex": (N, 3)
    float32}, per vertex ``axial`` (y at rest) and ``around`` (signed arc length from the
    back's midline over the ring's length: 0 on the back, +-0.5 on the palm side), and
    ``landmarks`` (rest points): ``wrist_back``, ``wrist_palm``, ``hand_back``,
    ``forearm_back``.  ``rings`` x ``around`` vertices (45 600 by default)."""
    if rings < 2 or around < 8 or around % 2:
        raise ValueError("make_arm needs at least 2 rings and an even number >= 8 around")
    ys = np.linspace(Y_MIN, Y_MAX, rings)
    params = _smooth_profile(ys)
    ring, circumference = _resample(_contours(params), around)  # (K, M, 2)
    x, z = ring[..., 0], ring[..., 1]
    y = np.broadcast_to(ys[:, None], x.shape)
    tangent = np.roll(ring, -1, axis=1) - np.roll(ring, 1, axis=1)
    normal = np.stack([tangent[..., 1], -tangent[..., 0]], -1)  # outward: the ring turns counter-clockwise
    normal /= np.maximum(np.linalg.norm(normal, axis=2, keepdims=True), 1e-12)
    lift = _relief(x.ravel(), y.ravel(), z.ravel(), np.repeat(params, around, axis=0)).reshape(x.shape)
    x, z = x + lift * normal[..., 0], z + lift * normal[..., 1]
    positions = np.stack([x, y, z], -1).reshape(-1, 3)

    idx = np.arange(rings * around).reshape(rings, around)
    nxt = np.roll(idx, -1, axis=1)  # wraps round the seam
    quads = np.stack([idx[:-1], idx[1:], nxt[1:], nxt[:-1]], -1).reshape(-1, 4)

    # UVs: around = arc length from the back's midline, along = y, one scale for both
    frac = np.arange(around + 1) / around  # the seam's far side repeats the first column
    scale = (1.0 - 2.0 * UV_MARGIN) / max(float(circumference.max()), Y_MAX - Y_MIN)
    # u grows toward the little-finger side (-X), so the UVs turn as the faces do seen from outside
    u = 0.5 - (frac[None, :] - 0.5) * circumference[:, None] * scale  # (K, M + 1)
    v = 0.5 + (ys - 0.5 * (Y_MIN + Y_MAX)) * scale
    uv = np.stack([u, np.broadcast_to(v[:, None], u.shape)], -1)  # (K, M + 1, 2)
    k, j = np.meshgrid(np.arange(rings - 1), np.arange(around), indexing="ij")
    corner = np.stack([uv[k, j], uv[k + 1, j], uv[k + 1, j + 1], uv[k, j + 1]], axis=2)

    around_frac = np.broadcast_to(frac[None, :around] - 0.5, (rings, around)).ravel()

    def at(y0, frac0):
        k0 = int(np.argmin(np.abs(ys - y0)))
        return positions[k0 * around + int(round((frac0 + 0.5) * around)) % around].astype(np.float32)

    landmarks = {"wrist_back": at(0.0, 0.0), "wrist_palm": at(0.0, 0.5),
                 "hand_back": at(0.055, 0.0), "forearm_back": at(-0.07, 0.0)}
    return {
        "positions": positions.astype(np.float32),
        "quads": quads.astype(np.int32),
        "corner_uvs": corner.reshape(-1, 4, 2).astype(np.float32),
        "shape_keys": {"Extend": bend(positions, EXTEND_ANGLE).astype(np.float32),
                       "Flex": bend(positions, FLEX_ANGLE).astype(np.float32)},
        "axial": positions[:, 1].astype(np.float32),
        "around": around_frac.astype(np.float32),
        "landmarks": landmarks,
    }
