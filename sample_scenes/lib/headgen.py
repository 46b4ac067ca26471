"""Procedural human head for demos, tests and benchmarks. Pure NumPy, no bpy.

Conventions: metres, Z up, the face looks toward -Y, the character's left is +X.
An adult of average build: 22 cm from the chin (z = 0.004) to the crown
(z = 0.227) with the eyes (z = 0.1165, 63 mm apart) at half that height; the
skull 15 cm wide and 19 cm from the glabella to the back of the head, the face
14 cm across the cheekbones, the neck 11.5 cm wide under the jaw, the ears
6.4 cm tall standing 1.5-2 cm off the head.

How it is built
---------------
* The shape is an implicit function ``head_field(p)`` (negative inside, close to
  a signed distance), smoothly blended solids:

  - the cranium, a superellipsoid egg;
  - the face's soft tissue over the skull, lofted through superellipse sections
    (a B-spline in z, from under the chin to the top of the forehead) and cut
    underneath along the lower border of the mandible, which gives the jaw line;
  - the neck, leaning forward and spreading toward the shoulders, with the two
    sternocleidomastoids;
  - the nose: a ridged dorsum from the nasion to the tip, the tip lobule, the
    columella and underside, the alae with a crease round them, and the
    nostrils carved once the nose is on the face;
  - the ears: each a slab leaning back 15 degrees, its lateral face turned toward
    the back and carved into helix, scapha, antihelix, triangular fossa, concha,
    tragus, antitragus and lobe, the space behind it filled;
  - the eyes: eyeballs (the cornea bulging over a carved iris and pupil) inside
    the lids, a shell over each eyeball that opens along the palpebral fissure,
    with a ledge at the margins, the tarsal plates, the upper lid crease and the
    fold above it, and the roll under the lower lid;

  plus a relief displaced along the normal: the brow ridge with the glabella's
  prominence over the nasion, the frontal eminences and the forehead rounding
  into the crown, the eye sockets and the lateral orbital rims, the cheekbones
  and zygomatic arches, the cheek's fullness beside the nose and over the
  buccal region, the nasolabial folds (the cheek's fat ending medially on a soft
  crease from above the ala down to beside the mouth corner), the lips
  (vermilion borders with the cupid's bow and the white roll, the philtrum, the
  mouth line, the corners tucked in beside the modiolus, all on the curve of
  the teeth), the mentolabial sulcus and the chin.
* Every vertex is first the root of the field along a ray. Above the throat
  the rays leave ``ORIGIN`` (the head is star-shaped from there; ``tests``
  checks it); the neck is sampled by level rays from the same vertical axis, so
  the open neck ring lies in the plane z = -0.085.
* The rays form a latitude-longitude grid whose columns and rows are packed
  densely over the face and sparsely elsewhere, with a ray through each pupil
  (the eye landmarks are vertices on the eyes' axes): at the default 40k
  vertices the forehead, brows, eyes, nose and mouth get edges of 1.6-1.9 mm
  while the back of the skull gets 3-7 mm. The crown is closed by a quad cap: a
  Coons patch on the azimuthal-equidistant plane, relaxed together with the top
  rows so its four valence-3 corners open up. All faces are quads, wound
  counter-clockwise seen from outside.
* Where a ray meets the surface at a glancing angle (under the nose, round the
  ears and the lids) the quads would be long slivers, so those vertices and a
  few rings round them are relaxed: moved toward the weighted mean of their
  neighbours within the tangent plane, then back onto the surface by Newton
  steps along the gradient (``_relax``).
* Narrow grooves are widened to the mesh resolution (``detail``), so coarse
  meshes do not alias them.
* UVs: the band uses (azimuth, elevation seen from ``ORIGIN``) of the ray hits
  at the same scale on both axes over the face (close to conformal there), with
  the back of the head squeezed into the outer 5 % of U. The crown is a separate
  disc island above the band.
* Landmarks are found on the surface by their anatomical definitions
  (``_landmarks``), independently of the add-on's landmark finder.
"""

from functools import partial

import numpy as np

__all__ = ["make_head", "make_forehead_patch", "head_field", "LANDMARK_NAMES", "ORIGIN"]

LANDMARK_NAMES = (
    "glabella",
    "brow_inner_L", "brow_inner_R", "brow_mid_L", "brow_mid_R", "brow_outer_L", "brow_outer_R",
    "hairline_center", "hairline_L", "hairline_R",
    "eye_L", "eye_R",
    "nose_bridge", "nose_tip", "nose_ala_L", "nose_ala_R",
    "cheekbone_L", "cheekbone_R",
    "mouth_corner_L", "mouth_corner_R", "upper_lip", "lower_lip",
    "chin", "jaw_L", "jaw_R", "cheek_lateral_L", "cheek_lateral_R",
)

# Rays start here, near the middle of the head at eye level; the head is
# star-shaped with respect to this point.
ORIGIN = np.array([0.0, 0.005, 0.105])

_RAY_MAX = 0.26  # every ray leaves the head before this distance (m)
_NECK_CUT = -0.085  # z of the open neck ring
_NECK_TOP = -0.020  # below this the neck is sampled by level rays
_EL_LOW = np.radians(-78.0)  # lowest ray from ORIGIN (at the front of the throat)
_EL_FIXED = np.radians(52.0)  # outer edge of the relaxed crown region
_EL_CAP = np.radians(64.0)  # ring where the band meets the cap grid


# --------------------------------------------------------------------------
# Implicit modelling primitives (p: (N, 3) float64; return (N,) values)
# --------------------------------------------------------------------------
def _ellipsoid(p, c, r):
    """Near-Euclidean distance bound to an axis-aligned ellipsoid."""
    q = (p - c) / r
    k0 = np.sqrt(np.einsum("ij,ij->i", q, q))
    q2 = (p - c) / (np.asarray(r) ** 2)
    k1 = np.sqrt(np.einsum("ij,ij->i", q2, q2))
    return k0 * (k0 - 1.0) / np.maximum(k1, 1e-12)


def _superellipsoid(p, c, r, e):
    """Distance estimate to the superellipsoid sum(|(p - c) / r|^e) = 1."""
    q = np.abs((p - c) / r) + 1e-12
    k = np.sum(q ** e, axis=1) ** (1.0 / e)
    grad = (q / k[:, None]) ** (e - 1.0) / np.asarray(r)
    return (k - 1.0) / np.sqrt(np.einsum("ij,ij->i", grad, grad))


def _round_cone(p, a, b, ra, rb):
    """Capsule from a (radius ra) to b (radius rb), radius interpolated linearly."""
    a = np.asarray(a, float)
    ab = np.asarray(b, float) - a
    h = np.clip((p - a) @ ab / (ab @ ab), 0.0, 1.0)
    d = p - a - h[:, None] * ab
    return np.sqrt(np.einsum("ij,ij->i", d, d)) - (ra + (rb - ra) * h)


def _smin(a, b, k):
    """Polynomial smooth minimum (union) with blend width k."""
    h = np.clip(0.5 + 0.5 * (b - a) / k, 0.0, 1.0)
    return b + (a - b) * h - k * h * (1.0 - h)


def _smax(a, b, k):
    """Smooth maximum (intersection / subtraction with -b)."""
    return -_smin(-a, -b, k)


def _smoothstep(e0, e1, x):
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def _soft_abs(x, eps=0.003):
    """|x| rounded off within ``eps`` of 0, so mirrored features meet smoothly."""
    return np.sqrt(x * x + eps * eps) - eps


def _mirror(p):
    """Fold the character's right onto the left (features are symmetric)."""
    q = p.copy()
    q[:, 0] = _soft_abs(q[:, 0])
    return q


# --------------------------------------------------------------------------
# The head field
# --------------------------------------------------------------------------
def _segment_distance_2d(x, z, a, b):
    """Distance in the XZ plane from (x, z) to the segment a-b, and the segment parameter."""
    ax, az_ = a
    dx, dz = b[0] - ax, b[1] - az_
    t = np.clip(((x - ax) * dx + (z - az_) * dz) / (dx * dx + dz * dz), 0.0, 1.0)
    return np.hypot(x - ax - t * dx, z - az_ - t * dz), t


def _groove(d, sigma, detail):
    """Gaussian groove profile across distance ``d``, widened to ``detail``."""
    return np.exp(-0.5 * d * d / (sigma * sigma + detail * detail))


def _spline(z, z0, dz, table):
    """Uniform cubic B-spline of the rows of ``table`` (K, m) as control values at
    z0 + k dz (curvature-continuous, so sections blend without bands)."""
    k = len(table)
    t = np.clip((z - z0) / dz, 0.0, k - 1.0)
    i = np.minimum(np.floor(t).astype(np.int64), k - 2)
    u = (t - i)[:, None]
    p0, p1 = table[np.maximum(i - 1, 0)], table[i]
    p2, p3 = table[i + 1], table[np.minimum(i + 2, k - 1)]
    u2, u3 = u * u, u * u * u
    return ((1.0 - u) ** 3 * p0 + (3.0 * u3 - 6.0 * u2 + 4.0) * p1
            + (-3.0 * u3 + 3.0 * u2 + 3.0 * u + 1.0) * p2 + u3 * p3) / 6.0


def _ellipsoid_rot(p, c, r, angle):
    """``_ellipsoid`` turned by ``angle`` (radians) about Z: its first axis then
    points along (cos, sin) in the XY plane."""
    q = p - c
    ca, sa = np.cos(angle), np.sin(angle)
    u = np.stack([ca * q[:, 0] + sa * q[:, 1], -sa * q[:, 0] + ca * q[:, 1], q[:, 2]], axis=1)
    return _ellipsoid(u, np.zeros(3), r)


# Sections of the face's soft tissue over the skull, from under the chin to the
# forehead: z of the first knot, knot spacing, then per knot the half width, the y
# of the section's middle, its depth in front of and behind the middle, and the
# superellipse exponent of its front half (the back half is an ellipse).
_LOFT_Z0, _LOFT_DZ = -0.01, 0.01
_LOFT = np.array([
    # W      Yc      Df     Db     nf
    [0.042, 0.014, 0.078, 0.035, 2.2],  # -0.01
    [0.046, 0.012, 0.096, 0.035, 2.2],  # 0.00
    [0.050, 0.010, 0.103, 0.035, 2.3],  # 0.01
    [0.054, 0.008, 0.105, 0.035, 2.4],  # 0.02 chin
    [0.058, 0.006, 0.102, 0.035, 2.4],  # 0.03
    [0.062, 0.004, 0.102, 0.035, 2.25],  # 0.04
    [0.065, 0.002, 0.103, 0.035, 2.3],  # 0.05 mouth
    [0.067, 0.000, 0.101, 0.035, 2.35],  # 0.06
    [0.068, -0.002, 0.097, 0.035, 2.4],  # 0.07
    [0.069, -0.004, 0.091, 0.035, 2.45],  # 0.08 nose base
    [0.070, -0.006, 0.085, 0.035, 2.5],  # 0.09
    [0.071, -0.008, 0.081, 0.035, 2.5],  # 0.10 cheekbones
    [0.071, -0.010, 0.078, 0.035, 2.5],  # 0.11
    [0.069, -0.012, 0.077, 0.032, 2.5],  # 0.12 eyes
    [0.067, -0.012, 0.080, 0.030, 2.3],  # 0.13 brows
    [0.066, -0.012, 0.081, 0.030, 2.25],  # 0.14
    [0.064, -0.012, 0.081, 0.030, 2.25],  # 0.15
    [0.061, -0.012, 0.078, 0.030, 2.2],  # 0.16
    [0.057, -0.012, 0.0745, 0.030, 2.2],  # 0.17
    [0.052, -0.012, 0.0700, 0.030, 2.1],  # 0.18
    [0.046, -0.012, 0.0610, 0.030, 2.0],  # 0.19
    [0.036, -0.012, 0.046, 0.028, 2.0],  # 0.20
    [0.024, -0.012, 0.026, 0.022, 2.0],  # 0.21
    [0.012, -0.012, 0.008, 0.018, 2.0],  # 0.22
])


def _face_mass(p):
    """The face's soft tissue over the skull's front: lofted superellipse sections,
    cut underneath along the lower border of the mandible."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    w, yc, df, db, nf = _spline(z, _LOFT_Z0, _LOFT_DZ, _LOFT).T
    front = y < yc
    d = np.where(front, df, db)
    e = np.where(front, nf, 2.0)
    qx = np.abs(x / w) + 1e-12
    qy = np.abs((y - yc) / d) + 1e-12
    k = (qx ** e + qy ** e) ** (1.0 / e)
    gx = (qx / k) ** (e - 1.0) / w
    gy = (qy / k) ** (e - 1.0) / d
    f = (k - 1.0) / np.sqrt(gx * gx + gy * gy)
    # The lower border of the mandible rises from the menton back to the angles;
    # between its two halves the floor of the mouth runs level to the throat.
    rise = -0.02 + 0.31 * _smoothstep(0.012, 0.036, np.abs(x))
    border = 0.006 + rise * (y + 0.090)
    f = _smax(f, border - z, 0.008)
    return _smax(f, z - 0.22, 0.01)  # the top of the forehead is the cranium's


def _neck(p):
    """An elliptic column leaning forward, the trapezius spreading it toward the
    shoulders behind, and the sternocleidomastoids: a ridge either side from behind
    the ear down to the front of the collarbones."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    t = np.clip((0.04 - z) / 0.14, 0.0, 1.0)
    yc = 0.016 + 0.004 * t
    flare = 0.016 * _smoothstep(-0.025, -0.10, z) * _smoothstep(-0.01, 0.04, y)
    rx = 0.0570 + 0.004 * t * t + flare
    # the throat slopes forward down to the breastbone, the nape back to the shoulders
    ry = np.where(y < yc, 0.057 + 0.014 * t * t, 0.057 + 0.020 * t * t)
    f = (np.hypot(x / rx, (y - yc) / ry) - 1.0) * np.minimum(rx, ry)
    f = _smax(f, z - 0.09, 0.02)
    m = _mirror(p)
    scm = _round_cone(m, (0.043, 0.026, 0.072), (0.012, -0.028, -0.095), 0.0115, 0.0085)
    return _smin(f, scm, 0.012)


# The nose's dorsum in profile: y of the ridge at z = 0.080 + k 0.0075, and the
# slope of its side walls (dy/dx) and the rounding of the ridge (m).
_DORSUM_Z0, _DORSUM_DZ = 0.080, 0.0075
_DORSUM = np.array([
    # y       slope  rounding
    [-0.1160, 1.40, 0.0050],  # 0.0800 tip
    [-0.1150, 1.25, 0.0044],  # 0.0875 supratip
    [-0.1108, 1.10, 0.0040],  # 0.0950
    [-0.1058, 1.05, 0.0038],  # 0.1025 rhinion
    [-0.1008, 1.05, 0.0040],  # 0.1100
    [-0.0950, 1.05, 0.0044],  # 0.1175
    [-0.0885, 1.00, 0.0050],  # 0.1250 the nasion, under the glabella's relief
    [-0.0830, 1.00, 0.0060],  # 0.1325
    [-0.0800, 1.00, 0.0060],  # 0.1400
])
_SUBNASALE = (-0.1005, 0.0712)  # (y, z)


def _nose(p, m):
    """The external nose as a solid: a ridged dorsum, the tip lobule, the columella
    and underside, and the alae; the nostrils' pockets are returned apart, to be
    carved once the nose is joined to the face."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    yd, slope, rnd = _spline(z, _DORSUM_Z0, _DORSUM_DZ, _DORSUM).T
    side = np.sqrt(x * x + rnd * rnd)
    yn = yd + slope * (side - rnd)
    f = (yn - y) / np.sqrt(1.45 + (slope * x / side) ** 2)
    # Tip lobule, a little wider than the dorsum above it.
    tip = _ellipsoid(p, (0.0, -0.1120, 0.0814), (0.0072, 0.0086, 0.0068))
    f = _smin(f, tip, 0.004)
    # The underside: from the subnasale forward and up to the tip.
    under = _SUBNASALE[1] - 0.33 * (y - _SUBNASALE[0]) - z
    f = _smax(f, under, 0.0035)
    # Alae: wings from the cheek forward and in toward the tip.
    ala = _ellipsoid_rot(m, (0.0118, -0.1010, 0.0752), (0.0084, 0.0047, 0.0053), np.radians(60.0))
    # The alar rims end level with the nostrils' openings, not below them.
    ala = _smax(ala, under - 0.0008, 0.0015)
    f = _smin(f, ala, 0.0045)
    # Nostrils (carved once the nose is on the face): pockets under the tip between
    # the columella and each ala, deepest at the back and opening forward gently
    # (the rays from ORIGIN cross them once).
    q = m - (0.0060, -0.1046, 0.0716)
    u = np.cos(np.radians(70.0)) * q[:, 0] + np.sin(np.radians(70.0)) * q[:, 1]  # back and out
    v = -np.sin(np.radians(70.0)) * q[:, 0] + np.cos(np.radians(70.0)) * q[:, 1]
    tilt = np.radians(28.0)  # the pocket rises toward its back
    uu = np.cos(tilt) * u + np.sin(tilt) * q[:, 2]
    zz = -np.sin(tilt) * u + np.cos(tilt) * q[:, 2]
    nostril = _ellipsoid(np.stack([uu, v, zz], axis=1), np.zeros(3), (0.0050, 0.0022, 0.0030))
    return f, ala, nostril


def _brow_z(ax):
    """z of the brow ridge's crest at |x| = ``ax``: over the glabella, rising over
    the inner brow, level over the eye and falling toward the temple."""
    return 0.1297 + 0.312 * ax - 4.58 * ax * ax


def _face_relief(p, m, detail):
    """Height (m) of the facial features above the blended base shapes."""
    x, z = p[:, 0], p[:, 2]
    ax = m[:, 0]
    # Brow ridge: the superciliary arches strongest over the inner half of each
    # brow, meeting in the glabella; the orbital roof under it steeper than the
    # forehead above.
    zb = _brow_z(ax)
    hb = 0.0018 * np.exp(-(((ax - 0.014) / 0.016) ** 2)) + 0.0008 * np.exp(-(((ax - 0.040) / 0.016) ** 2))
    dz = z - zb
    sz = np.where(dz < 0.0, 0.0048, 0.0085)
    r = hb * np.exp(-0.5 * (dz / sz) ** 2)
    r += 0.0026 * np.exp(-0.5 * ((x / 0.010) ** 2 + ((z - 0.1297) / 0.0055) ** 2))
    # The top of the forehead, rounding over into the crown; the frontal eminences.
    r += 0.0035 * np.exp(-0.5 * ((x / 0.040) ** 2 + ((z - 0.193) / 0.013) ** 2))
    r += 0.0020 * np.exp(-0.5 * (((ax - 0.028) / 0.018) ** 2 + ((z - 0.163) / 0.018) ** 2))
    # Eye sockets: a bowl under the brow, deepest behind the upper lid; the temples.
    ex = (ax - 0.0312) / np.where(ax > 0.0312, 0.0165, 0.0190)
    ez = (z - 0.1172) / np.where(z > 0.1172, 0.0102, 0.0095)
    r -= 0.0065 * np.exp(-(np.hypot(ex, ez) ** 2.2)) + 0.0060 * np.exp(-(np.hypot(ex, ez) ** 5))
    r -= 0.0020 * np.exp(-0.5 * (((ax - 0.064) / 0.010) ** 2 + ((z - 0.132) / 0.016) ** 2))
    # Lower lid's edge on the cheek: the lid-cheek junction.
    lx = (ax - 0.0340) / 0.0150
    lidw = np.clip(1.0 - lx * lx, 0.0, None) ** 2
    z_junction = 0.1040 - 0.0012 * lx + 0.0030 * lx * lx
    r -= 0.0004 * _groove(z - z_junction, 0.0025, detail) * lidw
    # The cheek's fullness under the eye, beside the nose.
    r += 0.0033 * np.exp(-0.5 * (((ax - 0.024) / 0.010) ** 2 + ((z - 0.095) / 0.012) ** 2))
    # The lateral rim of the orbit, from the brow down to the cheekbone.
    r += 0.0014 * np.exp(-0.5 * (((ax - 0.0525) / 0.0045) ** 2 + ((z - 0.1160) / 0.0110) ** 2))
    # Cheekbones, the zygomatic arches and the hollow under them.
    r += 0.0028 * np.exp(-0.5 * (((ax - 0.0515) / 0.014) ** 2 + ((z - 0.0970) / 0.0105) ** 2))
    r += 0.0015 * np.exp(-0.5 * (((ax - 0.064) / 0.010) ** 2 + ((z - 0.1000) / 0.0060) ** 2))
    r += 0.0018 * np.exp(-0.5 * (((ax - 0.052) / 0.012) ** 2 + ((z - 0.062) / 0.020) ** 2))
    # Nasolabial folds: the cheek's fat pad ends medially on a crease from above
    # the ala down to beside the mouth corner; the lip side is lower.
    a, b = (0.0195, 0.0750), (0.0335, 0.0395)
    d_fold, t_fold = _segment_distance_2d(ax, z, a, b)
    normal = np.array([a[1] - b[1], b[0] - a[0]]) / np.hypot(a[1] - b[1], b[0] - a[0])
    side = (ax - a[0]) * normal[0] + (z - a[1]) * normal[1]  # > 0 on the cheek side
    taper = np.sin(np.pi * np.clip(0.08 + 0.92 * t_fold, 0.0, 1.0)) ** 0.8
    cheek = _smoothstep(-0.006, 0.008, side) * np.exp(-0.5 * (np.maximum(side, 0.0) / 0.014) ** 2)
    r += 0.0020 * cheek * taper * _smoothstep(0.030, 0.050, z + 0.3 * side)
    r -= 0.0004 * _groove(side, 0.0030, detail) * taper
    mouth = (ax < 0.050) & (z < 0.080)
    r[mouth] += _mouth_relief(x[mouth], z[mouth], detail)
    return r


def _mouth_relief(x, z, detail):
    """Lips (vermilion border, cupid's bow), philtrum, mouth line and chin as a
    height (m) over (x, z)."""
    ax = _soft_abs(x)
    s = np.clip(ax / 0.0225, 0.0, 1.6)  # 1 where the lips end, 2 mm inside the corners
    z_m = 0.0478 - 0.0012 * s * s - 0.0003 * np.exp(-0.5 * (x / 0.0030) ** 2)  # mouth line
    # Vermilion borders: the cupid's bow peaks at x = +-5.5 mm over a dip on the
    # midline; both borders run down to the corners.
    bow = 0.0011 * np.exp(-0.5 * ((ax - 0.0058) / 0.0030) ** 2) - 0.0006 * np.exp(-0.5 * (x / 0.0022) ** 2)
    z_ub = z_m + (0.0085 + bow) * np.clip(1.0 - s ** 2.2, 0.0, None) ** 0.55
    z_lb = z_m - 0.0105 * np.clip(1.0 - s ** 2.4, 0.0, None) ** 0.6
    w = max(0.0007, 0.8 * detail)
    fade = np.clip(1.0 - s ** 2, 0.0, None) ** 0.6
    # Upper lip: the skin leans forward from the nose to the border ...
    lean = 0.0032 * np.exp(-((x / 0.020) ** 4))
    up_skin = lean * _smoothstep(0.0715, z_ub, z) ** 0.9 * _smoothstep(z_ub - 0.004, z_ub, z + 0.004)
    # ... the vermilion, a roll that stands proud of it, ...
    u = np.clip((z - z_m) / np.maximum(z_ub - z_m, 1e-4), 0.0, 1.0)
    inside_up = _smoothstep(z_ub + w, z_ub - w, z) * _smoothstep(z_m - w, z_m + w, z)
    v_up = lean * (1.0 - u) + 0.0042 * np.sin(np.pi * u) ** 0.6 * fade
    r = np.where(z > z_ub, up_skin, v_up * inside_up + up_skin * (1.0 - inside_up))
    # ... edged by the white roll of the border.
    r += 0.0005 * _groove(z - z_ub, 0.0006, detail) * fade
    # Philtrum: two columns from the columella to the bow's peaks, a dip between.
    t = _smoothstep(z_ub, z_ub + 0.003, z) * _smoothstep(0.0700, 0.0650, z)
    colx = 0.0038 + 0.0020 * _smoothstep(0.066, 0.057, z)
    r += t * (0.0008 * np.exp(-0.5 * ((ax - colx) / 0.0015) ** 2)
              - 0.0005 * np.exp(-0.5 * (x / 0.0019) ** 2))
    # Lower lip: a fuller roll under the mouth line, bounded by its border, in two
    # soft lobes either side of the midline; the skin under it recedes to the sulcus.
    u2 = np.clip((z_m - z) / np.maximum(z_m - z_lb, 1e-4), 0.0, 1.0)
    inside_lo = _smoothstep(z_lb - w, z_lb + w, z) * _smoothstep(z_m + w, z_m - w, z)
    lo_base = 0.0022 * np.exp(-((x / 0.020) ** 4))
    v_lo = lo_base + 0.0048 * np.sin(np.pi * (0.08 + 0.92 * u2)) ** 0.9 * fade
    v_lo *= 1.0 + 0.12 * np.exp(-0.5 * ((ax - 0.008) / 0.006) ** 2)
    lo_skin = lo_base * _smoothstep(0.031, z_lb, z) * (z < z_m)
    r += v_lo * inside_lo + lo_skin * (1.0 - inside_lo)
    # Mouth line (the lips meet) and the corners of the mouth (modiolus): the line
    # fades before the corners, which are pits tucked in behind the lips; the
    # modiolus is a soft knot of muscle just outside each corner.
    r -= 0.0012 * _groove(z - z_m, 0.0006, detail) * np.exp(-((x / 0.0225) ** 4))
    r -= 0.0028 * np.exp(-0.5 * (((ax - 0.0235) / 0.0036) ** 2 + ((z - 0.0468) / 0.0045) ** 2))
    r += 0.0010 * np.exp(-0.5 * (((ax - 0.0285) / 0.0055) ** 2 + ((z - 0.0475) / 0.0090) ** 2))
    # The lips and the skin round them lie on the curve of the teeth.
    r += 0.0038 * np.exp(-((x / 0.021) ** 2)) * np.exp(-0.5 * ((z - 0.0480) / 0.0110) ** 2)
    # Mentolabial sulcus and the chin.
    r -= 0.0012 * np.exp(-0.5 * ((z - 0.0320) / 0.0040) ** 2) * np.exp(-0.5 * (x / 0.016) ** 2)
    r += 0.0045 * np.exp(-0.5 * ((z - 0.0190) / 0.0090) ** 2) * np.exp(-((x / 0.017) ** 4))
    return r


_EAR_C = (0.019, 0.099)  # (y, z) of the middle of the ear
_EAR_SIZE = (0.0170, 0.0322)  # half width and half height (m)


def _ear(p, ax, detail):
    """The auricle as a solid on the side of the head: a slab whose outline is an
    egg leaning back 15 degrees, its lateral face turned 22 degrees toward the back
    (the ear stands off the head most at the back of the helix), the space behind
    it filled (so the head stays star-shaped), and the lateral face carved: helix,
    scapha, antihelix, triangular fossa, concha, tragus, antitragus and lobe."""
    dy, dz = p[:, 1] - _EAR_C[0], p[:, 2] - _EAR_C[1]
    c, s_ = np.cos(np.radians(15.0)), np.sin(np.radians(15.0))
    u = c * dy + s_ * dz  # toward the back of the head
    v = -s_ * dy + c * dz  # up
    au0, av = _EAR_SIZE
    au = au0 * (1.0 - 0.24 * _smoothstep(0.0, -av, v))  # narrower toward the lobe
    qu, qv = u / au, v / av
    k0 = np.hypot(qu, qv)
    k1 = np.hypot(qu / au, qv / av)
    outline = k0 * (k0 - 1.0) / np.maximum(k1, 1e-12)
    lobe = _smoothstep(-0.35, -0.85, qv)
    lateral = 0.0750 + 0.52 * (u + au0) - 0.0050 * lobe
    f = _smax(ax - lateral, outline, 0.0032)
    # The lateral face: the helix's rim stands proud of the scapha inside it,
    # which runs round the upper back; the antihelix between the scapha and the
    # concha; the concha a deep bowl leading in toward the ear canal.
    g = max(0.08, detail / au0)
    upper_back = _smoothstep(-0.4, 0.3, qu + 0.8 * qv)
    carve = 0.0026 * np.exp(-0.5 * ((k0 - 0.74) / g) ** 2) * upper_back
    carve += 0.0018 * np.exp(-0.5 * (np.hypot((qu - 0.05) / 0.22, (qv - 0.50) / 0.16) ** 2))
    carve += 0.0070 * np.exp(-(np.hypot((qu + 0.14) / 0.44, (qv + 0.13) / 0.40) ** 4))
    carve += 0.0020 * np.exp(-0.5 * (np.hypot((qu + 0.30) / 0.30, (qv - 0.20) / 0.14) ** 2))
    # Tragus and antitragus, either side of the notch under the concha.
    carve -= 0.0030 * np.exp(-0.5 * (((qu + 0.72) / 0.14) ** 2 + ((qv + 0.16) / 0.15) ** 2))
    carve -= 0.0016 * np.exp(-0.5 * (((qu + 0.05) / 0.16) ** 2 + ((qv + 0.58) / 0.10) ** 2))
    return f + carve


# Eye geometry (left eye; the right is mirrored). Metres.
_EYE_C = np.array([0.0315, -0.0660, 0.1165])  # centre of the eyeball
_EYE_R = 0.0122  # eyeball radius (the cornea bulges up to 2.8 mm more)
_CANTHUS_IN = (0.0162, 0.1152)  # (x, z) of the inner corner of the eye
_CANTHUS_OUT = (0.0462, 0.1187)  # outer corner: a slight upward canthal tilt


def _fissure(ax, z):
    """Heights (m) above the upper lid's margin and below the lower lid's (both
    negative inside the palpebral fissure), and the position ``s`` (0 inner
    corner, 1 outer) along it."""
    (xi, zi), (xo, zo) = _CANTHUS_IN, _CANTHUS_OUT
    s = (ax - xi) / (xo - xi)
    b = np.clip(4.0 * s * (1.0 - s), 0.0, None)
    zc = zi + (zo - zi) * s
    # The upper lid peaks a little medial of the pupil, the lower lid lateral of it.
    upper = zc + 0.0056 * b ** 0.62 * (1.0 - 0.18 * (s - 0.42))
    lower = zc - 0.0050 * b ** 0.95 * (1.0 + 0.20 * (s - 0.55))
    return z - upper, lower - z, s


def _eyes(m, detail):
    """``m``: points with x folded by |x| (the eyes are far from the midline).
    Eyeballs with the iris and pupil carved like a sculpture's, and the lids: a
    shell over each eyeball that opens along the fissure."""
    q = m - _EYE_C
    r = np.sqrt(np.einsum("ij,ij->i", q, q))
    rho = np.hypot(q[:, 0], q[:, 2])  # distance from the visual axis
    # The cornea bulges over the iris, whose face is a shallow dish round the pupil.
    cornea = 0.0028 * np.clip(1.0 - (rho / 0.0068) ** 2, 0.0, None) ** 1.2
    iris = 0.0003 * np.exp(-((rho / 0.0048) ** 4))
    pupil = 0.0020 * np.exp(-0.5 * (rho / 0.0009) ** 2)
    ball = r - (_EYE_R + cornea - iris - pupil)
    d_up, d_lo, s = _fissure(m[:, 0], m[:, 2])
    inside = -np.maximum(d_up, d_lo)  # > 0 in the fissure
    w = max(0.0006, 0.6 * detail)
    corner = np.clip(4.0 * s * (1.0 - s), 0.0, 1.0) ** 0.3
    # Upper lid: the margin a ledge over the eye, the tarsal plate hugging the ball up
    # to the lid crease, the skin above it folding forward toward the brow.
    crease_h = 0.0035 + 0.0035 * corner
    t_up = (0.0015 + 0.0005 * _smoothstep(0.0, 0.003, d_up)
            - 0.0005 * _groove(d_up - crease_h, 0.0007, detail) * corner
            + 0.0032 * _smoothstep(crease_h, crease_h + 0.006, d_up))
    # Lower lid: a thinner margin, the pretarsal roll under it, then the cheek.
    t_lo = (0.0013 + 0.0004 * _smoothstep(0.0, 0.002, d_lo)
            + 0.0004 * np.exp(-0.5 * ((d_lo - 0.0030) / 0.0015) ** 2) * corner
            + 0.0020 * _smoothstep(0.005, 0.011, d_lo))
    t = np.where(m[:, 2] > _EYE_C[2] + 0.002 * (s - 0.5), t_up, t_lo)
    # Toward the corners the lids part more gently, so the rays from ORIGIN, which
    # cross the outer corner obliquely, still meet one surface.
    soft = w * (1.0 + 8.0 * (1.0 - corner))
    t = t - 0.0055 * (0.3 + 0.7 * corner) * _smoothstep(-0.3 * w, soft, inside)
    lids = r - (_EYE_R + t)
    return ball, lids


def head_field(p, detail=0.0):
    """Implicit function of the head: negative inside, ~signed distance (m).

    ``detail`` (m) is the narrowest groove the mesh can show; narrower ones
    (lid margins, mouth line, creases) are widened to it so they do not alias.
    """
    p = np.asarray(p, dtype=np.float64)
    m = _mirror(p)
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    ax = m[:, 0]

    # Cranium: an egg, narrower at the forehead than over the parietals, and
    # shorter behind its middle than in front (19 cm from the glabella to the
    # back of the head): y behind the middle is stretched before evaluating it.
    widen = 1.0 + np.where(y < 0.0, 0.04, 0.07) * np.clip(y / 0.1, -1.0, 1.0)
    yc = np.where(y > 0.014, 0.014 + (y - 0.014) * (0.099 / 0.082), y)
    pc = np.stack([x / widen, yc, z], axis=1)
    f = _superellipsoid(pc, (0.0, 0.014, 0.135), (0.074, 0.099, 0.091), 2.4)
    f = _smin(f, _face_mass(p), 0.015)
    f = _smin(f, _neck(p), 0.02)

    # Relief along the normal, evaluated only where it can be non-zero.
    front = y < -0.005
    if front.any():
        pf = p[front]
        f[front] -= _face_relief(pf, m[front], detail) * _smoothstep(-0.005, -0.045, pf[:, 1])
    ear = (ax > 0.055) & (np.abs(y - _EAR_C[0]) < 0.032) & (np.abs(z - _EAR_C[1]) < 0.042)
    if ear.any():
        f[ear] = _smin(f[ear], _ear(p[ear], ax[ear], detail), 0.004)

    # The nose, a solid joined onto the face; the alae with a crease round them.
    near = (ax < 0.035) & (y < -0.075) & (z > 0.055) & (z < 0.145)
    if near.any():
        fn, ala, nostril = _nose(p[near], m[near])
        fn = _smin(f[near], fn, 0.0080)
        fn = _smin(fn, ala, 0.0012)
        f[near] = _smax(fn, -nostril, 0.0015)

    # Eyes: the lids blend into the socket, the eyeballs show between them.
    near = (np.abs(np.abs(x) - _EYE_C[0]) < 0.03) & (np.abs(z - _EYE_C[2]) < 0.03) & (y < -0.03)
    if near.any():
        pe = p[near].copy()
        pe[:, 0] = np.abs(pe[:, 0])
        ball, lids = _eyes(pe, detail)
        fe = _smin(f[near], lids, 0.0015)
        f[near] = np.minimum(fe, ball)
    return f


# --------------------------------------------------------------------------
# Ray casting
# --------------------------------------------------------------------------
def _directions(az, el):
    """Unit rays: azimuth 0 looks toward -Y, +pi/2 toward +X; elevation up."""
    ce = np.cos(el)
    return np.stack([ce * np.sin(az), -ce * np.cos(az), np.sin(el)], axis=-1)


def _cast(origins, dirs, field, t_max=_RAY_MAX):
    """Distance along each ray to the zero of ``field`` (inside at t = 0,
    outside at ``t_max``, one crossing in between)."""
    o = np.broadcast_to(origins, dirs.shape).reshape(-1, 3)
    d = dirs.reshape(-1, 3)
    lo = np.zeros(len(d))
    hi = np.full(len(d), t_max)
    for _ in range(8):  # bisection to ~1 mm
        mid = 0.5 * (lo + hi)
        inside = field(o + mid[:, None] * d) < 0.0
        lo = np.where(inside, mid, lo)
        hi = np.where(inside, hi, mid)
    f_lo = field(o + lo[:, None] * d)
    f_hi = field(o + hi[:, None] * d)
    for _ in range(5):  # Illinois false position
        t = hi - f_hi * (hi - lo) / (f_hi - f_lo)
        ft = field(o + t[:, None] * d)
        inside = ft < 0.0
        lo, hi = np.where(inside, t, lo), np.where(inside, hi, t)
        f_lo = np.where(inside, ft, 0.5 * f_lo)
        f_hi = np.where(inside, 0.5 * f_hi, ft)
    t = hi - f_hi * (hi - lo) / (f_hi - f_lo)
    return t.reshape(dirs.shape[:-1])


def _project(starts, dirs, field, length=0.3, step=2.5e-4):
    """First crossing of ``field`` marching from ``starts`` (outside) along ``dirs``."""
    ts = np.arange(0.0, length, step)
    pts = starts[:, None, :] + ts[None, :, None] * dirs[:, None, :]
    inside = (field(pts.reshape(-1, 3)) < 0.0).reshape(len(starts), len(ts))
    k = np.argmax(inside, axis=1)
    lo, hi = ts[np.maximum(k - 1, 0)], ts[k]
    for _ in range(20):
        mid = 0.5 * (lo + hi)
        inn = field(starts + mid[:, None] * dirs) < 0.0
        lo, hi = np.where(inn, lo, mid), np.where(inn, mid, hi)
    return starts + (0.5 * (lo + hi))[:, None] * dirs


# --------------------------------------------------------------------------
# Grid layout
# --------------------------------------------------------------------------
def _warp(u, lo, hi, dense_lo, dense_hi, blend, sparse, ears=0.0):
    """Map uniform samples ``u`` in [0, 1] to [lo, hi], dense inside
    [dense_lo, dense_hi] and ``sparse`` times as dense outside; with ``ears``,
    that density over the ears (azimuths of 75-120 degrees either side)."""
    a = np.linspace(lo, hi, 4097)
    w = _smoothstep(dense_lo - blend, dense_lo, a) * (1.0 - _smoothstep(dense_hi, dense_hi + blend, a))
    rho = sparse + (1.0 - sparse) * w
    if ears:
        e = _smoothstep(np.radians(62), np.radians(78), np.abs(a)) \
            * _smoothstep(np.radians(128), np.radians(114), np.abs(a))
        rho = np.maximum(rho, ears * e)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (rho[1:] + rho[:-1]) * np.diff(a))])
    return np.interp(u * cum[-1], cum, a)


def _grid_size(target_verts):
    """Columns (multiple of 8) and rows for a vertex budget."""
    # vertices = C * R + (C/4 - 1)^2 with R = 0.8 C
    c = np.sqrt(target_verts / (0.8 + 1.0 / 16.0))
    cols = max(32, int(round(c / 8.0)) * 8)
    rows = max(16, int(round((target_verts - (cols // 4 - 1) ** 2) / cols)))
    return cols, rows


def _pupil_angles():
    """Azimuth and elevation, seen from ORIGIN, of the left pupil."""
    pupil = _EYE_C - (0.0, _EYE_R, 0.0)
    d = pupil - ORIGIN
    return np.arctan2(d[0], -d[1]), np.arctan2(d[2], np.hypot(d[0], d[1]))


def _snap(a, target, periodic=False, reach=5):
    """Shift the sorted samples ``a`` so that the one nearest ``target`` lands on it,
    spreading the shift over ``reach`` samples either side (a gentle, monotone
    change of spacing)."""
    i = int(np.argmin(np.abs(a - target)))
    k = np.arange(len(a))
    d = np.abs(k - i)
    if periodic:
        d = np.minimum(d, len(a) - d)
    return a + (target - a[i]) * np.clip(1.0 - d / reach, 0.0, 1.0)


def _band_rays(cols, rows, field):
    """Ray origins and directions of the band, neck ring first, row-major."""
    s = np.linspace(-np.pi, np.pi, cols, endpoint=False)
    az0 = _warp((s + np.pi) / (2 * np.pi), -np.pi, np.pi, np.radians(-70), np.radians(70),
                np.radians(30), 0.25, ears=0.8)
    az0[0] = -np.pi
    rows_neck = max(3, int(round(0.07 * rows)))
    el = _warp(np.linspace(0.0, 1.0, rows - rows_neck), _EL_LOW, _EL_CAP,
               np.radians(-44), np.radians(48), np.radians(14), 0.45)
    # A ray through each pupil, so that the eye landmark is a vertex on the axis.
    az_p, el_p = _pupil_angles()
    az0 = _snap(az0, az_p, periodic=True)
    az0 = _snap(az0, -az_p, periodic=True)
    el = _snap(el, el_p)
    az = np.broadcast_to(az0, (len(el), cols))
    # The lowest ray of each column meets the neck wall at z = _NECK_TOP ...
    flat = _directions(az0, np.zeros(cols))
    o_top = np.array([ORIGIN[0], ORIGIN[1], _NECK_TOP])
    rho = _cast(o_top, flat, field) * np.hypot(flat[:, 0], flat[:, 1])
    el_low = np.arctan2(_NECK_TOP - ORIGIN[2], rho)
    w = 1.0 - _smoothstep(_EL_LOW, np.radians(-30.0), el)
    el2 = el[:, None] + w[:, None] * np.maximum(el_low - _EL_LOW, 0.0)[None, :]
    dirs = _directions(az, el2)
    origins = np.broadcast_to(ORIGIN, dirs.shape)
    # ... and below it the neck is sampled by level rays from the axis.
    zs = _NECK_CUT + (_NECK_TOP - _NECK_CUT) * np.arange(rows_neck) / rows_neck
    neck_o = np.zeros((rows_neck, cols, 3))
    neck_o[..., 0], neck_o[..., 1], neck_o[..., 2] = ORIGIN[0], ORIGIN[1], zs[:, None]
    neck_d = np.broadcast_to(flat, (rows_neck, cols, 3))
    origins = np.concatenate([neck_o, origins]).reshape(-1, 3)
    dirs = np.concatenate([neck_d, dirs]).reshape(-1, 3)
    az_all = np.concatenate([np.broadcast_to(az0, (rows_neck, cols)), az]).ravel()
    el_row = np.concatenate([np.full(rows_neck, -0.5 * np.pi), el])
    return origins, dirs, az_all, el_row


def _cap_walk(m):
    """Boundary of an (m+1)^2 grid, in the order of the ring columns."""
    return np.concatenate([
        np.stack([np.arange(m), np.zeros(m, int)], 1),
        np.stack([np.full(m, m), np.arange(m)], 1),
        np.stack([np.arange(m, 0, -1), np.full(m, m)], 1),
        np.stack([np.zeros(m, int), np.arange(m, 0, -1)], 1),
    ])


def _topology(cols, rows):
    """Quads of the band (rows x cols, periodic) and of the cap on its top ring."""
    band = np.arange(rows * cols).reshape(rows, cols)
    nxt = np.roll(band, -1, axis=1)
    band_quads = np.stack([band[:-1], nxt[:-1], nxt[1:], band[1:]], -1).reshape(-1, 4)
    m = cols // 4
    cap = np.zeros((m + 1, m + 1), dtype=np.int64)
    walk = _cap_walk(m)
    cap[walk[:, 0], walk[:, 1]] = band[-1]
    cap[1:m, 1:m] = (rows * cols + np.arange((m - 1) ** 2)).reshape(m - 1, m - 1)
    cap_quads = np.stack([cap[:-1, :-1], cap[1:, :-1], cap[1:, 1:], cap[:-1, 1:]], -1)
    quads = np.concatenate([band_quads, cap_quads.reshape(-1, 4)]).astype(np.int32)
    return rows * cols + (m - 1) ** 2, quads, cap


def _neighbours(n_verts, quads):
    """Edge neighbours of every vertex, padded with -1."""
    e = np.concatenate([quads[:, [0, 1]], quads[:, [1, 2]], quads[:, [2, 3]], quads[:, [3, 0]]])
    e = np.unique(np.sort(e, 1), axis=0)
    e = np.concatenate([e, e[:, ::-1]])
    e = e[np.argsort(e[:, 0], kind="stable")]
    counts = np.bincount(e[:, 0], minlength=n_verts)
    start = np.concatenate([[0], np.cumsum(counts)[:-1]])
    nb = np.full((n_verts, counts.max()), -1, dtype=np.int64)
    nb[e[:, 0], np.arange(len(e)) - start[e[:, 0]]] = e[:, 1]
    return nb


def _crown(az, el, n_verts, quads, cap, polar, nb):
    """2D azimuthal-equidistant coordinates of the crown: the cap is a Coons
    patch of its ring, then cap and the rows above _EL_FIXED are relaxed by
    umbrella smoothing so the four valence-3 corners open up."""
    q = np.zeros((n_verts, 2))
    theta = 0.5 * np.pi - el
    band = slice(0, len(az))
    q[band] = np.stack([theta * np.sin(az), -theta * np.cos(az)], 1)
    m = cap.shape[0] - 1
    qc = q[cap]  # interior rows are zero, the boundary holds the ring
    u = np.linspace(0.0, 1.0, m + 1)[:, None, None]
    v = np.linspace(0.0, 1.0, m + 1)[None, :, None]
    coons = ((1 - u) * qc[:1] + u * qc[-1:] + (1 - v) * qc[:, :1] + v * qc[:, -1:]
             - ((1 - u) * (1 - v) * qc[0, 0] + u * (1 - v) * qc[-1, 0]
                + (1 - u) * v * qc[0, -1] + u * v * qc[-1, -1]))
    q[cap[1:m, 1:m].ravel()] = coons[1:m, 1:m].reshape(-1, 2)

    idx = np.flatnonzero(polar)
    nb = nb[idx]
    valid = nb >= 0
    nb = np.where(valid, nb, 0)
    weight = valid / valid.sum(1, keepdims=True)
    for _ in range(250):
        q[idx] = np.einsum("ik,ikj->ij", weight, q[nb])
    return q


def _gradient(field, p, f0, h=2e-5):
    """Forward-difference gradient of ``field`` at ``p`` (whose values are ``f0``)."""
    g = np.empty_like(p)
    for k in range(3):
        q = p.copy()
        q[:, k] += h
        g[:, k] = (field(q) - f0) / h
    return g


def _vertex_normals(x, quads, n_verts):
    """Area-weighted unit normals of the quad mesh ``x``."""
    fn = np.cross(x[quads[:, 2]] - x[quads[:, 0]], x[quads[:, 3]] - x[quads[:, 1]])
    vn = np.zeros((n_verts, 3))
    for k in range(4):
        np.add.at(vn, quads[:, k], fn)
    return vn / np.maximum(np.linalg.norm(vn, axis=1, keepdims=True), 1e-12)


def _relax(hits, origins, dirs, quads, nb, fixed, field, iterations=8, step=0.6, rings=4):
    """Slide the ray hits over the surface so that the quads where the rays graze
    it (under the nose, round the ears and the lids) become as even as their
    neighbours.

    Only the vertices where a ray meets the surface at a glancing angle, and a
    few rings round them, move. Each step moves every one of them toward the
    weighted mean of its neighbours, within the tangent plane, then back onto the
    surface along the gradient (x <- x - f grad f / |grad f|^2). The weights are
    the inverse angular spacing of the rays, so the grid's designed density (dense
    face, sparse back) is the resting state and only the grazing regions move."""
    n = len(hits)
    valid = nb >= 0
    nbi = np.where(valid, nb, 0)
    grazing = np.abs(np.einsum("ij,ij->i", _vertex_normals(hits, quads, n), dirs)) < 0.55
    active = grazing.copy()
    for _ in range(rings):
        active |= (active[nbi] & valid).any(axis=1)
    idx = np.flatnonzero(active & ~fixed)
    if len(idx) == 0:
        return hits
    nbi, valid = nbi[idx], valid[idx]
    # Parameter length of each edge: its extent across the rays, over the distance.
    dp = hits[nbi] - hits[idx, None, :]
    dbar = dirs[nbi] + dirs[idx, None, :]
    dbar /= np.maximum(np.linalg.norm(dbar, axis=2, keepdims=True), 1e-12)
    perp = dp - np.einsum("ijk,ijk->ij", dp, dbar)[..., None] * dbar
    reach = np.linalg.norm(hits - origins, axis=1)
    rbar = 0.5 * (reach[nbi] + reach[idx, None])
    h = np.linalg.norm(perp, axis=2) / np.maximum(rbar, 1e-9)
    w = np.where(valid, 1.0 / np.maximum(h, 1e-6), 0.0)
    w /= w.sum(axis=1, keepdims=True)
    x = hits.copy()
    xi = x[idx]
    f = field(xi)
    for it in range(iterations + 1):
        g = _gradient(field, xi, f)
        g2 = np.maximum(np.einsum("ij,ij->i", g, g), 1e-12)
        if it == iterations:  # a last projection onto the surface
            x[idx] = xi - (f / g2)[:, None] * g
            break
        nrm = g / np.sqrt(g2)[:, None]
        lap = np.einsum("ik,ikj->ij", w, x[nbi]) - xi
        lap -= np.einsum("ij,ij->i", lap, nrm)[:, None] * nrm
        # at most a quarter of the shortest edge per step, so no quad folds
        move = step * lap
        size = np.linalg.norm(move, axis=1)
        near = np.min(np.where(valid, np.linalg.norm(x[nbi] - xi[:, None, :], axis=2), np.inf), axis=1)
        xi = xi + move * np.minimum(1.0, 0.25 * near / np.maximum(size, 1e-12))[:, None]
        f = field(xi)
        xi = xi - (f / g2)[:, None] * g
        f = field(xi)
        x[idx] = xi
    return x


# --------------------------------------------------------------------------
# UVs
# --------------------------------------------------------------------------
_UV_AZ_FACE = np.radians(80.0)
_UV_SCALE = 0.45 / _UV_AZ_FACE  # UV units per radian on the face (both axes)
_UV_EL_MIN = np.radians(-78.0)


def _corner_uvs(positions, az, q, polar, quads, cols):
    """Band: u from the azimuth (linear over +-80 degrees, the back squeezed
    into the outer 5 %), v from the elevation seen from ORIGIN at the same
    scale. Crown (faces with every corner above _EL_FIXED): a disc island
    above the band."""
    n_band = len(az)
    rel = positions[:n_band].astype(np.float64) - ORIGIN
    el = np.arctan2(rel[:, 2], np.hypot(rel[:, 0], rel[:, 1]))
    az = np.where(np.arange(n_band) % cols == 0, -np.pi, az)  # column 0 is the seam
    a = np.abs(az)
    u = np.where(a <= _UV_AZ_FACE, _UV_SCALE * a,
                 0.45 + 0.05 * (a - _UV_AZ_FACE) / (np.pi - _UV_AZ_FACE))
    band_uv = np.stack([0.5 + np.sign(az) * u, 0.02 + _UV_SCALE * (el - _UV_EL_MIN)], axis=1)
    v_top = 0.02 + _UV_SCALE * (_EL_FIXED - _UV_EL_MIN)
    half = 0.5 * (1.0 - v_top) - 0.01
    centre = np.array([0.5, 1.0 - 0.01 - half])
    island_uv = centre + q * (half / (0.5 * np.pi - _EL_FIXED))

    crown = polar[quads].all(axis=1)
    corner = np.empty(quads.shape + (2,))
    corner[crown] = island_uv[quads[crown]]
    corner[~crown] = band_uv[quads[~crown]]
    # The last column closes on column 0 at u = 1.
    col = quads % cols
    wrap = ~crown[:, None] & (col == 0) & (col == cols - 1).any(axis=1, keepdims=True)
    corner[..., 0] = np.where(wrap, 1.0, corner[..., 0])
    return corner.astype(np.float32)


# --------------------------------------------------------------------------
# Landmarks
# --------------------------------------------------------------------------
# (x, z) seen from the front, for the left side (the right is mirrored), of the
# landmarks that sit at a fixed place of the model; the others are found on the
# surface by their anatomical definition (``_landmarks``).
_FRONT_LANDMARKS = {
    "eye_L": (_EYE_C[0], _EYE_C[2]),  # the pupil, on the eyeball's visual axis
    "nose_ala_L": (0.0172, 0.0752),  # the wing, just inside its most lateral point
    "cheekbone_L": (0.0515, 0.0970),  # the malar eminence's summit
    "mouth_corner_L": (0.0243, 0.0469),  # where the lips meet at the side
    "jaw_L": (0.029, 0.0235),  # the chin's side, over the mandible
}
_BROWS = {"brow_inner_L": 0.014, "brow_mid_L": 0.032, "brow_outer_L": 0.049}
_HAIRLINE = {"hairline_center": 0.0, "hairline_L": 0.032}
_HAIRLINE_SLOPE = np.radians(40.0)  # the forehead turns into the crown


def _front_profile(field, x, zs):
    """y of the front surface at ``x`` for each of ``zs`` (seen along +Y)."""
    starts = np.column_stack([np.full(len(zs), x), np.full(len(zs), -0.14), zs])
    return _project(starts, np.tile([0.0, 1.0, 0.0], (len(zs), 1)), field, length=0.1)[:, 1]


def _landmarks(positions, field):
    """Every landmark of ``LANDMARK_NAMES`` at its feature, as an anatomist puts it,
    snapped to the nearest vertex:

    * on the midline profile: the nasion (its deepest point at the eyes), the
      glabella (the most forward point above it), the hairline (where the profile
      leans back 40 degrees, the forehead turning into the crown), the nose tip
      (the most forward point of the nose), the lips (the most forward points of
      the vermilion above and below the mouth line) and the chin (the most forward
      point under the mentolabial sulcus);
    * the brows: on the crest of the brow ridge (``_brow_z``) at the inner, middle
      and outer brow;
    * the pupils, the alae, the cheekbones, the mouth corners and the jaw at the
      model's own positions; the lateral cheek 60 degrees round from the front at
      the mouth's height."""
    xz = {}
    zs = np.arange(0.110, 0.150, 0.0005)
    y = _front_profile(field, 0.0, zs)
    eyes = zs < 0.128
    nasion = zs[eyes][np.argmax(y[eyes])]
    above = (zs >= nasion) & (zs <= nasion + 0.025)
    glabella = zs[above][np.argmin(y[above])]
    xz["glabella"] = (0.0, glabella)
    xz["nose_bridge"] = (0.0, _EYE_C[2] - 0.004)
    for name, x in _BROWS.items():
        xz[name] = (x, _brow_z(x))
    for name, x in _HAIRLINE.items():
        zh = np.arange(glabella + 0.03, glabella + 0.09, 0.0005)
        yh = _front_profile(field, x, zh)
        lean = np.arctan(np.gradient(yh, zh))
        xz[name] = (x, zh[np.argmax(lean >= _HAIRLINE_SLOPE)])
    zm = np.arange(0.036, 0.060, 0.0002)
    ym = _front_profile(field, 0.0, zm)
    mouth = zm[np.argmax(np.where((zm > 0.044) & (zm < 0.052), ym, -1.0))]  # the mouth line
    xz["upper_lip"] = (0.0, zm[zm > mouth][np.argmin(ym[zm > mouth])])
    xz["lower_lip"] = (0.0, zm[zm < mouth][np.argmin(ym[zm < mouth])])
    zc = np.arange(0.008, 0.040, 0.0005)
    yc = _front_profile(field, 0.0, zc)
    sulcus = zc[np.argmax(np.where(zc > 0.026, yc, -1.0))]
    below = zc < sulcus
    xz["chin"] = (0.0, zc[below][np.argmin(yc[below])])
    xz.update(_FRONT_LANDMARKS)

    names, starts, dirs = [], [], []
    for name, (x, z) in xz.items():
        sides = [(name, x)] if not name.endswith("_L") else [(name, x), (name[:-2] + "_R", -x)]
        for n, xx in sides:
            names.append(n)
            starts.append((xx, -0.3, z))
            dirs.append((0.0, 1.0, 0.0))
    for n, sign in (("cheek_lateral_L", 1.0), ("cheek_lateral_R", -1.0)):
        toward = -_directions(np.radians(60.0) * sign, 0.0)
        names.append(n)
        starts.append(np.array([ORIGIN[0], ORIGIN[1], 0.048]) - 0.2 * toward)
        dirs.append(toward)
    hits = _project(np.array(starts, float), np.array(dirs, float), field)
    pos = positions.astype(np.float64)
    out = {}
    for name, hit in zip(names, hits):
        out[name] = positions[np.argmin(np.einsum("ij,ij->i", pos - hit, pos - hit))]
    # The nose tip is the most forward vertex of the nose, on the midline.
    near = (np.abs(pos[:, 0]) < 0.0015) & (np.abs(pos[:, 2] - 0.082) < 0.012)
    out["nose_tip"] = positions[np.flatnonzero(near)[np.argmin(pos[near, 1])]]
    return {n: out[n].astype(np.float32).copy() for n in LANDMARK_NAMES}


# --------------------------------------------------------------------------
# Public API
# --------------------------------------------------------------------------
def make_head(target_verts=40000):
    """An all-quad human head, closed at the crown and open at the neck.

    Returns a dict: ``positions`` (N, 3) float32, ``quads`` (F, 4) int32
    wound counter-clockwise seen from outside, ``corner_uvs`` (F, 4, 2)
    float32 and ``landmarks`` (name -> (3,) float32, each a vertex position).
    ``target_verts`` sets the resolution (the count lands within 1 % of it);
    at the default 40k the forehead, brows, eyes, nose and mouth have edges of
    1.6-1.9 mm (median), at 10k about 3.5 mm, at 200k about 0.8 mm.
    Deterministic: the same target gives the same arrays.
    """
    cols, rows = _grid_size(float(target_verts))
    edge = 0.0016 * np.sqrt(40000.0 / float(target_verts))
    field = partial(head_field, detail=0.6 * edge)
    n_verts, quads, cap = _topology(cols, rows)
    origins, dirs, az, el_row = _band_rays(cols, rows, field)
    n_band = rows * cols
    polar = np.zeros(n_verts, bool)
    polar[n_band:] = True
    polar[:n_band] = np.repeat(el_row > _EL_FIXED, cols)
    el = np.arcsin(np.clip(dirs[:, 2], -1.0, 1.0))
    nb = _neighbours(n_verts, quads)
    q = _crown(az, el, n_verts, quads, cap, polar, nb)
    theta = np.hypot(q[:, 0], q[:, 1])
    az_all = np.concatenate([az, np.zeros(n_verts - n_band)])
    az_all[polar] = np.arctan2(q[polar, 0], -q[polar, 1])
    origins = np.concatenate([origins, np.broadcast_to(ORIGIN, (n_verts - n_band, 3))])
    all_dirs = np.concatenate([dirs, np.zeros((n_verts - n_band, 3))])
    all_dirs[polar] = _directions(az_all[polar], 0.5 * np.pi - theta[polar])
    t = _cast(origins, all_dirs, field)
    hits = origins + t[:, None] * all_dirs
    corner_uvs = _corner_uvs(hits.astype(np.float32), az_all[:n_band], q, polar, quads, cols)
    border = np.zeros(n_verts, bool)
    border[:cols] = True  # the neck ring stays in its plane
    az_p, el_p = _pupil_angles()
    for sign in (1.0, -1.0):  # and the pupils on their axes
        pupil = _directions(sign * az_p, el_p)
        border[np.argmax(all_dirs[:n_band] @ pupil)] = True
    positions = _relax(hits, origins, all_dirs, quads, nb, border, field).astype(np.float32)
    return {"positions": positions, "quads": quads, "corner_uvs": corner_uvs,
            "landmarks": _landmarks(positions, field)}


def make_forehead_patch(width=0.14, height=0.08, target_verts=20000, radius=0.10):
    """A forehead-like sheet: a cylinder section about the Z axis facing -Y.

    The patch spans ``width`` of arc and ``height`` in Z (from z = 0 at the
    brows up to z = height at the hairline), on a cylinder of ``radius``
    centred on the Z axis, so its middle is at (0, -radius, height/2). Square
    quads; UVs are arc length and height divided by ``width`` (isometric).
    Landmarks: ``attachment_L/R`` on the top edge (hairline), ``insertion_L/R``
    near the bottom edge (brows), at x = +-width/5.
    """
    aspect = height / width
    nx = max(2, int(round(np.sqrt(target_verts / aspect))))
    nz = max(2, int(round(target_verts / nx)))
    s = np.linspace(-0.5 * width, 0.5 * width, nx)
    zs = np.linspace(0.0, height, nz)
    phi = s / radius
    S, Z = np.meshgrid(s, zs)
    P = np.stack([radius * np.sin(phi)[None, :].repeat(nz, 0),
                  -radius * np.cos(phi)[None, :].repeat(nz, 0), Z], -1)
    positions = P.reshape(-1, 3).astype(np.float32)
    idx = np.arange(nx * nz).reshape(nz, nx)
    quads = np.stack([idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]], -1)
    quads = quads.reshape(-1, 4).astype(np.int32)
    uv = np.stack([(S + 0.5 * width) / width, Z / width], -1).reshape(-1, 2)
    corner_uvs = uv[quads].astype(np.float32)

    def at(arc, zz):
        a = arc / radius
        target = np.array([radius * np.sin(a), -radius * np.cos(a), zz])
        d2 = np.einsum("ij,ij->i", positions - target, positions - target)
        return positions[np.argmin(d2)].copy()

    lx = 0.2 * width
    landmarks = {
        "attachment_L": at(lx, height),
        "attachment_R": at(-lx, height),
        "insertion_L": at(lx, 0.1 * height),
        "insertion_R": at(-lx, 0.1 * height),
    }
    return {"positions": positions, "quads": quads, "corner_uvs": corner_uvs,
            "landmarks": landmarks}
